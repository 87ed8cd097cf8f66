"""Held against interpolated port forces: the frozen port FMU's port-velocity error against the communication step.

The companion of :mod:`sphrom.bench.input_derivatives` for the mechanical ports.
``python -m sphrom.bench.port_rates [--out FOLDER]`` packages the frozen port FMU of
damped_forced (k = 12, ports at x/L = 0.3 and 0.7, FMI 2), drives its ports with the open-loop
forces of :mod:`sphrom.bench.port_coupling` (F_1 = 1e-3 sin(5t + 0.3), F_2 = 1e-3 cos²(2t) N) and
the scene's f with its derivative, at communication steps of 4, 10, 20, 50 ms with the port forces
held over each step and with dF/dt (fmi2SetRealInputDerivatives: F_j + (dF_j/dt) τ at each refresh
of the force term), over 2 s.  Reference: the same FMU stepped one refresh period (n_freeze Δt) at a
time with the exact forces (the frozen model's own sampling of its inputs).  Errors: relative L² of
v_port over ports and the coarse communication points, against the reference's v_port and against the
port forces' effect on it (the reference minus the same run without port forces).  Writes
``port_rates.csv`` and prints a Markdown table.
"""

from __future__ import annotations

import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ..fmu.make.build import ensure_binaries
from ..fmu.kinds import unpack
from ..fmu.run.driver import FMU
from ..progress import progress_bar
from ..scene import load_scene
from . import program_parser
from .lib.ports import PORTS, open_loop_forces
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

STEPS = (4e-3, 1e-2, 2e-2, 5e-2)
T_END = 2.0


def port_loop(path, scene, h, n, forces, port_rates):
    """v_port (n+1, P) of the port FMU at ``path`` over n steps of h [s] on the FMU driver: f with df/dt, the
    port forces ``forces(t) -> (len(t), P)`` [N] set at each communication point, with their rates (the chord to
    the next point) when ``port_rates``, else held."""
    t = np.arange(n + 1) * h
    F = forces(t)
    P = F.shape[1]
    inputs = {"f": np.asarray(scene.force(t), float), **{f"F_port_{j + 1}": F[:, j] for j in range(P)}}
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        return s.simulate(t, inputs, rates=True if port_rates else {"f"},
                          outputs=[f"v_port_{j + 1}" for j in range(P)], steps=np.full(n, h))


def measure(scene_name="damped_forced", steps=STEPS, t_end=T_END, k=12, progress=True):
    """Rows (model, step_ms, input, v_port error against the reference, against the port forces' effect,
    communication steps) of the frozen port FMU (module docstring)."""

    from ..fmu.make.package import package_fmu
    scene = load_scene(scene_name)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frozen-ports.fmu"
        package_fmu(scene, path, k=k, fmi=2, progress=progress, binaries=ensure_binaries(quiet=not progress),
                    model="frozen", ports=PORTS)
        data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
        fine = data.n_freeze * data.dt
        n_fine = int(round(t_end / fine))
        rows = []
        with progress_bar(2 * len(steps) + 2, "port-force rates", unit="run", enabled=progress) as bar:
            ref = port_loop(path, scene, fine, n_fine, open_loop_forces, False)
            bar.update(1)
            free = port_loop(path, scene, fine, n_fine, lambda t: 0.0 * open_loop_forces(t), False)
            bar.update(1)
            for h in steps:
                stride = int(round(h / fine))
                if abs(stride * fine - h) > 1e-12 * h:
                    raise ValueError(f"step {h:g} s is not a multiple of the refresh period {fine:g} s")
                n = int(round(t_end / h))
                sub, effect = ref[::stride][:n + 1], (ref - free)[::stride][:n + 1]
                for rates in (False, True):
                    v = port_loop(path, scene, h, n, open_loop_forces, rates)
                    rows.append({"model": "frozen, ports", "step_ms": h * 1e3,
                                 "input": "derivative" if rates else "held",
                                 "v_port_error_rel_l2": float(np.linalg.norm(v - sub) / np.linalg.norm(sub)),
                                 "v_port_error_rel_effect": float(np.linalg.norm(v - sub) / np.linalg.norm(effect)),
                                 "communication_steps": n})
                    bar.update(1)
    return rows


def markdown(rows):
    """A Markdown table: one line per step, held and derivative errors side by side."""
    by = {(r["step_ms"], r["input"]): r for r in rows}
    lines = ["| communication step | v_port error, F held | v_port error, F linear (dF/dt) | "
             "of the forces' effect, held | of the forces' effect, linear |", "| --- | --- | --- | --- | --- |"]
    for h in sorted({r["step_ms"] for r in rows}):
        held, lin = by[h, "held"], by[h, "derivative"]
        lines.append(f"| {h:g} ms | {held['v_port_error_rel_l2']:.2e} | {lin['v_port_error_rel_l2']:.2e} | "
                     f"{held['v_port_error_rel_effect']:.2e} | {lin['v_port_error_rel_effect']:.2e} |")
    return "\n".join(lines)


def main(argv=None):
    p = program_parser("port_rates", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--scene", default="damped_forced")
    args = p.parse_args(argv)
    rows = measure(args.scene)
    out = Path(args.out) / "port_rates.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    print(f"{args.scene}, frozen port FMU (FMI 2, k = 12), open-loop port forces; v_port error (relative L2 over "
          f"ports and time) against the same FMU fed the exact forces at every refresh")
    print(markdown(rows))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
