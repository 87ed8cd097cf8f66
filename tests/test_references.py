"""Continuum references of eqs. 2.2-2.4: orders against the exact solution, agreement, invariants, CLI."""

import h5py
import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.compare import error_table
from sphrom.norms import relative_l2
from sphrom.references import fd, pypde_ref, skfem_ref
from sphrom.references.common import coefficient_breaks, interpolate, step_plan
from sphrom.references.convergence import observed_orders
from sphrom.references.exact import exact_solution
from sphrom.runio import read_run
from sphrom.sph.operator import particle_positions

T = 1.0
TIMES = np.arange(51) * 0.02              # every 0.02 s to T = 1 s
X = particle_positions(1.0, 64)           # the SPH particles of N = 64
SMOOTH_V0 = "1e-3*sum(l*sin(2*pi*l*x/L) for l in range(1, 4))"


@pytest.fixture(scope="module")
def truth():
    """Scenes shrunk to T = 1 s and their exact (v, ρ) at X, TIMES."""
    scenes = {
        "multimode": small_scene("multimode", T=T, n=64, every=10),
        "damped_forced": small_scene("damped_forced", T=T, n=64, every=10),
        # damped_forced with a smooth v0: every term (damping, force) at the schemes' design order
        "smooth_forced": small_scene("damped_forced", T=T, n=64, every=10, v0=SMOOTH_V0),
    }
    return {name: (sc, *exact_solution(sc, X, TIMES)) for name, sc in scenes.items()}


# solver label -> (run(scene, N), resolutions)
SOLVERS = {
    "skfem-P1": (lambda sc, n: skfem_ref.solve(sc, n, 0.32 / n, X, TIMES, order=1), (32, 64, 128)),
    "skfem-P2": (lambda sc, n: skfem_ref.solve(sc, n, 2.56 / n**2, X, TIMES, order=2), (16, 32, 64)),
    "pypde": (lambda sc, n: pypde_ref.solve(sc, n, 0.32 / n, X, TIMES, backend="numpy"), (32, 64, 128)),
    "fd": (lambda sc, n: fd.solve(sc, n, 0.32 / n, X, TIMES), (64, 128, 256)),
    "fd-collocated": (lambda sc, n: fd.solve(sc, n, 0.32 / n, X, TIMES, layout="collocated"), (64, 128, 256)),
}

# expected observed order on the last pair of resolutions: (v, ρ - ρ0), (low, high)
# Δt ∝ h for P1, pypde and fd; Δt ∝ h² for P2 (Newmark's O(Δt²) is then O(h⁴), below P2's O(h³)).
# damped_forced's v0 (eq. 3.8) has a kink at x = 0: a dispersive scheme then converges at ~1.5-2 in L²,
# whatever its design order, which shows on the fourth-order pypde.
EXPECTED = {
    ("skfem-P1", "multimode"): ((1.8, 2.2), (1.8, 2.2)),
    ("skfem-P1", "damped_forced"): ((1.8, 2.2), (1.8, 2.2)),
    ("skfem-P2", "multimode"): ((2.7, 6.0), (2.7, 6.0)),
    ("skfem-P2", "damped_forced"): ((2.7, 6.0), (2.7, 6.0)),
    ("pypde", "multimode"): ((3.7, 4.3), (3.7, 4.3)),
    ("pypde", "smooth_forced"): ((3.7, 4.3), (3.7, 4.3)),
    ("pypde", "damped_forced"): ((1.5, 4.3), (1.5, 4.3)),
    ("fd", "multimode"): ((1.8, 2.2), (1.8, 2.2)),
    ("fd", "damped_forced"): ((1.8, 2.2), (1.8, 2.2)),
    ("fd-collocated", "multimode"): ((1.8, 2.2), (0.9, 1.1)),
    ("fd-collocated", "damped_forced"): ((1.8, 2.2), (0.9, 1.1)),
}


@pytest.mark.parametrize("solver, scene_name", list(EXPECTED))
def test_convergence_order_against_exact(truth, solver, scene_name):
    scene, v_ex, rho_ex = truth[scene_name]
    run, resolutions = SOLVERS[solver]
    rho0 = scene.field("rho0", X)
    errors = [error_table(*run(scene, n)[:2], v_ex, rho_ex, TIMES, rho0) for n in resolutions]
    ev = [e["v"] for e in errors]
    er = [e["rho_var"] for e in errors]
    ov, orr = observed_orders(resolutions, ev), observed_orders(resolutions, er)
    print(f"\n{solver} {scene_name}: N {resolutions} err v {np.array(ev)} order {ov[1:]}; "
          f"err rho-rho0 {np.array(er)} order {orr[1:]}")
    (v_lo, v_hi), (r_lo, r_hi) = EXPECTED[(solver, scene_name)]
    assert v_lo <= ov[-1] <= v_hi, (ov, ev)
    assert r_lo <= orr[-1] <= r_hi, (orr, er)
    assert np.all(np.diff(ev) < 0) and np.all(np.diff(er) < 0)


def test_skfem_and_pypde_agree_on_the_heterogeneous_scene():
    """The jump of c (eq. 3.11) makes kinks that travel: every scheme is first order there."""
    scene = small_scene("heterogeneous", T=T, n=64, every=10)
    ref_v, ref_rho, _ = skfem_ref.solve(scene, 512, 2e-4, X, TIMES, order=2)
    diffs = {}
    for label, run in (("pypde", lambda n: pypde_ref.solve(scene, n, 0.32 / n, X, TIMES, backend="numpy")),
                       ("skfem-P1", lambda n: skfem_ref.solve(scene, n, 0.32 / n, X, TIMES, order=1))):
        d = []
        for n in (64, 128):
            v, rho, _ = run(n)
            d.append((relative_l2(v, ref_v, TIMES), relative_l2(rho, ref_rho, TIMES, baseline=1.0)))
        d = np.array(d)
        order = np.log2(d[0] / d[1])
        print(f"\n{label} vs skfem P2 (N = 512) on heterogeneous: N = 64, 128: v {d[:, 0]}, rho-rho0 {d[:, 1]}; "
              f"observed order v {order[0]:.2f}, rho-rho0 {order[1]:.2f}")
        assert np.all(order >= 0.8), (label, d)
        assert np.all(d[1] <= 1.0 / 128), (label, d)      # first order: |e| <= C h with C = 1 m^-1 · m
        diffs[label] = d
    v_p, rho_p, _ = pypde_ref.solve(scene, 128, 0.32 / 128, X, TIMES, backend="numpy")
    v_f, rho_f, _ = skfem_ref.solve(scene, 128, 0.32 / 128, X, TIMES, order=1)
    assert relative_l2(v_p, v_f, TIMES) <= 2.0 / 128


def test_heterogeneous_jumps_are_found_and_interpolated_piecewise():
    scene = small_scene("heterogeneous", T=T, n=64)
    breaks = coefficient_breaks(scene)
    np.testing.assert_allclose(breaks, [0.0, 0.5], atol=1e-12)
    # a function with a jump at 0.5 and a kink at 0: exact for piecewise cubics, no overshoot
    xs = (np.arange(40) + 0.5) / 40
    f = np.where(xs <= 0.5, xs**3, 2.0 - xs)
    xq = np.linspace(0.0, 0.999, 97)
    got = interpolate(xs, f[None, :], xq, 1.0, breaks)[0]
    want = np.where(xq <= 0.5, xq**3, 2.0 - xq)
    np.testing.assert_allclose(got[(xq > 0.01) & (xq < 0.49)], want[(xq > 0.01) & (xq < 0.49)], atol=1e-12)
    np.testing.assert_allclose(got[xq > 0.51], want[xq > 0.51], atol=1e-12)


def test_step_plan_lands_on_every_output_time():
    dt, steps = step_plan(np.arange(11) * 0.016, 1e-3)
    assert dt == pytest.approx(0.016 / 16) and steps[-1] == 160
    dt, steps = step_plan(np.array([0.0, 0.3, 0.5]), 0.04)        # common spacing 0.1
    np.testing.assert_array_equal(steps * dt, [0.0, 0.3, 0.5])
    assert dt <= 0.04


CONSERVATION_SCENE = dict(base="heterogeneous", T=T, n=32, every=10, rho0="1 + 0.3*sin(2*pi*x/L)",
                          v0="2e-2*(1 + sin(2*pi*x/L) + 0.7*sin(4*pi*x/L + 1))")


@pytest.mark.parametrize("label, run, dts, length_order", [
    ("fd (Heun)", lambda sc, dt: fd.run(sc, 64, dt, TIMES), (4e-3, 2e-3), 2.0),
    ("pypde (RK4)", lambda sc, dt: pypde_ref.run(sc, 64, dt, TIMES, backend="numpy"), (2e-2, 1e-2), 4.0),
    ("skfem P1", lambda sc, dt: skfem_ref.run(sc, 64, dt, TIMES, order=1), (2e-2, 1e-2), None),
    ("skfem P2", lambda sc, dt: skfem_ref.run(sc, 32, dt, TIMES, order=2), (2e-2, 1e-2), None),
])
def test_momentum_and_length_conserved_to_the_schemes_order(label, run, dts, length_order):
    """d = f = 0, non-uniform ρ0, the jump of c, a large amplitude: ∫ρ0 v and ∫ρ0/ρ are invariants."""
    scene = small_scene(**CONSERVATION_SCENE)
    drifts = []
    for dt in dts:
        r = run(scene, dt)
        p, length = r.momentum(), r.length()
        assert np.max(np.abs(p - p[0])) <= 1e-12 * abs(p[0])           # momentum: round-off, any scheme
        assert p[0] == pytest.approx(0.023, rel=1e-12)        # ∫ρ0 v0 = 2e-2 (1 + 0.3/2) (ρ0, v0 above)
        drifts.append(np.max(np.abs(length - length[0])) / length[0])
    print(f"\n{label}: length drift {drifts}")
    if length_order is None:       # skfem: ∫(1 + u_x) = L identically for periodic u
        assert max(drifts) <= 1e-14
    else:
        observed = np.log2(drifts[0] / drifts[1])
        assert observed >= length_order - 0.2, (observed, drifts)
        assert drifts[0] < 1e-7


# --------------------------------------------------------------------------- CLI
def test_reference_cli_file_layout_and_attributes(tmp_path, capsys):
    out = tmp_path / "ref.h5"
    assert main(["reference", "multimode", "--solver", "pypde", "--resolution", "64", "--t-end", "0.5",
                 "--every", "50", "--n-particles", "32", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "relative L2 error vs exact" in text and "CFL" in text
    run = read_run(out)
    assert run.t.shape == (51,) and run.x.shape == (32,) and run.v.shape == (51, 32) == run.rho.shape
    np.testing.assert_allclose(run.t, np.arange(51) * 0.01, atol=1e-12)
    np.testing.assert_allclose(run.x, particle_positions(1.0, 32))
    np.testing.assert_allclose(run.steps * run.attrs["solver.dt"], run.t, atol=1e-12)
    with h5py.File(out) as h5:
        a = h5.attrs
        assert h5["v"].attrs["units"] == "m s^-1" and h5["rho"].attrs["units"] == "kg m^-3"
        assert a["solver"] == "pypde" and a["solver.resolution"] == 64 and a["scene.name"] == "multimode"
        assert a["scene.T"] == 0.5 and a["wall_time_s"] > 0 and "[sph]" in a["scene.toml"]
        assert 0 < a["error.exact.v"] < 1e-3 and 0 < a["error.exact.rho_var"] < 1e-3
        assert "RK4" in a["solver.method"]


@pytest.mark.parametrize("solver, extra", [("skfem", ["--order", "2", "--resolution", "16", "--dt", "0.005"]),
                                           ("fd", ["--resolution", "64", "--layout", "collocated"])])
def test_reference_cli_heterogeneous_has_no_exact_errors(tmp_path, capsys, solver, extra):
    out = tmp_path / "het.h5"
    assert main(["reference", "heterogeneous", "--solver", solver, *extra, "--t-end", "0.32", "--out", str(out),
                 "--quiet"]) == 0
    assert "no exact solution" in capsys.readouterr().out
    run = read_run(out)
    assert run.v.shape == (21, 100) and np.all(np.isfinite(run.rho))
    assert not any(k.startswith("error.") for k in run.attrs) and run.attrs["solver"] == solver


def test_reference_cli_exact(tmp_path):
    out = tmp_path / "ex.h5"
    assert main(["reference", "damped_forced", "--solver", "exact", "--t-end", "0.24", "--out", str(out)]) == 0
    run = read_run(out)
    v, rho = exact_solution(load_short("damped_forced", 0.24), run.x, run.t)
    np.testing.assert_array_equal(run.v, v)


def load_short(name, T):
    from sphrom.scene import load_scene
    return load_scene(name).with_T(T)


@pytest.mark.parametrize("argv, expect", [
    (["multimode", "--solver", "pypde", "--resolution", "4"], "--resolution: 4 is out of range (allowed: an integer"),
    (["multimode", "--solver", "skfem", "--dt", "0"], "--dt: 0.0 is out of range (allowed: a number > 0)"),
    (["multimode", "--solver", "fd", "--dt", "0.01"], "CFL number"),
    (["multimode", "--solver", "pypde", "--resolution", "1024", "--dt", "0.012", "--t-end", "1"], "--dt: 0.012"),
    (["multimode", "--solver", "skfem", "--order", "3"], "--order: 3 is out of range (allowed: 1 or 2)"),
    (["multimode", "--solver", "fd", "--order", "2"], "--order: only for --solver skfem"),
    (["multimode", "--solver", "fem"], "--solver: 'fem' is out of range"),
    (["multimode", "--solver", "exact", "--resolution", "64"], "--resolution: not used by --solver exact"),
    (["heterogeneous", "--solver", "exact"], "--solver: exact is out of range"),
    (["multimode", "--solver", "fd", "--t-end", "-1"], "--t-end"),
])
def test_reference_cli_bad_option_is_one_line_exit_2_no_file(tmp_path, capsys, argv, expect):
    out = tmp_path / "bad.h5"
    assert main(["reference", *argv, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expect in err, err
    assert list(tmp_path.iterdir()) == []
