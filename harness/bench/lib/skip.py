"""What the specialised right-hand sides save: the same loop with every term on.

For a scene, each solver is timed twice on identical inputs: once with the
terms the scene has (its own flags: no damping when d ≡ 0, no force when
f ≡ 0, scalars for uniform c, ρ0, d), once forced through the general path
(every term evaluated, with zero damping and force, per-particle arrays).
The results are identical (asserted); the time difference is what skipping
saves.  Medians of repeats, ratios from the same run.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...defaults import PROBES as DEFAULT_PROBES
from ...fmu.make.build import ensure_binaries
from ...fmu.make.models import reduced_model
from ...fmu.kinds import pack
from ...fmu.run.core import Core
from ...pod.pipeline import accel_modes, basis_for_scene
from ...rom.registry import get_model
from ...sph import loops
from ...sph.solver import METHODS, build_problem, step_count
from .timing import median_times_interleaved

# the reduced models timed: the ones on density modes whose loop has the specialised damping and force terms
SKIP_MODELS = ("linearized", "frozen")


def _sph_loop(problem, scene, n, general):
    nb = problem.neighbours
    (index, weight, *packed), layout_bit = problem.loop_args()       # the layout run_sph takes
    if general:
        arrays = [np.ascontiguousarray(a) for a in (problem.rho0, problem.c, problem.d, problem.profile)]
        flags = loops.DAMPING | loops.FORCE | layout_bit
    else:
        arrays = packed
        flags = problem.flags(False) | layout_bit
    g = np.zeros((n, 3))
    method = METHODS[scene.sph.integrator]
    out = np.zeros((1, problem.n))
    state = {}

    def go():
        v, rho = problem.v0.copy(), problem.rho0.copy()
        loops.advance(method, v, rho, 0, n, scene.sph.dt, g, index, weight, *arrays, flags,
                   np.array([n]), 0, out, out.copy(), 64, np.inf, nb.dx)   # energy checked as in run_sph
        state["v"] = v
    return go, state


def skip_savings(scene, steps=20000, k=None, repeats=5, fmu=True, reduced_factor=10):
    """Rows (solver, specialised µs/step, general µs/step, saving) for ``scene``; ``fmu``: with the FMU's C core."""
    problem = build_problem(scene)
    n = min(steps, step_count(scene.T, scene.sph.dt))
    n_rom = reduced_factor * n          # a reduced step costs a tenth of a full one or less: time more of them
    rows = []
    fast, sf = _sph_loop(problem, scene, n, general=False)
    slow, sg = _sph_loop(problem, scene, n, general=True)
    t_fast, t_slow = median_times_interleaved([fast, slow], repeats)
    assert np.array_equal(sf["v"], sg["v"]) or not (problem.terms["damping"] or problem.terms["force_profile"])
    rows.append(("full SPH", 1e6 * t_fast / n, 1e6 * t_slow / n))

    basis, run = basis_for_scene(scene, progress=False, problem=problem)
    k = k or max(accel_modes(scene, basis))
    built = {}                                  # one set of operators per basis kind, shared by its models
    for model in SKIP_MODELS:
        spec = get_model(model)
        if spec.basis_kind not in built:
            ops = spec.build(problem, basis, k, k, input_direction="never", **spec.paper_build)
            # the general path: a zero damping matrix and a zero-force input row, evaluated every step
            general = ops.with_every_term()
            built[spec.basis_kind] = ops, general
        ops, general = built[spec.basis_kind]
        res = {}
        # a model refreshed every n_freeze steps costs O(k²) per step; the others O(N k), like a full one
        steps_m = n_rom if spec.uses_n_freeze else n

        def run_with(o, key):
            def go():
                res[key] = spec.run(o, problem, n_steps=steps_m, dt=scene.sph.dt, sample_steps=[steps_m],
                                    options=spec.select_options(n_freeze=10), force=lambda t: np.zeros_like(t))
            return go
        tf, tg = median_times_interleaved([run_with(ops, "fast"), run_with(general, "slow")], repeats)
        np.testing.assert_array_equal(res["fast"].a_v, res["slow"].a_v)
        rows.append((f"{model} POD-MOR (k = {k})", 1e6 * tf / steps_m, 1e6 * tg / steps_m))
    row = _fmu_core_rows(scene, problem, k, reduced_factor * n_rom, repeats) if fmu else None
    if row is not None:
        rows.append(row)
    return [{"scene": scene.name, "solver": s, "specialised_us": a, "general_us": b, "saving": 1 - a / b}
            for s, a, b in rows]


def _fmu_core_rows(scene, problem, k, n, repeats):
    """The FMU's C core (the frozen step of fmu_src/rom_frozen.c): the scene's resources against the same
    resources with a zero damping matrix and a zero input column present (flags set), so that the step evaluates
    both terms every step.

    Returns (label, specialised µs/step, general µs/step), or None when the core cannot be built here.
    """
    try:
        core = Core(ensure_binaries(quiet=True).core)
    except Exception:                     # no compiler or cmake: the Python rows stand alone
        return None
    data, *_ = reduced_model(scene, k, 10, DEFAULT_PROBES, scene.sph.integrator, progress=False, problem=problem)
    general = dataclasses.replace(data, D=data.D if data.D is not None else np.zeros((data.k_v, data.k_v)),
                                  p=data.p if data.p is not None else np.zeros(data.k_v))
    models = [core.load(pack(d)) for d in (data, general)]
    try:
        def runner(model):
            def go():
                model.reset()
                model.advance(n)
            return go
        times = median_times_interleaved([runner(m) for m in models], repeats)
        states = [m.reduced_state() for m in models]
    finally:
        for m in models:
            m.close()
    np.testing.assert_array_equal(states[0], states[1])
    return (f"FMU core, C (k = {k})", 1e6 * times[0] / n, 1e6 * times[1] / n)
