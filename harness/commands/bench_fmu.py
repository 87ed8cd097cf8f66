"""``sphrom bench-fmu``: ns per internal step of the C core, and the FMU end to end beside the full SPH."""

from ..options import MAX_REPEATS, add_quiet, add_scene, float_list, int_in, int_list, max_particles


def _min_particles():
    """Enough particles for the benchmark's k modes: 4 k."""
    from ..bench.lib.fmu import BENCH_K
    return 4 * BENCH_K


def add_parser(sub):
    p = sub.add_parser("bench-fmu", help="time the FMU: C core ns/step against N, end to end through fmpy vs full SPH",
                       description="(1) ns per internal step of the C model core at k = 12, n_freeze = 10 for "
                                   "several particle counts N (scenes derived from SCENE), showing the cost does "
                                   "not depend on N; (2) the end-to-end time of SCENE's FMU through "
                                   "sphrom's FMU driver with 10 ms and 1 ms communication steps beside the Python "
                                   "full SPH of the same scene in the same run, as ratios, with the time split into "
                                   "the fixed cost, the driver's per-doStep cost and the core's. Medians of --repeats."
                                   " Also: sphrom bench fmu-speed.")
    add_scene(p, default="tenmode")
    p.add_argument("--n-particles", "--sizes", dest="n_particles", metavar="N,...", default="100,400,1600",
                   type=int_list(lo=_min_particles, hi=max_particles),
                   help="particle counts for the core benchmark, enough for 12 modes (default %(default)s)")
    p.add_argument("--repeats", type=int_in(5, MAX_REPEATS), default=5, help="repeats per figure, >= 5 (median)")
    p.add_argument("--step", "--steps", dest="step", type=float_list(lo=0, lo_open=True), metavar="H,...",
                   default="0.01,0.001", help="communication steps [s] for the end-to-end runs (default %(default)s)")
    p.add_argument("--core-only", action="store_true", help="only the core benchmark")
    p.add_argument("--out", metavar="DIR", help="folder for bench_fmu_core.csv, bench_fmu_e2e.csv, bench_fmu.md")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):

    from ..bench.lib.fmu import benched_fmu_models, core_rows, end_to_end, write_fmu_csv
    from ..bench.lib.document import fmu_tables
    from ..progress import progress_bar
    from ..markdown import write_text
    from ..rom.registry import fmu_model_names, get_model
    from ..scene import load_scene

    sizes, steps = args.n_particles, args.step
    scene = load_scene(args.scene)
    if not args.core_only:
        from ..errors import UserError, exact
        from ..fmu.run.cosim import MAX_COMM_STEPS
        for h in steps:                 # each step runs the scene's horizon T through fmpy
            if h > scene.T or scene.T / h > MAX_COMM_STEPS:
                raise UserError(f"--step: {exact(h)} is out of range (allowed: T / 1e8 = {scene.T / MAX_COMM_STEPS:g} s "
                                f"<= step <= T = {scene.T:g} s, at most 1e8 communication steps)")
    from ..runio import check_output_dir, output_dir
    out = check_output_dir(args.out) if args.out else None
    total = len(sizes) + (0 if args.core_only else len(benched_fmu_models()) * len(steps) + args.repeats)
    with progress_bar(total=total, desc="bench-fmu", enabled=not args.quiet) as bar:
        core = core_rows(args.scene, sizes, repeats=args.repeats, progress=False, bar=bar)
        e2e = None if args.core_only else end_to_end(args.scene, steps=steps, repeats=args.repeats, progress=False,
                                                     bar=bar)
    print(f"C core (libsphrom_core, no FMI), k = 12, n_freeze = 10, scenes like {scene.name} at several N; "
          f"median of {args.repeats}")
    print(f"{'N':>7} {'k_v':>4} {'k_rho':>5} {'ns/step':>9} {'min':>7} {'max':>7} {'CPU ns':>7}  (slopes M -> 2M steps)")
    for r in core:
        print(f"{r['n']:>7} {r['k_v']:>4} {r['k_rho']:>5} {r['ns_per_step']:>9.1f} {r['ns_min']:>7.1f} "
              f"{r['ns_max']:>7.1f} {r['ns_per_step_cpu']:>7.1f}")
    target = "meets" if max(r["ns_per_step"] for r in core) <= 150 else "misses"
    print(f"  target <= 150 ns/step: {target} it")
    if e2e is not None:
        print(f"\nend to end: {e2e['scene']} (N = {e2e['n']}, T = {e2e['T']:g} s, {e2e['internal_steps']} internal "
              f"steps of {e2e['dt']:g} s), fmpy {e2e['fmpy']}")
        sph_err = e2e["sph"]["probe_error_v_vs_exact"]
        print(f"  full SPH (run_sph, numba): {e2e['sph']['call_s']:.3f} s per run "
              f"({e2e['sph']['loop_s']:.3f} s in its time loop); probe v error against exact: "
              + ("—" if sph_err is None else f"{sph_err:.3e}"))
        for r in e2e["rows"]:
            err = r["probe_error_v_vs_sph"]
            print(f"  FMU {r['model']} (k_v = {r['k_v']}, k_rho = {r['k_rho']}), {r['step_s'] * 1e3:g} ms steps "
                  f"({r['doSteps']} doSteps): {r['fmu_e2e_s']:.4f} s -> {r['speedup']:.1f}x faster than the full SPH "
                  f"({r['speedup_vs_loop']:.1f}x vs its loop alone)"
                  + ("" if err is None else f"; probe v error against the full SPH {err:.3e}"))
            if not get_model(r["model"]).linear:        # a time-stepped model: the core's internal steps
                print(f"    where the time goes (slopes between two step counts): fixed cost (extract, load, "
                      f"instantiate, free) {r['fixed_s']:.4f} s, {r['us_per_doStep_fmpy']:.1f} us per doStep through "
                      f"the driver, of which the core's internal steps {r['us_per_doStep_core']:.1f} us; a bare doStep "
                      f"call of one internal step {r['us_per_doStep_bare_call']:.1f} us")
        for model in dict.fromkeys(r["model"] for r in e2e["rows"]):
            first = next(r for r in e2e["rows"] if r["model"] == model)
            verdict = "meets" if first["speedup"] >= 50 else "misses"
            accuracy = ""
            if first["probe_error_v_vs_sph"] is not None and sph_err is not None:
                below = first["probe_error_v_vs_sph"] < sph_err
                accuracy = f", at a probe v error {'below' if below else 'above'} the SPH's"
            print(f"  target >= 50x at {first['step_s'] * 1e3:g} ms, FMU {model}: {verdict} it "
                  f"({first['speedup']:.1f}x{accuracy})")
    if out is not None:
        with output_dir(out):
            write_fmu_csv(out, core, e2e)
            write_text(out / "bench_fmu.md", fmu_tables(core, e2e))
        print(f"wrote {out / 'bench_fmu_core.csv'}" + (", bench_fmu_e2e.csv" if e2e else "") + ", bench_fmu.md")
    return 0
