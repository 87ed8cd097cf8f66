"""Mechanical ports measured: a port FMU against the full SPH with the same point forces, alone and coupled.

Two measurements on a scene (default damped_forced, two ports at x/L = 0.3 and 0.7, k = 12 POD modes):

* **open loop**: the FMU (frozen and exact) under port forces no model was trained on (F_1 = 1e-3 sin(5t + 0.3),
  F_2 = 1e-3 cos²(2t) N, held over 1 ms communication steps, the scene's own f as usual), its port velocities
  against the full SPH with the same forces spread by the same kernel (:func:`sphrom.sph.ports.run_sph_ports`);
  beside it the scene's POD error level: the same FMU without port forces against the full SPH without them,
  read through the same port rows.
* **coupled**: the FMU and a lumped mass-spring (mass 0.05 kg, spring 5 N/m, stretched 1 mm at t = 0) on port 1,
  exchanging force and velocity at each communication step in an fmpy loop (the FMU's v_port_1 held over a step
  while the mass-spring is advanced exactly; the spring force k s at the start of a step held as F_port_1 over
  it), port 2 driven open loop by F_2; against ONE full SPH of the coupled system, the mass-spring integrated
  together with the particles (same integrator, same Δt).  Errors: relative L² of v_port_1, v_port_2 and the
  spring elongation s over the samples.

Run as::

    python -m sphrom.bench.port_coupling [--t-end T] [--out validation/benchmarks/port_coupling.csv]
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..fmu.make.build import ensure_binaries
from ..fmu.run.driver import FMU
from ..scene import load_scene
from . import program_parser
from .lib.ports import MASS, PORTS, S0, STIFFNESS, mass_spring_step, open_loop_forces, rel

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).


def fmu_loop(path, scene, h, n, *, coupled, forced=True):
    """Run the port FMU over n steps of h on the FMU driver: (t, v_port (n+1, P), s (n+1,)).

    ``coupled``: port 1 is the mass-spring (module docstring), else F_1 open loop; port 2 is always open loop
    (zero when not ``forced``)."""
    P = len(PORTS)
    t = np.arange(n + 1) * h
    F = np.array([open_loop_forces(x)[0] for x in t]) if forced else np.zeros((n + 1, P))
    inputs = {"f": np.array([float(scene.force(x)) for x in t]), **{f"F_port_{j + 1}": F[:, j] for j in range(P)}}
    y = np.array([S0, 0.0])
    out_s = []

    def spring(j, tj, v_port):
        """The spring force k s at the step's start as F_port_1, then the mass-spring advanced over the step."""
        nonlocal y
        out_s.append(y[0])
        force = STIFFNESS * y[0]                       # the spring pulls the port
        y = mass_spring_step(y, v_port[0], h)
        return {"F_port_1": force}
    with FMU(path) as fmu:
        fmu.initialize(initial_state_scale=1)        # the scene's initial state, as the coupled full SPH
        v = fmu.simulate(t, inputs, outputs=[f"v_port_{j + 1}" for j in range(P)],
                         feedback=spring if coupled else None)
    out_s.append(y[0])
    return t, v, np.array(out_s if coupled else np.full(n + 1, S0))


def measure(scene_name="damped_forced", t_end=2.0, h=1e-3, k=12, models=("frozen", "exact"), progress=False):
    """Rows (dict) of the open-loop and coupled errors per model (module docstring)."""
    from ..fmu.make.package import package_fmu
    from ..sph.ports import mass_spring, run_sph_ports
    from ..sph.solver import build_problem
    scene = load_scene(scene_name)                  # trained over the scene's T, compared over [0, t_end]
    problem = build_problem(scene)
    n = int(round(t_end / h))
    every = int(round(h / scene.sph.dt))
    sph_free = run_sph_ports(scene, PORTS, problem=problem, every=every, t_end=t_end)
    sph_open = run_sph_ports(scene, PORTS, forces=lambda t: open_loop_forces(t)[0], problem=problem, every=every,
                             t_end=t_end)
    lumped = mass_spring(MASS, STIFFNESS, port=0, n_ports=len(PORTS), s0=S0)
    sph_coupled = run_sph_ports(scene, PORTS, forces=lambda t: open_loop_forces(t)[0] * np.array([0.0, 1.0]),
                                lumped=lumped, problem=problem, every=every, t_end=t_end)
    binaries = ensure_binaries(quiet=not progress)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for model in models:
            path = Path(tmp) / f"{model}.fmu"
            package_fmu(scene, path, k=k, progress=progress, binaries=binaries, model=model, ports=PORTS,
                        problem=problem)
            _, v_free, _ = fmu_loop(path, scene, h, n, coupled=False, forced=False)
            _, v_open, _ = fmu_loop(path, scene, h, n, coupled=False)
            _, v_coup, s_coup = fmu_loop(path, scene, h, n, coupled=True)
            rows.append({"scene": scene.name, "model": model, "k": k, "t_end": t_end, "step": h,
                         "pod_level": rel(v_free, sph_free.v_port),
                         "open_loop": rel(v_open, sph_open.v_port),
                         "coupled_v_port_1": rel(v_coup[:, 0], sph_coupled.v_port[:, 0]),
                         "coupled_v_port_2": rel(v_coup[:, 1], sph_coupled.v_port[:, 1]),
                         "coupled_spring": rel(s_coup, sph_coupled.y[:, 0]),
                         "port_force_effect": rel(sph_open.v_port, sph_free.v_port),
                         "coupling_effect": rel(sph_coupled.v_port[:, 0], sph_open.v_port[:, 0])})
    return rows


def main(argv=None):
    ap = program_parser("port_coupling", description=__doc__.split("\n\n")[0])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--out", default="validation/benchmarks/port_coupling.csv")
    args = ap.parse_args(argv)
    rows = measure(t_end=args.t_end, progress=True)
    keys = list(rows[0])
    lines = [",".join(keys)] + [",".join(f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in keys)
                                for r in rows]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
