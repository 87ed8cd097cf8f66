"""The frozen port FMU's accuracy against the port-force amplitude: what the training envelope with ports rests on.

``python -m sphrom.bench.port_envelope [--out FOLDER] [--t-end T]`` packages damped_forced's frozen
port FMU (k = 12, ports at x/L = 0.3 and 0.7, FMI 2, as :mod:`sphrom.bench.port_coupling`) and
drives it with the open-loop port forces of that benchmark scaled by 0, 1, 2, 5, 12, 20 (1 ms steps,
the scene's f as usual), against the full SPH with the same forces (:func:`sphrom.sph.ports.run_sph_ports`).
Per scale: the relative L² error of v_port, the largest probe strain |ρ0/ρ - 1| of the FMU (and as a
multiple of the trained one), and the FMU's envelope warning (none, or the quantity it names).  Writes
``port_envelope.csv`` and prints a Markdown table.
"""

from __future__ import annotations

import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ..fmu.kinds import unpack
from ..fmu.make.build import ensure_binaries
from ..fmu.run.driver import FMU
from ..fmu.variables import members
from ..progress import progress_bar
from ..scene import load_scene
from . import program_parser
from .lib.ports import PORTS, open_loop_forces, rel
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SCALES = (0.0, 1.0, 2.0, 5.0, 12.0, 20.0)
ENVELOPE_TEXT = "outside the training envelope"


def fmu_run(path, scene, h, n, forces):
    """(v_port (m, P), largest probe strain, envelope warning or "", error or "") of the port FMU over n steps
    of h [s] on the FMU driver with the port forces ``forces(t) -> (P,)`` [N] held over each step (m < n + 1
    after an error)."""
    from ..fmu.training.envelope import Envelope
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    rho0 = Envelope.from_sections(data.sections, data.k_v).probe_rho0
    P = data.sections["PORTX"].shape[1]
    t = np.arange(n + 1) * h
    F = np.array([forces(x) for x in t], dtype=float).reshape(n + 1, P)
    inputs = {"f": np.array([float(scene.force(x)) for x in t]), **{f"F_port_{j + 1}": F[:, j] for j in range(P)}}
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        rho_names = [s.outputs[i] for i in members(s.outputs, "rho_probe_j")]
        y = s.simulate(t, inputs, outputs=[f"v_port_{j + 1}" for j in range(P)] + rho_names, steps=np.full(n, h),
                       stop_on_error=True)
        error = "" if len(y) == n + 1 else (s.errors() or ["doStep failed"])[-1]
        warnings = [text for text in s.warnings() if ENVELOPE_TEXT in text]
    strain = float(np.max(np.abs(rho0 / y[1:, P:] - 1.0))) if len(y) > 1 else 0.0
    return y[:, :P], strain, (warnings[0] if warnings else ""), error


def measure(scene_name="damped_forced", scales=SCALES, t_end=1.0, h=1e-3, k=12, progress=True):
    """Rows (scale, port force amplitude [N], v_port error, probe strain, its multiple of the trained one,
    warning, error) of the frozen port FMU (module docstring)."""
    from ..fmu.make.package import package_fmu
    from ..fmu.training.envelope import Envelope
    from ..sph.ports import run_sph_ports
    from ..sph.solver import build_problem
    scene = load_scene(scene_name)
    problem = build_problem(scene)
    n = int(round(t_end / h))
    every = int(round(h / scene.sph.dt))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frozen-ports.fmu"
        package_fmu(scene, path, k=k, fmi=2, progress=progress, binaries=ensure_binaries(quiet=not progress),
                    model="frozen", ports=PORTS, problem=problem)
        data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
        trained = Envelope.from_sections(data.sections, data.k_v).max_probe_strain
        with progress_bar(len(scales), "port-force amplitudes", unit="run", enabled=progress) as bar:
            for scale in scales:
                def forces(t, a=scale):
                    return a * open_loop_forces(t)[0]
                sph = run_sph_ports(scene, PORTS, forces=forces, problem=problem, every=every, t_end=t_end)
                v, strain, warning, error = fmu_run(path, scene, h, n, forces)
                rows.append({"scale": scale, "port_force_amplitude_N": 1e-3 * scale,
                             "v_port_error_rel_l2": rel(v, sph.v_port[:len(v)]), "probe_strain": float(strain),
                             "probe_strain_over_trained": float(strain / trained),
                             "warning": warning.split(": ", 2)[-1][:120] if warning else "",
                             "error": error[:120]})
                bar.update(1)
    return rows


def markdown(rows):
    lines = ["| port forces | v_port error | probe strain (x trained) | envelope warning |", "| --- | --- | --- | --- |"]
    for r in rows:
        warning = r["warning"].split(", where")[0].replace("|", "\\|") if r["warning"] else "none"
        lines.append(f"| {r['scale']:g}x ({r['port_force_amplitude_N']:.3g} N) | {r['v_port_error_rel_l2']:.2e} | "
                     f"{r['probe_strain']:.3g} ({r['probe_strain_over_trained']:.2f}x) | {warning} |")
    return "\n".join(lines)


def main(argv=None):
    p = program_parser("port_envelope", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--t-end", type=float, default=1.0)
    args = p.parse_args(argv)
    rows = measure(t_end=args.t_end)
    out = Path(args.out) / "port_envelope.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    print(f"damped_forced, frozen port FMU (k = 12), open-loop port forces of sphrom.bench.port_coupling scaled, "
          f"over {args.t_end:g} s, against the full SPH")
    print(markdown(rows))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
