"""The exact linear reduced model in specific volume, Python side (the FMU side is test_fmu_exact.py)."""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.compare import error_table
from sphrom.pod.pipeline import basis_for_scene, error_steps, on_steps
from sphrom.rom.exact_linear import build_linear_operators, propagators, run_exact
from sphrom.sph.solver import run_sph


def _ops(scene, k, spec=None):
    basis, run = basis_for_scene(scene, spec, progress=False)
    return build_linear_operators(run.problem, basis.U_ve[:, :k], basis.U_e[:, :k]), basis, run


def test_bases_are_energy_orthonormal_and_operator_block_skew():
    scene = small_scene("heterogeneous", T=1.0, n=48, rho0="1 + 0.3*sin(2*pi*x/L)")
    ops, basis, run = _ops(scene, 8, {"count": 25, "window": [0, 1.0]})
    p = run.problem
    np.testing.assert_allclose(basis.U_ve.T @ (p.rho0[:, None] * basis.U_ve), np.eye(basis.U_ve.shape[1]), atol=1e-12)
    np.testing.assert_allclose(basis.U_e.T @ (p.c[:, None] * basis.U_e), np.eye(basis.U_e.shape[1]), atol=1e-12)
    k = ops.k_v
    A = ops.A
    np.testing.assert_array_equal(A[:k, :k], 0.0)                       # d = 0
    np.testing.assert_array_equal(A[k:, :k], -A[:k, k:].T)              # ḃ = -Pᵀ a: skew
    assert ops.skew


def test_energy_conserved_over_t_1000():
    scene = small_scene("heterogeneous", T=1.0, n=40)
    ops, _, _ = _ops(scene, 8, {"count": 20, "window": [0, 1.0]})
    res = run_exact(ops, np.arange(0, 1001, 10.0), step=0.01)
    e = ops.energy(res.z)
    assert np.max(np.abs(e - e[0])) / e[0] <= 1e-12


def test_with_all_modes_it_is_the_linear_sph_system_exactly_in_time():
    """k = N: the model is the semi-discrete SPH system (linear in J), so a fine RK4 SPH run
    agrees to its own time error - an independent check of the operators and the exponential."""
    # a force linear in t with a non-uniform profile: the linear input hold is exact for it
    scene = small_scene("damped_forced", T=1.0, n=24, d="3", dt=1e-3, integrator="rk4", every=20,
                        f="1e-2*(1 + 3*t)", profile="1 + 0.5*cos(2*pi*x/L)")
    basis, run = basis_for_scene(scene, {"all": True}, progress=False)
    ops = build_linear_operators(run.problem, basis.U_ve, basis.U_e)
    assert ops.k_v >= 24 and ops.k_e == 24
    sph = run_sph(scene, progress=False)
    res = run_exact(ops, sph.t, step=0.02, force=scene.force)
    err = error_table(res.v, res.rho, sph.v, sph.rho, sph.t, run.problem.rho0)
    assert err["v"] < 1e-9 and err["rho_var"] < 1e-9, err


def test_independent_of_the_step():
    scene = small_scene("multimode", T=2.0, n=40, every=50)
    ops, _, _ = _ops(scene, 7, {"count": 30, "window": [0, 1.6]})
    t = np.linspace(0, 2.0, 21)
    a = run_exact(ops, t, step=0.1).z
    b = run_exact(ops, t, step=0.0125).z
    c = run_exact(ops, t, step=0.03).z                                   # samples off its grid: shortened steps
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    assert np.max(np.abs(a - c)) <= 1e-12 * np.max(np.abs(a))


def test_input_hold_converges_at_second_order_and_matches_quadrature():
    scene = small_scene("damped_forced", T=1.0, n=32)
    ops, _, _ = _ops(scene, 6, {"count": 10, "window": [0, 1.0]})
    t = np.array([0.0, 1.0])
    z = {h: run_exact(ops, t, step=h, force=scene.force).z[-1] for h in (0.004, 0.002, 0.001)}   # f has 100 rad/s at T = 1
    e1, e2 = np.linalg.norm(z[0.004] - z[0.001]), np.linalg.norm(z[0.002] - z[0.001])
    assert 3.0 < e1 / e2 < 5.5                                          # O(H²): (1 - 1/16)/(1/4 - 1/16) = 5
    phi, g0, g1 = propagators(ops.A, ops.B, 0.1)
    with pytest.raises(AssertionError):
        np.testing.assert_allclose(g1, 0)                               # the linear-hold column exists


def test_rom_exact_command(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(small_scene("heterogeneous", T=2.0, n=40, every=25).text)
    basis = tmp_path / "b.h5"
    assert main(["pod", str(path), "--snapshots", "20", "--window", "0,2", "--modes", "8",
                 "--out", str(basis), "--quiet"]) == 0
    out = tmp_path / "r.h5"
    assert main(["rom", str(path), "--basis", str(basis), "--model", "exact", "--step", "0.01",
                 "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "matrix exponential, H = 0.01 s" in text and "vs full SPH" in text


def test_sph_exact_in_time_and_the_pod_error_split():
    """The full SPH solved exactly in time (every particle a mode) is what a fine RK4 SPH converges to; against
    it the exact model's error is a POD error like the original's (undamped scene), while against the Euler SPH
    it also carries the SPH's time error."""
    from sphrom.report.exact_model import compare_exact_and_original, sph_exact_in_time
    scene = small_scene("multimode", T=1.0, n=32, every=25)
    fine = run_sph(scene.with_sph(dt=scene.sph.dt / 4, integrator="rk4"), progress=False)
    v, rho = sph_exact_in_time(fine.problem, fine.t)
    err = error_table(fine.v, fine.rho, v, rho, fine.t, fine.problem.rho0)
    assert err["v"] < 1e-8 and err["rho_var"] < 1e-8, err
    (row,) = compare_exact_and_original(scene, ks=[6])
    assert row["time_v"] > 10 * row["pure_v"]                 # Euler's time error dominates the exact model's gap
    assert row["exact_v"] == pytest.approx(row["time_v"], rel=0.2)
    assert row["pure_v"] <= 2 * row["orig_v"] and row["pure_rho"] <= 2 * row["orig_rho"]
