"""Time against error of the linear reduced models (balanced, exact) and the paper's (frozen, original), with
the certified bounds beside, on the training force and on an unseen one.

At each state dimension r (default 4, 8, ..., 24) every model gets r reduced coordinates: the balanced model
its order r, the POD models k = r/2 velocity and r/2 second modes (one more velocity mode where the force
profile is appended, as each model's FMU does).  Errors are the probe velocity errors (eq. 3.4 at the probes
x/L = 0.25, 0.5, 0.66) against the full SPH, on the scene's own force (the training force: the POD snapshots
saw it) and on UNSEEN_FORCE (another time history along the same profile, the POD basis unchanged).  For the
linear models, the absolute error against the full linear SPH (exact in time, the input linear between
samples as in the models) stands beside its certified bound force_error_bound ||f||_L2 +
initial_state_error_bound (the largest over the probes; :func:`sphrom.rom.balanced.error_bounds`).  Online
times are medians of ``repeats`` runs.  Run as::

    python -m sphrom.bench.linear_tradeoff [--scenes damped_forced,damped_forced@shaped] [--orders 4,8,...]
        [--repeats 3] [--benchmarks BENCHMARKS.md]

which prints the table and writes it as the section "Linear models: time against error" of BENCHMARKS.md
(:func:`linear_tradeoff_section`), replacing an earlier one.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import defaults
from ..cache import cached_sph
from ..markdown import write_text
from ..norms import relative_l2
from ..progress import progress_bar
from ..rom.result import probe_values
from ..scene import derive_scene
from . import program_parser
from .lib.document import fmt
from .lib.timing import median_time

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

DEFAULT_SCENES = ("damped_forced", "damped_forced@shaped")
ORDERS = (4, 8, 12, 16, 20, 24)
MODELS = ("balanced", "exact", "frozen", "original")
UNSEEN_FORCE = "2e-2*sin(2*pi*3.7*t)*exp(-t/T) + 5e-3*sin(2*pi*0.37*t)"      # not the scene's three tones
PROBES = defaults.PROBES
SECTION_TITLE = "## Linear models: time against error"
STRESS_TITLE = "## Stability stress maps"


def _scenes(name):
    """(training scene, unseen-force scene) of NAME or NAME@shaped (the shaped force profile)."""
    from .lib.linear_scenes import setup
    scene, _, _ = setup(name)
    return scene, derive_scene(scene, {"force": {"f": UNSEEN_FORCE}})


def _probe_v(result, problem, scene):
    return probe_values(result.v, result.rho, problem.rho0, problem.x, scene.L, PROBES)[:, :len(PROBES)]


def measure_scene(name, orders=ORDERS, repeats=3, progress=None):
    """Rows (dict) of one scene: per force, order and model the online time, the probe velocity error against
    the full SPH and, for the linear models, the error against the full linear SPH and its bound."""
    from ..pod.pipeline import basis_for_scene, on_steps
    from ..rom.lti import full_linear_system, input_norm, sample_outputs
    from ..rom.registry import get_model
    from ..sph.solver import build_problem, step_count
    scene, unseen = _scenes(name)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    n = step_count(scene.T, scene.sph.dt)
    steps = np.arange(0, n + 1, scene.sph.every)               # a uniform sample grid (the exact reference's)
    t = steps * scene.sph.dt
    n = int(steps[-1])
    lti = full_linear_system(problem, PROBES)
    A = lti.dense()
    h = float(t[1] - t[0])
    P = len(PROBES)
    # the linear models' error against the full linear SPH on a finer uniform grid (Simpson at h_f and 2 h_f,
    # extrapolated): 4m intervals of every/6 steps, at most T
    every_f = max(1, scene.sph.every // 6)
    m_f = (n // every_f) // 4 * 4
    steps_f = np.arange(m_f + 1) * every_f
    h_f = every_f * scene.sph.dt
    forces = {}
    for label, sc in (("training", scene), ("unseen", unseen)):
        sph = cached_sph(sc, steps, progress=False, problem=build_problem(sc))
        v, rho = on_steps(sph, steps)
        f = np.asarray(sc.force(t), float)
        f_f = np.asarray(sc.force(steps_f * scene.sph.dt), float)
        full = sample_outputs(A, lti.B[:, 0], lti.C[:P], lti.x0, h_f, f_f)
        forces[label] = (sc, probe_values(v, rho, problem.rho0, problem.x, scene.L, PROBES)[:, :P], f_f, full)
    rows = []
    balanced_ops = None
    for r in orders:
        k = max(1, r // 2)
        for model in MODELS:
            spec = get_model(model)
            if spec.needs_basis:                      # the paper's frozen and original models, the exact one
                ops = spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction, **spec.paper_build)
            else:
                if balanced_ops is None:              # one balancing; each order truncates it (= build at r)
                    balanced_ops = spec.build(problem, None, max(orders), max(orders), probes=PROBES)
                ops = spec.truncate(problem, balanced_ops, r, r)
            t0 = time.perf_counter()
            bounds = ops.error_bounds(problem, PROBES)              # the linear models' certified bounds
            if bounds is not None:
                bounds["time"] = time.perf_counter() - t0
            state_dim = ops.order
            for label, (sc, y_sph, f, full) in forces.items():
                kwargs = dict(n_steps=n, dt=scene.sph.dt, sample_steps=steps, force=sc.force,
                              options=spec.select_options(integrator=scene.sph.integrator, n_freeze=10))
                out = {}

                def go():
                    out["r"] = spec.run(ops, problem, **kwargs)
                try:
                    online, _ = median_time(go, repeats=repeats)
                except Exception as exc:                       # a runaway of the nonlinear models: say so
                    rows.append({"scene": name, "force": label, "order": r, "model": model, "state": state_dim,
                                 "online_s": np.nan, "err_sph": np.nan, "err_linear": np.nan, "bound": np.nan,
                                 "note": f"failed: {str(exc)[:60]}"})
                    continue
                y = _probe_v(out["r"], problem, scene)
                row = {"scene": name, "force": label, "order": r, "model": model, "state": state_dim,
                       "online_s": online, "err_sph": relative_l2(y, y_sph, t), "err_linear": np.nan,
                       "bound": np.nan, "note": ""}
                if bounds is not None:
                    fine = spec.run(ops, problem, **dict(kwargs, n_steps=int(steps_f[-1]), sample_steps=steps_f))
                    err = _l2(_probe_v(fine, problem, scene) - full, h_f)
                    bound = bounds["force_error_bound"] * input_norm(h_f, f) + bounds["initial_state_error_bound"]
                    row.update(err_linear=float(np.max(err)), bound=float(np.max(bound)),
                               bound_time=bounds["time"], sigma=bounds["sigma"])
                rows.append(row)
            if progress is not None:
                progress.update(1)
    return rows


def _l2(e, h):
    """‖e‖_L2 per column from samples at spacing h (4m intervals): Simpson at h and 2h, extrapolated."""
    from scipy.integrate import simpson
    e2 = e ** 2
    fine, coarse = simpson(e2, dx=h, axis=0), simpson(e2[::2], dx=2 * h, axis=0)
    return np.sqrt(np.maximum(fine + (fine - coarse) / 15.0, 0.0))


def linear_tradeoff_section(rows, command, wall):
    """Time against error of balanced, exact, frozen and original at equal state dimension, per scene and force,
    with the linear models' certified bounds beside their measured errors ."""
    lines = ["## Linear models: time against error", "",
             f"Produced by `{command}` ({wall:.0f} s wall; online times are medians of repeated runs on a shared "
             "2-core machine). State dimension r for every model: the balanced model's order, k = r/2 POD modes "
             "of each kind for the others (one more velocity mode where the force profile is appended, as in each "
             "model's FMU; the column *state* gives the count). "
             "Errors: probe velocities at x/L = 0.25, 0.5, 0.66; *vs SPH* the relative L² error (eq. 3.4) against "
             "the full SPH run; *vs linear* the absolute ‖y − y_full‖_L2(0,T) [m s⁻¹ s^½] against the full "
             "linear SPH exact in time (largest over the probes), beside its certified *bound* "
             "force_error_bound ‖f‖_L2 + initial_state_error_bound (what `sphrom fmu` stores in the FMU). "
             "*training*: the scene's own force; *unseen*: another time history along the same profile "
             "(`UNSEEN_FORCE` of the module), the POD basis unchanged. Where *vs linear* lies far below "
             "*vs SPH*, the rest is the difference between the time-stepped full SPH run and the linear SPH exact "
             "in time (the linear models have no time-step error).", ""]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for force in ("training", "unseen"):
            sub = [r for r in rows if r["scene"] == scene and r["force"] == force]
            if not sub:
                continue
            lines += [f"### {scene}, {force} force", "",
                      "| r | model | state | online [s] | v error vs SPH | vs linear | bound | bound / measured | note |",
                      "| -- | ----- | ----- | ---------- | -------------- | --------- | ----- | ---------------- | ---- |"]
            for r in sub:
                ratio = r["bound"] / r["err_linear"] if r["err_linear"] and not math.isnan(r["err_linear"]) else None
                lines.append(f"| {r['order']} | {r['model']} | {r['state']} | {fmt(r['online_s'], '.4f')} | "
                             f"{fmt(r['err_sph'])} | {fmt(r['err_linear'])} | {fmt(r['bound'])} | "
                             f"{fmt(ratio, '.5f')} | {r['note']} |")
            lines.append("")
    return lines


def write_section(path, text):
    """Replace the section SECTION_TITLE of the Markdown file ``path`` with ``text``; a new one goes before the
    stress maps (where ``sphrom bench --report`` carries it over, :data:`sphrom.bench.suite.CARRIED`), else at
    the end."""
    path = Path(path)
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    lines = old.splitlines()
    body = text.rstrip("\n").splitlines()
    if SECTION_TITLE in lines:
        start = lines.index(SECTION_TITLE)
        end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
        new_lines = lines[:start] + body + ([""] if end < len(lines) else []) + lines[end:]
    elif STRESS_TITLE in lines:
        at = lines.index(STRESS_TITLE)
        new_lines = lines[:at] + body + [""] + lines[at:]
    else:
        new_lines = lines + ([""] if lines else []) + body
    new = "\n".join(new_lines) + "\n"
    write_text(path, new if new.endswith("\n") else new + "\n")


def main(argv=None):
    p = program_parser("linear_tradeoff", description=__doc__.split("\n")[0])
    p.add_argument("--scenes", default=",".join(DEFAULT_SCENES), help="NAME[@shaped],... (default %(default)s)")
    p.add_argument("--orders", default=",".join(map(str, ORDERS)), help="state dimensions r (default %(default)s)")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per point, the median kept (default 3)")
    p.add_argument("--benchmarks", default="BENCHMARKS.md", help="the Markdown file whose section is replaced")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    orders = [int(x) for x in args.orders.split(",") if x]
    if not scenes or not orders or min(orders) < 2 or args.repeats < 1:
        p.error("--scenes, --orders (each >= 2) and --repeats (>= 1) need values")
    rows = []
    t0 = time.perf_counter()
    with progress_bar(len(scenes) * len(orders) * len(MODELS), "tradeoff", enabled=not args.quiet) as bar:
        for name in scenes:
            rows += measure_scene(name, orders, args.repeats, progress=bar)
    command = ("python -m sphrom.bench.linear_tradeoff --scenes " + ",".join(scenes) + " --orders "
               + ",".join(map(str, orders)) + f" --repeats {args.repeats}")
    text = "\n".join(linear_tradeoff_section(rows, command, time.perf_counter() - t0)) + "\n"
    print(text)
    write_section(args.benchmarks, text)
    print(f"wrote the section to {args.benchmarks}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
