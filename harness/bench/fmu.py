"""The FMU section of BENCHMARKS.md alone: ``python -m sphrom.bench.fmu`` / ``sphrom bench fmu``.

``[--scene S] [--repeats R] [--out FOLDER] [--report BENCHMARKS.md]``: the FMU measurements of ``sphrom bench``
(:func:`sphrom.bench.lib.fmu.fmu_measurements`: the C core against N, end to end through the FMU driver, the
same-language ratio); replaces the report's "Headline" and "The FMU" sections (the figures of the rest of
``sphrom bench`` do not depend on the FMU) and writes fmu_core.csv, fmu_e2e.csv.
"""

from __future__ import annotations


def main(argv=None):
    import platform
    import sys
    import time
    from pathlib import Path

    from .lib.fmu import fmu_measurements, write_fmu_csv
    from .lib.document import fmu_section, headline_section, update_report
    from . import program_parser

    p = program_parser("fmu", description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="tenmode")
    p.add_argument("--repeats", type=int, default=5, metavar="R")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    from .lib.timing import cpu_model, load_average
    load_start = load_average()
    t0 = time.perf_counter()
    fmu = fmu_measurements(args.scene, repeats=args.repeats, progress=not args.quiet)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_fmu_csv(out, fmu["core"], fmu["e2e"], prefix="fmu_")
    given = argv if argv is not None else sys.argv[1:]
    note = (f"Re-measured alone by `python -m sphrom.bench.fmu{' ' + ' '.join(given) if given else ''}` "
            f"on {cpu_model()}, Python {platform.python_version()}, {wall:.0f} s wall, load average (1 / 5 / 15 "
            f"min) {' / '.join(map(str, load_start or ()))} at the start, "
            f"{' / '.join(map(str, load_average() or ()))} at the end; medians of {args.repeats}), after the rest "
            "of this report.")
    head = headline_section(fmu)
    section = fmu_section(fmu)
    section[1:1] = ["", note]
    update_report(args.report, {"## Headline": head, "## The FMU": section})
    print("\n".join(head + section))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
