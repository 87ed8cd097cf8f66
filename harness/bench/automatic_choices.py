"""What the automatic rules of a scene (sphrom.pod.automatic) choose on the physics of each paper scene.

    python -m sphrom.bench.automatic_choices [--out validation/benchmarks/automatic_choices.csv]

Each built-in scene with its [snapshots], [rom], [paper] and sph.every removed (what a user's own scene of the
same physics would give), loaded and taken through its full SPH and POD: T', the automatic sph.every, the
automatic snapshots and the automatic mode count k, beside the scene file's settings and the paper's mode
threshold.  The full SPH runs at the paper's N and dt (tenmode: 200,000 steps of N = 400; high_frequency:
1,000,000 of N = 1000), so this is a command of its own, not a test.
"""

from __future__ import annotations

import argparse

from ..scene import builtin_names, dump_toml, load_scene, parse_scene, scene_dict
from . import program_parser

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

COLUMNS = ["scene", "period_s", "every", "snapshots", "k", "file_every", "file_snapshots", "file_modes",
           "paper_threshold", "why"]


def table(progress=False):
    """Rows (dicts of :data:`COLUMNS`), one per built-in scene."""
    from ..pod.automatic import automatic_modes          # (deferred: numba; --help answers before it loads)
    from ..pod.pipeline import basis_for_scene
    from ..pod.snapshots import describe
    rows = []
    for name in builtin_names():
        given = load_scene(name)
        data = scene_dict(given)
        for section in ("snapshots", "rom", "paper"):
            data.pop(section, None)
        data["sph"].pop("every")
        auto = parse_scene(dump_toml(data), f"<{name} without snapshots, rom, paper, every>")
        basis, _ = basis_for_scene(auto, progress=progress)
        k, why = automatic_modes(basis)
        rows.append({"scene": name, "period_s": auto.period(), "every": auto.sph.every,
                     "snapshots": describe(auto.snapshots), "k": k, "file_every": given.sph.every,
                     "file_snapshots": describe(given.snapshots), "file_modes": given.rom["modes"],
                     "paper_threshold": given.paper.get("mode_threshold", ""), "why": why})
    return rows


def main(argv=None):
    p = program_parser("automatic_choices", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", metavar="FILE.csv", help="also write the rows as CSV")
    args = p.parse_args(argv)
    rows = table(progress=True)
    print("| scene | T' [s] | every (file) | snapshots (file) | k (file's rom.modes; paper's threshold) |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['scene']} | {r['period_s']:.4g} | {r['every']} ({r['file_every']}) | {r['snapshots']} "
              f"({r['file_snapshots']}) | {r['k']} ({r['file_modes']}; {r['paper_threshold'] or '-'}) |")
    if args.out:
        from .lib.tables import write_csv
        write_csv(args.out, rows, COLUMNS)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
