"""Capture the outputs of every kind of FMU and Python model a checkout makes, to compare two checkouts bitwise.

A refactoring that claims to change no number runs this once on the code before and once after, then compares:

    python3 tests/data/capture_outputs.py --code OLD_CHECKOUT --out /tmp/before.npz
    python3 tests/data/capture_outputs.py --code NEW_CHECKOUT --out /tmp/after.npz
    python3 tests/data/capture_outputs.py --compare /tmp/before.npz /tmp/after.npz

It drives only the command line (``python -m sphrom fmu|pod|rom``, the contract both checkouts keep) and runs
the FMUs with fmpy's FMU2Slave / FMU3Slave directly (not sphrom's co-simulation), so what is compared is
what a user gets.  Per FMU: every output and calculated parameter at each of 150 communication points (10 ms,
inputs held; FMI 2 FMUs that can interpolate inputs once more with input derivatives), the sha256 of
resources/model.bin and the declared variables.  Per Python run: every dataset of the run file.  Each checkout
gets a private SPH cache.  ``--quick`` keeps two scenes.
"""

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

SCENES = ["tenmode", "damped", "damped_forced", "mild_damped_forced", "gaussian", "multimode", "heterogeneous",
          "high_frequency"]
QUICK = ["damped_forced", "heterogeneous"]
STEP, N_STEPS = 0.01, 150


def variants(scenes):
    """(label, scene, fmu options) of every FMU to capture."""
    for s in scenes:
        for model in ("frozen", "exact", "balanced"):
            for fmi in (2, 3):
                yield f"{s}/{model}/fmi{fmi}", s, ["--model", model, "--fmi", str(fmi), "--no-bounds"]
    for s, ports in (("damped_forced", "0.3,0.7"), ("tenmode", "0.5")):
        if s in scenes:
            for model in ("frozen", "exact"):
                for fmi in (2, 3):
                    yield f"{s}/{model}-ports/fmi{fmi}", s, ["--model", model, "--fmi", str(fmi), "--no-bounds",
                                                            "--ports", ports]
    if "damped_forced" in scenes:
        for model in ("frozen", "exact"):
            for fmi in (2, 3):
                yield (f"damped_forced/{model}-vary-c/fmi{fmi}", "damped_forced",
                       ["--model", model, "--fmi", str(fmi), "--no-bounds", "--vary", "c=0.05:0.2"])
            yield (f"damped_forced/{model}-vary-d/fmi2", "damped_forced",
                   ["--model", model, "--no-bounds", "--vary", "d=5:15"])
        yield "damped_forced/exact-bounds/fmi2", "damped_forced", ["--model", "exact"]


def python_runs(scenes):
    """(label, scene, rom options) of the Python model runs to capture."""
    for s in scenes:
        if s in ("damped_forced", "heterogeneous", "multimode"):
            for model in ("frozen", "exact", "linearized", "original"):
                yield f"py/{s}/{model}", s, ["--model", model]
            yield f"py/{s}/frozen-nf3-symplectic", s, ["--model", "frozen", "--n-freeze", "3",
                                                      "--integrator", "symplectic"]
            yield f"py/{s}/exact-held", s, ["--model", "exact", "--hold", "held", "--step", "0.02"]
    if "damped_forced" in scenes:
        yield "py/damped_forced/balanced", "damped_forced", ["--model", "balanced", "--modes", "12"]


def sphrom(code, args, env):
    done = subprocess.run([sys.executable, "-m", "sphrom", *args, "--quiet"], cwd=code, env=env,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: exit {done.returncode}\n{done.stderr[-2000:]}")


def run_fmu(path, rates):
    """{name: (N_STEPS + 1, ) array} of every output and calculated parameter of the FMU at path."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave
    md = read_model_description(path)
    unzipdir = extract(path)
    fmi3 = md.fmiVersion.startswith("3")
    cls = FMU3Slave if fmi3 else FMU2Slave
    fmu = cls(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName="capture")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    watched = [v.name for v in md.modelVariables if v.causality in ("output", "calculatedParameter")]
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]

    def set_real(names, values):
        if names:
            (fmu.setFloat64 if fmi3 else fmu.setReal)([vr[n] for n in names], list(values))

    def get_real(names):
        return (fmu.getFloat64 if fmi3 else fmu.getReal)([vr[n] for n in names])

    def signal(name, t):
        if name == "f":
            return 1e-3 * np.sin(2 * np.pi * 0.7 * t) + 5e-4
        j = int(name.rsplit("_", 1)[1])
        return 2e-3 * np.sin(1.3 * t) if j % 2 else 1e-3 * np.cos(3.1 * t) + 5e-4

    def rate(name, t, h=1e-6):
        return (signal(name, t + h) - signal(name, t - h)) / (2 * h)

    if fmi3:
        fmu.instantiate()
    else:
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    params = {"initial_state_scale": 1.0, "c": 0.13, "d": 9.0}
    set_real([n for n in params if n in vr], [params[n] for n in params if n in vr])
    fmu.exitInitializationMode()
    rows = []
    t = 0.0
    for i in range(N_STEPS + 1):
        if inputs:
            set_real(inputs, [signal(n, t) for n in inputs])
            if rates:
                fmu.setRealInputDerivatives([vr[n] for n in inputs], [1] * len(inputs),
                                            [rate(n, t) for n in inputs])
        rows.append(get_real(watched))
        if i == N_STEPS:
            break
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
        t = (i + 1) * STEP
    fmu.terminate()
    fmu.freeInstance()
    values = np.array(rows, dtype=float)
    return {name: values[:, j] for j, name in enumerate(watched)}, md


def capture(code, out, scenes):
    from fmpy import read_model_description  # noqa: F401  (fail early without fmpy)
    code = Path(code).resolve()
    work = Path(tempfile.mkdtemp(prefix="sphrom-capture-"))
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from checkout import import_path
    env = dict(os.environ, SPHROM_CACHE=str(work / "cache"), PYTHONPATH=import_path(code))
    arrays = {}
    for label, scene, options in variants(scenes):
        path = work / (label.replace("/", "_") + ".fmu")
        print(f"fmu {label}", flush=True)
        sphrom(code, ["fmu", scene, *options, "--no-verify", "--out", str(path)], env)
        with zipfile.ZipFile(path) as z:
            arrays[f"{label}/model.bin.sha256"] = np.array(hashlib.sha256(z.read("resources/model.bin")).hexdigest())
        values, md = run_fmu(str(path), rates=False)
        arrays.update({f"{label}/{name}": v for name, v in values.items()})
        if not md.fmiVersion.startswith("3") and md.coSimulation.canInterpolateInputs:
            values, _ = run_fmu(str(path), rates=True)
            arrays.update({f"{label}/rates/{name}": v for name, v in values.items()})
        arrays[f"{label}/variables"] = np.array(sorted(
            f"{v.name}|{v.valueReference}|{v.causality}|{v.variability}|{v.start}" for v in md.modelVariables))
    for scene in {s for _, s, _ in python_runs(scenes)}:
        sphrom(code, ["pod", scene, "--out", str(work / f"{scene}_basis.h5")], env)
    for label, scene, options in python_runs(scenes):
        print(f"rom {label}", flush=True)
        path = work / (label.replace("/", "_") + ".h5")
        basis = [] if "balanced" in options else ["--basis", str(work / f"{scene}_basis.h5")]
        sphrom(code, ["rom", scene, *basis, *options, "--out", str(path)], env)
        import h5py
        with h5py.File(path, "r") as h:
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu":
                    arrays[f"{label}/{name}"] = obj[()]
            h.visititems(visit)
    np.savez_compressed(out, **arrays)
    print(f"wrote {out}: {len(arrays)} arrays from {code}")


def compare(a, b):
    """Print every key that differs (bitwise) and the largest difference; exit 1 when any does."""
    A, B = np.load(a), np.load(b)
    only_a, only_b = sorted(set(A.files) - set(B.files)), sorted(set(B.files) - set(A.files))
    differ = []
    for key in sorted(set(A.files) & set(B.files)):
        x, y = A[key], B[key]
        if x.dtype.kind in "US" or y.dtype.kind in "US":
            if not np.array_equal(x, y):
                differ.append((key, "text differs"))
            continue
        if x.shape != y.shape or x.tobytes() != y.tobytes():
            d = np.max(np.abs(x - y)) if x.shape == y.shape else "shape"
            differ.append((key, f"max |diff| {d}"))
    for key in only_a:
        print(f"only in {a}: {key}")
    for key in only_b:
        print(f"only in {b}: {key}")
    for key, what in differ:
        print(f"differs: {key}: {what}")
    same = len(set(A.files) & set(B.files)) - len(differ)
    print(f"{same} arrays bitwise equal, {len(differ)} differ, {len(only_a)} only before, {len(only_b)} only after")
    return 1 if differ else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--code", default=str(Path(__file__).resolve().parents[2]))
    parser.add_argument("--out")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = parser.parse_args()
    if args.compare:
        sys.exit(compare(*args.compare))
    capture(args.code, args.out, QUICK if args.quick else SCENES)


if __name__ == "__main__":
    main()
