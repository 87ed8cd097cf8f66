"""Ranges of every number a user gives: a one-line error naming the option or field and the allowed range,
exit status 2, no traceback, no output file created and an existing one left intact.

Each case is refused before any long run or large allocation (huge step counts, snapshot counts).
"""

import zipfile

import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.scene import dump_toml, scene_dict

DUMMY = b"an earlier result, not to be touched\n"


def _scene_file(tmp_path, name="tiny", **changes):
    """A tiny scene TOML (multimode at N = 16, T = 0.1) with nested ``changes`` merged in; its path."""
    data = scene_dict(small_scene("multimode", T=0.1, n=16, dt=1e-3, every=10))
    data["name"] = name
    for table, values in changes.items():
        data[table].update(values)
    path = tmp_path / f"{name}.toml"
    path.write_text(dump_toml(data))
    return path


def _refused(capsys, tmp_path, args, out_name, *needles):
    """Run ``args + --out OUT`` twice (OUT absent, then OUT holding dummy bytes): status 2, one stderr line that
    holds every needle and 'allowed', no traceback, OUT not created and then left byte for byte."""
    for existing in (False, True):
        out = tmp_path / ("existing-" if existing else "new-") / out_name
        out.parent.mkdir(exist_ok=True)
        if existing:
            out.write_bytes(DUMMY)
        assert main(args + ["--out", str(out)]) == 2
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1, captured.err
        assert "Traceback" not in captured.err + captured.out
        for needle in needles + ("allowed",):
            assert needle in lines[0], lines[0]
        if existing:
            assert out.read_bytes() == DUMMY
        else:
            assert not out.exists()
        assert sorted(p.name for p in out.parent.iterdir()) == ([out_name] if existing else [])
    return lines[0]


# ---------------------------------------------------------------------------
# the SPH step count T / dt, from options and from the scene file
# ---------------------------------------------------------------------------

def test_sph_dt_too_small_for_T_names_the_smallest_dt(tmp_path, capsys):
    scene = _scene_file(tmp_path)
    line = _refused(capsys, tmp_path, ["sph", str(scene), "--dt", "1e-320", "--quiet"], "x.h5", "--dt", "1e9")
    assert "dt >= T / 1e9 = 1e-10 s" in line             # T = 0.1 s


def test_sph_t_end_too_long_for_dt(tmp_path, capsys):
    scene = _scene_file(tmp_path)
    line = _refused(capsys, tmp_path, ["sph", str(scene), "--t-end", "1e300", "--quiet"], "x.h5", "--t-end", "1e9")
    assert "T <= 1e9 dt = 1e+06 s" in line                # dt = 1e-3 s


@pytest.mark.parametrize("changes, needles", [
    ({"sph": {"dt": 1e-12}}, ("sph.dt", "1e9", "T = 0.1")),
    ({"domain": {"T": 1e14}}, ("sph.dt", "1e9", "T = 1e+14")),
    ({"domain": {"T": 1e300}}, ("domain.T", "[1e-15, 1e15]")),
    ({"domain": {"T": float("inf")}}, ("domain.T", "finite")),
    ({"domain": {"T": -1.0}}, ("domain.T", "[1e-15, 1e15]")),
    ({"domain": {"L": float("nan")}}, ("domain.L", "finite")),
    ({"domain": {"L": 0.0}}, ("domain.L", "[1e-15, 1e15]")),
    ({"sph": {"n_particles": 4}}, ("sph.n_particles", "[8, 10000000]")),
    ({"sph": {"n_particles": 10**8}}, ("sph.n_particles", "[8, 10000000]")),
    ({"sph": {"alpha": 0.0}}, ("sph.alpha", "0.5 < alpha < N/4")),
    ({"sph": {"alpha": float("inf")}}, ("sph.alpha", "finite")),
])
def test_scene_file_numbers(tmp_path, capsys, changes, needles):
    scene = _scene_file(tmp_path, **changes)
    line = _refused(capsys, tmp_path, ["sph", str(scene), "--quiet"], "x.h5", *needles)
    assert str(scene) in line


@pytest.mark.parametrize("option, value, needles", [
    ("--n-particles", "4", ("--n-particles", "[8, 10000000]")),
    ("--n-particles", "100000000", ("--n-particles", "[8, 10000000]")),
    ("--alpha", "nan", ("--alpha", "> 0")),
    ("--alpha", "1e9", ("--alpha", "N/4")),
    ("--t-end", "inf", ("--t-end", "> 0")),
    ("--t-end", "0", ("--t-end", "> 0")),
    ("--dt", "-1", ("--dt", "> 0")),
])
def test_sph_options(tmp_path, capsys, option, value, needles):
    scene = _scene_file(tmp_path)
    _refused(capsys, tmp_path, ["sph", str(scene), option, value, "--quiet"], "x.h5", *needles)


# ---------------------------------------------------------------------------
# pod: snapshot counts bounded by the run's steps and by memory
# ---------------------------------------------------------------------------

def test_pod_snapshots_beyond_the_run(tmp_path, capsys):
    scene = _scene_file(tmp_path)                         # 100 steps of 1e-3 s: 101 in [0, 0.1]
    line = _refused(capsys, tmp_path, ["pod", str(scene), "--snapshots", "1000000000", "--window", "0,0.1",
                                       "--quiet"], "b.h5", "--snapshots", "at most 101 snapshots")
    assert "1000000000" in line


def test_pod_snapshots_beyond_memory(tmp_path, capsys):
    # 1e8 steps are allowed; 4e7 snapshots of 16 particles need 4e7 x 16 x 8 x 2 bytes = 9.5 GiB
    scene = _scene_file(tmp_path, sph={"dt": 1e-9, "every": 10**7})
    line = _refused(capsys, tmp_path, ["pod", str(scene), "--snapshots", "40000000", "--window", "0,0.1",
                                       "--quiet"], "b.h5", "--snapshots", "9.5 GiB", "at most 16777216 snapshots")
    assert "4 GiB" in line


# ---------------------------------------------------------------------------
# cosim: t_end finite and > 0, at most 1e8 communication steps
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def fmu_file(tmp_path_factory):
    from sphrom.fmu.make.package import package_fmu
    path = tmp_path_factory.mktemp("fmu") / "tiny.fmu"
    package_fmu(small_scene("multimode", T=0.1, n=16, dt=1e-3, every=10), path, k=4, fmi=2, n_freeze=10,
                probes=(0.5,), progress=False)
    assert zipfile.is_zipfile(path)
    return path


@pytest.mark.parametrize("args, needles", [
    (["--t-end", "1e308"], ("--t-end", "at most 1e8", "t_end <= 1e8 x step")),
    (["--t-end", "1", "--step", "1e-300"], ("--step", "at most 1e8", "step >= t_end / 1e8 = 1e-08 s")),
    (["--t-end", "inf"], ("--t-end", "> 0")),
    (["--t-end", "nan"], ("--t-end", "> 0")),
    (["--t-end", "0"], ("--t-end", "> 0")),
    (["--step", "-0.1"], ("--step", "> 0")),
])
def test_cosim_steps(fmu_file, tmp_path, capsys, args, needles):
    _refused(capsys, tmp_path, ["cosim", str(fmu_file)] + args, "r.csv", *needles)


# ---------------------------------------------------------------------------
# sweep spec: t_end finite, > 0, and a bounded step count
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("t_end, needles", [
    ("1e308", ("t_end = 1e+308", "at most 10000000", ": step")),
    ("inf", (": t_end", "finite number > 0")),
    ("nan", (": t_end", "finite number > 0")),
    ("-1.0", (": t_end", "finite number > 0")),
])
def test_sweep_spec_t_end(tmp_path, capsys, t_end, needles):
    scene = _scene_file(tmp_path)
    spec = tmp_path / "spec.toml"
    spec.write_text(f'scene = "{scene}"\nt_end = {t_end}\n\n[grid]\namplitude = [0.01]\n')
    line = _refused(capsys, tmp_path, ["sweep", str(spec)], "s.h5", *needles)
    assert str(spec) in line


# ---------------------------------------------------------------------------
# reference: the continuum solvers' step count, bounded like the SPH's
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("solver", ["fd", "skfem"])
def test_reference_dt_too_small_for_T(tmp_path, capsys, solver):
    scene = _scene_file(tmp_path)
    line = _refused(capsys, tmp_path, ["reference", str(scene), "--solver", solver, "--dt", "1e-320", "--quiet"],
                    "r.h5", "--dt", "1e9")
    assert "dt >= T / 1e9 = 1e-10 s" in line


def test_sph_samples_beyond_memory(tmp_path, capsys):
    # T / dt = 1e8 steps stored every step: 1e8 samples x 16 particles x 8 bytes x 2 = 23.8 GiB
    scene = _scene_file(tmp_path)
    line = _refused(capsys, tmp_path, ["sph", str(scene), "--dt", "1e-9", "--every", "1", "--quiet"], "x.h5",
                    "--every", "23.8 GiB", "at most 4 GiB")
    least = int(line.split("every >= ")[1].split(",")[0])
    assert (10**8 // least + 2) * 16 * 16 <= 4 * 2**30 < (10**8 // (least - 1) + 2) * 16 * 16


def test_scene_file_samples_beyond_memory(tmp_path, capsys):
    scene = _scene_file(tmp_path, sph={"dt": 1e-9, "every": 1})
    _refused(capsys, tmp_path, ["sph", str(scene), "--quiet"], "x.h5", "sph.every", "GiB")


def test_bench_fmu_step_too_small_for_T(tmp_path, capsys):
    scene = _scene_file(tmp_path)
    out = tmp_path / "bench"
    assert main(["bench-fmu", str(scene), "--step", "1e-300", "--out", str(out), "--quiet"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert "--step" in lines[0] and "allowed: T / 1e8 = 1e-09 s <= step" in lines[0], lines[0]
    assert not out.exists()
