"""POD and the three reduced models: exactness limits, agreements between paths, contracts."""

import h5py
import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.errors import SimulationError, UserError
from sphrom.norms import relative_l2
from sphrom.pod.basis import modes_for_energy
from sphrom.pod.io import read_basis
from sphrom.pod.pipeline import basis_for_scene, error_steps, on_steps
from sphrom.pod.snapshots import snapshot_steps
from sphrom.rom.frozen import frozen_advance, refresh_direct_path, refresh_tensor_path
from sphrom.rom.loops import FrozenOperators
from sphrom.rom.operators import augment_with, build_operators, density_matrix, pair_index, probe_rows
from sphrom.rom.registry import get_model
from sphrom.scene import load_scene
from sphrom.sph.solver import build_problem, run_sph, step_count

ORIGINAL, LINEARIZED, FROZEN = (get_model(name) for name in ("original", "linearized", "frozen"))


def test_snapshot_strategies_are_the_papers():
    n = 50000
    sv, sr = snapshot_steps({"count": 100, "window": [0.0, 1.6]}, 2e-4, n)
    np.testing.assert_array_equal(sv, np.arange(100) * 80)                 # spacing 0.016 s
    sv, sr = snapshot_steps({"count": 5, "window": [0.0, 0.1]}, 2e-4, n)
    np.testing.assert_allclose(sv * 2e-4, [0, 0.02, 0.04, 0.06, 0.08])
    sv, sr = snapshot_steps({"times_v": [0, 0.4, 0.8], "times_rho": [0, 0.4, 0.8, 1.2]}, 2e-4, n)
    assert sv.size == 3 and sr.size == 4 and sr[-1] == 6000
    a, _ = snapshot_steps({"count": 100, "window": [0, 0.1], "random": 3}, 2e-4, n)
    b, _ = snapshot_steps({"count": 100, "window": [0, 0.1], "random": 3}, 2e-4, n)
    c, _ = snapshot_steps({"count": 100, "window": [0, 0.1], "random": 4}, 2e-4, n)
    assert np.array_equal(a, b) and not np.array_equal(a, c) and np.unique(a).size == 100 and a.max() < 500
    with pytest.raises(UserError, match="outside the run"):
        snapshot_steps({"times": [11.0]}, 2e-4, n)


def test_pod_is_orthonormal_and_ordered():
    basis, _ = basis_for_scene(small_scene("tenmode", T=1.0, n=48, every=20), {"count": 30, "window": [0, 1.0]},
                               progress=False)
    for U, s in ((basis.U_v, basis.sigma_v), (basis.U_rho, basis.sigma_rho)):
        np.testing.assert_allclose(U.T @ U, np.eye(U.shape[1]), atol=1e-12)
        assert np.all(np.diff(s) <= 0)
    assert modes_for_energy(basis.sigma_v, 1e-30) == basis.sigma_v.size
    s = np.array([10.0, 1.0, 0.1])
    assert modes_for_energy(s, 0.02) == 1 and modes_for_energy(s, 1e-3) == 2


@pytest.mark.parametrize("integrator", ["euler", "symplectic", "rk4"])
def test_original_with_k_equal_n_is_the_full_sph(integrator):
    scene = small_scene("damped_forced", T=0.5, n=20, every=25, integrator=integrator, d="2")
    scene = scene.with_sph(integrator=integrator)
    basis, _ = basis_for_scene(scene, {"all": True}, progress=False)
    assert basis.U_v.shape == (20, 20)
    problem = build_problem(scene)
    ops = build_operators(problem, basis.U_v, basis.U_rho, input_direction="never")
    n = step_count(scene.T, scene.sph.dt)
    res = ORIGINAL.run(ops, problem, n_steps=n, dt=scene.sph.dt, every=25,
                       options=ORIGINAL.options(integrator=integrator))
    full = run_sph(scene, progress=False, sample_steps=res.steps, problem=problem)
    assert np.max(np.abs(res.v - full.v)) <= 1e-12 * np.max(np.abs(full.v))     # round-off over 2500 steps
    assert np.max(np.abs(res.rho - full.rho)) <= 1e-13


@pytest.mark.parametrize("integrator", ["euler", "symplectic"])
def test_frozen_with_nfreeze_1_is_the_linearized_model(integrator):
    scene = small_scene("damped_forced", T=1.0, n=40, every=50)
    basis, run = basis_for_scene(scene, {"count": 20, "window": [0, 1.0]}, progress=False)
    ops = build_operators(run.problem, basis.U_v[:, :8], basis.U_rho[:, :8])
    n = step_count(scene.T, scene.sph.dt)
    lin = LINEARIZED.run(ops, run.problem, n_steps=n, dt=scene.sph.dt, every=50,
                         options=LINEARIZED.options(integrator=integrator))
    fro = FROZEN.run(ops, run.problem, n_steps=n, dt=scene.sph.dt, every=50,
                     options=FROZEN.options(integrator=integrator, n_freeze=1))
    scale = np.max(np.abs(lin.a_v))
    assert np.max(np.abs(lin.a_v - fro.a_v)) <= 1e-12 * scale
    assert np.max(np.abs(lin.a_rho - fro.a_rho)) <= 1e-12 * np.max(np.abs(lin.a_rho))


def test_tensor_refresh_equals_direct_refresh():
    scene = small_scene("heterogeneous", T=1.0, n=64, rho0="1 + 0.2*cos(2*pi*x/L)")
    basis, run = basis_for_scene(scene, {"count": 30, "window": [0, 1.0]}, progress=False)
    ops = build_operators(run.problem, basis.U_v[:, :9], basis.U_rho[:, :7])
    rng = np.random.default_rng(0)
    for _ in range(5):
        ar = ops.a_rho0 * (1 + 0.1 * rng.normal(size=ops.k_rho))
        m_t, m_d = np.empty((7, ops.k_v)), np.empty((7, ops.k_v))
        refresh_tensor_path(ar, ops.T, pair_index(7), m_t)
        refresh_direct_path(ar, ops.U_rho, ops.GU_v, ops.inv_rho0, m_d)
        ref = density_matrix(ops, ar)
        np.testing.assert_allclose(m_t, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
        np.testing.assert_allclose(m_d, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
    n = step_count(scene.T, scene.sph.dt)
    a, b = (FROZEN.run(ops, run.problem, n_steps=n, dt=scene.sph.dt, every=100,
                       options=FROZEN.options(n_freeze=7, refresh=refresh)) for refresh in ("tensor", "direct"))
    assert np.max(np.abs(a.a_v - b.a_v)) <= 1e-11 * np.max(np.abs(a.a_v))


def test_frozen_online_loop_touches_no_particle_array():
    """The tensor path runs with the N-sized arrays removed: its online cost has no N."""
    scene = small_scene("damped_forced", T=0.5, n=40)
    basis, run = basis_for_scene(scene, {"count": 10, "window": [0, 0.5]}, progress=False)
    ops = build_operators(run.problem, basis.U_v[:, :6], basis.U_rho[:, :6])
    n = step_count(scene.T, scene.sph.dt)
    ref = FROZEN.run(ops, run.problem, n_steps=n, dt=scene.sph.dt, sample_steps=[n], options=FROZEN.options(n_freeze=5))
    av, ar = ops.a_v0.copy(), ops.a_rho0.copy()
    out_v, out_r = np.empty((1, ops.k_v)), np.empty((1, ops.k_rho))
    g = scene.force(np.arange(n) * scene.sph.dt)
    loop = FrozenOperators(K=ops.K, b=ops.b, D=ops.D, has_d=True, p=ops.p, has_f=True, T=ops.T, pairs=pair_index(6),
                           use_tensor=True, U_rho=np.empty((0, 6)), GU_v=np.empty((0, ops.k_v)), inv_rho0=np.empty(0),
                           n_freeze=5)
    status, _, _ = frozen_advance(0, av, ar, np.zeros((6, ops.k_v)), np.zeros(ops.k_v), 0, n, scene.sph.dt, g, loop,
                                  np.array([n]), 0, out_v, out_r, 1e300)
    assert status == 0
    np.testing.assert_array_equal(out_v[0], ref.a_v[-1])


def test_input_direction_augmentation():
    rng = np.random.default_rng(2)
    U, _ = np.linalg.qr(rng.normal(size=(30, 4)))
    inside = U @ np.array([1.0, -2.0, 0.5, 0.0])
    U2, err, aug = augment_with(U, inside)
    assert err < 1e-12 and not aug and U2 is U
    ones = np.ones(30)
    U3, err, aug = augment_with(U, ones)
    assert aug and U3.shape == (30, 5)
    assert err == pytest.approx(np.linalg.norm(ones - U @ (U.T @ ones)) / np.linalg.norm(ones))
    np.testing.assert_allclose(U3.T @ U3, np.eye(5), atol=1e-14)
    np.testing.assert_allclose(U3 @ (U3.T @ ones), ones, atol=1e-13)
    # a forced scene: the paper projects the force on the POD modes (and we report what is lost);
    # augmenting puts the whole direction in the basis (the FMU, whose f may be anything)
    scene = small_scene("damped_forced", T=0.5, n=32)
    basis, run = basis_for_scene(scene, {"count": 6, "window": [0, 0.5]}, progress=False)
    prof = run.problem.profile
    proj = build_operators(run.problem, basis.U_v[:, :4], basis.U_rho[:, :4])
    assert proj.k_v == 4 and not proj.augmented and proj.input_error > 1e-6
    np.testing.assert_allclose(proj.p, basis.U_v[:, :4].T @ prof)
    aug = build_operators(run.problem, basis.U_v[:, :4], basis.U_rho[:, :4], input_direction="augment")
    assert aug.augmented and aug.k_v == 5 + aug.input_added and aug.input_error == proj.input_error
    # a uniform force on a uniform bar only moves it rigidly: its directions at every frequency are the constant
    # velocity at most (sphrom.rom.inputs), no strain
    assert aug.input_added <= 1 and aug.input_added_2 == 0
    resid = prof - aug.U_v @ (aug.U_v.T @ prof)
    assert np.linalg.norm(resid) < 1e-12 * np.linalg.norm(prof)
    assert build_operators(run.problem, basis.U_v[:, :4], basis.U_rho[:, :4], input_direction="never").p is None
    # "needed" (the FMU): append only when the modes miss more than the tolerance, else project
    for tol, appended in ((2 * proj.input_error, False), (0.5 * proj.input_error, True)):
        ops = build_operators(run.problem, basis.U_v[:, :4], basis.U_rho[:, :4], input_direction="needed",
                              input_tolerance=tol)
        assert ops.augmented is appended and ops.k_v == 4 + appended + ops.input_added and ops.p is not None
        if not appended:
            np.testing.assert_array_equal(ops.p, proj.p)


def test_probe_rows_interpolate_linearly_and_periodically():
    n, L = 10, 2.0
    x = (np.arange(n) + 0.5) * L / n
    U = np.column_stack([np.sin(2 * np.pi * x / L), x])
    rows = probe_rows(U, x, L, [x[3] / L, (x[3] + x[4]) / (2 * L), 0.0])
    np.testing.assert_allclose(rows[0], U[3])
    np.testing.assert_allclose(rows[1], 0.5 * (U[3] + U[4]))
    np.testing.assert_allclose(rows[2], 0.5 * (U[0] + U[-1]), atol=1e-14)   # across the periodic boundary


def test_errors_decrease_with_modes_and_models_report_times():
    scene = small_scene("multimode", T=2.0, n=50, every=40)
    basis, run = basis_for_scene(scene, {"count": 40, "window": [0, 1.6]}, progress=False)
    steps = error_steps(scene)
    v_sph, _ = on_steps(run, steps)
    n = step_count(scene.T, scene.sph.dt)
    errs = []
    for k in (2, 4, 8):
        ops = build_operators(run.problem, basis.U_v[:, :k], basis.U_rho[:, :k])
        res = ORIGINAL.run(ops, run.problem, n_steps=n, dt=scene.sph.dt, sample_steps=steps)
        errs.append(relative_l2(res.v, v_sph, res.t))
        assert res.wall_time > 0 and res.offline["operators"] > 0
    assert errs[0] > errs[1] > errs[2] and errs[2] < 1e-2


def test_minimal_snapshots_of_section_312_already_work():
    """3 velocity and 4 density snapshots (section 3.1.2): POD error far below the SPH error."""
    scene = load_scene("multimode")
    spec = scene.paper["snapshot_studies"][0]
    basis, run = basis_for_scene(scene, {"times_v": spec["times_v"], "times_rho": spec["times_rho"]}, progress=False)
    ops = build_operators(run.problem, basis.U_v[:, :3], basis.U_rho[:, :4])
    steps = error_steps(scene)
    res = ORIGINAL.run(ops, run.problem, n_steps=step_count(scene.T, scene.sph.dt), dt=scene.sph.dt,
                       sample_steps=steps)
    v_sph, _ = on_steps(run, steps)
    assert relative_l2(res.v, v_sph, res.t) < 0.1 * scene.paper["sph_error_v"]


def test_blow_up_is_reported_with_step_and_time():
    scene = small_scene("multimode", T=2.0, n=32)
    basis, run = basis_for_scene(scene, {"count": 10, "window": [0, 1]}, progress=False)
    ops = build_operators(run.problem, basis.U_v[:, :4], basis.U_rho[:, :4])
    with pytest.raises(SimulationError, match=r"by step \d+ \(t = "):
        FROZEN.run(ops, run.problem, n_steps=2000, dt=0.5, options=FROZEN.options(n_freeze=1))


def test_pod_and_rom_commands(tmp_path, capsys):
    scene_path = tmp_path / "s.toml"
    scene_path.write_text(small_scene("damped_forced", T=1.0, n=32, every=25).text)
    basis_file = tmp_path / "b.h5"
    assert main(["pod", str(scene_path), "--snapshots", "12", "--window", "0,0.96", "--modes", "6,5",
                 "--augment-input", "--out", str(basis_file), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "force direction: projection error" in text and "appended" in text
    b = read_basis(basis_file)
    assert b.U_v.shape == (32, 12) and b.steps_v.size == 12 and b.attrs["default_modes_v"] == 6
    with h5py.File(basis_file) as h5:
        assert h5["operators"].attrs["k_v"] == 7 and h5["operators/K"].shape == (7, 5)
        np.testing.assert_allclose(h5["snapshot_times_v"][()], np.arange(12) * 0.08)
    for model in ("original", "linearized", "frozen"):
        out = tmp_path / f"{model}.h5"
        assert main(["rom", str(scene_path), "--basis", str(basis_file), "--model", model, "--freeze", "5",
                     "--augment-input", "--out", str(out), "--quiet"]) == 0
        text = capsys.readouterr().out
        assert "vs full SPH" in text and "vs exact" in text and "online" in text and "offline" in text
        with h5py.File(out) as h5:
            assert h5["v"].shape == (201, 32) and h5.attrs["solver.model"] == model
            assert 0 < h5.attrs["error.sph.v"] < 0.1 and h5["a_v"].shape == (201, 7)
            assert h5.attrs.get("solver.b") == ("paper" if model == "frozen" else None)   # the paper's model
    # the frozen model's b: eq. 2.22's by default here (the paper's model), --b rest the FMU's (b = K a_rho_rest)
    rest = tmp_path / "frozen-rest.h5"
    assert main(["rom", str(scene_path), "--basis", str(basis_file), "--model", "frozen", "--freeze", "5",
                 "--augment-input", "--b", "rest", "--out", str(rest), "--quiet"]) == 0
    assert "b = K a_rho_rest" in capsys.readouterr().out
    with h5py.File(rest) as h5, h5py.File(tmp_path / "frozen.h5") as paper:
        assert h5.attrs["solver.b"] == "rest" and not np.array_equal(h5["a_v"][()], paper["a_v"][()])
        np.testing.assert_array_equal(h5["a_v"][0], paper["a_v"][0])              # the same start
    assert main(["rom", str(scene_path), "--basis", str(basis_file), "--model", "original", "--b", "rest",
                 "--out", str(tmp_path / "o.h5")]) == 2
    assert "--b: applies to the frozen model only" in capsys.readouterr().err
    assert main(["rom", str(scene_path), "--basis", str(basis_file), "--model", "frozen", "--modes", "40",
                 "--out", str(tmp_path / "x.h5")]) == 2
    assert "--modes: 40,40 is out of range" in capsys.readouterr().err
    assert main(["rom", "tenmode", "--basis", str(basis_file), "--model", "frozen", "--out", str(tmp_path / "y.h5")]) == 2
    assert "32 particles" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "y.h5").exists()


def test_modes_command_finds_a_threshold(tmp_path, capsys):
    scene_path = tmp_path / "mm.toml"
    scene_path.write_text(small_scene("multimode", T=2.0, n=50, every=40).text)
    assert main(["modes", str(scene_path), "--snapshots", "40", "--window", "0,1.6", "--kmax", "9",
                 "--out", str(tmp_path), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "POD error below the SPH error from k = " in text
    assert (tmp_path / "multimode.png").stat().st_size > 10_000 and (tmp_path / "multimode.csv").exists()
