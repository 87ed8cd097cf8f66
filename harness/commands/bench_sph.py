"""``sphrom bench-sph``: µs per step of the full SPH model against N."""

from .options import int_at_least


def add_parser(sub):
    p = sub.add_parser("bench-sph", help="time the full SPH step against the particle count",
                       description="Median microseconds per step of the full SPH loop (numba) for several particle "
                                   "counts and integrators, and the growth exponent of time against N "
                                   "(1 = linear). Writes CSV and a PNG plot when --out is given.")
    p.add_argument("--scene", default="tenmode", help="scene whose fields are used (default tenmode)")
    p.add_argument("--sizes", default="100,400,10000,100000", help="comma-separated particle counts")
    p.add_argument("--integrators", default="euler,symplectic,rk4", help="comma-separated integrators")
    p.add_argument("--repeats", type=int_at_least(1), default=5, help="repeats per point (median reported)")
    p.add_argument("--out", metavar="DIR", help="folder for sph_scaling.csv and sph_scaling.png")
    p.set_defaults(handler=run)


def run(args):
    from pathlib import Path

    from ..bench.sph_scaling import growth_exponent, plot_scaling, scaling_table
    from ..bench.tables import write_csv
    from ..errors import UserError
    from ..progress import progress_bar

    try:
        sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        raise UserError(f"--sizes: {args.sizes!r} is not a comma-separated list of integers") from None
    if min(sizes) < 8:
        raise UserError(f"--sizes: {min(sizes)} is out of range (allowed: integers >= 8)")
    integrators = args.integrators.split(",")
    bad = [i for i in integrators if i not in ("euler", "symplectic", "rk4")]
    if bad:
        raise UserError(f"--integrators: {bad[0]!r} is not one of euler, symplectic, rk4")
    out = Path(args.out) if args.out else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    with progress_bar(total=len(sizes) * len(integrators), desc="bench-sph", enabled=True) as bar:
        rows = scaling_table(args.scene, sizes, integrators, args.repeats, bar)
    print(f"full SPH step (numba, one thread), scene {args.scene}, median of {args.repeats} repeats")
    print(f"{'integrator':<11} {'N':>8} {'us/step':>10} {'ns/particle':>12}")
    for r in rows:
        print(f"{r['integrator']:<11} {r['n']:>8} {r['us_per_step']:>10.3f} {r['ns_per_particle_step']:>12.2f}")
    for integrator in integrators:
        print(f"{integrator}: time ~ N^{growth_exponent(rows, integrator):.2f} for N >= 1000")
    if out is not None:
        write_csv(out / "sph_scaling.csv", rows)
        plot_scaling(rows, integrators, out / "sph_scaling.png", args.scene)
        print(f"wrote {out / 'sph_scaling.csv'} and {out / 'sph_scaling.png'}")
    return 0
