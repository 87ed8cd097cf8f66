"""The CLI contract: names, HDF5 layout, one-line errors with exit status 2, no partial files."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from sphrom.cli import main
from sphrom.runio import atomic_path, read_run
from sphrom.scene import builtin_names, dump_toml, load_scene, scene_dict

PAPER_SCENES = ["damped", "damped_forced", "gaussian", "heterogeneous", "high_frequency",
                "mild_damped_forced", "multimode", "tenmode"]


def test_builtin_scenes_are_the_papers():
    assert builtin_names() == PAPER_SCENES
    for name in PAPER_SCENES:
        scene = load_scene(name)
        assert scene.name == name and scene.L == 1.0 and scene.T == 10.0
        assert scene.paper["sph_error_v"] > 0


def test_scenes_command(capsys):
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split()[0] for line in lines] == PAPER_SCENES


def test_sph_run_file_layout(tmp_path, capsys):
    out = tmp_path / "run.h5"
    assert main(["sph", "multimode", "--n-particles", "32", "--t-end", "0.5", "--every", "25",
                 "--integrator", "rk4", "--dt", "1e-3", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "relative L2 error vs exact" in text
    run = read_run(out)
    assert run.t.shape == (21,) and run.x.shape == (32,) and run.v.shape == (21, 32) == run.rho.shape
    np.testing.assert_allclose(run.t, np.arange(21) * 0.025)
    with h5py.File(out) as h5:
        assert h5["v"].attrs["units"] == "m s^-1" and h5["t"].attrs["units"] == "s"
        a = h5.attrs
        assert a["solver"] == "sph" and a["solver.integrator"] == "rk4" and a["scene.name"] == "multimode"
        assert a["scene.T"] == 0.5 and a["solver.n_particles"] == 32 and a["wall_time_s"] > 0
        assert "sum(l*sin" in a["scene.v0"] and "[sph]" in a["scene.toml"] and a["sphrom_version"]
        assert 0 < a["error.exact.v"] < 0.2          # N = 32: the SPH dispersion dominates


def _write_variant(tmp_path, mutate):
    data = scene_dict(load_scene("multimode"))
    mutate(data)
    path = tmp_path / "bad.toml"
    path.write_text(dump_toml(data))
    return path


@pytest.mark.parametrize("mutate, expect", [
    (lambda d: d["sph"].update(foo=1), "sph.foo"),
    (lambda d: d["sph"].update(dt=0.1), "sph.dt: 0.1 s is above the stability limit 0.0638 s of the euler integrator"),
    (lambda d: d["sph"].update(dt=0.07, integrator="symplectic"), "sph.dt: 0.07 s is above the stability limit"),
    (lambda d: d["sph"].update(n_particles="100"), "sph.n_particles: expected an integer"),
    (lambda d: d["sph"].update(n_particles=4), "sph.n_particles: 4 is out of range"),
    (lambda d: d["sph"].update(alpha=0.4), "sph.alpha: 0.4 is out of range (allowed: 0.5 < alpha"),
    (lambda d: d["sph"].update(dt=0.0), "sph.dt: 0.0 is out of range (allowed: a number > 0)"),
    (lambda d: d["sph"].update(dt=-1e-3), "sph.dt"),
    (lambda d: d["fields"].update(v0="sin(y)"), "fields.v0: name 'y' is not allowed"),
    (lambda d: d["fields"].update(rho0="-1"), "fields.rho0: -1.0 at x = 0.005 m is out of range (allowed: a number in [1e-15, 1e15] kg m^-3"),
    (lambda d: d["fields"].update(c="1/(x - x)"), "fields.c: non-finite value"),
    (lambda d: d["force"].update(f="open('x')"), "force.f: function 'open' is not allowed"),
    (lambda d: d["snapshots"].pop("window"), "snapshots.window: missing key"),
    (lambda d: d.update(extra=1), "unknown key 'extra'"),
])
def test_bad_scene_file_is_one_line_exit_2_no_output(tmp_path, capsys, mutate, expect):
    path = _write_variant(tmp_path, mutate)
    out = tmp_path / "out.h5"
    assert main(["sph", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and expect in err, err
    assert not out.exists()


@pytest.mark.parametrize("argv, expect", [
    (["--alpha", "0.4"], "--alpha: 0.4 is out of range"),
    (["--n-particles", "5"], "--n-particles: 5 is out of range"),
    (["--t-end", "1e-5"], "--t-end"),
])
def test_bad_options(tmp_path, capsys, argv, expect):
    out = tmp_path / "out.h5"
    assert main(["sph", "multimode", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expect in err, err
    assert not out.exists()


def test_unknown_scene_and_bad_out(tmp_path, capsys):
    assert main(["sph", "nosuchscene", "--out", str(tmp_path / "x.h5")]) == 2
    assert "built-in:" in capsys.readouterr().err
    assert main(["sph", "multimode", "--out", str(tmp_path / "missing" / "x.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_a_step_above_the_stability_limit_is_refused_before_any_work(tmp_path, capsys):
    """An impossible request (a dt above the limit of the integrator) is one line naming the option, the limit and
    the remedy, exit 2, before any run; the blow-up of a run below the limit is tests/test_hostile.py's."""
    out = tmp_path / "out.h5"
    code = main(["sph", "multimode", "--dt", "0.1", "--t-end", "5", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "--dt: 0.1 s is above the stability limit 0.0638 s of the euler integrator" in err[0]
    assert "remedy: dt <= 0.0638 s" in err[0] and "another integrator" not in err[0], err
    assert main(["sph", "multimode", "--dt", "0.07", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "or another integrator (rk4 up to 0.0902 s)" in err[0], err
    assert not out.exists() and list(tmp_path.iterdir()) == []
    # below RK4's limit RK4 runs; the integrator changed on the command line alone is checked too, and named
    assert main(["sph", "multimode", "--dt", "0.08", "--integrator", "rk4", "--t-end", "1", "--out", str(out),
                 "--quiet"]) == 0
    path = _write_variant(tmp_path, lambda d: d["sph"].update(dt=0.08, integrator="rk4"))
    assert main(["sph", str(path), "--integrator", "symplectic", "--t-end", "1", "--out", str(tmp_path / "b.h5"),
                 "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error: --integrator: 0.08 s is above the stability limit" in err[0], err


def test_interrupted_write_leaves_nothing(tmp_path):
    target = tmp_path / "x.h5"
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"half")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def console_script():
    """The ``sphrom`` console script of the installation that runs the tests, as a command: run through this
    interpreter (a bare ``sphrom`` may not be on PATH, or may be another installation's)."""
    import importlib.metadata
    import sysconfig
    (entry,) = [e for e in importlib.metadata.entry_points(group="console_scripts") if e.name == "sphrom"]
    assert entry.value == "sphrom.cli:main"
    for scheme in (None, f"{os.name}_user"):
        try:
            folder = sysconfig.get_path("scripts", scheme) if scheme else sysconfig.get_path("scripts")
        except KeyError:
            continue
        script = Path(folder) / "sphrom"
        if script.is_file():
            return [sys.executable, str(script)]
    pytest.fail(f"the sphrom console script is declared ({entry.value}) but not installed in {folder}")


def test_console_script_and_module_entry_points():
    sphrom = console_script()
    for cmd in (sphrom + ["scenes"], [sys.executable, "-m", "sphrom", "scenes"]):
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0 and "tenmode" in done.stdout
    done = subprocess.run(sphrom + ["sph", "multimode", "--dt", "-1", "--out", "x.h5"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr


def test_every_subpackage_is_installed():
    """pyproject lists every package of sphrom (the folder harness/): a non-editable install must not lose a module."""
    import tomllib
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(("sphrom",) + p.parent.relative_to(root / "harness").parts)
             for p in (root / "harness").rglob("__init__.py")}
    assert found <= listed, f"missing from pyproject packages: {sorted(found - listed)}"


def test_the_import_package_is_sphrom(tmp_path):
    """The code imports as ``sphrom`` from anywhere (its folder is harness/, pyproject maps it); no module named
    ``harness`` is ever imported, even by the whole command line and packaging."""
    code = ("import sys, sphrom, sphrom.cli, sphrom.fmu.make.package, sphrom.bench; "
            "print(sphrom.__version__, sorted(m for m in sys.modules if m.split('.')[0] == 'harness'))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    version, loaded = done.stdout.split(" ", 1)
    assert version.count(".") >= 1 and loaded.strip() == "[]"
