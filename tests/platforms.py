"""One FMU's binaries for two platforms driven alike and their outputs compared bit for bit: this platform's
(linux64) run by the C loader ``fmu_src/tests/load.c`` built natively, and the cross-compiled win64 one run by the
same loader cross-compiled with MinGW-w64, under wine.  Used by tests/test_fmu_platforms.py; run as a program it
prints the comparison of the FMUs given::

    python3 tests/platforms.py FMU [FMU ...]

The loader is an importer as a system simulator is one: it loads the library at run time and calls it through
the FMI functions only; inputs and outputs cross as the bits of IEEE 754 doubles (16 hex digits), so nothing is
rounded on the way.
"""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

STEPS = 120          # communication steps of the fixed input sequence
SEED = 35            # its inputs: uniform in [-1, 1] times the input's scale, from this seed
INPUT_SCALE = {"f": 0.05, "F_port": 1e-3, "a_port": 1e-3}   # [m s^-2], [N], [N]: inside the training envelope
# (a_port_j, the wave form's incident wave, is read only with port_impedance > 0: driven alike, it must not matter)


def bits(x):
    """The 16 hex digits of the IEEE 754 double ``x``."""
    return struct.pack("<d", float(x))[::-1].hex()


def runner():
    """The command that runs a win64 program here (``wine``, else ``wine64``), or None."""
    for name in ("wine", "wine64"):
        found = shutil.which(name)
        if found:
            return found
    return None


class Wine:
    """wine with a prefix of its own (``prefix``, made on first use) and its server kept up while the ``with``
    block lasts, so that each run skips wine's start (seconds) and other users' prefixes are left alone; the
    server (this prefix's only) is stopped on leaving."""

    def __init__(self, prefix):
        self.command = runner()
        self.environment = {**os.environ, "WINEPREFIX": str(prefix), "WINEDEBUG": "-all",
                            "WINEDLLOVERRIDES": "mscoree,mshtml="}     # quiet, no installer dialog on creation

    def __enter__(self):
        # the server and the prefix's services started here outlive the call: their output goes nowhere (a pipe
        # they held open would keep a later run's output from closing)
        quiet = dict(stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        Path(self.environment["WINEPREFIX"]).mkdir(parents=True, exist_ok=True)
        subprocess.run(["wineserver", "-p"], env=self.environment, timeout=120, check=True, **quiet)
        subprocess.run([self.command, "wineboot", "--init"], env=self.environment, timeout=600, **quiet)
        return self

    def __exit__(self, *exc):
        subprocess.run(["wineserver", "-k"], env=self.environment, timeout=120, capture_output=True)

    def windows_path(self, path):
        """``path`` as wine sees it (``Z:\\tmp\\...``): winepath's answer."""
        proc = subprocess.run(["winepath", "-w", str(path)], capture_output=True, text=True, env=self.environment,
                              timeout=300)
        if proc.returncode != 0 or not proc.stdout.strip():
            raise RuntimeError(f"winepath -w {path} failed: {proc.stderr.strip()}")
        return proc.stdout.strip()


@dataclass
class Drive:
    """A fixed drive of one FMU: its variables (value references), the step and the input sequence."""

    fmi: int
    token: str
    inputs: list          # value references of the Float64 inputs
    outputs: list         # value references of the Float64 outputs
    names: list           # the outputs' names
    h: float              # communication step [s]
    values: np.ndarray    # (STEPS, len(inputs)) input values
    starts: dict          # {value reference: value} set before initialization


def drive_of(folder, steps=STEPS, seed=SEED):
    """The fixed drive of the FMU extracted to ``folder``: every Float64 input, a seeded uniform sequence scaled
    per input (:data:`INPUT_SCALE`), the DefaultExperiment's step, the scene's initial velocity
    (``initial_state_scale`` = 1), every Float64 output."""
    import fmpy
    md = fmpy.read_model_description(str(folder))
    fmi = int(md.fmiVersion.split(".")[0])
    real = ("Real", "Float64")
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type in real]
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type in real]
    starts = {v.valueReference: 1.0 for v in md.modelVariables if v.name == "initial_state_scale"}
    scale = np.array([next(s for p, s in INPUT_SCALE.items() if v.name.startswith(p)) for v in inputs])
    values = np.random.default_rng(seed).uniform(-1, 1, (steps, len(inputs))) * scale
    h = float(md.defaultExperiment.stepSize) if md.defaultExperiment and md.defaultExperiment.stepSize else 1e-3
    token = md.guid if fmi == 2 else md.instantiationToken
    return Drive(fmi, token, [v.valueReference for v in inputs], [v.valueReference for v in outputs],
                 [v.name for v in outputs], h, values, starts)


def script(drive, library, resources):
    """The loader's script (fmu_src/tests/load.c) of ``drive`` with the library and resource location given."""
    lines = [f"fmi {drive.fmi}", f"library {library}", f"resources {resources}", f"token {drive.token}",
             "instantiate", f"inputs {len(drive.inputs)} {' '.join(map(str, drive.inputs))}",
             f"outputs {len(drive.outputs)} {' '.join(map(str, drive.outputs))}"]
    lines += [f"set {vr} {bits(x)}" for vr, x in drive.starts.items()]
    lines.append("initialize")
    lines += [f"step {bits(drive.h)} {' '.join(bits(u) for u in row)}".rstrip() for row in drive.values]
    lines += ["state", "end"]
    return "\n".join(lines) + "\n"


@dataclass
class Run:
    """What the loader printed: the time and output bits per step, and the serialized state's bytes."""

    words: np.ndarray     # (steps, 1 + outputs) uint64
    state: bytes

    @property
    def values(self):
        return self.words.view(np.float64)


def parse(stdout):
    rows, state = [], b""
    for line in stdout.splitlines():
        if line.startswith("state "):
            _, size, *hexes = line.split()
            state = bytes.fromhex(hexes[0] if hexes else "")
            assert len(state) == int(size), line[:80]
        elif line.strip():
            rows.append([int(w, 16) for w in line.split()])
    return Run(np.array(rows, dtype=np.uint64), state)


def run_loader(command, script_path, environment=None):
    proc = subprocess.run([*command, str(script_path)], capture_output=True, text=True, env=environment,
                          timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} {script_path} failed ({proc.returncode}):\n"
                           f"{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    return parse(proc.stdout)


def resource_location(fmi, folder):
    """FMI 2: the resources folder's file URI; FMI 3: its path with a trailing separator (POSIX)."""
    return f"file://{folder.resolve().as_posix()}/resources" if fmi == 2 else f"{folder.resolve()}/resources/"


def windows_resource_location(fmi, windows_folder):
    """The same for a folder wine names ``windows_folder`` (``Z:\\...``)."""
    if fmi == 2:
        return "file:///" + windows_folder.replace("\\", "/") + "/resources"
    return windows_folder + "\\resources\\"


@dataclass
class Comparison:
    """linux64 against win64 over one FMU's fixed drive."""

    fmu: str
    fmi: int
    names: list
    linux: Run
    windows: Run

    @property
    def n_values(self):
        """Output values compared (steps x outputs)."""
        return int(self.linux.words[:, 1:].size)

    @property
    def n_different(self):
        """Output values whose bits differ."""
        return int(np.count_nonzero(self.linux.words[:, 1:] != self.windows.words[:, 1:]))

    def max_relative(self):
        """The largest |win64 - linux64| over the output's largest |value| over the run, across the outputs."""
        a, b = self.linux.values[:, 1:], self.windows.values[:, 1:]
        scale = np.abs(a).max(axis=0)
        scale[scale == 0] = 1.0
        return float(np.max(np.abs(a - b) / scale)) if a.size else 0.0

    def line(self):
        return (f"{self.fmu} (FMI {self.fmi}): {self.n_values} output values ({len(self.names)} outputs x "
                f"{len(self.linux.words)} steps), {self.n_different} differ in their bits, largest relative "
                f"difference {self.max_relative():.3g}; serialized states ({len(self.linux.state)} bytes) "
                + ("equal" if self.linux.state == self.windows.state else "DIFFER"))


def compare(fmu, linux_loader, windows_loader, workdir, wine):
    """Drive the linux64 and the win64 binary of ``fmu`` alike (:func:`drive_of`; the win64 one with the
    :class:`Wine` ``wine``) and return the :class:`Comparison`; ``workdir`` is a scratch folder."""
    workdir = Path(workdir)
    folder = workdir / Path(fmu).stem
    shutil.rmtree(folder, ignore_errors=True)
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(folder)
    drive = drive_of(folder)
    plat = {2: ("linux64", "win64"), 3: ("x86_64-linux", "x86_64-windows")}[drive.fmi]
    (folder / "linux.txt").write_text(script(drive, folder / "binaries" / plat[0] / "sphrom.so",
                                             resource_location(drive.fmi, folder)))
    linux = run_loader([str(linux_loader)], folder / "linux.txt")
    assert (folder / "binaries" / plat[1] / "sphrom.dll").is_file(), f"{fmu} carries no {plat[1]} binary"
    win_folder = wine.windows_path(folder.resolve())
    (folder / "windows.txt").write_text(script(drive, f"{win_folder}\\binaries\\{plat[1]}\\sphrom.dll",
                                               windows_resource_location(drive.fmi, win_folder)))
    windows = run_loader([wine.command, str(windows_loader)], folder / "windows.txt", wine.environment)
    return Comparison(Path(fmu).name, drive.fmi, drive.names, linux, windows)


def main(argv):
    sys.path.insert(0, str(Path(__file__).parent))
    import tempfile

    from sphrom.fmu.make.build import WIN64, ensure_binaries, ensure_cross_binaries
    native = ensure_binaries(quiet=False)
    cross = ensure_cross_binaries(WIN64, quiet=False)
    with tempfile.TemporaryDirectory() as tmp, Wine(Path(tmp) / "wine") as wine:
        for fmu in argv:
            print(compare(fmu, native.loader, cross.loader, tmp, wine).line())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
