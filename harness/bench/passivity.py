"""Passive ports on every built-in scene: each port model's passivity check and its coupled poles.

For each scene (the built-in ones, at their own N) with ports at x/L = 0.3 and 0.7, k = 12, the port map (F_port
to v_port) of: the frozen model in the paper's Euclidean projection (``inner="euclid"``), the frozen model as a
port FMU builds it (the energy inner products, the default with ports), and the exact model.  Per model:
the verdict of :func:`sphrom.rom.passivity.port_passivity` (passive by structure, positive real on the grid,
passive to within 1e-3 of ‖H‖, or not passive), the grid's min λ(H + Hᴴ)/‖H‖ where no storage proves it, the
largest real part of the eigenvalues of the model linearised at rest [s^-1], and of the model coupled at each
port to a spring and a mass ten times the bar's (stiffness 1e4 N/m, no damper: every part passive, so a
passive model keeps every pole in the closed left half-plane) [s^-1].

Run as::

    python -m sphrom.bench.passivity [--scene NAME ...] [--out passivity.csv]

It prints a Markdown table (docs/fmu/ports.md quotes it) and writes the CSV.  About a minute on the shared 2-core
machine (tenmode's bases reach k_v = 233).
"""

from __future__ import annotations

import sys

import numpy as np

from ..progress import progress_bar
from ..scene import builtin_names, load_scene
from . import program_parser

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

PORTS = (0.3, 0.7)
K = 12
MASS_RATIO = 10.0        # the lumped mass at each port, in bar masses
STIFFNESS = 1e4          # the spring at each port [N/m]


def measure(name):
    """Rows {scene, N, model, k_v, k_2, verdict, margin, max_re, coupled_max_re} of one scene."""
    from ..rom import passivity as pv
    from ..pod.pipeline import basis_for_scene
    from ..rom.registry import get_model
    from ..sph.solver import build_problem
    scene = load_scene(name)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    bar = float(np.sum(problem.rho0) * problem.neighbours.dx)
    rows = []
    for label, model, options in (("frozen (euclid)", "frozen", {"inner": "euclid", "tensor": "never"}),
                                  ("frozen (energy, the FMU's)", "frozen", {"tensor": "never"}),
                                  ("exact", "exact", {})):
        spec = get_model(model)
        ops = spec.build(problem, basis, K, K, input_direction=spec.fmu_input_direction, ports=PORTS, **options)
        system = pv.port_system(ops) if spec.linear else pv.frozen_port_system(ops)
        found = pv.port_passivity(ops, spec.linear)
        coupled = pv.coupled_matrix(system, mass=MASS_RATIO * bar, stiffness=STIFFNESS)
        rows.append({"scene": name, "N": problem.n, "model": label, "k_v": ops.sizes["velocity"],
                     "k_2": list(ops.sizes.values())[1], "verdict": found.verdict,
                     "margin": found.margin, "max_re": float(np.max(np.linalg.eigvals(system.A).real)),
                     "coupled_max_re": float(np.max(np.linalg.eigvals(coupled).real))})
        print(f"{name} {label}: {found.line()}", file=sys.stderr, flush=True)
    return rows


def table(rows):
    """The Markdown table, one line per scene and model."""
    lines = ["| scene (N) | model | basis | port map | grid margin | max Re λ(A) [1/s] | coupled max Re λ [1/s] |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        margin = "-" if r["margin"] != r["margin"] else f"{r['margin']:.2g}"
        lines.append(f"| {r['scene']} ({r['N']}) | {r['model']} | ({r['k_v']}, {r['k_2']}) | {r['verdict']} | "
                     f"{margin} | {r['max_re']:.2g} | {r['coupled_max_re']:.2g} |")
    return "\n".join(lines)


def main(argv=None):
    parser = program_parser("passivity", description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", action="append", choices=sorted(builtin_names()),
                        help="a built-in scene (default all)")
    parser.add_argument("--out", help="CSV file to write")
    args = parser.parse_args(argv)
    rows = []
    names = args.scene or sorted(builtin_names())
    with progress_bar(len(names), desc="passivity", unit="scene") as bar:
        for name in names:
            rows += measure(name)
            bar.update(1)
    print(table(rows))
    if args.out:
        from .lib.tables import write_csv
        write_csv(args.out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
