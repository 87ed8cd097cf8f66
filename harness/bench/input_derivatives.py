"""Held against interpolated inputs: the FMUs' probe-velocity error against the communication step.

``python -m sphrom.bench.input_derivatives [--out FOLDER]`` packages tenmode's
exact linear FMU and its frozen-coefficient FMU (FMI 2), co-simulates each with
f = 1e-2 sin(2 pi t) at communication steps of 1, 5, 10, 20, 50 ms with the
input held over each step and with df/dt (fmi2SetRealInputDerivatives, f
linear between the samples: integrated exactly by the exact model, evaluated
at each refresh of the force term by the frozen one), and measures the probe
velocities against the same FMU at 0.1 ms with derivatives: relative L2 over
probes and time at the coarse communication points.  Writes
``input_derivatives.csv`` and prints a Markdown table per model.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from ..fmu.make.build import ensure_binaries
from ..fmu.run.cosim import run_cosim
from ..fmu.variables import members
from ..progress import progress_bar
from ..scene import load_scene
from . import program_parser
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

FORCE = "1e-2*sin(2*pi*t)"
MODELS = ("exact", "frozen")
STEPS = (1e-3, 5e-3, 1e-2, 2e-2, 5e-2)
REFERENCE_STEP = 1e-4


def velocity_columns(result):
    """The v_probe_* columns of a CosimResult, (M, n_probes) [m s^-1]."""
    cols = members(result.names, "v_probe_j")
    return result.values[:, cols]


def relative_l2(v, ref):
    """||v - ref|| / ||ref|| over all probes and times."""
    return float(np.linalg.norm(v - ref) / np.linalg.norm(ref))


def measure(scene_name="tenmode", steps=STEPS, reference_step=REFERENCE_STEP, force=FORCE, workdir=None,
            progress=True, models=("exact",)):
    """Rows (model, step [s], input, relative L2 v error, communication steps) for the FMUs of ``models``.

    The reference is the same FMU at ``reference_step`` with input derivatives;
    every step in ``steps`` must be a whole multiple of it.
    """
    return [row for model in models
            for row in _measure_model(model, scene_name, steps, reference_step, force, workdir, progress)]


def _measure_model(model, scene_name, steps, reference_step, force, workdir, progress):
    """:func:`measure` for one model's FMU."""

    from ..fmu.make.package import package_fmu
    scene = load_scene(scene_name)
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        path = Path(tmp) / f"{scene_name}-{model}.fmu"
        package_fmu(scene, path, fmi=2, progress=progress, binaries=ensure_binaries(), model=model)
        t_end = float(scene.T)
        rows = []
        with progress_bar(2 * len(steps) + 1, f"input derivatives, {model}", unit="run", enabled=progress) as bar:
            ref = run_cosim(path, force=force, t_end=t_end, step=reference_step, initial_state_scale=1)
            assert ref.input_derivatives
            v_ref = velocity_columns(ref)
            bar.update(1)
            for h in steps:
                stride = int(round(h / reference_step))
                if abs(stride * reference_step - h) > 1e-12 * h:
                    raise ValueError(f"step {h:g} s is not a multiple of the reference step {reference_step:g} s")
                for hold in (True, False):
                    res = run_cosim(path, force=force, t_end=t_end, step=h, hold_inputs=hold,
                                    initial_state_scale=1)
                    n = res.values.shape[0]
                    sub = v_ref[::stride][:n]
                    assert np.allclose(res.values[:, 0], ref.values[::stride, 0][:n], rtol=0, atol=1e-9)
                    rows.append({"model": model, "step_ms": h * 1e3,
                                 "input": "derivative" if res.input_derivatives else "held",
                                 "v_error_rel_l2": relative_l2(velocity_columns(res), sub),
                                 "communication_steps": res.steps})
                    bar.update(1)
    return rows


def markdown(rows, model="exact"):
    """A Markdown table of ``model``'s rows: one line per step, held and derivative errors side by side."""
    by = {(r["step_ms"], r["input"]): r["v_error_rel_l2"] for r in rows if r["model"] == model}
    lines = ["| communication step | v error, f held | v error, f linear (df/dt) |", "| --- | --- | --- |"]
    for h in sorted({r["step_ms"] for r in rows if r["model"] == model}):
        lines.append(f"| {h:g} ms | {by[h, 'held']:.2e} | {by[h, 'derivative']:.2e} |")
    return "\n".join(lines)


def main(argv=None):
    p = program_parser("input_derivatives", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--scene", default="tenmode")
    p.add_argument("--model", choices=MODELS, action="append",
                   help="measure this model's FMU (repeat for several; default both)")
    args = p.parse_args(argv)
    models = tuple(args.model or MODELS)
    rows = measure(args.scene, models=models)
    out = Path(args.out) / "input_derivatives.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    for model in models:
        print(f"{args.scene}, {model} FMU (FMI 2), f = {FORCE}; probe-velocity error (relative L2 over probes and "
              f"time) against the same FMU at {REFERENCE_STEP * 1e3:g} ms with df/dt")
        print(markdown(rows, model))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
