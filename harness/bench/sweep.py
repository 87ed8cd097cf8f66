"""``sphrom bench sweep``: the committed measurement of ``sphrom sweep`` (validation/sweeps/README.md).

    sphrom bench sweep [--spec validation/sweeps/tenmode_forces.toml]
        [--sph-spec validation/sweeps/tenmode_forces_sph.toml] [--workers 1,2] [--repeats 3]
        [--work DIR] [--out validation/sweeps]

(also ``python -m sphrom.bench.sweep``, and its old name ``python -m sphrom.sweep.measure``)

1. packages the study's FMUs (cached), so that no timed run packages;
2. runs ``sphrom sweep SPEC --workers W --out ...`` (a fresh LocalCluster, a
   fresh result file) ``repeats`` times per worker count, interleaved
   (1, 2, 1, 2, ...) so that a drift of a shared machine's load falls on both;
   throughput is each run's own figure (entries finished per second of its
   compute phase);
3. runs ``sphrom sweep SPH_SPEC --workers max(W)`` once: the same entries, and
   the full SPH beside the FMU for the compared sub-grid, in the same tasks;
   the speed ratio is median SPH wall time over median FMU wall time per run
   on those entries;
4. writes README.md (tables, machine, versions, the commands) and the two
   summary PNGs into ``--out``.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .. import __version__
from ..markdown import write_text
from ..sweep.table import finite, read_results
from . import program_parser

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

LOADS = []       # CPU used by other processes during each sweep run [cores]


def _cpu():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _busy():
    """CPU seconds the whole machine has been busy (/proc/stat; nan elsewhere)."""
    try:
        values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:9]]
        return (sum(values) - values[3] - values[4]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def _children_cpu():
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _sweep(spec, workers, out):
    cmd = [sys.executable, "-m", "sphrom", "sweep", str(spec), "--workers", str(workers), "--out", str(out), "--quiet"]
    busy, mine, t0 = _busy(), _children_cpu(), time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    # the CPU the rest of the machine used meanwhile, in cores: busy time less this run's own processes
    LOADS.append(((_busy() - busy) - (_children_cpu() - mine)) / (time.perf_counter() - t0))
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    rows, attrs = read_results(out)
    return rows, attrs, " ".join(cmd)


def _rel(path, base):
    try:
        return str(Path(path).resolve().relative_to(base.resolve()))
    except ValueError:
        return str(path)


def main(argv=None):
    root = Path(__file__).resolve().parents[2]
    p = program_parser("sweep", description=__doc__.split("\n\n")[0])
    p.add_argument("--spec", default=str(root / "validation/sweeps/tenmode_forces.toml"))
    p.add_argument("--sph-spec", default=str(root / "validation/sweeps/tenmode_forces_sph.toml"))
    p.add_argument("--workers", default="1,2")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--work", default=None, help="folder for the result files (default: a temporary one)")
    p.add_argument("--out", default=str(root / "validation/sweeps"))
    args = p.parse_args(argv)
    from ..sweep.fmus import ensure_fmus
    from ..sweep.spec import load_spec
    workers = [int(w) for w in args.workers.split(",")]
    out = Path(args.out)
    work = Path(args.work) if args.work else Path(out / ".measure-work")
    work.mkdir(parents=True, exist_ok=True)
    spec = load_spec(args.spec)
    sph_spec = load_spec(args.sph_spec)
    for s in (spec, sph_spec):
        ensure_fmus(s, s.entries, progress=False, log=lambda text: print(text, file=sys.stderr))
    started = _dt.datetime.now(_dt.timezone.utc)

    runs = {w: [] for w in workers}
    commands = {}
    for r in range(args.repeats):
        for w in workers:
            path = work / f"plain-w{w}-r{r}.h5"
            path.unlink(missing_ok=True)
            rows, attrs, cmd = _sweep(args.spec, w, path)
            commands.setdefault(w, cmd.replace(str(path), "RESULTS.h5").replace(str(root) + "/", ""))
            runs[w].append({"throughput": float(attrs["throughput_runs_per_s"]), "load": LOADS[-1],
                            "compute": float(attrs["compute_wall_s"]), "start": float(attrs["cluster_start_s"]),
                            "ok": int(attrs["ok"]), "failed": int(attrs["failed"]), "path": path,
                            "fmu": statistics.median(r_["fmu_wall_s"] for r_ in rows if r_["status"] == "ok"),
                            "task": statistics.median(r_["task_wall_s"] for r_ in rows if r_["status"] == "ok")})
            print(f"workers {w} repeat {r + 1}: {runs[w][-1]['throughput']:.2f} runs/s", file=sys.stderr)
    wmax = max(workers)
    sph_path = work / f"sph-w{wmax}.h5"
    sph_path.unlink(missing_ok=True)
    sph_rows, sph_attrs, sph_cmd = _sweep(args.sph_spec, wmax, sph_path)
    sph_cmd = sph_cmd.replace(str(sph_path), "RESULTS.h5").replace(str(root) + "/", "")
    finished = _dt.datetime.now(_dt.timezone.utc)

    shutil.copyfile(runs[wmax][0]["path"].with_suffix(".png"), out / "tenmode_forces.png")
    shutil.copyfile(sph_path.with_suffix(".png"), out / "tenmode_forces_sph.png")
    text = report(spec, sph_spec, runs, commands, sph_rows, sph_attrs, sph_cmd, started, finished, args, root)
    write_text(out / "README.md", text)
    print(f"wrote {out / 'README.md'}, {out / 'tenmode_forces.png'}, {out / 'tenmode_forces_sph.png'}")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    return 0


WHY_TENMODE = ("  Why this scene: it is the paper's main case (section 3.2) at its own resolution, N = 400, so a "
               "full SPH run costs what it costs in the paper, and a uniform force on its free vibration makes "
               "the probe response a function of the force frequency and the damping, which the full SPH "
               "comparison below checks.")


def _compare_text(spec):
    c = spec.compare
    if isinstance(c, bool):
        return "true" if c else "false"
    return "{ " + ", ".join(f"{k} = {v!r}".replace("'", '"') for k, v in c.items()) + " }"


def report(spec, sph_spec, runs, commands, sph_rows, sph_attrs, sph_cmd, started, finished, args, root):
    """The Markdown of the measurement."""
    lines = []
    add = lines.append
    workers = sorted(runs)
    base = statistics.median(x["throughput"] for x in runs[workers[0]])
    n = len(spec.entries)
    add("# Parameter sweeps: measured throughput of `sphrom sweep`")
    add("")
    add("Written by `sphrom bench sweep "
        f"--workers {','.join(map(str, workers))} --repeats {args.repeats}` (harness/bench/sweep.py); "
        "do not edit by hand.")
    add("")
    add(f"Study: `{_rel(args.spec, root)}`: {spec.title}. {n} FMU co-simulations of the built-in scene "
        f"`{spec.scene.name}` (N = {spec.scene.sph.n_particles}, SPH dt = {spec.scene.sph.dt:g} s) to "
        f"t_end = {spec.t_end:g} s in communication steps of {spec.step:g} s ({spec.steps} steps per run), "
        f"on {len({e.variant_inputs() for e in spec.entries})} FMUs (one per scene variant: its own full SPH "
        "training run, POD basis and FMU, packaged once and cached before the timed runs)."
        + (WHY_TENMODE if spec.scene.name == "tenmode" else ""))
    add("")
    add(f"Machine: {os.cpu_count()} cores ({_cpu()}), shared with other work; Python "
        f"{platform.python_version()}, sphrom {__version__}, dask {sph_attrs.get('version.dask')}, "
        f"distributed {sph_attrs.get('version.distributed')}, fmpy {sph_attrs.get('version.fmpy')}.  "
        f"Measured {started:%Y-%m-%d %H:%M}-{finished:%H:%M} UTC.")
    add("")
    add("## Throughput at 1 and 2 workers")
    add("")
    add("Each repeat is a fresh `sphrom sweep` (a new LocalCluster of W worker processes with one thread each, "
        "a new result file), run as:")
    add("")
    for w in workers:
        add(f"    {commands[w]}")
    add("")
    add("Throughput is the command's own figure: entries finished per second of the compute phase (first task "
        "submitted to last result; FMU loading on each worker included, cluster start-up not).  The client and "
        "the scheduler share the same cores as the workers.")
    add("")
    add(f"The last column is the CPU that other processes used during each run, in cores (of {os.cpu_count()}): "
        "the machine's busy time (/proc/stat) less the CPU time of the run's own processes.")
    add("")
    add("| workers | runs | throughput per repeat [runs/s] | median [runs/s] | speed-up | median FMU run "
        "[ms] | median task [ms] | cluster start [s] | other work [cores] |")
    add("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for w in workers:
        rs = runs[w]
        med = statistics.median(x["throughput"] for x in rs)
        add(f"| {w} | {rs[0]['ok'] + rs[0]['failed']} ({rs[0]['failed']} failed) | "
            f"{', '.join('%.2f' % x['throughput'] for x in rs)} | **{med:.2f}** | {med / base:.2f} | "
            f"{1e3 * statistics.median(x['fmu'] for x in rs):.0f} | {1e3 * statistics.median(x['task'] for x in rs):.0f} | "
            f"{statistics.median(x['start'] for x in rs):.1f} | {', '.join('%.2f' % x['load'] for x in rs)} |")
    add("")
    add(f"The FMU run is the reset, the initialization and the co-simulation loop ({spec.steps} doStep calls "
        "through fmpy, with the frozen model's internal steps of the scene's dt inside); the task adds the "
        "force evaluation and the statistics.")
    add("")
    add("![summary](tenmode_forces.png)")
    add("")
    add(f"`tenmode_forces.png` (the summary PNG of a {max(workers)}-worker run): max |v| at probe 1 over "
        f"t in [{spec.window[0]:g}, {spec.window[1]:g}] s against the force frequency and the damping, at the "
        "largest amplitude.")
    add("")
    # --- full SPH comparison
    cmp_rows = [r for r in sph_rows if r["compare_sph"] and r["status"] == "ok"]
    fmu = np.array([r["fmu_wall_s"] for r in cmp_rows])
    sph = np.array([r["sph_wall_s"] for r in cmp_rows])
    err = np.array([r["sph_err_v"] for r in cmp_rows])
    err_rho = np.array([r["sph_err_rho"] for r in cmp_rows if finite(r["sph_err_rho"])])
    ratio = float(np.median(sph) / np.median(fmu)) if len(cmp_rows) else float("nan")
    failed_cmp = sum(1 for r in sph_rows if r["compare_sph"] and r["status"] != "ok")
    add("## Full SPH beside the FMU: the speed ratio")
    add("")
    add(f"`{_rel(args.sph_spec, root)}` is the same spec with `compare_sph` on a sub-grid "
        f"({sum(e.compare_sph for e in sph_spec.entries)} entries: `compare_sph = {_compare_text(sph_spec)}`): "
        "for those, the same task also runs the full SPH (eqs. 2.10-2.11, numba) of the "
        "same scene variant with exactly the input the FMU received (held over each communication step), "
        "samples the velocity at the probes by linear interpolation, as the FMU's outputs are, and computes the "
        "relative L2 error (eq. 3.4) over probes and communication points.  The full SPH of all "
        f"{n} entries would take about {n * np.median(sph) / max(workers) / 60:.0f} min at {max(workers)} workers, so it runs on this "
        "sub-grid only.  Run once, in the same session as the table above:")
    add("")
    add(f"    {sph_cmd}")
    add("")
    add(f"(other work during it: {LOADS[-1]:.2f} cores)")
    add("")
    add("| compared runs | median FMU run [ms] | median full SPH run [ms] | speed ratio SPH / FMU | whole "
        "study [runs/s] | median error of v | max error of v | median error of rho - rho0 |")
    add("| --- | --- | --- | --- | --- | --- | --- | --- |")
    add(f"| {len(cmp_rows)}{f' ({failed_cmp} failed)' if failed_cmp else ''} | {1e3 * np.median(fmu):.0f} | "
        f"{1e3 * np.median(sph):.0f} | **{ratio:.1f}** | {float(sph_attrs['throughput_runs_per_s']):.2f} | "
        f"{np.median(err):.3g} | {np.max(err):.3g} | "
        f"{(np.median(err_rho) if err_rho.size else float('nan')):.3g} |")
    add("")
    add("Both times are wall times inside the same worker task (FMU: reset, initialization, loop; SPH: the "
        "held force, the time loop from the scene's v0, rho0 and the probe sampling, with the neighbour lists "
        "built and the compiled loop loaded once per worker before the first timed run), with every worker "
        "busy.")
    add("")
    add("![SPH comparison](tenmode_forces_sph.png)")
    add("")
    add("`tenmode_forces_sph.png`: the same surface, and the relative L2 error of the FMU's probe velocities "
        "against the full SPH for the compared entries, per damping.")
    add("")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
