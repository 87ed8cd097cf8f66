"""User scenes at the first try: a corpus of plausible bars (:mod:`sphrom.bench.lib.corpus`) through ``sphrom fmu``.

``sphrom bench scenes [--seed S] [--count C] [--n-min N] [--n-max N] [--out FILE.csv] [--report FILE.md]
[--resume]`` writes each scene of the corpus to a TOML file and does what a user does with it: loads it (the
loader's automatic integrator and dt, or a refusal in one line), packages the default FMU (``sphrom fmu SCENE``: the
cheaper per simulated second of the frozen and the exact model among those that meet the accuracy, then a cheaper
configuration of it where it is slower than the full SPH, :func:`sphrom.fmu.make.auto.default_choice`) and the exact FMU (``sphrom fmu SCENE --model exact``), each measured
by packaging's own check (:mod:`sphrom.fmu.check.verify`: the training force from the scene's initial state, a step
and an in-band sine from rest, against the full SPH linear in J integrated exactly in time, at the communication
step that resolves the scene's band).  Per scene and FMU:

- built at the first try: the FMU was written (packaging's verdict: no failure, no runaway, v error at most 0.1 on
  every case);
- v errors: the largest over the three cases (eq. 3.4 at the probes);
- bounds: whether the certified bound of every v_probe held at every point, and the largest ratio over the cases of
  max bound / max(100 max error, 1 % max |v|) (useful when at most 1: the issue's criterion);
- warnings: those the FMU logged, and the false alarms among them (a warning while the true error is below a tenth of
  error_tolerance);
- cost: packaging's own figure (:func:`sphrom.fmu.check.verify.measure_cost`, the one its choice and its verdict
  use): the FMU's own work (its doStep calls, in steady stepping at its communication step: the first call, a
  setup done once per step length, left out and reported apart) per simulated second over the full SPH's (its
  compiled loop): the median of the ratios of ``COST_REPEATS`` pairs of runs timed in turn, each run's CPU time of
  the process's thread (:func:`time.thread_time`), so that the time other processes take the cores does not count;
  and the configuration packaging took (k, bounds: a cheaper one where the FMU was slower than the full SPH,
  :func:`sphrom.fmu.make.auto.cheaper_if_slower`);
- the full SPH's own time error: the scene's full SPH (its integrator and dt) against the same truth on the training
  force.

Writes the CSV, a PNG beside it (the errors and the cost ratios of every scene against the thresholds) and the
section "User scenes at the first try" of the report, with a summary against each acceptance criterion of a
user's first try.

The outputs are rewritten after every scene, so a run stopped part way leaves the table of the scenes it measured
(saying how many); ``--resume`` keeps the rows of ``--out`` that a run of the same corpus (seed, index and N)
measured and measures the rest, so the corpus can be measured over several sittings.  The wall time reported is
the sum of every scene's.
"""

from __future__ import annotations

import math
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..errors import SimulationError, ToleranceError, UserError
from ..runio import atomic_path
from ..scene import load_scene
from . import machine_text, program_command, program_parser
from .lib.corpus import corpus
from .lib.document import fmt, program_outputs, publish, update_report
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## User scenes at the first try"
DEFAULT_LIMIT, EXACT_LIMIT = 0.1, 0.05      # the must-show's largest v errors of the default and the exact FMU
USEFUL_FACTOR, USEFUL_FRACTION = 100.0, 0.01  # a bound is useful when max bound <= max(100 max error, 1 % max |v|)
FALSE_ALARM = 0.1                           # a warning is false while the true error is below this x error_tolerance
_WARN_TIME = re.compile(r"at t = ([-+0-9.eE]+) s")


def bound_figures(verification):
    """(holds, usefulness) over the cases of a verification: whether every v bound held, and the largest ratio
    max bound / max(100 max error, 1 % max |v|) (nan without bounds)."""
    holds, worst = None, float("nan")
    for c in verification.cases:
        if c.fmu_v_bound is None or not np.all(np.isfinite(c.fmu_v)):
            continue
        holds = (holds is not False) and bool(c.bound_holds)
        allowed = max(USEFUL_FACTOR * c.max_error, USEFUL_FRACTION * float(np.max(np.abs(c.sph_v))))
        ratio = float(np.max(c.fmu_v_bound)) / allowed if allowed > 0 else math.inf
        worst = ratio if not worst == worst else max(worst, ratio)
    return holds, worst


def warning_figures(verification):
    """(warnings, false alarms): the warnings every case logged, and those logged while the true error (the largest
    |v_FMU - v_truth| over the probes at the last point at or before the warning's time) was below
    :data:`FALSE_ALARM` x error_tolerance."""
    count, false = 0, 0
    tol = verification.error_tolerance
    for c in verification.cases:
        for w in c.warnings:
            count += 1
            m = _WARN_TIME.search(w)
            if m is None or not tol == tol:
                continue
            j = max(0, int(np.searchsorted(c.t, float(m.group(1)), side="right")) - 1)
            if float(np.max(np.abs(c.fmu_v[j] - c.sph_v[j]))) < FALSE_ALARM * tol:
                false += 1
    return count, false


def fmu_row(prefix, summary, verdict, note=""):
    """The columns of one FMU (``prefix`` ``default_`` or ``exact_``): its cost per simulated second is packaging's
    own (:class:`sphrom.fmu.check.verify.Cost`: the median of the CPU-time ratios of
    :data:`sphrom.fmu.check.verify.COST_REPEATS` pairs of runs of the FMU in steady stepping and the full SPH, timed
    in turn), the figure its choice and its verdict use; ``note``: packaging's note on its choice."""
    if summary is None:
        return {f"{prefix}built": False, f"{prefix}model": "", f"{prefix}note": verdict or ""}
    v = summary.verification
    c = v.cost
    fmu_s, sph_s, ratio = (c.fmu_s, c.sph_s, c.ratio) if c is not None else (v.training.step_s, v.training.sph_s,
                                                                             v.training.cost_ratio)
    holds, useful = bound_figures(v)
    warnings, false = warning_figures(v)
    return {f"{prefix}built": verdict is None, f"{prefix}model": summary.model,
            f"{prefix}training_v": v.training.err_v, f"{prefix}step_v": v.case("step").err_v,
            f"{prefix}unseen_v": v.unseen.err_v, f"{prefix}max_v": v.worst.err_v,
            f"{prefix}bound_holds": holds, f"{prefix}bound_usefulness": useful,
            f"{prefix}warnings": warnings, f"{prefix}false_alarms": false,
            f"{prefix}cost_ratio": ratio, f"{prefix}fmu_cpu_s": fmu_s,
            f"{prefix}sph_cpu_s": sph_s, f"{prefix}fmpy_ratio": v.training.fmu_s / v.training.sph_s,
            f"{prefix}setup_s": c.setup_s if c is not None else float("nan"),
            f"{prefix}steps": c.steps if c is not None else len(v.training.t) - 1,
            f"{prefix}k": summary.k, f"{prefix}bounds": summary.shadow_order > 0, f"{prefix}step": v.step,
            f"{prefix}choice": note, f"{prefix}note": verdict or ""}


def measure_scene(name, text, facts, folder, progress=False):
    """One row: the scene as a user's file, its default and exact FMUs (module docstring)."""
    from ..fmu.check.verify import acceptance, case_errors, sph_reference
    from ..fmu.make.auto import FALLBACK_MODEL, cheaper_if_slower, default_choice
    from ..fmu.make.package import package_fmu
    t0 = time.perf_counter()
    path = Path(folder) / f"{name}.toml"
    path.write_text(text)
    row = {**facts}
    try:
        scene = load_scene(path)
    except UserError as exc:
        return {**row, "loaded": False, "note": str(exc), "wall_s": time.perf_counter() - t0}
    row.update(loaded=True, integrator_used=scene.sph.integrator, dt=scene.sph.dt, T=scene.T,
               steps=round(scene.T / scene.sph.dt))
    options = dict(progress=progress, verify=True, tolerance=None, bounds=False)
    try:
        tried = []
        try:
            best, note, tried = default_choice(scene, folder, options, Path(folder) / "default.fmu")
            row.update(fmu_row("default_", best, None, note), default_choice=note)
        except ToleranceError as exc:
            from ..fmu.make.auto import default_candidates
            tried = tried or default_candidates(scene, folder, options)
            row.update(fmu_row("default_", tried[0][0], str(exc)), default_choice="")
        exact = next((s for s in (t[0] for t in tried) if s is not None and s.model == FALLBACK_MODEL), None)
        if exact is None:
            exact = package_fmu(scene, Path(folder) / "exact.fmu", model="exact", accept=False,
                                references=tried[0][0].verification.refs if tried and tried[0][0] else None,
                                **options)
        verdict = acceptance(exact.verification, None, "exact")
        note = ""
        if verdict is None:     # what `sphrom fmu --model exact` writes: a cheaper configuration where it is slower
            exact, note = cheaper_if_slower(scene, folder, exact, options)
        row.update(fmu_row("exact_", exact, verdict, note))
        v = exact.verification
        _, sph_v, sph_rho, rho0, _ = sph_reference(scene, scene.f.text, 1.0, v.step, v.probes)[:5]
        tr = v.training
        row["sph_time_error"] = case_errors(sph_v, sph_rho, tr.sph_v, tr.sph_rho, tr.rho0, tr.t)[0]
        row["step"] = v.step
        row["max_v"] = float(np.max(np.abs(tr.sph_v)))
    except (UserError, SimulationError) as exc:
        row.update(default_built=False, exact_built=False, note=str(exc))
    row["wall_s"] = time.perf_counter() - t0
    return row


def summary_lines(rows):
    """The section's summary: each acceptance criterion of a user's first try against the corpus."""
    from ..fmu.check.verify import COST_REPEATS
    from ..fmu.make.auto import DEFAULT_MODEL
    n = len(rows)
    loaded = [r for r in rows if r.get("loaded")]

    def count(pred):
        return sum(1 for r in rows if pred(r))

    def ok(x, limit):
        return isinstance(x, float) and x <= limit
    both = count(lambda r: r.get("default_built") and r.get("exact_built"))
    acc = count(lambda r: ok(r.get("default_max_v"), DEFAULT_LIMIT) and ok(r.get("exact_max_v"), EXACT_LIMIT))
    holds = count(lambda r: r.get("default_bound_holds") is not False and r.get("exact_bound_holds") is not False)
    useful = count(lambda r: all(ok(r.get(f"{p}bound_usefulness"), 1.0) for p in ("default_", "exact_")))
    false = sum(int(r.get("default_false_alarms") or 0) + int(r.get("exact_false_alarms") or 0) for r in rows)
    warns = sum(int(r.get("default_warnings") or 0) + int(r.get("exact_warnings") or 0) for r in rows)
    faster = count(lambda r: ok(r.get("default_cost_ratio"), 1.0) and ok(r.get("exact_cost_ratio"), 1.0))
    fallback = count(lambda r: r.get("default_model") and r.get("default_model") != DEFAULT_MODEL)
    cheaper = count(lambda r: "packaging chose" in f"{r.get('default_choice') or ''}{r.get('exact_choice') or ''}")
    setup = [max(float(r.get(f"{p}setup_s") or 0.0) / float(r.get(f"{p}sph_cpu_s")) for p in ("default_", "exact_")
                 if isinstance(r.get(f"{p}sph_cpu_s"), float) and r.get(f"{p}sph_cpu_s") > 0) for r in rows
             if any(isinstance(r.get(f"{p}sph_cpu_s"), float) for p in ("default_", "exact_"))]
    worst = lambda key: max((r[key] for r in rows if isinstance(r.get(key), float) and r[key] == r[key]),
                            default=float("nan"))
    return [f"- **Built at the first try** (the default and the exact FMU written, no failure, no runaway, v error "
            f"at most 0.1 on every case): {both} of {n} scenes ({len(loaded)} loaded; the default model was the "
            f"exact one on {fallback}, where the frozen missed the accuracy or cost more per simulated second than "
            "the exact one).",
            f"- **Accuracy** (largest v error over the three cases <= {DEFAULT_LIMIT:g} default, <= {EXACT_LIMIT:g} "
            f"exact): {acc} of {n} (largest: default {fmt(worst('default_max_v'), '.3g')}, exact "
            f"{fmt(worst('exact_max_v'), '.3g')}).",
            f"- **Bounds hold** at every point of every case, both FMUs: {holds} of {n}; **useful** (max bound <= "
            f"max(100 x max error, 1 % of max |v|)) on every case, both FMUs: {useful} of {n} (largest ratio "
            f"{fmt(worst('default_bound_usefulness'), '.3g')} default, {fmt(worst('exact_bound_usefulness'), '.3g')} "
            "exact).",
            f"- **Warnings**: {warns} logged, {false} while the true error was below a tenth of error_tolerance "
            "(false alarms).",
            f"- **Faster than the full SPH** per simulated second (the FMU's doStep calls in steady stepping at its "
            f"communication step against the full SPH's compiled loop, the median CPU-time ratio of {COST_REPEATS} "
            f"pairs of runs: packaging's own figure), both FMUs: {faster} of {n} (largest ratio: default "
            f"{fmt(worst('default_cost_ratio'), '.3g')}, exact {fmt(worst('exact_cost_ratio'), '.3g')}); a cheaper "
            f"configuration (fewer modes or no certified bounds) taken by packaging on {cheaper}. The one-time setup "
            f"(the first doStep: the maps of the step length) at most {fmt(max(setup, default=float('nan')), '.3g')} "
            "times the full SPH's cost over the scene's T.",
            f"- The full SPH's own time error (its integrator and dt against the same truth, training force): at "
            f"most {fmt(worst('sph_time_error'), '.3g')}."]


def table_lines(rows):
    def e(x, spec=".2e"):
        return fmt(x, spec) if isinstance(x, float) else ("—" if x in (None, "") else str(x))

    def yes(x):
        return "—" if x is None or x == "" else ("yes" if x in (True, "True") else "**no**")
    def config(r, p):
        if r.get(f"{p}k") in (None, ""):
            return "—"
        return f"{r.get(f'{p}k')}{'' if r.get(f'{p}bounds') in (True, 'True') else ' no bounds'}"
    lines = ["| scene | kind | modulus, density | damping | motion | N | integrator, dt | default | its v | exact "
             "v | bound holds | bound / allowed | warnings (false) | k: default, exact | steps: FMU, SPH | "
             "cost: default, exact | SPH time error |",
             "| --- | --- | --- | --- | --- | ---: | --- | --- | ---: | ---: | --- | ---: | --- | --- | --- | --- | "
             "---: |"]
    for r in rows:
        dt = f"{e(r.get('dt'), '.3g')} s" + (" given" if r.get("dt_given") in (True, "True") else " (auto)")
        built = (r.get("default_model") or "—") if r.get("default_built") in (True, "True") else "**refused**"
        holds = "/".join(yes(r.get(k)) for k in ("default_bound_holds", "exact_bound_holds"))
        useful = "/".join(e(r.get(k), ".2g") for k in ("default_bound_usefulness", "exact_bound_usefulness"))
        warn = (f"{int(r.get('default_warnings') or 0) + int(r.get('exact_warnings') or 0)} "
                f"({int(r.get('default_false_alarms') or 0) + int(r.get('exact_false_alarms') or 0)})")
        cost = "/".join(e(r.get(k), ".2g") for k in ("default_cost_ratio", "exact_cost_ratio"))
        lines.append(f"| {r['name']} | {r['kind']} | {r['modulus']}, {r['density']} | {r['damping']} | "
                     f"{r['motion']}{', ' + r['force'] if r.get('force') not in (None, 'none') else ''} | {r['n']} | "
                     f"{r.get('integrator_used', r['integrator'])}, {dt} | {built} | {e(r.get('default_max_v'))} | "
                     f"{e(r.get('exact_max_v'))} | {holds} | {useful} | {warn} | "
                     f"{config(r, 'default_')}/{config(r, 'exact_')} | "
                     f"{e(r.get('default_steps'))}/{e(r.get('exact_steps'))}, {e(r.get('steps'))} | {cost} | "
                     f"{e(r.get('sph_time_error'))} |")
    return lines


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    x = np.arange(len(rows))
    for key, marker, label in (("default_max_v", "o", "default FMU"), ("exact_max_v", "s", "exact FMU"),
                               ("sph_time_error", "^", "full SPH's own time error")):
        y = [r.get(key) if isinstance(r.get(key), float) else np.nan for r in rows]
        ax1.semilogy(x, np.maximum(np.asarray(y, float), 1e-16), marker, label=label, alpha=0.8)
    ax1.axhline(DEFAULT_LIMIT, color="C0", ls="--", lw=0.8)
    ax1.axhline(EXACT_LIMIT, color="C1", ls="--", lw=0.8)
    ax1.set_xlabel("scene")
    ax1.set_ylabel("largest v error over the cases (eq. 3.4)")
    ax1.set_title("accuracy against the exactly integrated linear SPH", fontsize=9)
    ax1.legend(fontsize=7)
    for key, marker, label in (("default_cost_ratio", "o", "default FMU"), ("exact_cost_ratio", "s", "exact FMU")):
        y = [r.get(key) if isinstance(r.get(key), float) else np.nan for r in rows]
        ax2.semilogy(x, np.asarray(y, float), marker, label=label, alpha=0.8)
    ax2.axhline(1.0, color="k", ls="--", lw=0.8)
    ax2.set_xlabel("scene")
    ax2.set_ylabel("FMU doStep time / full SPH time, per simulated second")
    ax2.set_title("cost against the full SPH", fontsize=9)
    ax2.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def csv_value(text):
    """A CSV cell as :func:`measure_scene` wrote it: bool, None (empty), int, float or the text."""
    if text in ("True", "False"):
        return text == "True"
    if text == "":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def read_rows(path, scenes):
    """{name: row} of the CSV at ``path`` (a previous run's) for the scenes of ``scenes`` it measured: the same name
    and N (the corpus's seed, index and N range); {} when the file is absent."""
    import csv
    path = Path(path)
    if not path.is_file():
        return {}
    wanted = {name: facts["n"] for name, _, facts in scenes}
    with path.open(newline="") as fh:
        rows = [{k: csv_value(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    return {r["name"]: r for r in rows if wanted.get(r.get("name")) == r.get("n")}


def write_outputs(args, argv, rows, wall, count):
    """The CSV, the PNG and the report's section of the scenes measured so far (``count``: the corpus's size); the
    section is printed once all are measured."""
    from ..fmu.check.verify import COST_REPEATS
    from ..runio import atomic_path
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    png = out.with_suffix(".png")
    with atomic_path(png) as tmp:
        plot(rows, tmp)
    csv_rel, png_rel = program_outputs("scenes", argv, args.report, out, png)[1]
    command = program_command("scenes", argv)
    done = "" if len(rows) == count else (f" **{len(rows)} of the {count} scenes measured** (a run stopped part "
                                          "way; `--resume` measures the rest).")
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine_text()}, {wall:.0f} s wall, the sum of every scene's; "
             f"`{csv_rel}`, `{png_rel}`).{done} "
             f"{count} scenes of the corpus of seed {args.seed} (`sphrom.bench.lib.corpus`: unit, rubber-like "
             "and steel-like magnitudes, two materials or a graded modulus up to 20x, uniform, graded, local or no "
             f"damping, non-uniform density, a uniform or a local force, N from {args.n_min} to {args.n_max}, dt at "
             "0.2 of the stability limit or left out, the integrator named or not), each written to a file and "
             "given to `sphrom fmu` as a user would (the default FMU) and to `sphrom fmu --model exact`; every FMU "
             "measured by packaging's own check against the full SPH linear in J, integrated exactly in time (the "
             "training force from the scene's initial state, a step and an in-band sine from rest, at the "
             "communication step that resolves the scene's band). Against the criteria of a user's first try:", "",
             *summary_lines(rows), "",
             "Per scene: *default* the model `sphrom fmu` wrote (or refused); *v*: the largest error over the three "
             "cases; *bound / allowed*: max bound / max(100 max error, 1 % max |v|), largest over the cases (useful "
             "when <= 1), default/exact; *warnings (false)*: logged by both FMUs (those while the true error was "
             "below a tenth of error_tolerance); *k*: the modes of the FMU packaging wrote ('no bounds': without "
             "certified error bounds: the cheaper configuration it took, or a bar beyond the bounds' particle limit), "
             "default/exact; *steps*: communication "
             "steps of the default/exact FMU over T, time steps of the full SPH; *cost*: the FMU's doStep CPU time "
             "in steady stepping / the full SPH's compiled loop's per simulated second (the median ratio of "
             f"{COST_REPEATS} pairs of runs), default/exact; *SPH time error*: the scene's full SPH against the "
             "same truth (training force).",
             "", *table_lines(rows), "", f"![errors and costs of the corpus]({png_rel})", ""]
    if len(rows) == count:
        publish(args.report, SECTION_HEADING, lines, [out, png], wall)
    else:
        update_report(args.report, {SECTION_HEADING: lines})


def main(argv=None):
    p = program_parser("scenes", description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, default=0, help="the corpus's seed (default 0)")
    p.add_argument("--count", type=int, default=16, help="scenes (default 16)")
    p.add_argument("--n-min", type=int, default=64, help="fewest particles (default 64)")
    p.add_argument("--n-max", type=int, default=2000, help="most particles (default 2000)")
    p.add_argument("--out", default="validation/benchmarks/scenes.csv", metavar="FILE.csv")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--resume", action="store_true",
                   help="keep the rows of --out that a previous run of the same corpus measured; measure the rest")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    from .lib.corpus import corpus
    scenes = corpus(args.seed, args.count, args.n_min, args.n_max)
    kept = read_rows(args.out, scenes) if args.resume else {}
    rows = []
    # the outputs are rewritten after every scene: a run stopped part way leaves the table of what it measured
    for name, text, facts in scenes:
        if name in kept:
            rows.append(kept[name])
            continue
        with tempfile.TemporaryDirectory(prefix="sphrom-scenes-") as folder:
            row = measure_scene(name, text, facts, folder, progress=False)
        rows.append(row)
        print(f"{name}: {facts['kind']}, N = {facts['n']}: default {row.get('default_model') or 'refused'} "
              f"{fmt(row.get('default_max_v'), '.3g')}, exact {fmt(row.get('exact_max_v'), '.3g')}, cost "
              f"{fmt(row.get('default_cost_ratio'), '.3g')}/{fmt(row.get('exact_cost_ratio'), '.3g')} "
              f"({row['wall_s']:.0f} s)" + (f"; {row['note']}" if row.get("note") else ""),
              file=sys.stderr if args.quiet else sys.stdout, flush=True)
        if len(rows) < len(scenes):
            write_outputs(args, argv, rows, sum(float(r.get("wall_s") or 0.0) for r in rows), len(scenes))
    write_outputs(args, argv, rows, sum(float(r.get("wall_s") or 0.0) for r in rows), len(scenes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
