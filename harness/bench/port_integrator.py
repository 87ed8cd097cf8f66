"""The frozen port FMU's own state in a long damped loop, per integrator: its energy against the full SPH's.

``python -m sphrom.bench.port_integrator`` / ``sphrom bench port_integrator [SCENE ...] [--t-end T]
[--integrators I1,I2] [--sph] [--out FOLDER] [--quiet]``

A frozen FMU with ports is its portless model (its own state) plus the port channel, which takes every port force
(docs/fmu/ports.md): no port force reaches the own state, but that state runs for as long as the co-simulation.
Each scene's frozen port FMU (ports at x/L = 0.3, 0.7, FMI 2, the scene's defaults, each integrator of
``--integrators``; default the scene's own and the port FMU's default) runs through its C core in the ports bench's
damped loop (port 1 tied to the lumped mass-spring with a dashpot of 0.1 N s/m beside the spring,
:func:`sphrom.bench.lib.ports.mass_spring_step`, 10 ms steps, forces held) from the scene's initial state over
``--t-end`` (default 200 s).  Per run: the integrator's amplification of the model's fastest mode over the run
(linearised about rest, :func:`sphrom.rom.stepping.reduced_amplification`); the own state's energy
½ Σ (ρ0 v² + c e²) Δx (e = ρ0/ρ − 1, its fields from the Python build of the same model, checked equal at t = 0):
its smallest, largest and last value over its start (undamped and unforced, physics keeps it); the own density's
smallest value over ρ0; when and why the FMU stopped.  With ``--sph``, the full SPH (symplectic Euler at the scene's dt,
:class:`sphrom.sph.ports.PortStepper`) in the same loop: its coupled energy (bar and mass-spring) at the end over its
start, its density range, and each run's v_port_1 error against it (relative L² over the points both reached).
Prints a Markdown table; ``port_integrator.csv`` with ``--out``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..options import choice_list
from . import program_parser
from .lib.ports import PORTS, damped_loop, frozen_fields, lumped_energy

# The measuring modules are imported inside the functions: `sphrom bench NAME --help` answers before they load.

STEP, DAMPING = 1e-2, 0.1          # the ports bench's damped loop (harness/bench/error_bounds_ports.py)
T_END = 200.0
PROBES = (0.25, 0.5, 0.66)         # the FMU's default probes


def fmu_run(scene, integrator, t_end, folder):
    """One frozen port FMU through its C core in the loop: a row (without the SPH comparison) and v_port_1."""
    import zipfile

    import numpy as np
    from ..fmu.kinds.frozen import reduced_model
    from ..fmu.make.options import check_options
    from ..fmu.make.package import package_fmu
    from ..fmu.run.core import built_core
    from ..rom.stepping import reduced_amplification
    path = Path(folder) / f"{scene.name}-frozen-{integrator}.fmu"
    package_fmu(scene, path, model="frozen", ports=PORTS, integrator=integrator, progress=False, verify=False,
                error_bounds=False, bounds=False)
    k, n_freeze = check_options(scene, ports=PORTS, integrator=integrator)[:2]
    _, ops, problem, _ = reduced_model(scene, k, n_freeze, PROBES, integrator, progress=False, ports=PORTS)
    model = built_core().load(zipfile.ZipFile(path).read("resources/model.bin"))
    try:
        model.set_initial_state_scale(1.0)
        if not np.allclose(model.reduced_state(), ops.z0, rtol=1e-12, atol=1e-15):
            raise RuntimeError(f"{path.name}: the FMU's start is not the Python build's (another k or basis)")
        fields = frozen_fields(ops, problem)
        clock = [0.0]

        def step(F):
            model.set_port_forces([F, 0.0])
            model.do_step(clock[0], STEP)
            clock[0] += STEP
        v, seen, stop = damped_loop(lambda: model.port_velocities()[0], step, int(round(t_end / STEP)),
                                    lambda y: fields(model.reduced_state()), STEP, DAMPING)
    finally:
        model.close()
    energy = np.array([s[0] for s in seen])
    k_v, k_rho = ops.sizes.values()
    return {"scene": scene.name, "integrator": integrator, "k_v": k_v, "k_rho": k_rho, "dt": scene.sph.dt,
            "amplification": reduced_amplification(ops, scene.sph.dt, integrator, t_end)[0],
            "energy_min": float(energy.min() / energy[0]), "energy_max": float(energy.max() / energy[0]),
            "energy_end": float(energy[-1] / energy[0]),
            "rho_min": min(s[1] for s in seen), "reached": (len(v) - 1) * STEP, "stop": stop or ""}, v


def sph_run(scene, t_end):
    """The full SPH in the same loop: (coupled energy end / start, min ρ/ρ0, max ρ/ρ0, v_port_1, stop)."""
    import numpy as np
    from ..sph.ports import PortStepper
    bar = PortStepper(scene, PORTS, integrator="symplectic", initial_state_scale=1.0)

    def watch(y):
        return bar.energy() + lumped_energy(y), float(np.min(bar.rho / bar.problem.rho0)), \
            float(np.max(bar.rho / bar.problem.rho0))
    v, seen, stop = damped_loop(lambda: bar.port_velocities()[0], lambda F: bar.step(STEP, [F, 0.0]),
                                int(round(t_end / STEP)), watch, STEP, DAMPING)
    return seen[-1][0] / seen[0][0], min(s[1] for s in seen), max(s[2] for s in seen), v, stop


def measure(scenes, t_end=T_END, integrators=None, sph=False, progress=True):
    """Rows of the module docstring's table, one per scene and integrator (with ``sph``: the full SPH's columns)."""
    import tempfile

    import numpy as np
    from ..fmu.make.options import default_integrator
    from ..progress import progress_bar
    from ..scene import load_scene
    rows = []
    loaded = [load_scene(s) for s in scenes]
    plan = [(scene, integrators or list(dict.fromkeys([scene.sph.integrator, default_integrator(scene, PORTS)])))
            for scene in loaded]
    with tempfile.TemporaryDirectory() as tmp, progress_bar(sum(len(i) + sph for _, i in plan), "loops", unit="run",
                                                            enabled=progress) as bar:
        for scene, names in plan:
            reference = None
            if sph:
                reference = sph_run(scene, t_end)
                bar.update(1)
            for integrator in names:
                row, v = fmu_run(scene, integrator, t_end, tmp)
                if reference is not None:
                    v_ref = reference[3]
                    m = min(v.size, v_ref.size)
                    row.update(sph_energy_end=reference[0], sph_rho_min=reference[1], sph_rho_max=reference[2],
                               sph_stop=reference[4] or "",
                               v_port_error=float(np.linalg.norm(v[:m] - v_ref[:m]) / np.linalg.norm(v_ref[:m])))
                rows.append(row)
                bar.update(1)
    return rows


def markdown(rows):
    """The table of :func:`measure`'s rows."""
    from .lib.document import fmt
    sph = any("v_port_error" in r for r in rows)
    head = ["scene", "integrator", "k_v, k_ρ", "fastest mode's amplification over the run",
            "own energy min / start", "own energy max / start", "own energy end / start", "own min ρ/ρ0", "ran to [s]",
            "stopped"]
    if sph:
        head += ["v_port_1 error against the full SPH", "full SPH: coupled energy end / start",
                 "full SPH: ρ/ρ0 range"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["scene"], r["integrator"], f"{r['k_v']}, {r['k_rho']}", fmt(r["amplification"]),
                 fmt(r["energy_min"]), fmt(r["energy_max"]), fmt(r["energy_end"]), f"{r['rho_min']:.4f}",
                 f"{r['reached']:.2f}", r["stop"] or "no"]
        if sph:
            cells += [fmt(r["v_port_error"]), fmt(r["sph_energy_end"]),
                      f"{r['sph_rho_min']:.4f} to {r['sph_rho_max']:.4f}"]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    from ..options import positive_float
    from .lib.tables import write_csv
    p = program_parser("port_integrator", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="default: heterogeneous")
    p.add_argument("--t-end", type=positive_float, default=T_END, metavar="T", help="seconds of loop (default 200)")
    p.add_argument("--integrators", type=choice_list("euler", "symplectic"), metavar="I1,I2",
                   help="euler and/or symplectic (default: the scene's own and the port FMU's default)")
    p.add_argument("--sph", action="store_true", help="the full SPH in the same loop too (minutes per 100 s)")
    p.add_argument("--out", metavar="FOLDER", help="write port_integrator.csv there")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    integrators = args.integrators
    rows = measure(args.scenes or ["heterogeneous"], t_end=args.t_end, integrators=integrators, sph=args.sph,
                   progress=not args.quiet)
    print(markdown(rows))
    if args.out:
        out = Path(args.out) / "port_integrator.csv"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_csv(out, rows)
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
