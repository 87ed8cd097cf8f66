"""The full linear SPH as an LTI system, balanced reduced models and their certified error bounds."""

import numpy as np
import pytest
import scipy.linalg as sla

from sphrom.rom.balanced import (balanced_reduce, balancing, error_bounds, hinf_norm, order_from_tolerance,
                                  reduced_from_exact, truncate)
from sphrom.rom.lti import full_linear_system, input_norm, output_energy, sample_outputs, sph_rates
from sphrom.rom.operators import probe_rows
from sphrom.sph.solver import build_problem, run_sph

from conftest import small_scene


def _problem(base, **kw):
    return build_problem(small_scene(base, **kw))


def _forces(rng, T, h, count):
    """Smooth (random sines up to 3 Hz) force samples on t = 0, h, ..., T, shape (K+1, count)."""
    t = np.arange(int(round(T / h)) + 1) * h
    out = np.zeros((t.size, count))
    for m in range(count):
        for _ in range(4):
            out[:, m] += rng.normal() * np.sin(2 * np.pi * rng.uniform(0, 3) * t + rng.uniform(0, 2 * np.pi))
    return out


def _free_error_l2(lti, red, rows, h=1e-4):
    """‖y_j - y_r,j‖_L2(0,T) of the free responses from x0, by Simpson's rule on samples (independent of Van Loan)."""
    from scipy.integrate import simpson
    k = int(round(lti.T / h))
    y = sample_outputs(lti.dense(), None, lti.C[rows], lti.x0, h, np.zeros(k + 1))
    yr = sample_outputs(red.Ar, None, red.Cr[rows], red.x0, h, np.zeros(k + 1))
    return np.sqrt(simpson((y - yr) ** 2, dx=h, axis=0))


def _measured_force_gain(lti, red, h, U, hold="linear"):
    """‖y_err,j‖_L2(0,T) / ‖f‖_L2(0,T) from rest, exactly (shape (P, m))."""
    Ae = sla.block_diag(lti.dense(), red.Ar)
    be = np.concatenate([lti.B[:, 0], red.Br[:, 0]])
    Ce = np.hstack([lti.C[:lti.n_probes], -red.Cr[:lti.n_probes]])
    E = output_energy(Ae, be, Ce, np.zeros((Ae.shape[0], U.shape[1])), h, U, hold=hold)
    return np.sqrt(np.maximum(E, 0.0)) / input_norm(h, U, hold)


@pytest.mark.cpu_sensitive
# --------------------------------------------------------------------------- the LTI system
@pytest.mark.parametrize("base,fields", [
    ("damped_forced", {}),
    ("heterogeneous", {}),                                            # c jumps 0.1 -> 0.2
    ("damped_forced", {"rho0": "1 + 0.3*sin(2*pi*x/L)", "c": "0.1 + 0.05*cos(2*pi*x/L)",
                       "d": "5 + 4*sin(4*pi*x/L)", "profile": "1 + x/L"}),
])
def test_lti_rhs_equals_sph_rhs(base, fields):
    problem = _problem(base, **fields)
    lti = full_linear_system(problem)
    rng = np.random.default_rng(1)
    for f in (0.0, 0.37):
        v = 1e-3 * rng.standard_normal(problem.n)
        e = 1e-3 * rng.standard_normal(problem.n)
        dv, de = sph_rates(problem, v, problem.rho0 / (1.0 + e), f)
        dv_l, de_l = lti.fields(lti.rhs(lti.state(v, e), f))
        assert np.max(np.abs(dv_l - dv)) <= 1e-12 * np.max(np.abs(dv))
        assert np.max(np.abs(de_l - de)) <= 1e-12 * np.max(np.abs(de))
    # the skew part is skew (G on the periodic uniform lattice), the damping part symmetric >= 0
    assert abs(lti.J + lti.J.T).max() <= 1e-12 * abs(lti.J).max()
    assert np.all(lti.R.diagonal() >= 0)
    # the null modes: A n = 0, Aᵀ n = 0, uncontrollable
    assert lti.null.shape[1] == 2
    assert np.max(np.abs(lti.A @ lti.null)) <= 1e-12 * abs(lti.A).max()
    assert np.max(np.abs(lti.A.T @ lti.null)) <= 1e-12 * abs(lti.A).max()
    assert np.max(np.abs(lti.null.T @ lti.B)) <= 1e-14 * np.max(np.abs(lti.B))


def test_lti_outputs_are_the_fmu_probes():
    problem = _problem("heterogeneous")
    lti = full_linear_system(problem, probes=(0.0, 0.25, 0.66, 1.0))
    rng = np.random.default_rng(2)
    v, e = rng.standard_normal(problem.n), rng.standard_normal(problem.n)
    y = lti.C @ lti.state(v, e)
    L = problem.scene.L
    assert np.allclose(y[:4], probe_rows(v[:, None], problem.x, L, lti.probes)[:, 0], rtol=0, atol=1e-14)
    assert np.allclose(y[4:], probe_rows(e[:, None], problem.x, L, lti.probes)[:, 0], rtol=0, atol=1e-14)
    assert np.array_equal(lti.B[:, 1], lti.x0)


def test_lti_free_response_matches_sph_rk4():
    """Free response of the LTI system (exact exponential) against the full SPH with RK4 at a small step."""
    scene = small_scene("multimode", T=0.2, n=32, dt=1e-4, integrator="rk4", every=100)
    run = run_sph(scene, progress=False)
    problem = run.problem
    lti = full_linear_system(problem)
    h = float(run.t[1] - run.t[0])
    y = sample_outputs(lti.dense(), None, np.eye(lti.order), lti.x0, h, np.zeros(run.t.size))
    v, e = lti.fields(y)
    ref = problem.rho0 / (1.0 + e)
    assert np.max(np.abs(v - run.v)) <= 1e-8 * np.max(np.abs(run.v))
    assert np.max(np.abs(ref - run.rho)) <= 1e-10


def test_output_energy_matches_quadrature():
    """Van Loan's output energy against a fine trapezoid of sampled outputs (two independent paths)."""
    problem = _problem("damped_forced")
    lti = full_linear_system(problem)
    h = 1e-3
    u = _forces(np.random.default_rng(3), 0.5, h, 1)[:, 0]
    A = lti.dense()
    E = output_energy(A, lti.B[:, 0], lti.C, lti.x0, h, u)
    fine = 20
    uf = np.interp(np.arange((u.size - 1) * fine + 1) * (h / fine), np.arange(u.size) * h, u)
    y = sample_outputs(A, lti.B[:, 0], lti.C, lti.x0, h / fine, uf)
    w = np.full(uf.size, h / fine)
    w[[0, -1]] *= 0.5
    assert np.allclose(E, w @ (y * y), rtol=1e-6, atol=0)


# --------------------------------------------------------------------------- norms
def test_hinf_norm_of_a_resonance():
    """|G| peak of ω²/(s² + 2ζωs + ω²) is 1/(2ζ√(1-ζ²)); the bounds bracket it."""
    w0, zeta = 3.0, 0.05
    A = np.array([[0.0, 1.0], [-w0 ** 2, -2 * zeta * w0]])
    b, c = np.array([0.0, 1.0]), np.array([w0 ** 2, 0.0])
    lo, hi, peak = hinf_norm(A, b, c, margin=zeta * w0, tol=1e-6)
    exact = 1.0 / (2 * zeta * np.sqrt(1 - zeta ** 2))
    assert lo <= exact <= hi <= lo * (1 + 3e-6)
    assert abs(peak - w0 * np.sqrt(1 - 2 * zeta ** 2)) < 1e-2


def test_order_from_tolerance_is_monotone():
    hsv = np.array([1.0, 0.5, 0.1, 1e-2, 1e-3, 1e-5, 1e-8])
    orders = [order_from_tolerance(hsv, tol) for tol in (0.5, 1e-1, 1e-2, 1e-3, 1e-5, 1e-9)]
    assert orders == sorted(orders)
    for tol, r in zip((0.5, 1e-1, 1e-2, 1e-3, 1e-5, 1e-9), orders):
        assert hsv[r:].sum() <= tol * hsv.sum()
        assert r == 0 or hsv[r - 1:].sum() > tol * hsv.sum()


# --------------------------------------------------------------------------- balanced truncation (damped)
def test_bt_damped_is_stable_and_within_its_bounds():
    # a non-uniform profile: the uniform one drives only the mean velocity, which BT keeps exactly
    problem = _problem("damped_forced", T=2.0, profile="1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)")
    lti = full_linear_system(problem)
    model = balanced_reduce(lti, order=8)
    assert model.method == "bt" and model.order == 8
    assert np.max(np.linalg.eigvals(model.Ar).real) < 0
    b = error_bounds(lti, model)
    assert b["sigma"] == 0.0 and b["factor"] == 1.0
    # the Hamiltonian bisection's lower end never exceeds BT's a priori bound (independent paths)
    assert np.all(b["hinf"][:, 0] <= model.bt_bound * (1 + 1e-6))
    h = 1e-2
    rng = np.random.default_rng(4)
    U = _forces(rng, lti.T, h, 3)
    gains = _measured_force_gain(lti, model, h, U)
    assert np.all(gains <= b["force_error_bound"][:, None])
    rough = rng.standard_normal((U.shape[0], 3))
    assert np.all(_measured_force_gain(lti, model, h, rough, hold="zero") <= b["force_error_bound"][:, None])
    # free response: the bound holds, and it is the measured error up to the round-off allowance
    measured = _free_error_l2(lti, model, np.arange(3))
    assert np.all(measured <= b["initial_state_error_bound"])
    assert np.allclose(measured, b["initial_state_error"], rtol=1e-6)


def test_tolerance_gives_the_order():
    lti = full_linear_system(_problem("damped_forced", T=2.0))
    bal = balancing(lti)
    orders = [balanced_reduce(lti, tolerance=tol).order for tol in (1e-1, 1e-3, 1e-5)]
    assert orders == sorted(orders)
    assert orders == [order_from_tolerance(bal.hsv, tol) for tol in (1e-1, 1e-3, 1e-5)]
    assert truncate(lti, bal, 6).bt_bound == pytest.approx(2 * bal.hsv[6:].sum())


def test_bt_refuses_undamped_scene():
    lti = full_linear_system(_problem("multimode"))
    with pytest.raises(ValueError, match="method 'bt'"):
        balanced_reduce(lti, order=6, method="bt")


# --------------------------------------------------------------------------- structure-preserving (undamped)
def test_galerkin_undamped_conserves_energy_and_is_within_its_bounds():
    problem = _problem("multimode", T=1.0, profile="1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)")
    lti = full_linear_system(problem)
    model = balanced_reduce(lti, order=10)
    assert model.method == "galerkin" and model.skew
    assert np.array_equal(model.Ar, -model.Ar.T)                     # skew to the last bit
    t = np.linspace(0.0, 1000.0, 501)
    E = model.energy(model.free_response(t))
    assert np.max(np.abs(E - E[0])) <= 1e-12 * E[0]
    b = error_bounds(lti, model)
    assert b["sigma"] == pytest.approx(1.0 / lti.T) and b["factor"] == pytest.approx(np.e)
    h = 1e-2
    U = _forces(np.random.default_rng(5), lti.T, h, 4)
    assert np.all(_measured_force_gain(lti, model, h, U) <= b["force_error_bound"][:, None])
    measured = _free_error_l2(lti, model, np.arange(3))
    assert np.all(measured <= b["initial_state_error_bound"])
    assert np.allclose(measured, b["initial_state_error"], rtol=1e-6)


# --------------------------------------------------------------------------- the exact POD model
@pytest.mark.parametrize("base", ["damped_forced", "multimode"])
def test_exact_pod_model_is_a_galerkin_model_within_its_bound(base):
    from sphrom.pod.pipeline import basis_for_scene
    from sphrom.rom.exact_linear import build_linear_operators
    scene = small_scene(base, T=1.0)
    problem = build_problem(scene)
    lti = full_linear_system(problem)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    ops = build_linear_operators(problem, basis.U_ve[:, :4], basis.U_e[:, :4], input_direction="needed")
    red = reduced_from_exact(lti, ops)
    V = red.V
    assert np.allclose(V.T @ V, np.eye(V.shape[1]), atol=1e-12)
    assert np.allclose(red.Ar, V.T @ (lti.A @ V), atol=1e-10 * np.abs(red.Ar).max())
    assert np.allclose(red.x0, ops.z0, atol=1e-15)
    b = error_bounds(lti, red)
    h = 1e-2
    U = _forces(np.random.default_rng(6), lti.T, h, 3)
    U[:, 0] = scene.force(np.arange(U.shape[0]) * h)                 # the scene's own force (zero for multimode)
    U = U[:, np.any(U != 0, axis=0)]
    assert np.all(_measured_force_gain(lti, red, h, U) <= b["force_error_bound"][:, None])


def test_bounds_are_finite_at_a_probe_the_motion_does_not_reach():
    """multimode's initial velocity is antisymmetric about x/L = 0.5, so the probe there sees no free response:
    its output energies are 0 computed as about -1e-20.  The bounds stay finite (they were NaN, and packaging
    the exact FMU of multimode failed), and the measured errors stay below them."""
    from sphrom.pod.pipeline import basis_for_scene
    from sphrom.rom.exact_linear import build_linear_operators
    scene = small_scene("multimode", T=1.0)
    problem = build_problem(scene)
    lti = full_linear_system(problem, probes=(0.25, 0.5))
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    ops = build_linear_operators(problem, basis.U_ve[:, :4], basis.U_e[:, :4], input_direction="needed")
    red = reduced_from_exact(lti, ops)
    b = error_bounds(lti, red)
    measured = _free_error_l2(lti, red, np.arange(2))
    assert np.all(np.isfinite(b["initial_state_error_bound"])) and np.all(np.isfinite(b["force_error_bound"]))
    assert measured[1] <= 1e-9 * measured[0]                         # the node: nothing to get wrong
    assert np.all(measured <= b["initial_state_error_bound"])
    assert b["initial_state_error_bound"][1] <= 1e-6 * b["full_output_norm"][0]     # round-off allowance only


# --------------------------------------------------------------------------- the registry's model and the CLI
def _small_toml(tmp_path):
    """damped_forced shrunk (N = 32, T = 0.5 s, RK4 at dt = 1e-4) as a scene file."""
    from sphrom.scene import dump_toml, scene_dict
    path = tmp_path / "small.toml"
    path.write_text(dump_toml(scene_dict(small_scene("damped_forced", T=0.5, n=32, dt=1e-4, integrator="rk4",
                                                     every=20))))
    return path


def _table(text):
    """{probe x/L: (force bound, measured force gain, initial bound, measured initial error)} of the bounds table."""
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) == 6:
            try:
                rows[float(cells[0])] = tuple(float(c) for c in cells[1:5])
            except ValueError:
                continue
    return rows


def test_rom_balanced_command_prints_its_bounds_and_the_errors_stay_below_them(tmp_path, capsys):
    import h5py
    from sphrom.cli import main
    from sphrom.rom import get_model
    scene_file = _small_toml(tmp_path)
    out = tmp_path / "bal.h5"
    assert main(["rom", str(scene_file), "--model", "balanced", "--modes", "6", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "order r = 6 (bt: square-root balanced truncation)" in text
    assert "force_error_bound [s]" in text and "initial_state_error_bound [m s^-1 s^1/2]" in text
    rows = _table(text)
    assert sorted(rows) == [0.25, 0.5, 0.66]
    for fb, gain, ib, measured in rows.values():
        assert 0 < gain <= fb and 0 < measured <= ib             # measured (Simpson, exact in time) <= certified
    with h5py.File(out) as h5:
        a = h5.attrs
        assert a["solver.model"] == "balanced" and a["solver.order"] == 6 and a["solver.method"] == "bt"
        assert h5["x_r"].shape == (h5["t"].size, 6) and h5["y"].shape == (h5["t"].size, 6)
        assert h5["v"].shape == (h5["t"].size, 32) and np.all(np.isfinite(h5["rho"][()]))
        # the printed bounds are the file's, and the file's are error_bounds' of the same model
        np.testing.assert_allclose(a["bound.initial_state_error_bound"], [rows[p][2] for p in (0.25, 0.5, 0.66)],
                                   rtol=1e-4)
        assert np.all(a["bound.initial_state_error_measured"] <= a["bound.initial_state_error_bound"])
        assert 0 < a["error.sph.probes.v"] < 0.05
    # the command's model is the registry's: the same build gives the same outputs
    problem = build_problem(small_scene("damped_forced", T=0.5, n=32, dt=1e-4, integrator="rk4", every=20))
    ops = get_model("balanced").build(problem, None, 6, 6)
    b = error_bounds(ops.lti, ops.reduced)
    with h5py.File(out) as h5:
        np.testing.assert_allclose(h5.attrs["bound.force_error_bound"], b["force_error_bound"], rtol=1e-3)


def test_rom_balanced_needs_no_basis_and_the_others_do(tmp_path, capsys):
    from sphrom.cli import main
    from sphrom.rom import MODELS
    scene_file = _small_toml(tmp_path)
    out = tmp_path / "r.h5"
    assert main(["rom", str(scene_file), "--model", "balanced", "--order-tolerance", "1e-2", "--out", str(out),
                 "--quiet"]) == 0
    assert "order r = " in capsys.readouterr().out and out.exists()
    for name, model in MODELS.items():
        if not model.needs_basis:
            continue
        path = tmp_path / f"{name}.h5"
        assert main(["rom", str(scene_file), "--model", name, "--out", str(path), "--quiet"]) == 2
        err = capsys.readouterr().err.strip()
        assert err == f"sphrom rom: error: --basis: required for the {name} model (a POD basis from 'sphrom pod')"
        assert not path.exists()
    # bad values: one line naming the option, no file
    for argv, expect in ((["--order-tolerance", "0"], "'0' is out of range (allowed: a number > 0)"),
                         (["--order-tolerance", "2"],
                          "--order-tolerance: 2.0 is out of range (allowed: 0 < order_tolerance < 1)"),
                         (["--tolerance", "2"],               # the earlier name, an alias in 'sphrom rom'
                          "--order-tolerance: 2.0 is out of range (allowed: 0 < order_tolerance < 1)"),
                         (["--modes", "64"], "--modes: 64 is out of range (allowed: 1 to 63, below 2N)"),
                         (["--modes", "6,4"], "--modes: the balanced model takes one order R"),
                         (["--modes", "6", "--order-tolerance", "1e-2"],
                          "--order-tolerance: give --modes R or --order-tolerance"),
                         (["--basis", "b.h5"], "--basis: the balanced model uses no POD basis")):
        path = tmp_path / "bad.h5"
        assert main(["rom", str(scene_file), "--model", "balanced", "--out", str(path), "--quiet", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and expect in err, err
        assert not path.exists()
