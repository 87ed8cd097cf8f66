"""``sphrom bench-sph``: µs per step of the full SPH model against N."""

from .options import MAX_REPEATS, add_quiet, add_scene, choice_list, int_in, int_list, min_particles

INTEGRATORS = ("euler", "symplectic", "rk4")


def add_parser(sub):
    p = sub.add_parser("bench-sph", help="time the full SPH step against the particle count",
                       description="Median microseconds per step of the full SPH loop (numba) for several particle "
                                   "counts and integrators, and the growth exponent of time against N "
                                   "(1 = linear). Writes CSV and a PNG plot when --out is given.")
    add_scene(p, default="tenmode", option_alias=True, help="scene whose fields are used")
    p.add_argument("--n-particles", "--sizes", dest="n_particles", type=int_list(lo=min_particles),
                   default="100,400,10000,100000", metavar="N,...",
                   help="comma-separated particle counts (default %(default)s)")
    p.add_argument("--integrator", "--integrators", dest="integrator", type=choice_list(*INTEGRATORS),
                   default=",".join(INTEGRATORS), metavar="NAME,...",
                   help="comma-separated integrators out of euler, symplectic, rk4 (default all)")
    p.add_argument("--repeats", type=int_in(1, MAX_REPEATS), default=5, help="repeats per point (median reported)")
    p.add_argument("--out", metavar="DIR", help="folder for sph_scaling.csv and sph_scaling.png")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    from ..bench.sph_scaling import growth_exponent, plot_scaling, scaling_table
    from ..bench.tables import write_csv
    from ..progress import progress_bar
    from ..runio import check_output_dir, output_dir
    from ..scene import load_scene

    load_scene(args.scene)                       # a bad name is a one-line error before any work
    sizes, integrators = args.n_particles, args.integrator
    out = check_output_dir(args.out) if args.out else None
    with progress_bar(total=len(sizes) * len(integrators), desc="bench-sph", enabled=not args.quiet) as bar:
        rows = scaling_table(args.scene, sizes, integrators, args.repeats, bar)
    print(f"full SPH step (numba, one thread), scene {args.scene}, median of {args.repeats} repeats")
    print(f"{'integrator':<11} {'N':>8} {'us/step':>10} {'ns/particle':>12}")
    for r in rows:
        print(f"{r['integrator']:<11} {r['n']:>8} {r['us_per_step']:>10.3f} {r['ns_per_particle_step']:>12.2f}")
    for integrator in integrators:
        print(f"{integrator}: time ~ N^{growth_exponent(rows, integrator):.2f} for N >= 1000")
    if out is not None:
        with output_dir(out):
            write_csv(out / "sph_scaling.csv", rows)
            plot_scaling(rows, integrators, out / "sph_scaling.png", args.scene)
        print(f"wrote {out / 'sph_scaling.csv'} and {out / 'sph_scaling.png'}")
    return 0
