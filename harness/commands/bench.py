"""``sphrom bench``: run time against error for every method, cost scaling, skipped terms."""

from .options import int_at_least

DEFAULT_SCENES = ("tenmode", "damped", "damped_forced", "heterogeneous", "mild_damped_forced")
KS_SCALING = (4, 8, 12, 20, 40)         # the k sweep of the cost table (N = 400)


def add_parser(sub):
    p = sub.add_parser("bench", help="run time against error of every method (writes BENCHMARKS.md with --report)",
                       description="For each SCENE (default: the paper's acceleration scenes) time the full SPH and "
                                   "every reduced model (original, linearized, frozen for n_freeze in 1,2,5,10,20,50, "
                                   "exact), and the FMU when it can be built, in one run on one machine: medians of "
                                   "--repeats runs, speed-ups as ratios to the full SPH timed in the same run, offline "
                                   "and online time apart. Also the cost per step against N and the saving of the "
                                   "specialised right-hand sides. Writes CSV, PNG plots and a Markdown report.")
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--repeats", type=int_at_least(1), default=5, help="timed runs per point (median; default 5)")
    p.add_argument("--ks", help="comma-separated mode counts (default: the scene's acceleration-study k)")
    p.add_argument("--sizes", default="100,400,1600,6400,10000", help="particle counts of the scaling table")
    p.add_argument("--scaling-ks", default=",".join(map(str, KS_SCALING)),
                   help="comma-separated mode counts of the cost-against-k table at N = 400")
    p.add_argument("--sph-sizes", default="100,400,10000,100000",
                   help="particle counts of the full-SPH step table (as sphrom bench-sph)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU entries")
    p.add_argument("--no-stress", action="store_true", help="leave the stress maps out of the report")
    p.add_argument("--fmu-scene", default="tenmode", metavar="SCENE",
                   help="scene of the FMU end-to-end table (default tenmode, the issue's headline)")
    p.add_argument("--out", default="validation/benchmarks", metavar="DIR", help="folder for CSV and PNG files")
    p.add_argument("--replot", action="store_true",
                   help="only redraw the time-against-error plots from --out's bench.csv (no timing)")
    p.add_argument("--report", metavar="FILE.md", nargs="?", const="BENCHMARKS.md",
                   help="also write the Markdown report (default BENCHMARKS.md)")
    p.set_defaults(handler=run)


def _fmt(x, spec=".3e"):
    import math
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _fmu_extra(no_fmu):
    """The FMU rows of harness.fmu.bench, when it exists and the FMU can be built."""
    if no_fmu:
        return None
    try:
        from ..fmu.bench import bench_rows
    except ImportError:
        return None
    return bench_rows


def run(args):
    import csv
    import platform
    import time
    from pathlib import Path


    from .. import __version__
    from ..bench.methods import bench_python, plot_time_error, savings_by_k
    from ..bench.scaling import growth, per_step_costs, plot_costs
    from ..bench.input_direction import input_direction_rows
    from ..bench.skip import skip_savings
    from ..rom.operators import INPUT_TOLERANCE
    from ..errors import UserError
    from ..progress import progress_bar
    from ..report.markdown import write_text
    from ..scene import load_scene

    if args.replot:
        return _replot(Path(args.out))
    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    try:
        ks = [int(k) for k in args.ks.split(",")] if args.ks else None
        sizes = [int(n) for n in args.sizes.split(",")]
        ks_scaling = [int(k) for k in args.scaling_ks.split(",")]
    except ValueError:
        raise UserError("--ks/--sizes/--scaling-ks: comma-separated integers expected") from None
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out: cannot create '{out}' ({exc})") from None
    started = time.perf_counter()
    extra = _fmu_extra(args.no_fmu)
    all_rows, savings = [], []
    total = sum(1 + len(ks or s.rom.get("accel_modes", [1])) * 9 for s in scenes)
    with progress_bar(total=total, desc="bench", enabled=True) as bar:
        for scene in scenes:
            rows = bench_python(scene, ks=ks, repeats=args.repeats, progress=bar, extra=extra)
            all_rows += rows
            plot_time_error(rows, out / f"{scene.name}_time_error.png", scene.name)
            savings.append((scene, savings_by_k(rows, scene)))
    with progress_bar(total=len(sizes), desc="scaling", enabled=True) as bar:
        scaling = per_step_costs(sizes=sizes, repeats=args.repeats, progress=bar)
    plot_costs(scaling, out / "scaling_n.png")
    with progress_bar(total=1, desc="scaling in k", enabled=True) as bar:
        scaling_k = per_step_costs(sizes=[400], ks=ks_scaling, repeats=args.repeats, progress=bar)
    plot_costs(scaling_k, out / "scaling_k.png", key="k")
    skips = []
    for scene in scenes[:2]:
        skips += skip_savings(scene, repeats=args.repeats, fmu=not args.no_fmu)
    directions = []
    for scene in scenes:
        directions += input_direction_rows(scene)
    from ..bench.sph_scaling import growth_exponent, scaling_table
    try:
        sph_sizes = [int(n) for n in args.sph_sizes.split(",")]
    except ValueError:
        raise UserError("--sph-sizes: comma-separated integers expected") from None
    with progress_bar(total=len(sph_sizes) * 3, desc="full SPH step", enabled=True) as bar:
        sph_steps = scaling_table("tenmode", sph_sizes, ["euler", "symplectic", "rk4"], args.repeats, bar)
    with open(out / "sph_scaling.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(sph_steps[0]))
        w.writeheader()
        w.writerows(sph_steps)
    sph_md = ["## The full SPH step against N (as `sphrom bench-sph`)", "",
              "µs per step of the numba loop (one thread), tenmode's fields, medians of "
              f"{args.repeats}; growth exponent of time against N for N ≥ 1000 (1 = linear). Target: ≤ 10 µs per "
              "step at N = 400 (explicit Euler).", "",
              "| integrator | " + " | ".join(f"N = {n}" for n in sph_sizes) + " | growth exponent |",
              "| --- |" + " ---: |" * (len(sph_sizes) + 1)]
    for integrator in ("euler", "symplectic", "rk4"):
        cells = [next(f"{r['us_per_step']:.3g} µs" for r in sph_steps if r["integrator"] == integrator and r["n"] == n)
                 for n in sph_sizes]
        sph_md.append(f"| {integrator} | " + " | ".join(cells) + f" | {growth_exponent(sph_steps, integrator):.2f} |")
    sph_md.append("")
    fmu_md, headline = [], []
    if not args.no_fmu:
        fmu_md, headline = _fmu_section(args, out)
    stress_md = []
    if args.report and not args.no_stress:
        from .stress import DEFAULT_SCENES as STRESS_SCENES
        from .stress import stress_report
        from ..bench import stress as st
        text, _ = stress_report([load_scene(s) for s in STRESS_SCENES], list(st.AMPLITUDES), list(st.HORIZONS),
                                list(st.MODE_COUNTS), st.DT_FACTORS, out / "stress", no_fmu=args.no_fmu,
                                command="sphrom bench --report (the stress maps of sphrom stress)")
        (out / "stress" / "stress.md").write_text(text)
        stress_md = ["#" + line if line.startswith("#") else line for line in text.splitlines()]
    wall = time.perf_counter() - started

    fields = ["scene", "method", "k", "n_freeze", "online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph",
              "err_v_ref", "err_rho_ref", "note"]
    with open(out / "bench.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(all_rows)
    with open(out / "scaling.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["method", "n", "k", "us_per_step"])
        w.writeheader()
        w.writerows(scaling)
    with open(out / "scaling_k.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["method", "n", "k", "us_per_step"])
        w.writeheader()
        w.writerows(scaling_k)
    with open(out / "skip.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(skips[0]))
        w.writeheader()
        w.writerows(skips)

    cmd = "sphrom bench " + " ".join(s.name for s in scenes) + f" --repeats {args.repeats}"
    md = ["# Benchmarks", "",
          f"Produced by `{cmd} --report` (sphrom {__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {wall:.0f} s wall). Times are medians of {args.repeats} runs on a shared 2-core "
          "machine; speed-ups are ratios to the full SPH timed in the same run. Errors: relative L² (square-root form "
          "of eq. 3.4); reduced models against the full SPH, the full SPH against the reference (exact, or a "
          "continuum reference for heterogeneous); ρ errors of ρ − ρ0. Online = the time loop; offline = SPH run for "
          "the snapshots, SVD and operators.", ""]
    if headline:
        md += ["## Headline", ""] + headline + [""]
    md += ["## CPU saving of the frozen model against the full SPH (n_freeze = 10)", "",
           "| scene | ours, per k | paper (\"up to\") |", "| --- | --- | --- |"]
    for scene, rows_s in savings:
        paper = scene.paper.get("cpu_saving")
        md.append(f"| {scene.name} | " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in rows_s.items())
                  + f" | {_fmt(None if paper is None else 100 * paper, '.0f')} % |")
    md += ["", "Both in Python in our case; the paper's full SPH was slower relative to its reduced models than our "
           "compiled (numba) one, which is why our savings are smaller: see the per-step costs below.", ""]
    for scene in scenes:
        md += [f"## {scene.name}", "", f"![time against error]({out.as_posix()}/{scene.name}_time_error.png)", "",
               "| method | k | n_freeze | online [s] | speed-up | offline [s] | error v | error ρ−ρ0 | vs ref: v | vs ref: ρ−ρ0 |",
               "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in (r for r in all_rows if r["scene"] == scene.name):
            md.append(f"| {r['method']} | {r['k']} | {r['n_freeze'] or ''} | {r['online_s']:.4f} | "
                      f"{r['speedup']:.1f}× | {r['offline_s']:.3f} | {_fmt(r['err_v_sph'])} | {_fmt(r['err_rho_sph'])} | "
                      f"{_fmt(r['err_v_ref'])} | {_fmt(r['err_rho_ref'])} |")
        md.append("")
    md += ["## Cost per step against N (k = 12, tenmode fields, Δt at the scene's CFL number)", "",
           f"![cost against N]({out.as_posix()}/scaling_n.png)", "",
           "| method | " + " | ".join(f"N = {n}" for n in sizes) + " | growth exponent |",
           "| --- |" + " --- |" * (len(sizes) + 1)]
    for method in dict.fromkeys(r["method"] for r in scaling):
        cells = [next((f"{r['us_per_step']:.3g} µs" for r in scaling if r["method"] == method and r["n"] == n), "—")
                 for n in sizes]
        md.append(f"| {method} | " + " | ".join(cells) + f" | {growth(scaling, method):.2f} |")
    md += ["", f"## Cost per step against k (N = 400, k = {', '.join(map(str, ks_scaling))})", "",
           f"![cost against k]({out.as_posix()}/scaling_k.png)", "",
           "| method | " + " | ".join(f"k = {k}" for k in ks_scaling) + " | growth exponent in k |",
           "| --- |" + " --- |" * (len(ks_scaling) + 1)]
    for method in dict.fromkeys(r["method"] for r in scaling_k if r["k"]):
        cells = [next((f"{r['us_per_step']:.3g} µs" for r in scaling_k if r["method"] == method and r["k"] == k),
                      "—") for k in ks_scaling]
        md.append(f"| {method} | " + " | ".join(cells) + f" | {growth(scaling_k, method, key='k'):.2f} |")
    md += ["", "Expected: the original and linearised models cost O(N k) per step (the nonlinear term is evaluated on "
           "the particles), the frozen model O(k²) per step plus O(k⁴)/n_freeze for the exact refresh tensor, the "
           "exact model O(k²) per communication step.", ""]
    md += ["", "## Skipping what a scene doesn't need", "",
           "The same loop on the same inputs with the scene's own terms (specialised) and with every term forced on "
           "(zero damping and force evaluated, per-particle arrays); the results are identical.", "",
           "| scene | solver | specialised [µs/step] | general [µs/step] | saving |", "| --- | --- | --- | --- | --- |"]
    for r in skips:
        md.append(f"| {r['scene']} | {r['solver']} | {r['specialised_us']:.3f} | {r['general_us']:.3f} | "
                  f"{100 * r['saving']:.0f} % |")
    if directions:
        with open(out / "input_direction.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(directions[0]))
            w.writeheader()
            w.writerows(directions)
        md += ["", "## How the force direction enters the frozen model", "",
               "The FMU takes any f(t) along the scene's force profile (uniform). Projected as in eq. 2.19, the part "
               "of the profile outside the POD velocity modes is lost; appended, the normalised residual becomes an "
               "extra velocity mode. Frozen model, n_freeze = 10, errors against the full SPH. The FMU appends only "
               f"when the modes miss more than {INPUT_TOLERANCE:g} of the profile (`INPUT_TOLERANCE`).", "",
               "| scene | k | modes miss | projected: v | ρ − ρ0 | appended (k_v + 1): v | ρ − ρ0 | FMU's rule |",
               "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for scene in scenes:
            pr = {r["choice"]: r for r in directions if r["scene"] == scene.name}
            if len(pr) == 2:
                a, b = pr["project"], pr["augment"]
                md.append(f"| {scene.name} | {a['k']} | {100 * a['input_error']:.2g} % | {_fmt(a['err_v'])} | "
                          f"{_fmt(a['err_rho'])} | {_fmt(b['err_v'])} | {_fmt(b['err_rho'])} | {a['fmu_rule']} |")
        md.append("")
    md += sph_md + fmu_md + [""] + stress_md
    write_text(out / "bench.md", "\n".join(md) + "\n")
    if args.report:
        write_text(Path(args.report), "\n".join(md) + "\n")
    for scene, by_k in savings:
        paper = scene.paper.get("cpu_saving")
        print(f"{scene.name}: frozen (n_freeze = 10) saves " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in
                                                                         by_k.items())
              + f" of the full SPH time (paper up to {_fmt(None if paper is None else 100 * paper, '.0f')} %)")
    print(f"wrote {out}/bench.csv, scaling.csv, skip.csv, bench.md and plots" +
          (f"; report {args.report}" if args.report else "") + f" ({wall:.0f} s)")
    return 0


def _fmu_section(args, out):
    """The FMU's own tables (end to end through fmpy.simulate_fmu, the C core against N, the same-language
    ratio at N = 400) as Markdown lines, and the headline sentences; CSV files into ``out``."""
    import csv

    from ..fmu.bench import core_rows, end_to_end, markdown, sph_step_rows
    from ..progress import progress_bar

    repeats = max(5, args.repeats)
    with progress_bar(total=4 + repeats + 3, desc="FMU", enabled=True) as bar:
        e2e = end_to_end(args.fmu_scene, steps=(0.01, 0.001), repeats=repeats, bar=bar)
        core = core_rows(args.fmu_scene, [100, 400, 1600], repeats=repeats, bar=bar)
        same = sph_step_rows(args.fmu_scene, n=400, repeats=repeats)
        bar.update(1)
    with open(out / "fmu_e2e.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(e2e["rows"][0]))
        w.writeheader()
        w.writerows(e2e["rows"])
    with open(out / "fmu_core.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(core[0]))
        w.writeheader()
        w.writerows(core)
    lines = ["## The FMU", "", markdown(core, e2e, heading="###"),
             f"### Same language: the C frozen step against the C full-SPH step (N = {same['n']})", "",
             f"`fmu_src/rom.c` at k = {same['k']} (k_v = {same['k_v']}, k_ρ = {same['k_rho']}), n_freeze = "
             f"{same['n_freeze']}: {same['frozen_ns']:.0f} ns per step; `fmu_src/sph.c` (eqs. 2.10-2.11, explicit "
             f"Euler): {same['sph_ns']:.0f} ns per step; ratio **{same['ratio']:.1f}×** (target ≥ 10×). Medians of "
             f"{repeats}.", ""]
    sph_err = e2e["sph"]["probe_error_v_vs_exact"]
    head = []
    for r in e2e["rows"]:
        if r["step_s"] != 0.01:
            continue
        err = r["probe_error_v_vs_sph"]
        cond = ("—" if err is None or sph_err is None else
                f"probe v error against the full SPH {err:.2e}, "
                f"{'below' if err < sph_err else '**above**'} the full SPH's own error against exact ({sph_err:.2e})")
        head.append(f"- {e2e['scene']}, FMU {r['model']} through `fmpy.simulate_fmu` at 10 ms: {r['fmu_e2e_s']:.4f} s "
                    f"for T = {e2e['T']:g} s against {e2e['sph']['call_s']:.3f} s for the Python full SPH (numba) in "
                    f"the same run: **{r['speedup']:.1f}×** (target ≥ 50×); {cond}.")
    head.append(f"- C frozen step against the C full-SPH step at N = {same['n']}: **{same['ratio']:.1f}×** "
                f"({same['frozen_ns']:.0f} ns against {same['sph_ns']:.0f} ns; target ≥ 10×).")
    head.append("- C core per internal step at k = 12, n_freeze = 10: "
                + ", ".join(f"{r['ns_per_step']:.0f} ns (N = {r['n']})" for r in core) + " (target ≤ 150 ns, "
                "independent of N).")
    return lines, head


def _replot(out):
    """Redraw ``out``/<scene>_time_error.png from ``out``/bench.csv (the measured rows, unchanged)."""
    import csv

    from ..bench.methods import plot_time_error
    from ..errors import UserError
    path = out / "bench.csv"
    if not path.is_file():
        raise UserError(f"--replot: no {path} (run sphrom bench --out {out} first)")
    rows = []
    with open(path) as fh:
        for r in csv.DictReader(fh):
            for key in ("online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph", "err_v_ref", "err_rho_ref"):
                r[key] = float(r[key]) if r[key] not in ("", "nan") else float("nan")
            r["k"] = int(r["k"]) if r["k"] else None
            r["n_freeze"] = int(r["n_freeze"]) if r["n_freeze"] else None
            rows.append(r)
    for scene in dict.fromkeys(r["scene"] for r in rows):
        plot_time_error([r for r in rows if r["scene"] == scene], out / f"{scene}_time_error.png", scene)
    print(f"redrew {out}/*_time_error.png from {path}")
    return 0
