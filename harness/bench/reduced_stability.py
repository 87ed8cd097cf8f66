"""The reduced models' blow-up guard on the paper's scenes: how close a sound run comes to its alarms.

``python -m sphrom.bench.reduced_stability [SCENE ...] [--out FOLDER]`` runs
the frozen and the density-linearised models of each scene (every k of
``rom.accel_modes`` and ``rom.modes``, explicit Euler and, for the frozen model,
symplectic Euler, the scene's Δt and T, the scene's force) and reports

* ``growth``: the factor by which the integrator amplifies the worst reduced
  mode over the run (:func:`sphrom.rom.stepping.reduced_amplification`;
  ``sphrom rom`` warns above :data:`sphrom.sph.solver.GROWTH_WARN`);
* ``energy_ratio``: the largest ratio, over the samples, of the energy of the
  reconstructed fields (:func:`sphrom.rom.stepping.reduced_energy`) to the bound
  the scene's initial energy and forcing allow (the run stops at
  :data:`sphrom.sph.solver.BLOWUP_FACTOR` times it).

Writes ``reduced_stability.csv`` and prints a Markdown table.
"""

import sys
import time
from pathlib import Path

import numpy as np

from ..scene import load_scene
from . import program_parser
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SCENES = ("multimode", "tenmode", "damped", "damped_forced", "heterogeneous", "mild_damped_forced", "gaussian",
          "high_frequency")
RUNS = (("frozen", "euler"), ("frozen", "symplectic"), ("linearized", "euler"))


def energy_ratio(result, ops, problem, scene):
    """max over the samples of E(t) / (e^{λt} (√E0 + σ ∫_0^t |f| ds))² (:func:`sphrom.sph.solver.energy_bound_factors`)."""
    from ..rom.stepping import reduced_energy
    from ..sph.solver import energy_bound_factors, step_count
    e = np.array([reduced_energy(ops, problem, av, ar) for av, ar in zip(result.a_v, result.a_rho)])
    n = step_count(scene.T, scene.sph.dt)
    f = np.abs(scene.force(np.arange(n + 1) * scene.sph.dt)) if problem.terms["force_profile"] else np.zeros(n + 1)
    f_int = np.concatenate([[0.0], np.cumsum(f[:-1]) * scene.sph.dt])[result.steps]
    sigma, lam = energy_bound_factors(problem)
    return float(np.max(e / (np.exp(lam * result.t) * (np.sqrt(e[0]) + sigma * f_int)) ** 2))


def measure(scenes=SCENES, progress=True):
    """Rows (scene, model, integrator, k, growth, energy_ratio, wall_s)."""

    from ..pod.pipeline import basis_for_scene, scene_modes
    from ..rom.registry import get_model
    from ..rom.stepping import reduced_amplification
    from ..sph.solver import build_problem, step_count
    rows = []
    for name in scenes:
        scene = load_scene(name)
        problem = build_problem(scene)
        basis, _ = basis_for_scene(scene, progress=progress, problem=problem)
        n = step_count(scene.T, scene.sph.dt)
        ks = sorted({scene_modes(scene, basis), *map(int, scene.rom.get("accel_modes", []) or [])})
        for k in ks:
            k = min(k, *basis.max_modes)
            for model_name, integrator in RUNS:
                model = get_model(model_name)
                ops = model.build(problem, basis, k, k, **model.paper_build)       # the paper's models
                t0 = time.perf_counter()
                res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, every=scene.sph.every,
                                options=model.options(integrator=integrator), force=scene.force, progress=progress)
                rows.append({"scene": name, "model": model_name, "integrator": integrator, "k": k,
                             "growth": reduced_amplification(ops, scene.sph.dt, integrator, scene.T)[0],
                             "energy_ratio": energy_ratio(res, ops, problem, scene),
                             "wall_s": time.perf_counter() - t0})
    return rows


def markdown(rows):
    lines = ["| scene | model | integrator | k | growth over the run | max E / bound |", "| --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {r['scene']} | {r['model']} | {r['integrator']} | {r['k']} | {r['growth']:.3g} | "
              f"{r['energy_ratio']:.3g} |" for r in rows]
    return "\n".join(lines)


def main(argv=None):
    p = program_parser("reduced_stability", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE", help=f"default: {' '.join(SCENES)}")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    args = p.parse_args(argv)
    rows = measure(tuple(args.scenes) or SCENES)
    out = Path(args.out) / "reduced_stability.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    print(markdown(rows))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
