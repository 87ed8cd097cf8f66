"""The error bounds of an FMU with ports: the shadow sized against the model's own error on its port rows too
(harness/rom/bounds.py model_errors, choose_planes; harness/fmu/training/steps.py core_runs), and the truth's matrix
a contraction only up to round-off, which the bounds' drift terms carry (harness/rom/lti.py skew_growth; section
SHSCAL's growth, fmu_src/rom_bound.c; section PCSCAL's growth, fmu_src/rom_port.c)."""

import numpy as np
import pytest
import scipy.linalg as sla

from conftest import fmu_scene

PROBES = (0.25, 0.5)
PORTS = (0.3, 0.7)
MODEL_PLANES = 3            # the modal stand-in's planes (the shadow's lowest, no free response table)


def modal_port_runs(p, planes=MODEL_PLANES):
    """``model_runs`` of a modal model of the ``planes`` lowest planes with ports (the channel's case: f alone as the
    shadow's input), as core_runs gives them: (v, ρ, v_port) after each step, t = 0 first from the initial state."""
    from sphrom.rom.bounds import build_shadow, free_part, run_shadow
    sh = build_shadow(p, PROBES, PORTS, order=planes, port_inputs=False)
    P = len(PROBES)

    def run(h, f, scale):
        f = np.asarray(f, float)
        y, _ = run_shadow(sh, np.full(f.size, h), f[:, None], np.zeros((f.size, 1)), scale=scale)
        tau = np.arange(f.size + 1) * h
        y = y - scale * np.array([free_part(sh.comp, t)[0] for t in tau])     # the planes alone: no table
        y = y if scale else y[1:]
        e = y[:, P:3 * P].reshape(-1, P, 2)
        rho = (sh.pw * sh.prho0 / (1.0 + e)).sum(axis=2)
        return y[:, :P], rho, y[:, 3 * P:]
    return run


def free_truth(p, rows, h, steps):
    """The full linear SPH's ``rows`` at t = j h from the initial state, no input, exact in time."""
    from sphrom.rom.lti import full_linear_system
    lti = full_linear_system(p, list(PROBES))
    E = sla.expm(lti.A.toarray() * h)
    x, out = lti.x0.copy(), []
    for _ in range(steps + 1):
        out.append(rows @ x)
        x = E @ x
    return np.array(out)


def test_port_rows_are_sized_against_the_models_own_error():
    """An undamped bar with ports (multimode shrunk, the channel's case): model_errors takes the model's v_port from
    its runs (before: NaN, the port rows sized by the target alone, 10x tighter than a known model's floor from the
    initial state since FREE_TARGET holds there too), and the shadow sized so bounds the modal model's v_port from
    its initial state: never below its true error against the full linear SPH (exact in time), and within
    1 + 2 MODEL_FRACTION of it (the sizing's guarantee on this reference input, 5 % for round-off) over the table."""
    from sphrom.rom.bounds import (FREE_SAMPLES, MODEL_FRACTION, TABLE_SPAN, build_shadow, decompose, input_columns,
                                   model_errors, output_bounds, output_rows, reference_omega, reference_responses,
                                   run_shadow)
    from sphrom.rom.planes import plane_modes
    from sphrom.sph.solver import build_problem
    p = build_problem(fmu_scene("unforced"))
    runs = modal_port_runs(p)
    P = len(PROBES)
    # the measured errors: the port rows' are the modal model's own, as the probes' are
    C = output_rows(p, PROBES, PORTS)[0]
    T = float(p.scene.T)
    h = TABLE_SPAN * T / FREE_SAMPLES
    truth = free_truth(p, C, h, FREE_SAMPLES)                             # (samples, rows)
    v, rho, vp = runs(h, np.zeros(FREE_SAMPLES), 1.0)
    shadow = build_shadow(p, PROBES, PORTS, port_inputs=False, model_runs=runs)
    planes = decompose(p)                                                 # the sizing's own reference runs
    chat = np.moveaxis(planes.right(C.T), 2, 0)
    bhat = planes.left(input_columns(p)[:, :1])
    x0 = np.concatenate([np.sqrt(p.rho0) * p.v0, np.zeros(p.n)])
    modes = plane_modes(planes.blocks[0], chat, bhat, planes.left(x0))
    step_r, sine_r, series = reference_responses(planes.blocks[0], chat, bhat, T, reference_omega(planes),
                                                 series=True)
    t = np.linspace(0.0, TABLE_SPAN * T, FREE_SAMPLES + 1)
    free_all = np.real(modes.P @ np.exp(np.outer(modes.mu, t)))
    _, _, free_e = model_errors(runs, series[0], series[1], free_all, reference_omega(planes), T, P,
                                shadow.pw, shadow.prho0)
    port_err = np.abs(vp - truth[:, 3 * P:]).max(axis=0)
    np.testing.assert_allclose(free_e[3 * P:], port_err, rtol=1e-6)
    # the bound of the model's v_port from its initial state
    y, cert = run_shadow(shadow, np.full(FREE_SAMPLES, h), np.zeros((FREE_SAMPLES, 1)), np.zeros((FREE_SAMPLES, 1)),
                         scale=1.0)
    _, _, port_bound = output_bounds(shadow, y, cert, v, rho, vp)
    error = np.abs(vp - truth[:, 3 * P:])
    assert np.all(error <= port_bound)
    assert np.all(port_bound.max(axis=0) <= (1.0 + 2.0 * MODEL_FRACTION) * 1.05 * error.max(axis=0))


def skewed(lti, size, seed=0):
    """``lti`` with a defect of relative ``size`` in M (the e rows from the v columns) on G's pattern: M + Kᵀ no
    longer round-off, e^{At} no longer a contraction."""
    import dataclasses

    import scipy.sparse as sp
    n = lti.w_v.size
    A = sp.csr_matrix(lti.A).tolil()
    M = sp.csr_matrix(A[n:, :n])
    M.data = M.data * (1.0 + size * np.random.default_rng(seed).uniform(-1.0, 1.0, M.data.size))
    A[n:, :n] = M
    return dataclasses.replace(lti, A=A.tocsr())


@pytest.mark.parametrize("size", [0.0, 1e-3])
def test_the_truths_growth_rate_bounds_its_symmetric_part(size):
    """skew_growth(lti) is at least the largest eigenvalue of (A + Aᵀ)/2, so ‖e^{At}‖ <= e^{ωt}: on the matrix the
    truth integrates (its M + Kᵀ of round-off size) and on one with a defect of 1e-3 in M (an eigenvalue of (A +
    Aᵀ)/2 of 1e-3 ‖K‖ or so), whose e^{At} grows."""
    from sphrom.rom.lti import full_linear_system, skew_growth
    from sphrom.sph.solver import build_problem
    lti = full_linear_system(build_problem(fmu_scene("unforced")), list(PROBES))
    lti = skewed(lti, size) if size else lti
    A = lti.A.toarray()
    omega = skew_growth(lti)
    assert np.max(np.linalg.eigvalsh(0.5 * (A + A.T))) <= omega
    for t in (0.5, 5.0, 50.0):
        assert np.linalg.norm(sla.expm(A * t), 2) <= np.exp(omega * t) * (1.0 + 1e-9)    # (expm's round-off)


def test_the_core_carries_the_growth(channel_port_fmu):
    """The C core multiplies the bounds' drift terms by e^{growth t}: the channel FMU's v_port and v_probe bounds with
    a growth of 5 s^-1 written into sections SHSCAL and PCSCAL are never below those with 0, above them once the
    drift is not 0, and never above growth_factor(5, t) (>= e^{5 t}) x them (the factor takes a part of the bound)."""
    import dataclasses

    from sphrom.fmu import layout
    from sphrom.fmu.kinds import pack
    from sphrom.fmu.run.core import built_core
    from sphrom.rom.lti import growth_factor
    _, data = channel_port_fmu
    assert "SHSCAL" in data.sections
    growth, h, steps = 5.0, 0.01, 60
    bounds = {}
    for g in (0.0, growth):
        sections = dict(data.sections)
        for tag in ("SHSCAL", "PCSCAL"):
            a = np.array(sections[tag], float)
            a[0, layout.column(tag, "growth")] = g
            sections[tag] = a
        model = built_core().load(pack(dataclasses.replace(data, sections=sections)))
        try:
            model.reset(0.0)
            out = []
            for k in range(steps):
                model.set_input(2e-3 * np.sin(3.0 * k * h))
                model.set_port_forces([1e-3 * np.cos(2.0 * k * h), 5e-4])
                model.do_step(k * h, h)
                out.append(model.error_bounds(len(PROBES)))
            bounds[g] = np.array(out)
        finally:
            model.close()
    t = (np.arange(steps) + 1) * h
    grown, plain = bounds[growth], bounds[0.0]
    assert np.all(grown >= plain)
    assert np.all(grown[-1] > plain[-1])
    assert np.all(grown <= np.array([growth_factor(growth, x) for x in t])[:, None] * plain)


def test_growth_factor_bounds_the_exponential():
    """lti.growth_factor (the C core's arithmetic: 1 + x + x² up to x = 1, then exp) is at least e^x, to the last
    ulp of either, and exactly 1 at x = 0 (a shadow or channel of growth 0 keeps its former bounds bit for bit)."""
    from sphrom.rom.lti import growth_factor
    x = np.concatenate([[0.0], np.geomspace(1e-18, 1.0, 200), np.linspace(1.0, 5.0, 41)])
    got = np.array([growth_factor(1.0, t) for t in x])
    assert np.all(got >= np.exp(x) * (1.0 - 2.0 ** -52))
    assert growth_factor(0.0, 1e9) == 1.0 and growth_factor(3.0, 0.0) == 1.0


def test_growth_factor_on_an_array_is_the_scalars():
    """lti.growth_factor on an array of times (tail_table's nodes) gives each element the bits of the scalar call
    (0 ulps: the same operations as the C core's rom_growth_factor), on both sides of x = 1 and at t <= 0."""
    from sphrom.rom.lti import growth_factor
    t = np.concatenate([[-1.0, -0.0, 0.0], np.geomspace(1e-12, 3.0, 301), np.linspace(0.19, 0.21, 101)])
    for omega in (0.0, 3.7e-9, 1.0, 5.0):
        scalars = np.array([growth_factor(omega, x) for x in t])
        assert np.array_equal(growth_factor(omega, t).view(np.int64), scalars.view(np.int64))
