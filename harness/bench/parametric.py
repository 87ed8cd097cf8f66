"""The parametric reduced model at held-out (c, d) against the full SPH there, and against a model trained there.

One parametric model is trained over the range (full SPH at the corners and
the centre, one POD of all their snapshots, operators affine in c and d:
:mod:`sphrom.rom.parametric`).  At held-out points (the Halton sequence in
the box, none a training point) the full SPH is run, and the probe-velocity
error (relative L² over the probes and the scene's error samples, eq. 3.4's
norm) is measured for

* the parametric model assembled at (c, d) - what the parametric FMU runs, and
* the model an FMU trained at that point alone carries (``sphrom fmu`` of the
  scene with that c and d: its own SPH run and POD, same k).

Both run in Python (the FMUs equal them: bitwise for the frozen model,
tests/test_parametric.py).  With ``--fmu`` (the default) it also times
doStep of the parametric FMU against the fixed one (the scene's values).
Run as::

    python -m sphrom.bench.parametric [--scene tenmode] [--vary c=0.05:0.2 --vary d=0:5] [--model frozen]
        [--points 10] [--out validation/benchmarks/parametric]

It writes ``<scene>_<model>.csv`` (one row per held-out point), ``<scene>_<model>.png`` (the map) and
prints a markdown table.
"""

from __future__ import annotations

import csv
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import defaults
from ..cache import cached_sph
from ..fmu.make.build import ensure_binaries
from ..fmu.run.driver import FMU
from ..norms import relative_l2
from ..progress import progress_bar
from ..scene import load_scene
from . import program_parser

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

PROBES = defaults.PROBES
DEFAULT_VARY = ("c=0.05:0.2", "d=0:5")


def probe_velocity_error(v_red, v_ref, t):
    """Relative L² error (eq. 3.4's norm, time by the trapezoidal rule) of probe velocities (M, P) [m s^-1]."""
    return relative_l2(v_red, v_ref, t)


def reduced_probe_velocity(model_name, ops, problem, scene, steps, n_freeze=10):
    """Probe velocities (M, P) [m s^-1] of reduced operators run over the scene at ``steps`` (f = the scene's)."""
    from ..rom.exact_linear import run_exact
    from ..rom.registry import get_model
    dt = scene.sph.dt
    if get_model(model_name).linear:
        t = steps * dt
        res = run_exact(ops, t, step=float(np.min(np.diff(t))), force=scene.force if ops.has_force_input else None)
        a_v = res.a_v
    else:
        frozen = get_model("frozen")
        res = frozen.run(ops, problem, n_steps=int(steps[-1]), dt=dt, sample_steps=steps,
                         options=frozen.options(n_freeze=n_freeze))
        a_v = res.a_v
    return a_v @ ops.velocity_probe_rows(problem, PROBES).T


def sph_probe_velocity(run, problem, scene, steps):
    """Probe velocities (M, P) of a cached full SPH run at ``steps`` (linear between particles, as the FMU)."""
    from ..rom.operators import probe_rows
    index = np.searchsorted(run.steps, steps)
    rows = probe_rows(np.eye(problem.x.size), problem.x, scene.L, PROBES)
    return run.v[index] @ rows.T


def measure(scene, vary, model="frozen", k=None, n_points=10, progress=True, input_direction=None):
    """Rows (dicts) per held-out point: c, d, the parametric and the single-point errors and their ratio.

    Also returns (space, training points, held-out points).
    """
    from ..rom import parametric as par
    from ..fmu.make.options import default_modes
    from ..fmu.make.parametric import parametric_model
    k = k or default_modes(scene)
    affine, space, _, train = parametric_model(scene, vary, k, model=model, progress=progress,
                                               input_direction=input_direction)
    held = par.held_out_points(space, n_points)
    rows = []
    with progress_bar(total=len(held), desc="held-out points", unit="point", enabled=progress) as bar:
        for c, d in held:
            rows.append(_held_out_row(scene, affine, model, k, c, d))
            bar.update(1)
    return rows, space, train, held


def _held_out_row(scene, affine, model, k, c, d):
    """One held-out point: the full SPH there, the parametric model and a model trained there alone."""
    from ..rom import parametric as par
    from ..fmu.make.models import exact_model, reduced_model
    from ..pod.pipeline import error_steps
    from ..rom.registry import get_model
    from ..sph.solver import build_problem
    s = par.scene_at(scene, c, d)
    problem = build_problem(s)
    steps = error_steps(s)
    run = cached_sph(s, steps, progress=False, problem=problem)
    ref = sph_probe_velocity(run, problem, s, steps)
    t = steps * s.sph.dt
    linear = get_model(model).linear
    ops_p = par.linear_at(affine, c, d) if linear else par.frozen_at(affine, c, d)
    t0 = time.perf_counter()
    e_par = probe_velocity_error(reduced_probe_velocity(model, ops_p, problem, s, steps), ref, t)
    if linear:
        _, ops_1, _, _ = exact_model(s, k, PROBES, progress=False, problem=problem)
    else:
        _, ops_1, _, _ = reduced_model(s, k, 10, PROBES, s.sph.integrator, progress=False, problem=problem)
    e_one = probe_velocity_error(reduced_probe_velocity(model, ops_1, problem, s, steps), ref, t)
    return {"c": float(c), "d": float(d), "error_parametric": e_par, "error_single": e_one,
            "ratio": e_par / e_one if e_one > 0 else float("inf"), "wall_s": time.perf_counter() - t0}


def step_cost(scene, vary, model="frozen", k=None, steps=2000, h=0.01):
    """Mean wall time [s] of one doStep (h) of the parametric FMU (at its start values) and of the fixed FMU."""
    from ..fmu.make.package import package_fmu
    binaries = ensure_binaries()
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, ranges in (("parametric", vary), ("fixed", ())):
            path = Path(folder) / f"{name}.fmu"
            package_fmu(scene, path, k=k, model=model, progress=False, binaries=binaries, vary=ranges,
                        probes=PROBES)
            best = float("inf")
            times = np.concatenate([[0.0], np.cumsum(np.full(steps, h))])     # tc += h, step after step
            for _ in range(3):
                with FMU(path) as s:
                    s.initialize()
                    t0 = time.perf_counter()
                    s.simulate(times, outputs=[], steps=np.full(steps, h))
                    best = min(best, (time.perf_counter() - t0) / steps)
            out[name] = best
    return out


def plot(rows, space, train, path, title):
    """The map: held-out points coloured by the parametric error, labelled with the ratio to the single-point one."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    c = np.array([r["c"] for r in rows])
    d = np.array([r["d"] for r in rows])
    err = np.array([r["error_parametric"] for r in rows])
    fig, ax = plt.subplots(figsize=(7.2, 5.2))
    sc = ax.scatter(c, d, c=err, cmap="viridis", s=90, edgecolors="k", zorder=3)
    fig.colorbar(sc, ax=ax, label="probe-velocity error, parametric model (rel. L²)")
    for r in rows:
        ax.annotate(f"{r['ratio']:.2f}x", (r["c"], r["d"]), textcoords="offset points", xytext=(6, 6), fontsize=8)
    ax.scatter(train[:, 0], train[:, 1], marker="s", color="red", s=50, label="training (full SPH + POD)", zorder=4)
    (c_lo, c_hi), (d_lo, d_hi) = space.bounds("c"), space.bounds("d")
    ax.add_patch(plt.Rectangle((c_lo, d_lo), c_hi - c_lo, max(d_hi - d_lo, 1e-12), fill=False, ls="--", lw=0.8))
    ax.set_xlabel("c [kg m^-1 s^-2]")
    ax.set_ylabel("d [s^-1]")
    ax.set_title(title, fontsize=8, loc="left")
    ax.legend(loc="upper left", fontsize=8, bbox_to_anchor=(0, -0.12))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def markdown(rows, cost=None):
    lines = ["| c [kg m^-1 s^-2] | d [s^-1] | error, parametric | error, trained at the point | ratio |",
             "|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['c']:.4g} | {r['d']:.4g} | {r['error_parametric']:.3e} | {r['error_single']:.3e} | "
                     f"{r['ratio']:.2f} |")
    worst = max(r["ratio"] for r in rows)
    lines.append("")
    lines.append(f"largest ratio {worst:.2f} over {len(rows)} held-out points")
    if cost:
        lines.append(f"doStep (h = 0.01 s): parametric FMU {cost['parametric'] * 1e6:.1f} us, fixed FMU "
                     f"{cost['fixed'] * 1e6:.1f} us, ratio {cost['parametric'] / cost['fixed']:.2f}")
    return "\n".join(lines)


def main(argv=None):
    p = program_parser("parametric", description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="tenmode")
    p.add_argument("--vary", action="append", default=None, metavar="c=LO:HI|d=LO:HI",
                   help="parameter ranges (default c=0.05:0.2 and d=0:5)")
    p.add_argument("--model", default="frozen", choices=("frozen", "exact"))
    p.add_argument("--modes", type=int, default=None, help="POD modes k (default: the scene's)")
    p.add_argument("--points", type=int, default=10, help="held-out points (default 10)")
    p.add_argument("--input-direction", default=None, choices=("needed", "project", "augment", "moments"),
                   help="how the force profile enters the parametric model (default: the FMU's rule)")
    p.add_argument("--no-fmu", action="store_true", help="skip the doStep timing of the FMUs")
    p.add_argument("--out", default="validation/benchmarks/parametric")
    args = p.parse_args(argv)
    from ..rom import parametric as par
    from ..rom import parametric as par           # after the options: --help answers before numba loads
    scene = load_scene(args.scene)
    vary = [par.parse_vary(text) for text in (args.vary or DEFAULT_VARY)]
    rows, space, train, _ = measure(scene, vary, model=args.model, k=args.modes, n_points=args.points,
                                    input_direction=args.input_direction)
    cost = None if args.no_fmu else step_cost(scene, vary, model=args.model, k=args.modes)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"{scene.name}_{args.model}"
    with open(out / f"{stem}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    ranges = ", ".join(f"{r.name} in [{r.lo:g}, {r.hi:g}]" for r in vary)
    plot(rows, space, train, out / f"{stem}.png",
         f"{scene.name}, {args.model} model, {ranges}: probe-velocity error at held-out points\n"
         f"(labels: parametric error / error of a model trained at the point)")
    text = markdown(rows, cost)
    print(text)
    (out / f"{stem}.md").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
