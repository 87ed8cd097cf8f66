"""A battery of hostile inputs: every command's options, scenes, output paths, mutated FMU resources
and states, FMI calls out of order, and signals at random moments of every long command.

    python3 -m tests.hostile [--out validation/hostile] [--seed 25] [--jobs 2] [--quick]

Each case runs in a process of its own (the command line through ``python -m sphrom`` of this checkout; the
FMU cases in a child that loads the binaries through ctypes / fmpy, restarted after a crash:
:mod:`tests.hostile.fmu_cases`) and gets one outcome.  The category "step bound" asks one doStep for the
most work it can be given (an internal dt of 1e-12 s set as the parameter, carried by a state or by the
resources, checksums recomputed; a communication step of 1e7 s): it must answer within 10 s, done or refused
naming the limit.

ok                    exit 0, its outputs present and finite
clean error           exit 2, 3 or 4 with one line on stderr ("sphrom CMD: error: ..." / "failed: ..."; warning
                      lines before it allowed); an FMU call refused with an error status and a message
clean interrupt       exit 128 + the signal with one line whose account of what was written is true
traceback             a Python traceback, an exit status no command uses, or a crash (SIGSEGV, SIGABRT)
hang                  no answer within the case's time limit
silent wrong result   exit 0 with an output missing or holding NaN; an FMU call that returns OK with non-finite
                      outputs or accepts a corrupted blob; a signal lost (exit 0 after it), or "no output written"
                      while an output was written
replaced file         a node (device, FIFO, socket, folder) or a link that is no longer what it was, or a regular
                      file changed by a command that failed
left behind           a temporary (.NAME.tmp-PID) left after the run
unclear error         exit 2/3/4 with more than one line (no traceback); an FMU call refused without a message
outside sphrom        a signal delivered before the interpreter ran sphrom's first line, or after it restored the
                      default handlers while exiting (nothing a program can catch there)

Writes ``hostile.csv`` (one row per case) and ``hostile_counts.csv`` (counts by category and outcome) under
--out, and prints the counts.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import math
import os
import random
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time
import zlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from sphrom.paths import import_path

REPO = Path(__file__).resolve().parents[2]
OUTCOMES = ("ok", "clean error", "clean interrupt", "traceback", "hang", "silent wrong result", "replaced file",
            "left behind", "unclear error", "outside sphrom")
BAD = ("traceback", "hang", "silent wrong result", "replaced file", "left behind", "unclear error")
# values every option of every command gets (as text): wrong types, huge, tiny, negative, NaN, inf, empty
HOSTILE_VALUES = ("abc", "", " ", "nan", "inf", "-inf", "-1", "0", "-1e-9", "1e308", "1e-300", "5e-324",
                  "99999999999999999999", str(2**63), str(2**31), "1e999", "0x10", "1,,2", "1,2", "--", "1e20")
# commands that run long on any valid value: they get only values no option of theirs accepts
LONG_COMMANDS = ("bench", "stress", "validate")
INVALID_VALUES = ("abc", "", "nan", "inf", "-inf", "-1", "1e999", "99999999999999999999", "1,,2", "0x10")


# ---------------------------------------------------------------------------
# the workspace
# ---------------------------------------------------------------------------

def small_scene_text(base="damped_forced", T=0.2, n=32, **sph):
    """A built-in scene shrunk to N particles and horizon T (as tests/conftest.small_scene)."""
    from sphrom.scene import derive_scene, load_scene
    scene = load_scene(base)
    changes = {"domain": {"T": T}, "sph": {"n_particles": n, **sph}}
    snaps = scene.snapshots
    if "window" in snaps and snaps["window"][1] > T:
        changes["snapshots"] = {"count": min(snaps["count"], 20), "window": [0.0, T]}
    return derive_scene(scene, changes).text


@dataclass
class Workspace:
    root: Path
    env: dict
    files: dict = field(default_factory=dict)

    def __getitem__(self, name):
        return self.files[name]


def run_cli(args, env, cwd, timeout=600):
    return subprocess.run([sys.executable, "-m", "sphrom", *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def prepare(root: Path) -> Workspace:
    """Scenes, a basis, FMUs (frozen FMI 2 and 3, exact FMI 2), a force CSV and sweep specs under ``root``."""
    root.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": import_path(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "SPHROM_CACHE": str(root / "cache")}
    ws = Workspace(root, env)
    (root / "s.toml").write_text(small_scene_text())
    ws.files["scene"] = root / "s.toml"
    setup = [("basis", ["pod", "s.toml", "--out", "b.h5", "--quiet"], "b.h5"),
             ("fmu2", ["fmu", "s.toml", "--modes", "4", "--no-verify", "--out", "f2.fmu", "--quiet"], "f2.fmu"),
             ("fmu3", ["fmu", "s.toml", "--modes", "4", "--no-verify", "--fmi", "3", "--out", "f3.fmu", "--quiet"],
              "f3.fmu"),
             ("exact2", ["fmu", "s.toml", "--modes", "4", "--model", "exact", "--no-verify", "--no-bounds", "--out",
                         "e2.fmu", "--quiet"], "e2.fmu")]
    for name, args, out in setup:
        proc = run_cli(args, env, root)
        if proc.returncode != 0:
            raise RuntimeError(f"setup {name} failed: {proc.stderr}")
        ws.files[name] = root / out
    (root / "force.csv").write_text("time,f\n0,0\n0.1,0.01\n0.2,0\n")
    ws.files["force"] = root / "force.csv"
    spec = ('title = "hostile"\nscene = "s.toml"\nt_end = {t_end}\nstep = 0.001\nprobes = [0.25, 0.66]\n'
            'parametric = false\n\n[grid]\nshape = ["sine"]\namplitude = [1e-2]\nfrequency = [{freqs}]\nk = [4]\n')
    (root / "spec.toml").write_text(spec.format(t_end=0.1, freqs="1.0, 2.0"))
    (root / "spec_long.toml").write_text(spec.format(t_end=20.0, freqs=", ".join(f"{0.5 + 0.25 * i}"
                                                                                 for i in range(40))))
    ws.files["spec"], ws.files["spec_long"] = root / "spec.toml", root / "spec_long.toml"
    # the sweep's FMU packaged once (cached): its runs then reach their cluster and tasks
    proc = run_cli(["sweep", "spec.toml", "--workers", "1", "--out", "warm.h5", "--quiet"], env, root)
    if proc.returncode != 0:
        raise RuntimeError(f"setup sweep failed: {proc.stderr}")
    return ws


# ---------------------------------------------------------------------------
# a command-line case and its outcome
# ---------------------------------------------------------------------------

@dataclass
class Case:
    category: str
    command: str
    args: list                      # argv after the command name (in the case's folder)
    outputs: list = field(default_factory=list)     # output paths (relative) the command should write on success
    make: list = field(default_factory=list)        # (relative path, kind) made before the run (guarded)
    signal: int = 0
    delay: float = 0.0              # s after sphrom's handler is up (negative: before it, from the start)
    timeout: float = 240.0
    note: str = ""
    address_space: int = 0          # bytes: the process's RLIMIT_AS (0: none), a machine of that memory


@dataclass
class Result:
    case: Case
    outcome: str
    detail: str
    code: int | None
    lines: list
    wall: float
    delivered: bool = False         # a signal case: the signal reached the running process


def _make_node(path: Path, kind: str, keep: list):
    """Create ``path`` as ``kind``; sockets and FIFO readers are kept alive in ``keep``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "file":
        path.write_bytes(b"precious")
    elif kind == "dir":
        path.mkdir()
    elif kind in ("fifo", "fifo-read"):
        os.mkfifo(path)
        if kind == "fifo-read":
            keep.append(_FifoReader(path))
    elif kind in ("null", "full", "zero"):
        if os.geteuid() != 0:
            raise PermissionError("device twins need root")
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, {"null": 3, "full": 7, "zero": 5}[kind]))
    elif kind == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
        keep.append(sock)
    elif kind == "link-file":
        target = path.with_name(path.name + ".target")
        target.write_bytes(b"precious")
        path.symlink_to(target.name)
    elif kind == "link-loop":
        path.symlink_to(path.name)
    elif kind.startswith("copy:"):
        path.write_bytes(Path(kind[5:]).read_bytes())
    elif kind == "tmpfs":                      # a real full file system: a 64 KiB tmpfs, 40 KiB of it taken
        path.mkdir()
        if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(path)],
                                                capture_output=True).returncode != 0:
            path.rmdir()
            raise PermissionError("mounting a tmpfs needs root")
        (path / "pad").write_bytes(bytes(40 * 1024))
        keep.append(_Mount(path))
    else:
        raise ValueError(kind)


class _Mount:
    """A tmpfs mounted for a case: unmounted after the run, a marker left in the case's folder for each temporary
    the run left on it (the case's 'left behind' check cannot see inside once it is unmounted)."""

    def __init__(self, path):
        self.path = path

    def close(self):
        left = [p.name for p in self.path.iterdir() if ".tmp-" in p.name]     # (an output that fitted is no leftover)
        subprocess.run(["umount", "-l", str(self.path)], capture_output=True)
        for name in left:
            (self.path.parent / f"on-tmpfs-{name}.tmp-left").write_text(name)


class _FifoReader(threading.Thread):
    def __init__(self, path):
        super().__init__(daemon=True)
        self.path, self.size = path, 0
        self.start()

    def run(self):
        with contextlib.suppress(OSError), open(self.path, "rb") as fh:
            while chunk := fh.read(1 << 16):
                self.size += len(chunk)

    def close(self):
        """Unblock a reader nobody wrote to (open for writing once)."""
        with contextlib.suppress(OSError):
            fd = os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
            os.close(fd)
        self.join(5)


def _snapshot(path: Path):
    """What a path is: (type, inode, device id, content hash for a small regular file)."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    digest = None
    if stat.S_ISREG(st.st_mode) and st.st_size < 1 << 20:
        digest = zlib.crc32(path.read_bytes())
    return (stat.S_IFMT(st.st_mode), st.st_ino, st.st_rdev, digest)


def sphrom_catches_sigterm(pid):
    """Whether process ``pid`` catches SIGTERM (Python alone does not): sphrom's own code is running (Linux
    /proc; False where it cannot tell)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("SigCgt:"):
                return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)
    except OSError:
        pass
    return False


PF_EXITING = 0x4          # the kernel's task flag of a process inside exit (linux/sched.h)


def still_running(proc):
    """Whether ``proc`` (a Popen) still runs its program: not reaped, not a zombie, not inside the kernel's exit
    (Linux /proc; elsewhere: not reaped).  ``Popen.poll() is None`` also holds for a process that has already
    called exit and is being torn down (a few ms for an interpreter with numpy loaded) or waits as a zombie: a
    signal sent then reaches no program, and its exit 0 is no lost signal."""
    if proc.poll() is not None:
        return False
    try:
        fields = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return proc.poll() is None
    return fields[0] not in ("Z", "X", "x") and not int(fields[6]) & PF_EXITING


def _nan_in_output(path: Path):
    """Whether an output file holds NaN/inf data (HDF5 datasets, CSV cells); None when it cannot tell."""
    try:
        if path.suffix == ".h5":
            import h5py
            import numpy as np
            bad = []
            with h5py.File(path, "r") as h5:
                if h5.attrs.get("format") == "sphrom-sweep":
                    return False                 # NaN marks "not measured" there by design
                h5.visititems(lambda name, obj: bad.append(name) if isinstance(obj, h5py.Dataset)
                              and obj.dtype.kind == "f" and not np.all(np.isfinite(obj[()])) else None)
            return bool(bad)
        if path.suffix == ".csv":
            if _nan_in_output(path.with_suffix(".h5")) is False and path.with_suffix(".h5").is_file():
                import h5py
                with h5py.File(path.with_suffix(".h5"), "r") as h5:
                    if h5.attrs.get("format") == "sphrom-sweep":
                        return False             # its CSV: the same table
            with open(path, newline="") as fh:
                rows = list(csv.reader(fh))
            for row in rows[1:]:
                for cell in row:
                    with contextlib.suppress(ValueError):
                        if not math.isfinite(float(cell)):
                            return True
            return False
    except Exception:
        return None
    return False


def run_case(case: Case, ws: Workspace, index: int) -> Result:
    folder = ws.root / "cases" / f"{index:05d}"
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    keep = []
    try:
        for rel, kind in case.make:
            _make_node(folder / rel, kind, keep)
    except PermissionError as exc:
        return Result(case, "ok", f"skipped: {exc}", None, [], 0.0)
    # a tmpfs's mount point is the battery's own, unmounted before the check (its inode then differs)
    guarded = {rel: _snapshot(folder / rel) for rel, kind in case.make if kind != "tmpfs"}
    guarded.update({rel + ".target": _snapshot(folder / (rel + ".target")) for rel, kind in case.make
                    if kind == "link-file"})
    before = {p.name for p in folder.iterdir()}
    argv = [sys.executable, "-m", "sphrom", case.command, *case.args]
    t0 = time.monotonic()
    def child_setup():
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        if case.address_space:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, (case.address_space, case.address_space))
    proc = subprocess.Popen(argv, cwd=folder, env=ws.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=child_setup)
    sent_alive, early = False, False
    if case.signal:
        if case.delay < 0:
            time.sleep(-case.delay)
            early = not sphrom_catches_sigterm(proc.pid)
        else:
            deadline = time.monotonic() + 120
            while not sphrom_catches_sigterm(proc.pid) and proc.poll() is None and time.monotonic() < deadline:
                time.sleep(0.001)
            time.sleep(case.delay)
        if still_running(proc):
            proc.send_signal(case.signal)
            sent_alive = True
    try:
        out, err = proc.communicate(timeout=case.timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        code = None
    wall = time.monotonic() - t0
    for k in keep:
        with contextlib.suppress(Exception):
            k.close()
    lines = [line for line in err.strip().splitlines() if line.strip()]
    outcome, detail = classify(case, folder, guarded, before, code, lines, out, sent_alive, early)
    if outcome in ("ok", "clean error", "clean interrupt"):
        shutil.rmtree(folder, ignore_errors=True)
    else:
        (folder / "stderr.txt").write_text(err)
    if case.signal and not sent_alive and outcome == "ok":
        detail = "the run ended before the signal"
    return Result(case, outcome, detail, code, lines, wall, delivered=sent_alive)


def classify(case, folder, guarded, before, code, lines, out, sent_alive, early):
    text = "\n".join(lines)
    if code is None:
        return "hang", f"no answer within {case.timeout:g} s"
    if early and ("Traceback" in text or code in (-signal.SIGINT, -signal.SIGTERM)) \
            and "harness" not in text.replace("-m sphrom", ""):
        return "outside sphrom", "signal before sphrom's first line (interpreter start-up)"
    if "Traceback" in text:
        raised = [line for line in lines if line and not line.startswith((" ", "Traceback"))]
        return "traceback", " | ".join(raised[-2:])[:300]
    # nodes and links must be what they were; a regular file changes only on success
    for rel, snap in guarded.items():
        now = _snapshot(folder / rel)
        if snap is None:
            continue
        if now is None or now[0] != snap[0] or (not stat.S_ISREG(snap[0]) and now[1] != snap[1]):
            return "replaced file", f"{rel}: was {stat.filemode(snap[0])}, now {now and stat.filemode(now[0])}"
        if stat.S_ISREG(snap[0]) and now != snap and code != 0:
            return "replaced file", f"{rel} changed by a run that failed (exit {code})"
    left = [p.name for p in folder.rglob("*") if ".tmp-" in p.name]
    if left:
        return "left behind", ", ".join(left[:3])
    if code in (-signal.SIGINT, -signal.SIGTERM) and case.signal:
        if "Traceback" not in text and not lines and all((folder / o).exists() for o in case.outputs):
            return "outside sphrom", "signal after the interpreter restored the default handlers (exiting)"
    if case.signal and sent_alive:
        if code == 0:
            return "silent wrong result", "exit 0 after the signal (lost)"
        if code == 128 + case.signal:
            body = [line for line in lines if ": warning:" not in line and not line.startswith("FMU warning")]
            if len(body) != 1 or "interrupted" not in body[0]:
                return "unclear error", " | ".join(lines[-3:])[:300]
            new = [o for o in case.outputs if (folder / o).exists() and o not in before]
            if "no output written" in body[0] and new:
                return "silent wrong result", f"'no output written' but {', '.join(new)} exist"
            if "finished runs kept" in body[0]:
                kept = int(body[0].split("); ")[1].split()[0])
                return _check_kept(folder, case, kept)
            return "clean interrupt", body[0][:200]
    if code == 0:
        missing = [o for o in case.outputs if not (folder / o).exists()]
        if missing:
            return "silent wrong result", f"exit 0 without {', '.join(missing)}"
        for o in case.outputs:
            if (folder / o).is_file() and _nan_in_output(folder / o):
                return "silent wrong result", f"NaN in {o}"
        return "ok", ""
    if code in (2, 3, 4):
        body = [line for line in lines if ": warning:" not in line and not line.startswith("FMU warning")]
        if len(body) == 1 and body[0].startswith("sphrom") and (": error: " in body[0] or ": failed: " in body[0]):
            return "clean error", body[0][:200]
        return "unclear error", " | ".join(lines[-3:])[:300]
    if code == 128 + signal.SIGINT or code == 128 + signal.SIGTERM:
        return "clean interrupt", lines[-1][:200] if lines else ""
    return "traceback", f"exit {code}: {' | '.join(lines[-2:])[:300]}"


def _check_kept(folder, case, kept):
    from sphrom.sweep.table import read_results
    h5 = [o for o in case.outputs if o.endswith(".h5")][0]
    try:
        rows, _ = read_results(folder / h5)
        csv_rows = (folder / h5).with_suffix(".csv").read_text().strip().splitlines()[1:]
    except Exception as exc:
        return "silent wrong result", f"'kept' but the results cannot be read ({exc})"
    if len(rows) != kept or len(csv_rows) != kept:
        return "silent wrong result", f"'{kept} kept' but {len(rows)} rows in .h5, {len(csv_rows)} in .csv"
    return "clean interrupt", f"{kept} finished runs kept"


# ---------------------------------------------------------------------------
# the command-line cases
# ---------------------------------------------------------------------------

def baselines(ws):
    """Valid, quick arguments of each command, its outputs, and the long commands' error-only ones."""
    s, b, f2 = "../../s.toml", "../../b.h5", "../../f2.fmu"
    return {
        "sph": (["sph", s, "--out", "o.h5", "--quiet"], ["o.h5"]),
        "pod": (["pod", s, "--out", "o.h5", "--quiet"], ["o.h5"]),
        "rom": (["rom", s, "--basis", b, "--model", "frozen", "--out", "o.h5", "--quiet"], ["o.h5"]),
        "rom-exact": (["rom", s, "--basis", b, "--model", "exact", "--out", "o.h5", "--quiet"], ["o.h5"]),
        "fmu": (["fmu", s, "--modes", "4", "--no-verify", "--out", "o.fmu", "--quiet"], ["o.fmu"]),
        "cosim": (["cosim", f2, "--out", "o.csv"], ["o.csv"]),
        "reference": (["reference", s, "--solver", "exact", "--out", "o.h5", "--quiet"], ["o.h5"]),
        "modes": (["modes", s, "--max-modes", "2", "--out", "d", "--quiet"], ["d"]),
        "bench-sph": (["bench-sph", s, "--n-particles", "16,32", "--integrator", "euler", "--repeats", "1", "--out",
                       "d", "--quiet"], ["d"]),
        "bench-fmu": (["bench-fmu", s, "--core-only", "--n-particles", "48", "--repeats", "5", "--out", "d",
                       "--quiet"], ["d"]),
        "sweep": (["sweep", "../../spec.toml", "--workers", "1", "--out", "r.h5", "--quiet"], ["r.h5", "r.csv"]),
        "scenes": (["scenes"], []),
        "bench": (["bench", "--no-fmu", "--out", "d", "--quiet"], []),
        "stress": (["stress", "--quick", "--out", "d", "--quiet"], []),
        "validate": (["validate", "multimode", "--out", "d", "--quiet"], []),
    }


def _options(command):
    """(option string, action) of a subcommand's parser (introspected: every option is fuzzed)."""
    from sphrom.cli import build_parser
    parser = build_parser()
    sub = parser.commands[command]
    out = []
    for action in sub._actions:
        if not action.option_strings or action.dest in ("help",):
            continue
        out.append((action.option_strings[0], action))
    return out


def _with_option(args, flag, values):
    """``args`` with the option string ``flag`` set to ``values`` (replacing a value it had)."""
    args = list(args)
    if flag in args:
        i = args.index(flag)
        takes = i + 1 < len(args) and not args[i + 1].startswith("--")
        del args[i:i + 1 + takes]
    return args + [flag, *values]


def option_cases(ws, rng, per_option):
    cases = []
    base = baselines(ws)
    for key, (args, outputs) in base.items():
        command = args[0]
        values = INVALID_VALUES if command in LONG_COMMANDS else HOSTILE_VALUES
        for option, action in _options(command):
            if option == "--out":
                continue                          # the path cases below
            long = command in LONG_COMMANDS
            if long and action.nargs != 0 and action.type is None:
                continue                          # any text is valid there: the command would run for hours
            if action.nargs == 0:                 # a flag: given a value, or given twice
                picks = [["=1"]] if long else [rng.choice([["=1"], ["twice"]])]
            else:                                 # hostile values; a third of the options also without a value
                picks = [[v] for v in rng.sample(values, min(per_option, len(values)))]
                picks += [rng.choice([["<missing>"], ["<dup>"]])] if rng.random() < 0.35 else []
            for pick in picks:
                if pick == ["=1"]:
                    new = args[1:] + [option + "=1"]
                elif pick == ["twice"]:
                    new = args[1:] + [option, option]
                elif pick == ["<missing>"]:
                    new = args[1:] + [option]
                elif pick == ["<dup>"]:
                    first = rng.choice(values)
                    new = _with_option(args[1:], option, [first]) + [option, rng.choice(values)]
                else:
                    new = _with_option(args[1:], option, pick)
                cases.append(Case("options", command, new, outputs, note=f"{option} {pick[0]!r}",
                                  timeout=180.0))
        if command not in LONG_COMMANDS and command != "scenes":   # positional arguments
            for value in ("abc", "", "/dev/zero", "/dev/null", "nosuch.toml", "../../b.h5", "-x"):
                new = list(args[1:])
                new[0] = value
                cases.append(Case("options", command, new, outputs, note=f"positional {value!r}", timeout=180.0))
    return cases


PATH_KINDS = ("file", "dir", "fifo", "fifo-read", "null", "full", "socket", "link-file", "link-loop")


def path_cases(ws, rng):
    """--out (or an input path) that is a node, a link, a folder, a trailing '/', /proc, /sys, too long a name."""
    cases = []
    base = baselines(ws)
    for key in ("sph", "rom", "fmu", "cosim", "sweep", "bench-sph"):
        args, outputs = base[key]
        out = outputs[0]
        i = args.index("--out")
        for kind in PATH_KINDS:
            if kind == "fifo" and key not in ("sph", "cosim"):
                continue                          # a FIFO nobody reads waits FIFO_WAIT_S (30 s): twice is enough
            new = args[1:i + 1] + [out] + args[i + 2:]           # --out (at i in args) set to the node
            written = outputs if kind in ("file", "link-file") else []
            cases.append(Case("paths", args[0], new, written, make=[(out, kind)], note=f"--out {kind}",
                              timeout=120.0))
        for odd in (f"sub/{out}/", "sub/", f"/proc/{out}", f"/sys/{out}", "x" * 300 + Path(out).suffix,
                    "x" * 250 + Path(out).suffix, f"nosuch/{out}", f"{out}/.", ""):
            new = args[1:i + 1] + [odd] + args[i + 2:]
            make = [("sub", "dir")] if odd.startswith("sub") else []
            cases.append(Case("paths", args[0], new, [], make=make, note=f"--out {odd[:40]!r}", timeout=120.0))
    # inputs that are nodes
    for key, option in (("rom", "--basis"), ("cosim", None), ("sph", None)):
        args, outputs = base[key]
        for kind in ("fifo", "null", "dir", "socket", "link-loop"):
            new = list(args[1:])
            if option:
                new[new.index(option) + 1] = "in"
            else:
                new[0] = "in"
            cases.append(Case("paths", args[0], new, [], make=[("in", kind)], note=f"input {kind}", timeout=120.0))
    args, outputs = base["cosim"]
    for kind in ("fifo", "null", "dir", "link-loop"):
        cases.append(Case("paths", "cosim", args[1:] + ["--force", "in.csv"], [], make=[("in.csv", kind)],
                          note=f"--force {kind}", timeout=120.0))
    return cases


def _toml_value(rng):
    return rng.choice(["1e308", "-1e308", "1e-320", "-1", "0", "nan", "inf", '"abc"', '""', "[]", "[1, 2]", "{}",
                       "true", str(2**63), "99999999999999999999", '"1/0"', '"x" ', '"\\u0000"', '"a/b"',
                       '"../../x"', '"' + "y" * 5000 + '"', "[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]"])


def scene_cases(ws, rng, count):
    """Scene files with one value (or key) replaced, run through `sphrom sph` (and `fmu` for the rom table)."""
    text = ws["scene"].read_text().splitlines()
    keyed = [i for i, line in enumerate(text) if "=" in line and not line.strip().startswith("#")]
    cases = []
    for n in range(count):
        lines = list(text)
        how = rng.random()
        if how < 0.75:
            i = rng.choice(keyed)
            key = lines[i].split("=")[0]
            lines[i] = f"{key}= {_toml_value(rng)}"
            note = f"{key.strip()} = ..."
        elif how < 0.85:
            i = rng.choice(keyed)
            note = f"without {lines[i].split('=')[0].strip()}"
            del lines[i]
        elif how < 0.95:
            i = rng.choice(range(len(lines)))
            lines.insert(i, f"unknown_{n} = 1")
            note = "an unknown key"
        else:
            lines = lines[: rng.randrange(len(lines))]
            note = "truncated"
        name = f"scene{n}.toml"
        (ws.root / "scenes").mkdir(exist_ok=True)
        (ws.root / "scenes" / name).write_text("\n".join(lines) + "\n")
        command = "fmu" if "[rom]" in "\n".join(lines) and rng.random() < 0.2 else "sph"
        args = ([f"../../scenes/{name}", "--out", "o.h5", "--quiet"] if command == "sph" else
                [f"../../scenes/{name}", "--no-verify", "--out", "o.fmu", "--quiet"])
        cases.append(Case("scenes", command, args, ["o.h5" if command == "sph" else "o.fmu"], note=note,
                          timeout=240.0))
    return cases


def round_four_cases(ws):
    """The round-four cases that live on the command line: damaged FMUs, an output that names an input (on the
    command line or in a sweep's spec), a full file system, byte-order marks, inputs that are folders or FIFOs,
    negative numbers, initial_state_scale, a scene dt longer than the FMU's step, a co-simulation table beyond
    memory, runs of 4e5 and 1e6 particles under a 6 GiB address-space limit."""
    from .damaged import damaged_fmus
    root = ws.root
    cases = []
    for name, path in damaged_fmus(ws["fmu2"], root / "damaged").items():
        cases.append(Case("round four", "cosim", [str(path), "--out", "o.csv"], [], note=f"damaged FMU: {name}"))
    s, f2, force = str(ws["scene"]), str(ws["fmu2"]), str(ws["force"])
    for command, args, make, note in (
            ("sph", ["in.toml", "--out", "in.toml"], [("in.toml", f"copy:{s}")], "--out names the scene"),
            ("pod", ["in.toml", "--out", "./in.toml"], [("in.toml", f"copy:{s}")], "--out names the scene (./)"),
            ("cosim", ["in.fmu", "--out", "in.fmu"], [("in.fmu", f"copy:{f2}")], "--out names the FMU"),
            ("cosim", [f2, "--force", "in.csv", "--out", "in.csv"], [("in.csv", f"copy:{force}")],
             "--out names the --force CSV"),
            ("sph", ["in.toml", "--out", "small/o.h5", "--quiet"], [("in.toml", f"copy:{s}"), ("small", "tmpfs")],
             "--out on a full 64 KiB tmpfs"),
            ("fmu", [s, "--modes", "4", "--no-verify", "--out", "small/o.fmu", "--quiet"], [("small", "tmpfs")],
             "--out on a full 64 KiB tmpfs"),
            ("cosim", [f2, "--t-end", "20", "--out", "small/o.csv"], [("small", "tmpfs")],
             "--out on a full 64 KiB tmpfs"),
            ("sph", ["in.toml", "--out", "o.h5"], [("in.toml", "dir")], "the scene is a folder"),
            ("cosim", [f2, "--force", "in.csv", "--out", "o.csv"], [("in.csv", "fifo")], "--force is a FIFO"),
            ("cosim", [f2, "--initial-state-scale", "1e308", "--out", "o.csv"], [], "initial_state_scale 1e308"),
            ("cosim", [f2, "--t-end", "1e6", "--step", "0.01", "--out", "o.csv"], [], "1e8 steps: memory")):
        cases.append(Case("round four", command, args, [], make=make, note=note, timeout=180.0))
    # case 7: N = 4e5 (its own stable dt) and 1e6 under a 6 GiB address-space limit: refused before the work from
    # the memory estimate (the eigensolver's MemoryError, SuperLU's SIGSEGV before), or one line if an allocation
    # still fails
    for n in (400_000, 1_000_000):
        dt = 2e-4 * 100 / n
        (root / f"n{n}.toml").write_text(small_scene_text(T=max(2e-4, 50 * dt), n=n, dt=dt))
        for command, extra in (("fmu", ["--modes", "4", "--no-verify"]), ("sph", []), ("pod", [])):
            out = "o.fmu" if command == "fmu" else "o.h5"
            cases.append(Case("round four", command, [f"../../n{n}.toml", *extra, "--out", out, "--quiet"], [out],
                              note=f"N = {n:g} under a 6 GiB address-space limit", timeout=900.0,
                              address_space=6 << 30))
    # a sweep's output beside it that is the scene its spec names
    (root / "spec_scene.toml").write_text('title = "t"\nscene = "r.csv"\nt_end = 0.1\nstep = 0.001\nprobes = '
                                          '[0.25]\nparametric = false\n\n[grid]\nshape = ["sine"]\namplitude = '
                                          '[1e-2]\nfrequency = [1.0]\nk = [4]\n')
    cases.append(Case("round four", "sweep", ["spec.toml", "--workers", "1", "--out", "r.h5", "--quiet"], [],
                      make=[("r.csv", f"copy:{s}"), ("spec.toml", f"copy:{root / 'spec_scene.toml'}")],
                      note="--out r.h5 writes r.csv beside it, the scene the spec names", timeout=240.0))
    (root / "bom.csv").write_bytes(b"\xef\xbb\xbf" + ws["force"].read_bytes())
    (root / "bom.toml").write_bytes(b"\xef\xbb\xbf" + ws["scene"].read_bytes())
    (root / "dt.toml").write_text(small_scene_text(T=0.4, n=32, dt=0.02))
    for command, args, outputs, note in (
            ("cosim", [f2, "--force", "../../bom.csv", "--out", "o.csv"], ["o.csv"], "a CSV with a byte-order mark"),
            ("sph", ["../../bom.toml", "--out", "o.h5", "--quiet"], ["o.h5"], "a TOML with a byte-order mark"),
            ("cosim", [f2, "--initial-state-scale", "-1e-3", "--out", "o.csv"], ["o.csv"], "a value -1e-3"),
            ("fmu", ["../../dt.toml", "--modes", "4", "--out", "o.fmu", "--quiet"], ["o.fmu"],
             "dt 0.02 s > the FMU's 0.01 s step, verified"),
            ("fmu", ["../../dt.toml", "--modes", "4", "--model", "exact", "--out", "o.fmu", "--quiet"], ["o.fmu"],
             "dt 0.02 s > the FMU's 0.01 s step, exact, verified")):
        cases.append(Case("round four", command, args, outputs, note=note, timeout=300.0))
    return cases


def running_span(ws, command, args):
    """Seconds from sphrom's handler being up to the end of an undisturbed run of ``command`` (a signal at a
    random moment inside it lands while the command works)."""
    folder = Path(tempfile.mkdtemp(prefix="span-", dir=ws.root))
    (folder / "a").mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "sphrom", command, *args], cwd=folder / "a", env=ws.env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while not sphrom_catches_sigterm(proc.pid) and proc.poll() is None:
        time.sleep(0.001)
    start = time.monotonic()
    proc.wait()
    shutil.rmtree(folder, ignore_errors=True)
    return time.monotonic() - start


def signal_cases(ws, rng, sweeps, per_command):
    """Signals at random moments of every long command: uniform over the run (its span measured once here, from
    sphrom's handler being up to the end), and a few in the interpreter's start-up; ``sweeps`` SIGINTs of a
    sweep."""
    root = ws.root
    (root / "long.toml").write_text(small_scene_text(T=16.0, n=64, every=500))
    (root / "ref.toml").write_text(small_scene_text(T=8.0, n=64, every=500))
    (root / "scenes").mkdir(exist_ok=True)

    def variant(tag):
        """A scene of its own per case (another T by 1e-9): nothing is taken from the cache."""
        path = root / "scenes" / f"long-{tag}.toml"
        path.write_text(small_scene_text(T=4.0 + rng.randrange(1, 10**6) * 1e-9, n=64, every=500))
        return f"../../scenes/{path.name}"

    plans = {
        "sweep": (lambda tag: ["../../spec_long.toml", "--workers", "2", "--out", "r.h5", "--quiet"],
                  ["r.h5", "r.csv"]),
        "sph": (lambda tag: ["../../long.toml", "--out", "o.h5", "--quiet"], ["o.h5"]),
        "pod": (lambda tag: [variant("p" + tag), "--out", "o.h5", "--quiet"], ["o.h5"]),
        "fmu": (lambda tag: [variant("f" + tag), "--modes", "4", "--out", "o.fmu", "--quiet"], ["o.fmu"]),
        "cosim": (lambda tag: ["../../f2.fmu", "--t-end", "120", "--step", "0.001", "--out", "o.csv"], ["o.csv"]),
        "reference": (lambda tag: ["../../ref.toml", "--solver", "fd", "--out", "o.h5", "--quiet"], ["o.h5"]),
    }
    spans = {command: running_span(ws, command, make("span")) for command, (make, _) in plans.items()}
    cases = []
    counts = {"sweep": [(signal.SIGINT, sweeps), (signal.SIGTERM, 2)]}
    for command, (make, outputs) in plans.items():
        for sig, n in counts.get(command, [(signal.SIGINT, (per_command + 1) // 2),
                                           (signal.SIGTERM, per_command // 2)]):
            for i in range(n):
                cases.append(Case("signals", command, make(f"{sig}-{i}"), outputs, signal=sig,
                                  delay=rng.uniform(0, 0.9 * spans[command]), timeout=240.0,
                                  note=f"{signal.Signals(sig).name}, {command} (runs {spans[command]:.1f} s)"))
    for i in range(4):                 # the interpreter's own start-up: reported apart
        sig = (signal.SIGINT, signal.SIGTERM)[i % 2]
        cases.append(Case("signals", "scenes", [], [], signal=sig, delay=-rng.uniform(0.0, 0.08), timeout=60.0,
                          note=f"{signal.Signals(sig).name} in the first 80 ms"))
    return cases


# ---------------------------------------------------------------------------
# the battery
# ---------------------------------------------------------------------------

def run_battery(out: Path, seed=25, jobs=2, quick=False, workdir=None, log=print,
                command="python3 -m tests.hostile"):
    rng = random.Random(seed)
    root = Path(workdir or tempfile.mkdtemp(prefix="sphrom-hostile-"))
    t0 = time.monotonic()
    log(f"workspace {root}: preparing scenes, a basis and FMUs ...")
    ws = prepare(root)
    scale = 0.3 if quick else 1.0
    cases = (option_cases(ws, rng, per_option=max(1, int(3 * scale)))
             + path_cases(ws, rng)
             + scene_cases(ws, rng, int(60 * scale))
             + round_four_cases(ws)
             + signal_cases(ws, rng, sweeps=int(20 * scale) or 1, per_command=max(2, int(6 * scale))))
    log(f"{len(cases)} command-line cases ({jobs} at a time) ...")
    results = []
    signal_jobs = [c for c in cases if c.signal]
    plain = [c for c in cases if not c.signal]
    with ThreadPoolExecutor(jobs) as pool:
        futures = [pool.submit(run_case, c, ws, i) for i, c in enumerate(plain)]
        for n, fut in enumerate(futures):
            results.append(fut.result())
            if (n + 1) % 50 == 0:
                log(f"  {n + 1}/{len(plain)} ({time.monotonic() - t0:.0f} s)")
    log(f"{len(signal_jobs)} signal cases (one at a time: their moments are timed) ...")
    for n, c in enumerate(signal_jobs):
        r = run_case(c, ws, len(plain) + n)
        for _ in range(3):         # ended before its signal (this run was faster than the measured one): earlier
            if r.delivered or c.delay <= 0:
                break
            c = dataclasses.replace(c, delay=c.delay / 2)
            r = run_case(c, ws, len(plain) + n)
        results.append(r)
    log("FMU resources, states and call sequences ...")
    from .fmu_cases import fmu_cases
    results += [Result(Case(category, kind, [], note=label), outcome, detail, None, [], 0.0)
                for category, kind, label, outcome, detail in
                fmu_cases(ws, rng, n_resources=int(2000 * scale), n_states=int(1800 * scale),
                          n_sequences=int(900 * scale))]
    wall = time.monotonic() - t0
    write_results(out, results, wall, seed, command)
    return results, wall, root


def counts(results):
    table = {}
    for r in results:
        table.setdefault(r.case.category, {o: 0 for o in OUTCOMES})[r.outcome] += 1
    return table


def write_results(out: Path, results, wall, seed, command="python3 -m tests.hostile"):
    """hostile.csv (one row per case), hostile_counts.csv (counts by category and outcome), battery_run.csv (the
    command, date, machine) under ``out``, and the README composed from them (:mod:`tests.hostile.report`)."""
    from .report import compose_readme, machine, now, write_run
    out.mkdir(parents=True, exist_ok=True)
    rows = [{"category": r.case.category, "command": r.case.command, "args": " ".join(r.case.args)[:400],
             "case": r.case.note, "signal": signal.Signals(r.case.signal).name if r.case.signal else "",
             "delay_s": f"{r.case.delay:.3f}" if r.case.signal else "", "exit": "" if r.code is None else r.code,
             "stderr_lines": len(r.lines), "outcome": r.outcome, "detail": r.detail, "wall_s": f"{r.wall:.2f}",
             "delivered": int(r.delivered)}
            for r in results]
    write_csv(out / "hostile.csv", rows)
    table = counts(results)
    count_rows = [{"category": cat, **by} for cat, by in table.items()]
    total = {o: sum(by[o] for by in table.values()) for o in OUTCOMES}
    count_rows.append({"category": "all", **total})
    write_csv(out / "hostile_counts.csv", count_rows)
    write_run(out / "battery_run.csv", command=command, seed=seed, cases=len(results), wall_s=f"{wall:.0f}",
              date=now(), machine=machine())
    compose_readme(out)
    return total


def write_csv(path, rows):
    """``rows`` (dicts, the keys of the first as columns) as a CSV file at ``path``, written whole or not at all."""
    from .report import write_csv as write
    write(path, rows)


def print_counts(results, wall, command):
    table = counts(results)
    width = max(len(c) for c in table) + 2
    shown = [o for o in OUTCOMES]
    print(f"{'category':<{width}}" + "".join(f"{o:>{max(len(o), 5) + 2}}" for o in shown) + f"{'cases':>8}")
    for cat, by in list(table.items()) + [("all", {o: sum(b[o] for b in table.values()) for o in OUTCOMES})]:
        print(f"{cat:<{width}}" + "".join(f"{by[o]:>{max(len(o), 5) + 2}}" for o in shown)
              + f"{sum(by.values()):>8}")
    bad = [r for r in results if r.outcome in BAD]
    print(f"{len(results)} cases in {wall:.0f} s ({command}); targets 0 tracebacks, hangs, silent wrong results, "
          f"replaced files: {'met' if not bad else 'missed'}")
    for r in bad[:40]:
        print(f"  {r.outcome}: {r.case.category} {r.case.command} {r.case.note}: {r.detail}")


def main(argv=None, prog="python3 -m tests.hostile"):
    from sphrom.parser import Parser              # one-line errors, as every sphrom program
    p = Parser(prog=prog, description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="validation/hostile", help="folder for hostile.csv and hostile_counts.csv")
    p.add_argument("--seed", type=int, default=25)
    p.add_argument("--jobs", type=int, default=2, help="command-line cases run at a time (default 2)")
    p.add_argument("--quick", action="store_true", help="about a third of the cases")
    p.add_argument("--workdir", help="workspace (default a new temporary folder, kept for the failed cases)")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        from .fmu_cases import child_main
        child_main(args.child)
        return 0
    command = "python3 -m tests.hostile " + " ".join(argv if argv is not None else sys.argv[1:])
    results, wall, root = run_battery(Path(args.out), seed=args.seed, jobs=args.jobs, quick=args.quick,
                                      workdir=args.workdir, command=command.strip())
    print_counts(results, wall, command.strip())
    print(f"wrote {Path(args.out) / 'hostile.csv'} and {Path(args.out) / 'hostile_counts.csv'}; failed cases' "
          f"folders kept under {root / 'cases'}")
    return 1 if any(r.outcome in BAD for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
