"""``sphrom bench stress`` (also the command ``sphrom stress``): numerical-stability maps of every method.

The maps are the library's (:mod:`sphrom.bench.lib.stress_maps`, which the whole report ``sphrom bench --report``
shares); this program writes them as the page stress.md with their CSV files and heat maps.
"""

from __future__ import annotations

from ..markdown import write_text
from ..options import add_quiet, float_list, int_list
from . import program_main
from .lib.stress_settings import AMPLITUDES, DEFAULT_SCENES, DT_FACTORS, HORIZONS, MODE_COUNTS, QUICK_DT_FACTORS

# The measuring modules (numpy, numba, fmpy) are imported inside run: `sphrom --help` builds this program's options
# (the command sphrom stress), which must not load them (tests/test_cli_imports.py).

HELP = "stability maps: time step, amplitude, horizon, modes, random forces"
DESCRIPTION = ("For each SCENE (default tenmode, damped_forced, heterogeneous): run every method over dt from 0.1x "
               "to 2x the explicit limit (and the paper's dt) against initial amplitudes x1..x1000, over horizons up "
               "to T = 1000, with k up to the number of snapshots, and under large random forces; record stable / "
               "growing / unphysical / blow-up, the time of blow-up and the energy drift. Writes a heat-map PNG per "
               "scene, CSV files and stress.md.")


def add_arguments(p):
    """The program's options on the parser ``p`` (``sphrom bench stress``'s, ``sphrom stress``'s)."""
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--amplitudes", type=float_list(lo=0, lo_open=True, integral_as_int=True), metavar="A,...",
                   default=",".join(map(str, AMPLITUDES)), help="initial-amplitude factors (default %(default)s)")
    p.add_argument("--horizons", type=float_list(lo=0, lo_open=True), metavar="T,...",
                   default=",".join(f"{h:g}" for h in HORIZONS), help="horizons T [s] at the paper's dt "
                   "(default %(default)s)")
    p.add_argument("--modes", type=int_list(lo=1), metavar="K,...", default=",".join(map(str, MODE_COUNTS)),
                   help="mode counts of the k sweep (default %(default)s)")
    p.add_argument("--quick", action="store_true", help="a small sweep (a smoke run)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU column")
    p.add_argument("--out", default="validation/stress", metavar="DIR")
    add_quiet(p)


def run(args):
    """Run the program with the parsed options ``args``; its exit status."""
    from ..runio import check_output_dir, output_dir
    from ..scene import load_scene
    from .lib.stress_maps import stress_report

    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    amps, horizons, ks, factors = args.amplitudes, args.horizons, args.modes, DT_FACTORS
    if args.quick:
        amps, horizons, ks, factors = amps[:2], horizons[:1], ks[:2], QUICK_DT_FACTORS
    out = check_output_dir(args.out)
    with output_dir(out):
        text, wall = stress_report(scenes, amps, horizons, ks, factors, out, no_fmu=args.no_fmu, quick=args.quick,
                                   progress=not args.quiet)
        write_text(out / "stress.md", text)
    print(f"wrote {out}/stress.md, stress_*.csv and a heat map per scene ({wall:.0f} s)")
    return 0


def main(argv=None):
    """``sphrom bench stress [SCENE ...] [options]`` (``python -m sphrom.bench.stress``); its exit status."""
    return program_main("stress", DESCRIPTION, add_arguments, run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
