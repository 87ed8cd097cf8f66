"""Hostile input, round four: the cases an outside battery found, each a contract here.

1 a sweep ends within seconds of a Ctrl-C (or a SIGTERM) to its process group, one line, exit 130 (143), the
  finished runs kept, nothing left (dask's scratch included), and writes no file its spec reads; 2 verification follows a scene dt longer than the FMU's step; 4 an output that names an input is
  refused before any work; 5 a full file system is one line, nothing left; 6 damaged FMUs are one line, no folder
  left; 7 a run beyond the machine's memory is refused before the work (cosim's table; sph, pod and fmu from
  their memory estimate, naming n_particles and the N that fits) or one line (MemoryError); 9 messages name
  what is wrong (a byte-order mark, a FIFO or folder for a file, the FMU's stepSize, negative numbers); 10 a
  signal sent to a process already inside its exit is no lost signal; 11 initial_state_scale is bounded.
"""

import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from conftest import small_scene
from hostile.battery import still_running
from hostile.damaged import damaged_fmus
from sphrom.cli import main
from sphrom.paths import import_path
from sphrom.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": import_path(ROOT)}


def one_line(capsys, code, expect_code=2, *words):
    err = capsys.readouterr().err.strip().splitlines()
    assert code == expect_code and len(err) == 1, err
    assert "Traceback" not in err[0] and all(w in err[0] for w in words), err
    return err[0]


# -- case 9: messages that name what is wrong --------------------------------------------------------------------

@pytest.mark.parametrize("value", ["-1e-3", "-1E-3", "-.5", "-inf", "-1e308"])
def test_a_negative_number_in_any_float_form_is_an_option_value(value, hostile_fmu, tmp_path, capsys):
    """'--initial-state-scale -1e-3' was "expected one argument" while -0.001 worked (argparse's own pattern)."""
    code = main(["cosim", str(hostile_fmu), "--t-end", value, "--out", str(tmp_path / "o.csv")])
    line = one_line(capsys, code, 2, "--t-end", value)
    assert "expected one argument" not in line


def test_a_byte_order_mark_is_no_column_and_no_statement(hostile_scene, hostile_fmu, tmp_path, capsys):
    csv = tmp_path / "f.csv"
    csv.write_bytes(b"\xef\xbb\xbftime,f\n0,0\n0.2,0.01\n")
    assert main(["cosim", str(hostile_fmu), "--force", str(csv), "--out", str(tmp_path / "o.csv")]) == 0
    scene = tmp_path / "bom.toml"
    scene.write_bytes(b"\xef\xbb\xbf" + hostile_scene.read_bytes())
    assert main(["sph", str(scene), "--out", str(tmp_path / "o.h5"), "--quiet"]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("kind", ["folder", "fifo"])
def test_an_input_that_is_no_regular_file_says_what_it_is(kind, hostile_fmu, tmp_path, capsys):
    node = tmp_path / "in.toml"
    node.mkdir() if kind == "folder" else os.mkfifo(node)
    what = "a folder" if kind == "folder" else "a FIFO"
    one_line(capsys, main(["sph", str(node), "--out", str(tmp_path / "o.h5")]), 2, what)
    one_line(capsys, main(["cosim", str(hostile_fmu), "--force", str(node), "--out", str(tmp_path / "o.csv")]),
             2, what)
    one_line(capsys, main(["cosim", str(node), "--out", str(tmp_path / "o.csv")]), 2, what)


# -- case 6 (and 9: a bad DefaultExperiment is the FMU's, not --step's) -------------------------------------------

@pytest.fixture(scope="module")
def damaged(hostile_fmu, tmp_path_factory):
    return damaged_fmus(hostile_fmu, tmp_path_factory.mktemp("damaged"), bomb_mib=600)


def test_damaged_fmus_are_one_line_and_leave_no_folder(damaged, tmp_path, capsys, monkeypatch):
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    for name, path in damaged.items():
        out = tmp_path / "o.csv"
        line = one_line(capsys, main(["cosim", str(path), "--out", str(out)]), 2, "FILE.fmu")
        assert not out.exists() and list(scratch.iterdir()) == [], (name, list(scratch.iterdir()))
        if "stepSize" in name or "stopTime" in name:
            assert "--step:" not in line and "DefaultExperiment" in line, line
    assert not Path("/tmp/sphrom-hostile-absolute.txt").exists()


def test_a_truncated_binary_is_refused_in_a_process_that_lives(damaged, tmp_path):
    """Mapped, a truncated library was SIGBUS (fmpy and the command died without a word)."""
    proc = subprocess.run([sys.executable, "-m", "sphrom", "cosim", str(damaged["truncated binary, one page"]),
                           "--out", str(tmp_path / "o.csv")], env=ENV, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


# -- case 4: no input overwritten -------------------------------------------------------------------------------

def test_an_output_that_names_an_input_is_refused_before_any_work(hostile_scene, hostile_fmu, tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_bytes(hostile_scene.read_bytes())
    fmu = tmp_path / "x.fmu"
    fmu.write_bytes(hostile_fmu.read_bytes())
    force = tmp_path / "f.csv"
    force.write_text("time,f\n0,0\n0.2,0\n")
    before = {p: p.read_bytes() for p in (scene, fmu, force)}
    for argv in (["sph", str(scene), "--out", str(scene)],
                 ["pod", str(scene), "--out", f"{tmp_path}/./s.toml"],
                 ["cosim", str(fmu), "--out", str(fmu)],
                 ["cosim", str(fmu), "--force", str(force), "--out", str(force)]):
        one_line(capsys, main(argv), 2, "--out", "input")
    link = tmp_path / "link.toml"
    link.symlink_to(scene)
    one_line(capsys, main(["sph", str(link), "--out", str(scene)]), 2, "--out", "input")
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.csv", "link.toml", "s.toml", "x.fmu"]


def test_a_sweep_writes_no_file_its_spec_reads(hostile_scene, tmp_path, capsys):
    """The command line's inputs were checked, but not the scene the spec names: a scene file r.csv beside
    --out r.h5 was replaced by the results' CSV."""
    scene = tmp_path / "r.csv"
    scene.write_bytes(hostile_scene.read_bytes())
    spec = tmp_path / "spec.toml"
    spec.write_text('title = "t"\nscene = "r.csv"\nt_end = 0.1\nstep = 0.001\nprobes = [0.25]\nparametric = false'
                    '\n\n[grid]\nshape = ["sine"]\namplitude = [1e-2]\nfrequency = [1.0]\nk = [4]\n')
    before = scene.read_bytes()
    line = one_line(capsys, main(["sweep", str(spec), "--out", str(tmp_path / "r.h5"), "--quiet"]), 2, "--out",
                    "is the scene", "spec")
    assert scene.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "spec.toml"], line


# -- case 11 and case 7 -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("scale", ["1e308", "-1e4", "1001"])
def test_initial_state_scale_is_bounded(scale, hostile_fmu, tmp_path, capsys):
    """1e308 was accepted: outputs of 4e305 m/s read back with OK until the first doStep failed."""
    one_line(capsys, main(["cosim", str(hostile_fmu), "--initial-state-scale", scale, "--out",
                           str(tmp_path / "o.csv")]), 2, "--initial-state-scale", "[-1000, 1000]")


def test_a_cosim_table_beyond_the_memory_available_is_refused_first(hostile_fmu, tmp_path, capsys, monkeypatch):
    import sphrom.runio as runio
    monkeypatch.setattr(runio, "available_memory", lambda: 64 * 2**20)
    line = one_line(capsys, main(["cosim", str(hostile_fmu), "--t-end", "100", "--step", "0.0001", "--out",
                                  str(tmp_path / "o.csv")]), 2, "--step", "available")
    assert "64 MiB" in line and not (tmp_path / "o.csv").exists()


def test_out_of_memory_is_one_line(hostile_scene, tmp_path, capsys, monkeypatch):
    import sphrom.sph.solver as solver

    def no_memory(*args, **kwargs):
        raise MemoryError("Unable to allocate 8.9 GiB for an array with shape (400000, 3000)")
    monkeypatch.setattr(solver, "run_sph", no_memory)
    line = one_line(capsys, main(["sph", str(hostile_scene), "--out", str(tmp_path / "o.h5"), "--quiet"]), 3,
                    "out of memory", "8.9 GiB")
    assert not list(tmp_path.iterdir()), line


# -- case 2: verification at any dt -----------------------------------------------------------------------------

@pytest.mark.parametrize("model", ["frozen", "exact"])
def test_verification_follows_a_dt_longer_than_the_step(model, tmp_path, capsys):
    """dt = 0.02 s against the FMU's 0.01 s step: ValueError 'shapes differ: (201, 3) vs (101, 3)'.  The check
    now runs at any dt: the exact FMU passes it; the frozen one, stepping the scene's coarse dt, misses the default
    accuracy against the SPH exact in time and is refused in one line that names the remedy (a shorter sph.dt)."""
    scene = tmp_path / "dt.toml"
    scene.write_text(small_scene("damped_forced", T=0.4, n=32, dt=0.02).text)
    out = tmp_path / "dt.fmu"
    code = main(["fmu", str(scene), "--modes", "4", "--model", model, "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert "Traceback" not in err and "shapes differ" not in err, err
    if model == "exact":
        assert code == 0 and out.exists(), err
    else:
        lines = [line for line in err.splitlines() if "failed" in line]
        assert code != 0 and not out.exists() and len(lines) == 1, err
        assert "is above the accuracy" in lines[0] and "sph.dt" in lines[0], err


# -- case 5: a real full file system ----------------------------------------------------------------------------

@pytest.fixture
def full_tmpfs(tmp_path):
    folder = tmp_path / "small"
    folder.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)], capture_output=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a 64 KiB tmpfs here (needs root): {proc.stderr.decode().strip()[:100]}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def test_a_full_file_system_is_one_line_and_nothing_left(full_tmpfs, hostile_scene, hostile_fmu, tmp_path):
    """On a 64 KiB tmpfs, sph died with SIGSEGV after h5py's tracebacks and left .o.h5.tmp-PID; fmu and cosim
    gave an ENOSPC traceback."""
    big = tmp_path / "big.toml"
    big.write_text(small_scene("damped_forced", T=1.0, n=64).text)
    (full_tmpfs / "pad").write_bytes(bytes(40 * 1024))
    for argv in (["sph", str(big), "--out", str(full_tmpfs / "o.h5"), "--quiet"],
                 ["fmu", str(hostile_scene), "--modes", "4", "--no-verify", "--out", str(full_tmpfs / "o.fmu"),
                  "--quiet"],
                 ["cosim", str(hostile_fmu), "--t-end", "20", "--out", str(full_tmpfs / "o.csv")]):
        proc = subprocess.run([sys.executable, "-m", "sphrom", *argv], env=ENV, capture_output=True, text=True,
                              timeout=300)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1 and "no space left" in lines[0], (argv[0], proc.stderr)
        assert sorted(p.name for p in full_tmpfs.iterdir()) == ["pad"], argv[0]


# -- case 10 ----------------------------------------------------------------------------------------------------

def test_a_process_inside_its_exit_is_not_running():
    """poll() is None for a zombie not yet reaped: a signal sent to it reached no program, and its exit 0 was
    counted as a lost SIGTERM."""
    import time
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    deadline = time.monotonic() + 30
    while Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
        assert time.monotonic() < deadline
        time.sleep(0.01)
    assert proc.returncode is None and not still_running(proc)
    proc.wait()


# -- case 1: a sample of the Ctrl-C trials ----------------------------------------------------------------------

def test_ctrl_c_to_a_sweep_process_group(hostile_scene, tmp_path):
    """A few of ``python3 -m tests.hostile signals``: SIGINT to the process group at moments across the run."""
    import random

    from hostile.trials import span, trial
    spec = tmp_path / "spec.toml"
    spec.write_text(f'title = "t"\nscene = "{hostile_scene}"\nt_end = 4.0\nstep = 0.001\nprobes = [0.25]\n'
                    'parametric = false\n\n[grid]\nshape = ["sine"]\namplitude = [1e-2]\n'
                    'frequency = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]\nk = [4]\n')
    work = tmp_path / "w"
    work.mkdir()
    env = {**ENV, "SPHROM_CACHE": os.environ.get("SPHROM_CACHE", str(tmp_path / "cache"))}
    argv = ["sweep", str(spec), "--workers", "2", "--out", "r.h5", "--quiet"]
    length = span(argv, work, env)
    for p in work.iterdir():
        p.unlink()
    rng = random.Random(1)
    for delay in (0.3 * length * rng.random(), 0.3 * length + 0.6 * length * rng.random()):
        row = trial(argv, work, env, signal.SIGINT, delay, to_group=True)
        assert row["outcome"] in ("clean", "ended before the signal"), row
        for p in work.iterdir():
            p.unlink()
    # SIGTERM to the group (kill -TERM -PGID) is a Ctrl-C's equal: the workers, which died on it with the results
    # they had not handed over ("no output written" at 85 % of the run), leave the closing to the command, and
    # the finished runs are kept
    kept, lines = [], []
    for attempt in range(3):                           # a timing test: each attempt measures the span anew
        if any(kept):
            break
        length = span(argv, work, env)                 # the FMU packaged now: the run's own span
        for p in work.iterdir():
            p.unlink()
        # (late moments: most of a short run's span can be the cluster's start, before any run has finished)
        for delay in (0.75 * length, 0.85 * length, 0.95 * length):
            if any(kept):
                break
            for _ in range(4):
                row = trial(argv, work, env, signal.SIGTERM, delay, to_group=True)
                if row["outcome"] != "ended before the signal":
                    break
                for p in work.iterdir():              # (a finished run's results would be resumed)
                    p.unlink()
                delay /= 2
            assert row["outcome"] in ("clean", "ended before the signal"), row
            if row["outcome"] == "clean":
                kept.append("finished runs kept" in row["last_line"])
                lines.append((round(delay / length, 2), row["last_line"]))
            for p in work.iterdir():
                p.unlink()
    assert any(kept), lines


# -- case 7: a run beyond the machine's memory is refused before the work ----------------------------------------

@pytest.mark.parametrize("command", ["sph", "pod", "fmu"])
def test_a_run_beyond_the_memory_available_is_refused_before_any_work(command, tmp_path, capsys, monkeypatch):
    """sphrom fmu at N = 4e5 (the schema allows 1e7) ended in a MemoryError traceback in the eigensolver and
    N = 1e6 in SIGSEGV inside SuperLU: the commands estimate the memory of the run's largest arrays first
    (sphrom.runio.run_memory) and refuse one that does not fit, naming the field and the N that fits here."""
    import time

    import sphrom.runio as runio
    monkeypatch.setattr(runio, "available_memory", lambda: 2**30)
    scene = tmp_path / "big.toml"
    scene.write_text(small_scene("damped_forced", T=2e-4, n=1_000_000, dt=2e-8).text)
    extra = ["--modes", "4", "--no-verify"] if command == "fmu" else []
    out = tmp_path / ("o.fmu" if command == "fmu" else "o.h5")
    start = time.monotonic()
    line = one_line(capsys, main([command, str(scene), *extra, "--out", str(out), "--quiet"]), 2,
                    "particles need about", "N = 1000000", "1 GiB available", "N up to")
    assert time.monotonic() - start < 30 and not out.exists(), line
    assert line.split(": ")[2] in ("n_particles", "--n-particles"), line      # the field, or sph's option for it
    allowed = int(line.split("N up to ")[1].split()[0])
    model, modes = ("frozen", 4) if command == "fmu" else (None, None)
    fits = runio.MEMORY_MARGIN * sum(b for b, _ in runio.run_memory(runio._with_particles(
        load_scene(str(scene)), allowed), command, model, modes))
    assert 0 < allowed < 1_000_000 and fits <= 2**30


def test_the_memory_estimate_covers_what_a_run_takes(tmp_path):
    """sphrom.runio.run_memory against the peak resident memory measured: what `sph` (with its comparison with the
    exact solution) and `pod` take beyond the same command at N = 500 is within the estimate at N = 16000."""
    measure = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], capture_output=True); "
               "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    from sphrom.runio import run_memory
    for command in ("sph", "pod"):
        peaks = {}
        for n in (500, 16000):
            dt = 2e-4 * 100 / n
            path = tmp_path / f"n{n}.toml"
            path.write_text(small_scene("damped_forced", T=200 * dt, n=n, dt=dt).text)
            env = {**ENV, "SPHROM_CACHE": str(tmp_path / f"cache-{command}-{n}")}
            proc = subprocess.run([sys.executable, "-c", measure, sys.executable, "-m", "sphrom", command, str(path),
                                   "--out", str(tmp_path / f"{command}{n}.h5"), "--quiet"], env=env,
                                  capture_output=True, text=True, timeout=600)
            code, peak = proc.stdout.split()
            assert code == "0", proc.stderr
            peaks[n] = int(peak) * 1024                                    # ru_maxrss: KiB on Linux
        grown = peaks[16000] - peaks[500]
        estimate = sum(b for b, _ in run_memory(load_scene(str(tmp_path / "n16000.toml")), command))
        assert grown <= estimate, (command, grown, estimate)
