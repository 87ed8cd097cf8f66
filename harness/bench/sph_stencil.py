"""The full SPH step (eqs. 2.10-2.11) in numba against a hand-written C stencil, and against an older checkout.

In one run, on one machine, this times per step:

* the numba loop of :mod:`sphrom.sph.loops` in the fixed-offset layout (what ``run_sph`` takes where the
  neighbour lists allow it) and in the neighbour-list layout;
* the C step of ``fmu_src/sph.c`` (:mod:`sphrom.fmu.run.sph_c`) in the same two layouts: its fixed-offset stencil
  is the hand-written reference of the machine's speed for this step;
* with ``--before DIR``, the numba and the C step of the checkout in DIR (the code before a change), through a
  second worker process (:mod:`sphrom.bench.sph_step_worker`), interleaved with the others;
* the tenmode training run, ``run_sph`` of the scene as it is (N = 400, 200 000 steps), this checkout
  against ``--before``.

The cost per step is a slope: each repeat runs M and 2M steps back to back and takes (t(2M) − t(M)) / M, so a
fixed cost of the call cancels instead of being subtracted; the figure is the median over the repeats, and
each ratio the median of the per-repeat ratios (paired in time).  Every timed run starts from the scene's
initial state with the scene's force, and every solver must end in the same bits (sha256 of the final v and
ρ, compared per size and integrator): the benchmark stops otherwise.  It names the CPU and the load average
at its start and end.

Run as::

    python -m sphrom.bench.sph_stencil [--sizes 10000,100000] [--integrators euler,symplectic,rk4]
        [--repeats 7] [--before /work/main] [--out validation/benchmarks] [--report BENCHMARKS.md]

It writes ``sph_stencil.csv`` and ``sph_stencil.png`` into ``--out`` and the section "The full SPH step:
numba against a hand-written C stencil" of the report.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from ..parser import positive_int
from ..paths import import_path
from ..progress import progress_bar
from ..runio import atomic_path
from ..scene import load_scene
from . import program_parser
from .lib.document import update_report
from .lib.tables import write_csv
from .lib.timing import cpu_model, load_average

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## The full SPH step: numba against a hand-written C stencil"
STEP_WORK = 1e7            # particle-steps in the shorter of the two timed runs (M = STEP_WORK / N steps)
TARGET = 2.0               # the target: the numba step within this factor of the C stencil
C_INTEGRATORS = ("euler", "symplectic")
WORKER = Path(__file__).with_name("sph_step_worker.py")


class Worker:
    """A :mod:`sphrom.bench.sph_step_worker` process over the checkout ``code`` (None: this one)."""

    def __init__(self, code=None):
        env = dict(os.environ)
        root = Path(code).resolve() if code else Path(__file__).resolve().parents[2]
        env["PYTHONPATH"] = import_path(root)
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        self.proc = subprocess.Popen([sys.executable, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, env=env, cwd=str(root))
        self.info = self.ask({"op": "info"})

    def ask(self, req):
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the step worker ({WORKER}) stopped")
        ans = json.loads(line)
        if "error" in ans:
            raise RuntimeError(f"step worker: {ans['error']}")
        return ans

    def close(self):
        if self.proc.poll() is None:
            self.proc.stdin.close()
            self.proc.wait(timeout=60)


def configurations(before):
    """(code, solver, layout) of every timed step: this checkout's two layouts of numba and C, and the other
    checkout's own step (``before``: its default layout)."""
    out = [("after", "numba", "auto"), ("after", "numba", "general"), ("after", "c", "auto"),
           ("after", "c", "general")]
    if before:
        out += [("before", "numba", "auto"), ("before", "c", "auto")]
    return out


def steps_for(n):
    """M, the shorter run's step count at N = n (:data:`STEP_WORK` particle-steps, at least 10)."""
    return max(10, int(round(STEP_WORK / n)))


def measure(scene, sizes, integrators, repeats, before=None, training=True, progress=None):
    """Slopes per step of every configuration, and the training runs.

    Returns (rows, training rows, machine info).  A row: code, solver, layout (as used), integrator, n, steps
    (M), us_per_step (median slope), us_min, us_max, repeats, and the per-repeat slopes ``slopes``.
    Raises RuntimeError when two solvers end one size's run in different bits.
    """
    workers = {"after": Worker()}
    if before:
        workers["before"] = Worker(before)
    info = {"cpu": cpu_model(), "load_start": load_average(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "codes": {k: w.info["code"] for k, w in workers.items()}}
    try:
        configs = configurations(before)
        cases = [(n, integ) for integ in integrators for n in sizes]
        slopes = {}
        used = {}
        digests = {}
        for n, integ in cases:                               # warm-up: compile, load, build the problem
            for code, solver, layout in configs:
                if solver == "c" and integ not in C_INTEGRATORS:
                    continue
                workers[code].ask({"op": "time", "solver": solver, "layout": layout, "scene": scene, "n": n,
                                   "integrator": integ, "steps": 2})
        for _ in range(repeats):
            for n, integ in cases:
                m = steps_for(n)
                for code, solver, layout in configs:
                    if solver == "c" and integ not in C_INTEGRATORS:
                        continue
                    req = {"op": "time", "solver": solver, "layout": layout, "scene": scene, "n": n,
                           "integrator": integ}
                    a = workers[code].ask({**req, "steps": m})
                    b = workers[code].ask({**req, "steps": 2 * m})
                    key = (code, solver, layout, integ, n)
                    slopes.setdefault(key, []).append(1e6 * (b["seconds"] - a["seconds"]) / m)
                    used[key] = b["layout"]
                    digests.setdefault((integ, n), {})[key] = b["digest"]
                if progress:
                    progress.update(1)
        for (integ, n), d in digests.items():
            if len(set(d.values())) != 1:
                raise RuntimeError(f"{integ}, N = {n}: the solvers end in different bits: " +
                                   ", ".join(f"{k[0]} {k[1]} {k[2]}: {v[:12]}" for k, v in d.items()))
        rows = []
        for (code, solver, layout, integ, n), s in slopes.items():
            rows.append({"code": code, "solver": "C" if solver == "c" else "numba", "layout": used[(code, solver, layout, integ, n)],
                         "integrator": integ, "n": n, "steps": steps_for(n), "us_per_step": statistics.median(s),
                         "us_min": min(s), "us_max": max(s), "repeats": len(s), "slopes": s})
        train = []
        if training:
            times = {code: [] for code in workers}
            digest = set()
            for _ in range(repeats):
                for code, w in workers.items():
                    ans = w.ask({"op": "time", "solver": "run_sph", "layout": "auto", "scene": scene})
                    times[code].append(ans["seconds"])
                    digest.add(ans["digest"])
                if progress:
                    progress.update(1)
            if len(digest) != 1:
                raise RuntimeError(f"run_sph({scene}): the checkouts end in different bits")
            for code, t in times.items():
                train.append({"code": code, "scene": scene, "seconds": statistics.median(t), "s_min": min(t),
                              "s_max": max(t), "repeats": len(t), "times": t})
    finally:
        for w in workers.values():
            w.close()
    info["load_end"] = load_average()
    return rows, train, info


def _find(rows, code, solver, layout, integ, n):
    return next((r for r in rows if (r["code"], r["solver"], r["layout"], r["integrator"], r["n"])
                 == (code, solver, layout, integ, n)), None)


def paired_ratio(num, den):
    """The median of the per-repeat ratios num/den of two rows' slopes (None when either is missing)."""
    if num is None or den is None:
        return None
    return statistics.median(a / b for a, b in zip(num["slopes"], den["slopes"]))


def ratio_rows(rows):
    """Per integrator and N: the numba stencil against the C stencil, and each step against its own before."""
    out = []
    for integ, n in dict.fromkeys((r["integrator"], r["n"]) for r in rows):
        nb, cs = _find(rows, "after", "numba", "stencil", integ, n), _find(rows, "after", "C", "stencil", integ, n)
        out.append({"integrator": integ, "n": n,
                    "numba_over_c_stencil": paired_ratio(nb, cs),
                    "numba_speedup": paired_ratio(_find(rows, "before", "numba", "lists", integ, n), nb),
                    "c_speedup": paired_ratio(_find(rows, "before", "C", "lists", integ, n), cs),
                    "numba_layout_speedup": paired_ratio(_find(rows, "after", "numba", "lists", integ, n), nb),
                    "c_layout_speedup": paired_ratio(_find(rows, "after", "C", "lists", integ, n), cs)})
    return out


def _us(r):
    if r is None:
        return "—"
    v = r["us_per_step"]
    return f"{v:.3g}" if v < 1000 else f"{v:.0f}"


def _x(v):
    return "—" if v is None else f"{v:.2f}×"


def section(rows, train, info, command, wall, csv_path, image):
    """The report's section (Markdown lines) from the measured rows; ``image`` the PNG's path from the report."""
    ratios = ratio_rows(rows)
    before = any(r["code"] == "before" for r in rows)
    load = lambda x: "n/a" if x is None else " / ".join(f"{v:.2f}" for v in x)      # noqa: E731
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({wall:.0f} s wall, {info['date']}; `{csv_path}`). Machine: {info['cpu']}; "
             f"load average (1 / 5 / 15 min) {load(info['load_start'])} at the start, {load(info['load_end'])} at "
             "the end (a shared machine: other work runs beside this). µs per step of tenmode's fields at the "
             "scene's CFL number: the slope between runs of M and 2M steps (M = 10⁷ / N), the median of "
             f"{rows[0]['repeats'] if rows else 0} repeats; ratios are medians of the per-repeat ratios. "
             "*Stencil*: the fixed-offset layout (every row's neighbours at the same offsets, weights by "
             "offset, no index loads); *lists*: the neighbour lists. The C step is `fmu_src/sph.c` (Euler and "
             "symplectic Euler only), its stencil the hand-written reference. Every solver ended each run in the "
             "same bits (checked by the command)."
             + (f" *Before*: the checkout `{info['codes'].get('before')}` (neighbour lists), timed in turn with "
                "this one." if before else ""), "",
             "| integrator | N | numba stencil | numba lists | C stencil | C lists |"
             + (" numba before | C before |" if before else "")
             + f" numba / C stencil (target ≤ {TARGET:g}) |" + (" numba before / after | C before / after |" if before else ""),
             "| --- | ---: | ---: | ---: | ---: | ---: |" + (" ---: | ---: |" if before else "") + " ---: |"
             + (" ---: | ---: |" if before else "")]
    for q in ratios:
        integ, n = q["integrator"], q["n"]
        cells = [_us(_find(rows, "after", "numba", "stencil", integ, n)), _us(_find(rows, "after", "numba", "lists", integ, n)),
                 _us(_find(rows, "after", "C", "stencil", integ, n)), _us(_find(rows, "after", "C", "lists", integ, n))]
        if before:
            cells += [_us(_find(rows, "before", "numba", "lists", integ, n)), _us(_find(rows, "before", "C", "lists", integ, n))]
        cells.append(_x(q["numba_over_c_stencil"]))
        if before:
            cells += [_x(q["numba_speedup"]), _x(q["c_speedup"])]
        lines.append(f"| {integ} | {n} | " + " | ".join(cells) + " |")
    met = [q for q in ratios if q["numba_over_c_stencil"] is not None]
    if met:
        worst = max(met, key=lambda q: q["numba_over_c_stencil"])
        ok = all(q["numba_over_c_stencil"] <= TARGET for q in met)
        lines += ["", f"Target, the numba step within {TARGET:g}× of the C stencil: **{'met' if ok else 'missed'}** "
                      f"(largest ratio {worst['numba_over_c_stencil']:.2f}×, {worst['integrator']} at N = {worst['n']})."]
    if train:
        by = {t["code"]: t for t in train}
        a = by.get("after")
        text = (f"The training run `run_sph({a['scene']})` as the scene sets it (the whole call, problem built "
                f"once): {a['seconds']:.3f} s (median of {a['repeats']})")
        if "before" in by:
            b = by["before"]
            ratio = statistics.median(x / y for x, y in zip(b["times"], a["times"]))
            text += f" against {b['seconds']:.3f} s before, **{ratio:.2f}×** faster, the same bits"
        lines += ["", text + "."]
    lines += ["", f"![full SPH step]({image})", ""]
    return lines


def plot(rows, path):
    """µs per step of every solver, grouped by integrator and N (log scale), as PNG at ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    groups = list(dict.fromkeys((r["integrator"], r["n"]) for r in rows))
    series = list(dict.fromkeys((r["code"], r["solver"], r["layout"]) for r in rows))
    fig, ax = plt.subplots(figsize=(max(5.0, 1.1 * len(groups) + 2), 3.8))
    width = 0.8 / max(1, len(series))
    for k, (code, solver, layout) in enumerate(series):
        ys = [(_find(rows, code, solver, layout, integ, n) or {}).get("us_per_step", float("nan")) for integ, n in groups]
        ax.bar([g + (k - (len(series) - 1) / 2) * width for g in range(len(groups))], ys, width,
               label=f"{solver} {layout}" + (" (before)" if code == "before" else ""))
    ax.set_yscale("log")
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([f"{integ}\nN = {n}" for integ, n in groups])
    ax.set_ylabel("µs per step")
    ax.set_title("full SPH step (slope between M and 2M steps)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _int_list(text):
    try:
        out = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of integers") from None
    if not out or min(out) < 16:
        raise argparse.ArgumentTypeError(f"{text!r}: allowed: particle counts >= 16")
    return out


def _integrators(text):
    out = [x.strip() for x in text.split(",") if x.strip()]
    bad = [x for x in out if x not in ("euler", "symplectic", "rk4")]
    if not out or bad:
        raise argparse.ArgumentTypeError(f"{text!r}: allowed: euler, symplectic, rk4")
    return out


def _checkout(text):
    if not (Path(text) / "harness" / "sph" / "loops.py").is_file():
        raise argparse.ArgumentTypeError(f"{text!r} is not a sphrom checkout (allowed: a folder with "
                                         "harness/sph/loops.py)")
    return text


def main(argv=None):
    p = program_parser("sph_stencil", description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="tenmode", help="scene whose fields, force and CFL number are used (default "
                                                      "%(default)s)")
    p.add_argument("--sizes", type=_int_list, default=[10_000, 100_000], metavar="N,...",
                   help="particle counts (default 10000,100000)")
    p.add_argument("--integrators", type=_integrators, default=["euler", "symplectic", "rk4"], metavar="NAME,...",
                   help="out of euler, symplectic, rk4 (default all; the C step has the first two)")
    p.add_argument("--repeats", type=positive_int, default=7, help="repeats, the median kept (default %(default)s)")
    p.add_argument("--before", type=_checkout, metavar="DIR", help="a checkout whose own step is timed in the same "
                                                                   "run")
    p.add_argument("--no-training", action="store_true", help="skip the training runs (run_sph of the scene)")
    p.add_argument("--out", default="validation/benchmarks", help="folder for sph_stencil.csv and .png "
                                                                  "(default %(default)s)")
    p.add_argument("--report", default="BENCHMARKS.md", help="the Markdown report whose section is replaced")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    load_scene(args.scene)                          # a bad name: one line, before any work
    t0 = time.perf_counter()
    total = args.repeats * (len(args.sizes) * len(args.integrators) + (0 if args.no_training else 1))
    with progress_bar(total=total, desc="sph steps", enabled=not args.quiet) as bar:
        rows, train, info = measure(args.scene, args.sizes, args.integrators, args.repeats, before=args.before,
                                    training=not args.no_training, progress=bar)
    wall = time.perf_counter() - t0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "sph_stencil.csv"
    write_csv(csv_path, [{k: v for k, v in r.items() if k != "slopes"} for r in rows]
              + [{"code": t["code"], "solver": f"run_sph {t['scene']}", "layout": "auto", "integrator": "",
                  "n": "", "steps": "", "us_per_step": 1e6 * t["seconds"], "us_min": 1e6 * t["s_min"],
                  "us_max": 1e6 * t["s_max"], "repeats": t["repeats"]} for t in train])
    with atomic_path(out / "sph_stencil.png") as tmp:
        plot(rows, tmp)
    given = argv if argv is not None else sys.argv[1:]
    command = "python -m sphrom.bench.sph_stencil" + (" " + " ".join(given) if given else "")
    here = Path(args.report).resolve().parent
    image, shown_csv = (Path(os.path.relpath(path, here)).as_posix() for path in (out / "sph_stencil.png", csv_path))
    lines = section(rows, train, info, command, wall, shown_csv, image)
    print("\n".join(lines))
    report = update_report(args.report, {SECTION_HEADING: lines})
    print(f"wrote {csv_path}, {out / 'sph_stencil.png'} and the section of {report} ({wall:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
