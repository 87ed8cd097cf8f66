"""Every input channel of a packaged FMU measured against the full SPH: the force f along the scene's
profile and each port force F_port_j, each from rest under

- ``constant``: a constant input (its response: the static deflection, and the rigid motion of the bar: an
  undamped bar accelerates without end);
- ``slow``: a sine at a quarter of the bar's lowest elastic frequency ω_1 (:func:`sphrom.rom.inputs.band`),
  a spring attached to a port applies this kind of force;
- ``in band``: a sine at 1.5 ω_1, between the bar's two lowest elastic frequencies (in the band the basis
  must hold, off its resonances);
- ``coupled`` (each port): the port closed by a spring-mass-damper (:func:`smd_parameters`: a mass a tenth of
  the bar's, its spring tuned to ω_1 / 2, 10 % of critical damping, the spring stretched at t = 0 to give the
  port force amplitude), the FMU coupled through the driver (the port velocity held over a step while the
  spring-mass-damper is advanced exactly, its force at the step's start held over it) against the full SPH
  integrated together with the spring-mass-damper (:func:`sphrom.sph.ports.run_sph_ports`): the error of the
  port velocity then includes the coupling's own, of order of the communication step;

over :func:`horizon` = min(T, :data:`HORIZON_PERIODS` T') at the FMU's communication step, the input held over each step as an
importer sets it.  Amplitudes: f the unseen force's (:func:`.verify.unseen_force`), F_port_j the force that gives
the bar (area A = 1) the same mean acceleration, A_f Σ ρ0 Δx [N].  Output compared: the probe velocities for f,
the channel's own port velocity for F_port_j (power-conjugate to it); the error is eq. 3.4's relative L2
(square-root form, trapezoidal in time), as the verification's cases.

The full SPH: :func:`sphrom.sph.solver.run_sph` for f (the scene with f replaced),
:func:`sphrom.sph.ports.run_sph_ports` for the ports (with the scene's own force off, so the port force alone
drives the bar), each from rest, with the FMU's integrator (:func:`reference_scene`). """

from __future__ import annotations

import time
import zipfile
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ...expr import compile_expr
from ...norms import relative_l2
from ...progress import progress_bar
from ...rom.inputs import band
from ...scene import derive_scene
from ...sph.ports import mass_spring, run_sph_ports
from ...sph.solver import build_problem, run_sph
from ..kinds import kind_of, unpack
from ..kinds.frozen import PORT_INTEGRATOR
from ..run.driver import FMU
from ..variables import members
from .verify import SCALE_NAME, communication_times, fmu_features, probe_values, rows_at, unseen_force

# the longest run per case, in units of the wave's time once around the bar T' (the full SPH with ports is a Python
# loop over the steps): 2 s on the paper's bars (c = 0.1, rho0 = 1, L = 1: T' = sqrt(10) s), the same fraction of
# any bar's own time scale (a steel bar's T' is a fifth of a millisecond)
HORIZON_PERIODS = 2.0 / np.sqrt(10.0)
SLOW_FRACTION = 0.25  # the slow sine's frequency, in units of the lowest elastic frequency ω_1
IN_BAND = 1.5         # the in-band sine's, likewise
SMD_MASS, SMD_TUNING, SMD_ZETA = 0.1, 0.5, 0.1   # the coupled spring-mass-damper: of the bar's mass, of ω_1, ζ


@dataclass
class ChannelCase:
    """One input channel under one force: channel (``f`` or ``F_port_j``), case (``constant``, ``slow``), the
    input as an expression in t, the output compared, eq. 3.4's error of it, the full SPH's wall time [s]."""

    channel: str
    case: str
    force: str
    output: str
    err: float
    sph_s: float
    note: str = ""

    def as_row(self):
        return {"channel": self.channel, "case": self.case, "force": self.force, "output": self.output,
                "err": self.err, "sph_s": self.sph_s, "note": self.note}


def horizon(scene):
    """The channels' horizon [s]: min(T, :data:`HORIZON_PERIODS` T'), T' the wave's time once around the bar
    (:meth:`sphrom.scene.Scene.period`)."""
    return float(min(float(scene.T), HORIZON_PERIODS * scene.period()))


def channel_forces(scene, problem, step):
    """{channel: {case: expression in t}} for f and, later, each port (module docstring)."""
    amplitude = float(unseen_force(scene, step, problem).split("*")[0])
    w1 = band(problem)[0]
    w, w_in = SLOW_FRACTION * w1, IN_BAND * w1
    mass = float(np.sum(problem.rho0) * problem.neighbours.dx)       # Σ ρ0 Δx [kg m^-1 ... per m^2 of A]
    F = amplitude * mass
    return ({"constant": f"{amplitude:.4g}", "slow": f"{amplitude:.4g}*sin({w:.4g}*t)",
             "in band": f"{amplitude:.4g}*sin({w_in:.4g}*t)"},
            {"constant": f"{F:.4g}", "slow": f"{F:.4g}*sin({w:.4g}*t)", "in band": f"{F:.4g}*sin({w_in:.4g}*t)",
             "coupled": "spring-mass-damper"})


def smd_parameters(scene, problem, step):
    """(mass [kg], stiffness [N m^-1], damping [N s m^-1], initial elongation [m]) of the coupled case (module
    docstring), for a bar of cross-section 1 m²."""
    bar = float(np.sum(problem.rho0) * problem.neighbours.dx)
    m = SMD_MASS * bar
    k = m * (SMD_TUNING * band(problem)[0]) ** 2
    c = 2.0 * SMD_ZETA * np.sqrt(k * m)
    F = float(unseen_force(scene, step, problem).split("*")[0]) * bar
    return m, k, c, F / k


def smd_step(y, v_port, h, mass, stiffness, damping):
    """The spring-mass-damper (s, w) advanced exactly over h [s] with the port velocity held (s' = w - v_port,
    m w' = -k s - c (w - v_port)): the exponential of its affine system."""
    M = np.zeros((3, 3))
    M[0, 1], M[0, 2] = 1.0, -v_port
    M[1, 0], M[1, 1], M[1, 2] = -stiffness / mass, -damping / mass, damping * v_port / mass
    return (sla.expm(M * h) @ np.array([y[0], y[1], 1.0]))[:2]


def reference_scene(path, scene, ports=()):
    """``scene`` with the integrator the FMU at ``path`` reduces (:func:`model_scene`)."""
    return model_scene(_model(path), scene, ports)


def model_scene(data, scene, ports=()):
    """``scene`` with the integrator of the FMU whose model.bin is ``data`` (unpacked): a time-stepped FMU's own,
    an FMU integrated exactly in time (exact, balanced) the default one for its ports
    (:func:`sphrom.fmu.kinds.frozen.default_integrator`: symplectic with ports, the scene's without)."""
    integrator = kind_of(data).integrator(data) or (PORT_INTEGRATOR if len(ports) else scene.sph.integrator)
    if integrator == scene.sph.integrator:
        return scene
    return scene.with_sph(integrator=integrator, stable=False)      # an RK4 scene's frozen FMU: symplectic


def measure_channels(path, scene, ports=(), problem=None, progress=False):
    """[ChannelCase] of the FMU at ``path`` (module docstring); ``ports`` the FMU's port positions x/L."""
    model = _model(path)                                   # read once: the integrator and the probes
    scene = model_scene(model, scene, ports)
    problem = problem or build_problem(scene)
    has_scale, _, step = fmu_features(path)
    horizon_ = horizon(scene)
    short = derive_scene(scene, {"domain": {"T": horizon_}})
    t, steps = communication_times(short, step)
    f_cases, port_cases = channel_forces(scene, problem, step)
    channels = [("f", None, f_cases)] + [(f"F_port_{j + 1}", j, port_cases) for j in range(len(ports))]
    out = []
    runs = sum(len(cases) for _, _, cases in channels)
    with progress_bar(runs, f"input channels of {scene.name}", unit="run", enabled=progress) as bar:
        for name, j, cases in channels:
            for case, force in cases.items():
                if case == "coupled":
                    out.append(_coupled(path, scene, short, problem, ports, j, t, step, has_scale))
                    bar.update(1)
                    continue
                values = np.broadcast_to(compile_expr(force, ("t", "L", "T"), "force")(t=t, L=scene.L, T=scene.T),
                                         t.shape).astype(float)
                t0 = time.perf_counter()
                if j is None:
                    unique, index = np.unique(steps, return_inverse=True)    # h < dt: a step named twice
                    run = run_sph(derive_scene(short, {"force": {"f": force}}), sample_steps=unique, progress=False,
                                  problem=problem, state=(0.0 * problem.v0, problem.rho0.copy()))
                    ref = probe_values(problem, scene.L, list(np.asarray(model.probe_x, float)), (run.v,))[0][index]
                    output = "v at the probes"
                else:
                    quiet = derive_scene(short, {"force": {"f": "0"}})
                    held = lambda s, j=j: np.eye(len(ports))[j] * values[min(int(s / step + 1e-9), t.size - 1)]
                    every = max(1, int(round(step / scene.sph.dt)))
                    run = run_sph_ports(quiet, ports, forces=held, problem=build_problem(quiet),
                                        state=(0.0 * problem.v0, problem.rho0.copy()), every=every)
                    ref = run.v_port[rows_at(t, every * scene.sph.dt, run.v_port.shape[0]), j:j + 1]
                    output = f"v_port_{j + 1}"
                sph_s = time.perf_counter() - t0
                inputs = {name: values} if j is not None else {"f": values}
                note = ""
                with FMU(path) as fmu:
                    fmu.initialize(parameters={SCALE_NAME: 0.0} if has_scale else {})
                    y = fmu.simulate(t, inputs, stop_on_error=True)
                    names = fmu.outputs
                    errors = fmu.errors()
                cols = members(names, "v_probe_j") if j is None else [names.index(output)]
                got = y[:, cols]
                if got.shape[0] < t.size:
                    err, note = float("inf"), "; ".join(errors) or "the FMU stopped"
                else:
                    err = relative_l2(got, ref, t)
                out.append(ChannelCase(channel=name, case=case, force=force, output=output, err=float(err),
                                       sph_s=sph_s, note=note))
                bar.update(1)
    return out


def _coupled(path, scene, short, problem, ports, j, t, step, has_scale):
    """The ChannelCase of port j closed by the spring-mass-damper (module docstring)."""
    m, k, c, s0 = smd_parameters(scene, problem, step)
    quiet = derive_scene(short, {"force": {"f": "0"}})
    t0 = time.perf_counter()
    every = max(1, int(round(step / scene.sph.dt)))
    run = run_sph_ports(quiet, ports, lumped=mass_spring(m, k, port=j, n_ports=len(ports), s0=s0, damping=c),
                        problem=build_problem(quiet), state=(0.0 * problem.v0, problem.rho0.copy()), every=every)
    sph_s = time.perf_counter() - t0
    ref = run.v_port[rows_at(t, every * scene.sph.dt, run.v_port.shape[0]), j:j + 1]
    output = f"v_port_{j + 1}"
    lumped, last_v = [np.array([s0, 0.0])], [0.0]
    with FMU(path) as fmu:
        names = fmu.outputs
        at = names.index(output)

        def feedback(n, tn, y):
            if n:
                lumped[0] = smd_step(lumped[0], last_v[0], step, m, k, c)
            last_v[0] = y[at]
            return {f"F_port_{j + 1}": k * lumped[0][0] + c * (lumped[0][1] - y[at])}

        fmu.initialize(parameters={SCALE_NAME: 0.0} if has_scale else {})
        y = fmu.simulate(t, {}, feedback=feedback, stop_on_error=True)
        errors = fmu.errors()
    note = ""
    if y.shape[0] < t.size:
        err, note = float("inf"), "; ".join(errors) or "the FMU stopped"
    else:
        err = relative_l2(y[:, [at]], ref, t)
    force = f"m = {m:.3g} kg, k = {k:.3g} N/m, c = {c:.3g} N s/m, s0 = {s0:.3g} m"
    return ChannelCase(channel=f"F_port_{j + 1}", case="coupled", force=force, output=output, err=float(err),
                       sph_s=sph_s, note=note)


def _model(path):
    """The FMU's model.bin, unpacked (its probes, its integrator)."""
    return unpack(zipfile.ZipFile(path).read("resources/model.bin"))
