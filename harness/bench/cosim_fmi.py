"""FMI 2 against FMI 3 under ``sphrom cosim``: the same model built for both, co-simulated with the same force.

``python -m sphrom.bench.cosim_fmi [SCENE] [--models frozen,exact,balanced] [--force EXPR] [--out FILE.csv]``
packages SCENE's FMU of each model for FMI 2 and FMI 3 (the scene's defaults, as ``sphrom fmu SCENE --model
MODEL --fmi 2|3``; the linear ones without bounds, which change no output) and co-simulates both through
:func:`sphrom.fmu.run.cosim.run_cosim` at their default step over T, with the quickstart's force, twice: with
``sphrom cosim``'s defaults (FMI 2: f linear over each step with df/dt; FMI 3: held, docs/fmu/cosim.md) and with
``--hold-inputs`` (both held).  Per model and input rule: the largest |y_FMI3 - y_FMI2| over every output and
point, relative to the largest |y_FMI2| of that output, and whether the outputs are bitwise equal.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..fmu.make.build import ensure_binaries
from ..fmu.make.package import package_fmu
from ..fmu.run.cosim import run_cosim
from ..rom.registry import get_model
from ..scene import load_scene
from . import program_parser
from .lib.tables import write_csv

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

FORCE = "1e-3*sin(2*pi*t)"          # the quickstart's (README.md)


def measure(scene_name="tenmode", models=("frozen", "exact", "balanced"), force=FORCE, progress=False):
    """Rows (scene, model, input rule, largest relative difference, bitwise equal, communication steps)."""
    scene = load_scene(scene_name)
    binaries = ensure_binaries(quiet=not progress)
    rows = []
    with tempfile.TemporaryDirectory(prefix="sphrom-cosim-fmi-") as tmp:
        for model in models:
            paths = {}
            for fmi in (2, 3):
                paths[fmi] = Path(tmp) / f"{model}-fmi{fmi}.fmu"
                package_fmu(scene, paths[fmi], model=model, fmi=fmi, progress=progress, binaries=binaries,
                            bounds=False if get_model(model).linear else True)
            for hold in (False, True):
                y2, y3 = (run_cosim(paths[fmi], force=force, hold_inputs=hold) for fmi in (2, 3))
                scale = np.maximum(np.max(np.abs(y2.values[:, 1:]), axis=0), np.finfo(float).tiny)
                diff = float(np.max(np.abs(y3.values[:, 1:] - y2.values[:, 1:]) / scale))
                rows.append({"scene": scene.name, "model": model,
                             "inputs": "held (--hold-inputs)" if hold else "defaults (FMI 2 linear, FMI 3 held)",
                             "max_rel_difference": diff,
                             "bitwise_equal": bool(np.array_equal(y2.values, y3.values)), "steps": y2.steps})
    return rows


def main(argv=None):
    p = program_parser("cosim_fmi", description=__doc__.split("\n\n")[0])
    p.add_argument("scene", nargs="?", default="tenmode")
    p.add_argument("--models", default="frozen,exact,balanced", metavar="M,...")
    p.add_argument("--force", default=FORCE, metavar="EXPR")
    p.add_argument("--out", metavar="FILE.csv", help="also write the rows as CSV")
    args = p.parse_args(argv)
    rows = measure(args.scene, tuple(args.models.split(",")), args.force)
    print(f"{args.scene}, f = {args.force}: FMI 3 against FMI 2 under sphrom cosim (largest |difference| / largest "
          "|output| over every output)")
    print("| model | inputs | relative difference | bitwise equal |\n| --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['model']} | {r['inputs']} | {r['max_rel_difference']:.2e} | "
              f"{'yes' if r['bitwise_equal'] else 'no'} |")
    if args.out:
        write_csv(Path(args.out), rows)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
