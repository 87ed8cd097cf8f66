"""``sphrom stress``: numerical-stability maps of every method."""

DEFAULT_SCENES = ("tenmode", "damped_forced", "heterogeneous")


def add_parser(sub):
    p = sub.add_parser("stress", help="stability maps: time step, amplitude, horizon, modes, random forces",
                       description="For each SCENE (default tenmode, damped_forced, heterogeneous): run every method "
                                   "over dt from 0.1x to 2x the explicit limit (and the paper's dt) against initial "
                                   "amplitudes x1..x1000, over horizons up to T = 1000, with k up to the number of "
                                   "snapshots, and under large random forces; record stable / growing / unphysical / "
                                   "blow-up, the time of blow-up and the energy drift. Writes a heat-map PNG per scene, "
                                   "CSV files and stress.md.")
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    from ..bench.stress import AMPLITUDES, HORIZONS, MODE_COUNTS
    p.add_argument("--amplitudes", default=",".join(map(str, AMPLITUDES)), help="initial-amplitude factors")
    p.add_argument("--horizons", default=",".join(f"{h:g}" for h in HORIZONS),
                   help="horizons T [s] at the paper's dt")
    p.add_argument("--modes", default=",".join(map(str, MODE_COUNTS)), help="mode counts of the k sweep")
    p.add_argument("--quick", action="store_true", help="a small sweep (a smoke run)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU column")
    p.add_argument("--out", default="validation/stress", metavar="DIR")
    p.set_defaults(handler=run)


def _ints(text, option):
    from ..errors import UserError
    try:
        return [float(x) if "." in x or "e" in x else int(x) for x in text.split(",") if x]
    except ValueError:
        raise UserError(f"{option}: {text!r} is not a comma-separated list of numbers") from None


def _fmu_stress(no_fmu):
    """An FMUStress (the FMU columns), or None with --no-fmu or when the FMU cannot be built here."""
    if no_fmu:
        return None
    try:
        from ..fmu.build import ensure_binaries
        from ..fmu.stress import FMUStress
        ensure_binaries(quiet=True)
    except Exception as exc:               # no compiler or cmake: say so, keep the Python columns
        print(f"stress: the FMU columns are skipped ({exc})")
        return None
    return FMUStress()


def run(args):
    from pathlib import Path

    from ..bench import stress as st
    from ..errors import UserError
    from ..scene import load_scene

    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    amps = _ints(args.amplitudes, "--amplitudes")
    horizons = [float(x) for x in _ints(args.horizons, "--horizons")]
    ks = [int(x) for x in _ints(args.modes, "--modes")]
    if min(amps) <= 0 or min(horizons) <= 0 or min(ks) < 1:
        raise UserError("--amplitudes, --horizons, --modes: allowed: positive values")
    factors = st.DT_FACTORS
    if args.quick:
        amps, horizons, ks, factors = amps[:2], horizons[:1], ks[:2], (0.5, 1.0, 2.0)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out: cannot create '{out}' ({exc})") from None
    text, wall = stress_report(scenes, amps, horizons, ks, factors, out, no_fmu=args.no_fmu, quick=args.quick)
    (out / "stress.md").write_text(text)
    print(f"wrote {out}/stress.md, stress_*.csv and a heat map per scene ({wall:.0f} s)")
    return 0


def stress_report(scenes, amps, horizons, ks, factors, out, no_fmu=False, quick=False, command=None):
    """Run the stress maps of ``scenes`` (CSV and PNG into ``out``); return (Markdown text, wall time [s]).

    ``command`` is the command line quoted in the text (default the ``sphrom stress`` one).
    """
    out.mkdir(parents=True, exist_ok=True)
    fmu = _fmu_stress(no_fmu)
    try:
        return _stress(scenes, amps, horizons, ks, factors, out, fmu, quick, command)
    finally:
        if fmu is not None:
            fmu.close()


def _stress(scenes, amps, horizons, ks, factors, out, fmu, quick, command):
    import csv
    import time

    from ..bench import stress as st
    from ..progress import progress_bar

    extra = None
    if fmu is not None:
        from ..fmu.stress import stress_runners
        extra = stress_runners(fmu)
    started = time.perf_counter()
    md = ["# Stability stress maps", "",
          "Produced by `" + (command or f"sphrom stress {' '.join(s.name for s in scenes)}"
                             + (" --quick" if quick else "")) + "`. Outcomes: stable (energy never above 1.1× its start), growing, "
          "unphysical (ρ ≤ 0 / J ≤ 0 reached: compression beyond the physical limit), blow-up (the method's own "
          "check fired: non-finite, non-positive density, runaway; the FMU returns an error status). Δt* = 2/ω_max is "
          "the explicit limit of the full SPH operator (ω_max Δt < 2 for the Euler schemes, 2√2 for RK4). Reduced "
          "models use the basis of the paper-setting run and start from the amplified state.", ""]
    all_map, all_hor, all_k, all_f = [], [], [], []
    for scene in scenes:
        ctx = st.context(scene)
        methods = list(st.METHODS) + list(extra or {})
        total = len(methods) * (len(factors) + 1) * len(amps) + len(methods) * len(horizons)
        with progress_bar(total=total, desc=f"stress {scene.name}", enabled=True) as bar:
            rows = st.dt_amplitude_map(ctx, dt_factors=factors, amplitudes=amps, progress=bar, extra=extra)
            hor_methods = ("sph-euler", "sph-symplectic", "frozen", "exact")
            hor = st.horizon_rows(ctx, methods=hor_methods, horizons=horizons, progress=bar, extra=extra)
            hor += st.horizon_rows(ctx, methods=("sph-rk4", "original", "linearized"),
                                   horizons=[h for h in horizons if h <= 100], progress=bar)
        krows = st.modes_rows(ctx, ks=ks)
        frows = st.force_rows(ctx, extra={k: v for k, v in (extra or {}).items()})
        st.plot_map(rows, out / f"{scene.name}_stress.png", scene.name, ctx.dt_limit)
        all_map += rows
        all_hor += hor
        all_k += krows
        all_f += frows
        md += [f"## {scene.name}", "", f"Explicit limit Δt* = {ctx.dt_limit:.4g} s; the paper's Δt = {scene.sph.dt:g} s "
               f"= {scene.sph.dt / ctx.dt_limit:.3g} Δt*; k = {ctx.k}.", "",
               f"![stress map]({out.as_posix()}/{scene.name}_stress.png)", "",
               "Largest Δt (in Δt*) at which each method stays finite and physical at amplitude ×1 over T = "
               f"{scene.T:g} s:", "", "| method | stable up to | first failure |", "| --- | --- | --- |"]
        for method in dict.fromkeys(r["method"] for r in rows):
            ok = [r for r in rows if r["method"] == method and r["amplitude"] == amps[0] and r["dt_factor"] != "paper"]
            good = [r["dt_factor"] for r in ok if r["outcome"] in ("stable", "growing")]
            bad = [r for r in ok if r["outcome"] in ("blow-up", "unphysical")]
            first = (f"{bad[0]['outcome']} at Δt = {bad[0]['dt_factor']} Δt*, t = {bad[0]['blowup_time']:.3g} s"
                     if bad and bad[0]["blowup_time"] is not None else (bad[0]["outcome"] if bad else "none"))
            md.append(f"| {method} | {max(good) if good else '—'} | {first} |")
        if extra:
            fmu_rows = [r for r in rows + hor + frows if str(r["method"]).startswith("FMU")]
            errors = [r for r in fmu_rows if r.get("fmu_error")]
            silent = sum(int(r.get("silent_nan", 0)) for r in fmu_rows)
            md += ["", f"The FMU (FMI 2 through fmpy, the same operators and internal grid): {len(fmu_rows)} runs, "
                       f"{len(errors)} ended with an error status whose message names the time"
                       + (f" (e.g. “{errors[0]['fmu_error'][:160]}”)" if errors else "")
                       + f"; non-finite outputs without an error status: **{silent}**."]
        md += ["", "Long horizons at the paper's Δt (amplitude ×1):", "", "| method | T | outcome | blow-up time | "
               "max E/E0 |", "| --- | --- | --- | --- | --- |"]
        for r in hor:
            bt = "" if r["blowup_time"] is None else f"{r['blowup_time']:.4g} s"
            md.append(f"| {r['method']} | {r['T']:g} | {r['outcome']} | {bt} | {r['energy_growth']:.4g} |")
        md += ["", "Mode count (paper's Δt, amplitude ×1):", "", "| method | k | outcome | max E/E0 |",
               "| --- | --- | --- | --- |"]
        for r in krows:
            md.append(f"| {r['method']} | {r['k']} | {r['outcome']} | {r['energy_growth']:.4g} |")
        md += ["", "Random piecewise-constant forces (held 0.05 s): final energy against the exact-in-time reduced "
               "model:", "", "| force amplitude [m/s²] | method | outcome | E_end / E_end(exact) − 1 |",
               "| --- | --- | --- | --- |"]
        for r in frows:
            md.append(f"| {r['force_amplitude']:g} | {r['method']} | {r['outcome']} | {r['energy_vs_exact']:.3g} |")
        md.append("")
    for name, rows in (("map", all_map), ("horizons", all_hor), ("modes", all_k), ("forces", all_f)):
        with open(out / f"stress_{name}.csv", "w", newline="") as fh:
            keys = list(dict.fromkeys(k for r in rows for k in r))
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
    wall = time.perf_counter() - started
    md[2] += f" Wall time {wall:.0f} s."
    return "\n".join(md) + "\n", wall
