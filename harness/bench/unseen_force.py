"""The FMUs driven by forces their basis never saw: forced response against the full SPH's.

On a scene with uniform ρ0, c and force profile (tenmode, trained as a free
vibration), a force moves the bar rigidly: the SPH gradient of a constant
vanishes, so the full SPH's forced response is v(t) = the integral of the
input at every particle and no density change.  The models are linear in the
input (the exact one exactly, the frozen one to its linearisation), so the
forced response is the forced run minus the free run at the communication
points.  Run as::

    python -m sphrom.bench.unseen_force [SCENE ...] [--out validation/benchmarks/unseen_force.csv]

and it prints, per model and force, the relative L² error of the forced probe
velocity against the held input's integral and the largest forced density
change at the probes [kg m^-3]; and, for the price of keeping the force
profile in the basis, each FMU's free response (the scene's own run, f = 0,
10 ms steps) against the full SPH at the probes.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from .. import defaults
from ..fmu.resources import probe_pairs
from ..fmu.run.driver import FMU
from ..scene import load_scene
from . import program_parser
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

FORCES = (
    ("sine 3.7 Hz + mean 1e-3, 10 s", 0.01, 1000, lambda t: 2e-3 * np.sin(2 * np.pi * 3.7 * t) + 1e-3),
    ("constant 1e-3, 1000 s", 0.25, 4000, lambda t: np.full_like(t, 1e-3)),
)


def forced_response(path, h, inputs):
    """(v, rho) at the probes: the run with ``inputs`` held over steps ``h`` minus the run without.

    Raises RuntimeError with the FMU's logged reason when a step ends in an error status."""
    runs = []
    for f in (inputs, np.zeros_like(inputs)):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            try:
                runs.append(s.run([h] * len(f), f))
            except Exception:                  # fmpy's FMICallException: the FMU logged why
                raise RuntimeError("; ".join(s.errors()) or "error status") from None
    d = runs[0] - runs[1]
    n = d.shape[1] // 2
    return d[:, :n], d[:, n:]


def _free_probe_velocities(path, h, n):
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        out = s.run([h] * n, np.zeros(n))
    return out[:, :out.shape[1] // 2]


def _sph_probe_velocities(scene, h, n, probes=defaults.PROBES):
    """The full SPH's velocity at the FMU's default probes (linear interpolation) every ``h`` [s]."""
    from ..sph.solver import build_problem, run_sph
    problem = build_problem(scene)
    steps = np.round(np.arange(n + 1) * h / scene.sph.dt).astype(int)
    run = run_sph(scene, sample_steps=steps, progress=False, problem=problem)
    i0, i1, w = probe_pairs(problem.x, scene.L, np.asarray(probes))
    return run.v[:, i0] * (1 - w) + run.v[:, i1] * w


def measure(scene_name, models=None, folder=None):
    """Rows (scene, model, force, err_v, max_drho) for the FMU of each model of ``scene_name``."""
    from ..fmu.make.package import package_fmu
    from ..rom.registry import fmu_model_names
    scene = load_scene(scene_name)
    folder = Path(folder or tempfile.mkdtemp(prefix="sphrom-unseen-"))
    rows = []
    sph_v = _sph_probe_velocities(scene, 0.01, int(round(scene.T / 0.01)))
    for model in models or fmu_model_names():
        path = folder / f"{scene.name}-{model}.fmu"
        package_fmu(scene, path, model=model, progress=False)
        free = _free_probe_velocities(path, 0.01, sph_v.shape[0] - 1)
        err_free = float(np.linalg.norm(free - sph_v) / np.linalg.norm(sph_v))
        rows.append({"scene": scene.name, "model": model, "force": "none (free response vs full SPH)",
                     "err_v": err_free, "max_drho": float("nan"), "note": ""})
        print(f"{scene.name} {model:7s} {'free response vs full SPH':30s} probe v error {err_free:.3e}", flush=True)
        for label, h, n, force in FORCES:
            f = force(np.arange(n) * h)
            try:
                v, rho = forced_response(path, h, f)
            except RuntimeError as exc:
                rows.append({"scene": scene.name, "model": model, "force": label, "err_v": float("nan"),
                             "max_drho": float("nan"), "note": str(exc)})
                print(f"{scene.name} {model:7s} {label:30s} FMU error: {exc}", flush=True)
                continue
            expected = np.concatenate([[0.0], np.cumsum(f * h)])[:, None] * np.ones((1, v.shape[1]))
            err = float(np.sqrt(np.sum((v - expected) ** 2) / np.sum(expected ** 2)))
            rows.append({"scene": scene.name, "model": model, "force": label, "err_v": err,
                         "max_drho": float(np.abs(rho).max()), "note": ""})
            print(f"{scene.name} {model:7s} {label:30s} forced v error {err:.3e}, "
                  f"max |forced rho change| {np.abs(rho).max():.3e} kg/m^3", flush=True)
    return rows


def main(argv=None):
    p = program_parser("unseen_force", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", default=["tenmode"], metavar="SCENE")
    p.add_argument("--out", default="validation/benchmarks/unseen_force.csv", metavar="FILE.csv")
    args = p.parse_args(argv)
    rows = [r for s in args.scenes for r in measure(s)]
    write_csv(Path(args.out), rows)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
