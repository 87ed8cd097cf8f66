"""``sphrom bench sph-step`` (also the command ``sphrom bench-sph``): µs per step of the full SPH model against N.

Each figure a slope between runs of M and 2M steps (:mod:`sphrom.bench.lib.sph_scaling`, which the whole report
``sphrom bench`` shares); with ``--report`` the section "The full SPH step against N" of BENCHMARKS.md, naming the
command, the CPU and the load.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..options import MAX_REPEATS, add_quiet, add_scene, choice_list, int_in, int_list, min_particles
from ..scene_schema import key
from . import program_main
from .lib.tables import write_csv
from .lib.timing import cpu_model, load_average

# The measuring modules (numpy, numba) are imported inside run: `sphrom --help` builds this program's options (the
# command sphrom bench-sph), which must not load them (tests/test_cli_imports.py).

INTEGRATORS = key("sph.integrator").range.choices      # every integrator the full SPH has
HELP = "time the full SPH step against the particle count"
DESCRIPTION = ("Median microseconds per step of the full SPH loop (numba) for several particle counts and "
               "integrators, and the growth exponent of time against N (1 = linear). Each figure is a slope: runs of "
               "M and 2M steps timed back to back give (t(2M) - t(M)) / M, so the call's fixed cost cancels. Names "
               "the CPU and the load average. Writes CSV and a PNG plot when --out is given. The numba step against "
               "the C stencil and an older checkout: sphrom bench sph_stencil.")


def add_arguments(p):
    """The program's options on the parser ``p`` (``sphrom bench sph-step``'s, ``sphrom bench-sph``'s)."""
    add_scene(p, default="tenmode", option_alias=True, help="scene whose fields are used")
    p.add_argument("--n-particles", "--sizes", dest="n_particles", type=int_list(lo=min_particles),
                   default="100,400,10000,100000", metavar="N,...",
                   help="comma-separated particle counts (default %(default)s)")
    p.add_argument("--integrator", "--integrators", dest="integrator", type=choice_list(*INTEGRATORS),
                   default=",".join(INTEGRATORS), metavar="NAME,...",
                   help="comma-separated integrators out of euler, symplectic, rk4 (default all)")
    p.add_argument("--repeats", type=int_in(1, MAX_REPEATS), default=5, help="repeats per point (median reported)")
    p.add_argument("--layout", choices=("auto", "general"), default="auto",
                   help="the SPH operator's layout in the loop: auto (the fixed-offset stencil where the neighbour "
                        "lists allow it, as sphrom sph runs) or general (the neighbour lists); the same bits")
    p.add_argument("--out", metavar="DIR", help="folder for sph_scaling.csv and sph_scaling.png")
    p.add_argument("--report", metavar="FILE.md",
                   help="replace the section 'The full SPH step against N' of this Markdown report (BENCHMARKS.md) "
                        "with the table, naming this command, the CPU and the load")
    add_quiet(p)


def run(args):
    """Run the program with the parsed options ``args``; its exit status."""
    from ..progress import progress_bar
    from ..runio import check_output_dir, output_dir
    from ..scene import load_scene
    from .lib.document import update_report
    from .lib.sph_scaling import SPH_STEP_HEADING, growth_exponent, plot_scaling, scaling_table, sph_step_section

    load_scene(args.scene)                       # a bad name is a one-line error before any work
    sizes, integrators = args.n_particles, args.integrator
    out = check_output_dir(args.out) if args.out else None
    load_start = load_average()
    with progress_bar(total=len(sizes) * len(integrators), desc="bench-sph", enabled=not args.quiet) as bar:
        rows = scaling_table(args.scene, sizes, integrators, args.repeats, bar, layout=args.layout)
    load = lambda x: "n/a" if x is None else " / ".join(f"{v:.2f}" for v in x)      # noqa: E731
    print(f"full SPH step (numba, one thread, {args.layout} layout), scene {args.scene}, slope between M and 2M "
          f"steps, median of {args.repeats} repeats")
    print(f"machine: {cpu_model()}; load average (1 / 5 / 15 min) {load(load_start)} at the start, "
          f"{load(load_average())} at the end")
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
    if args.report:
        command = (f"sphrom bench-sph {args.scene} --n-particles {','.join(map(str, sizes))} --integrator "
                   f"{','.join(integrators)} --repeats {args.repeats} --layout {args.layout}"
                   + (f" --out {args.out}" if args.out else "") + f" --report {args.report}")
        produced = (f"Produced by `{command}` on {cpu_model()}, load average (1 / 5 / 15 min) "
                    f"{load(load_start)} at the start, {load(load_average())} at the end.")
        image = None
        if out is not None:
            image = Path(os.path.relpath(out.resolve() / "sph_scaling.png", Path(args.report).resolve().parent))
        lines = sph_step_section(rows, sizes, args.repeats, integrators, produced=produced,
                                 image=image and image.as_posix())
        print(f"wrote the section of {update_report(args.report, {SPH_STEP_HEADING: lines})}")
    return 0


def main(argv=None):
    """``sphrom bench sph-step [SCENE] [options]`` (``python -m sphrom.bench.sph_step``); its exit status."""
    return program_main("sph-step", DESCRIPTION, add_arguments, run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
