"""A system simulator's master loop around a bar with ports: masses on springs tied to the ports, exchanged at a
fixed communication step (docs/fmu/coupling.md, "In a master loop").

Three ways to tie a component to a port at a communication step h:

* **Jacobi**: at t_n every subsystem reads the others' outputs at t_n and all advance over h at once: the bar with
  the spring forces k s_j(t_n) held, each mass-spring with the port velocity v_port_j(t_n) held (advanced exactly);
* **Gauss-Seidel**: the bar first, with the spring forces at t_n held, then each mass-spring with the bar's new
  port velocity v_port_j(t_{n+1}) held;
* **wave** (transmission line, TLM): the spring is the line between the port and the mass, of impedance
  Z = k h and delay h (its compliance h / Z is the spring's 1/k).  Each side takes an incident wave a held over
  the step, holds its force at F = 2 a - Z v̄ (v̄ its mean velocity over the step, solved exactly) and sends back
  b = a - F, which arrives at the other side as its incident wave one step later.  The power over a step is
  F v̄ = (a² - b²) / Z, so the energy of the bar, the masses and the waves in the lines (h / Z per wave) never grows
  at any h: passive where the explicit loops are not.  The FMU side is the FMU's wave form
  (``port_impedance`` = Z, inputs ``a_port_j``, outputs ``b_port_j``); the mass side is here.

The bar is any of :class:`FMUBar` (a packaged FMU through :mod:`.driver`), :class:`SPHBar` (the full SPH with the
port forces held over each step, :func:`sphrom.sph.ports.PortStepper`) and :class:`LinearBar` (the full linear SPH
exact in time).  :func:`monolithic` integrates the bar and the masses on their springs as one linear system, exactly
in time: the reference the loops are measured against.  Signs as :mod:`sphrom.sph.ports`: F_port_j is the force on
the bar along +x, the spring's elongation s = (mass position - port displacement), and the spring pulls the port
with k s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

MASTERS = ("jacobi", "gauss_seidel", "wave")


@dataclass
class MassSpring:
    """A mass ``mass`` [kg] on a spring ``stiffness`` [N m^-1] tied to a port: elongation s [m], velocity w [m s^-1]
    (starts with s = ``s0``, at rest)."""

    mass: float
    stiffness: float
    s0: float = 0.0
    s: float = field(init=False)
    w: float = field(init=False, default=0.0)

    def __post_init__(self):
        self.s = float(self.s0)

    @property
    def force(self):
        """The force on the port [N]: k s."""
        return self.stiffness * self.s

    def step(self, h, v_port):
        """Advance exactly over h [s] with the port velocity held at ``v_port`` [m s^-1] (s'' = -ω² s, w = s' +
        v_port)."""
        omega = math.sqrt(self.stiffness / self.mass)
        c, sn = math.cos(omega * h), math.sin(omega * h)
        rel = self.w - v_port
        self.s, self.w = self.s * c + rel / omega * sn, -self.s * omega * sn + rel * c + v_port

    def energy(self):
        """½ m w² + ½ k s² [J]."""
        return 0.5 * self.mass * self.w ** 2 + 0.5 * self.stiffness * self.s ** 2


@dataclass
class WaveMass:
    """The mass of :class:`MassSpring` on the line side of the wave form: a force F held over a step, F = 2 a - Z w̄
    with w̄ = w + F h / (2 m) its exact mean velocity, and b = a - F sent back."""

    mass: float
    w: float = 0.0

    def step(self, h, wave, impedance):
        """Advance over h [s] with the incident wave ``wave`` [N]; returns the reflected wave b [N]."""
        F = (2.0 * wave - impedance * self.w) / (1.0 + impedance * h / (2.0 * self.mass))
        self.w += F * h / self.mass
        return wave - F

    def energy(self):
        return 0.5 * self.mass * self.w ** 2


def line_waves(stiffness, s0):
    """(wave toward the bar, wave toward the mass) [N] of a line stretched as a spring by s0 at rest: the bar gets
    k s0, the mass -k s0 (a = F / 2 at each end, the waves' energy h/Z (a_1² + a_2²) = ½ k s0² with Z = k h)."""
    return 0.5 * stiffness * s0, -0.5 * stiffness * s0


# ---------------------------------------------------------------------------------------------------------------
# the bars
# ---------------------------------------------------------------------------------------------------------------

class FMUBar:
    """A packaged FMU with ports as the bar (FMI 2 or 3 through :class:`.driver.FMU`): ``impedance`` > 0 its wave
    form.  Starts at ``initial_state_scale`` with the scene's f zero."""

    def __init__(self, path, initial_state_scale=1.0, impedance=0.0, area=1.0):
        from .driver import FMU
        self.fmu = FMU(path)
        params = {"initial_state_scale": initial_state_scale}
        if impedance:
            params["port_impedance"] = impedance
        if area != 1.0:
            params["area"] = area
        self.fmu.initialize(parameters=params)
        self.n_ports = sum(1 for n in self.fmu.outputs if n.startswith("v_port_") and not n.endswith("_bound"))
        self.v_vrs = [self.fmu.vr[f"v_port_{j + 1}"] for j in range(self.n_ports)]
        self.f_vrs = [self.fmu.vr[f"F_port_{j + 1}"] for j in range(self.n_ports)]
        self.impedance = impedance
        if impedance:
            self.a_vrs = [self.fmu.vr[f"a_port_{j + 1}"] for j in range(self.n_ports)]
            self.b_vrs = [self.fmu.vr[f"b_port_{j + 1}"] for j in range(self.n_ports)]
        self.t = 0.0

    def port_velocities(self):
        return self.fmu.get_real(self.v_vrs)

    def step(self, h, forces=None, waves=None):
        """One communication step with the port forces [N] held (or, in the wave form, the incident waves);
        returns the reflected waves in the wave form, else None."""
        if self.impedance:
            self.fmu.set_real(self.a_vrs, list(waves))
        else:
            self.fmu.set_real(self.f_vrs, list(forces))
        self.fmu.do_step(self.t, h)
        self.t += h
        return self.fmu.get_real(self.b_vrs) if self.impedance else None

    def close(self):
        self.fmu.__exit__(None, None, None)


class CoreBar:
    """An FMU's model through its C core directly (:class:`.core.CoreModel`, the FMU's own code without the FMI
    layer), as the bar: the force or the wave form, and the port channel's energy (:meth:`energy`: the bar's whole
    energy when it starts at rest with f = 0, its own part then never moving)."""

    def __init__(self, blob, initial_state_scale=1.0, impedance=0.0):
        from .core import built_core
        self.model = built_core().load(blob)
        self.model.set_initial_state_scale(initial_state_scale)
        if impedance:
            self.model.set_port_impedance(impedance)
        self.impedance = impedance
        self.n_ports = self.model.n_ports
        self.t = 0.0

    def port_velocities(self):
        return self.model.port_velocities()

    def step(self, h, forces=None, waves=None):
        if self.impedance:
            self.model.set_port_waves(waves)
        else:
            self.model.set_port_forces(forces)
        self.model.do_step(self.t, h)
        self.t += h
        return self.model.reflected_waves() if self.impedance else None

    def energy(self):
        return self.model.channel_energy()

    def close(self):
        self.model.close()


class SPHBar:
    """The full SPH as the bar, the port forces held over each communication step (force form only)."""

    def __init__(self, scene, ports, initial_state_scale=1.0, integrator="symplectic", problem=None):
        from ...sph.ports import PortStepper
        self.stepper = PortStepper(scene, ports, integrator=integrator, problem=problem,
                                   initial_state_scale=initial_state_scale)
        self.n_ports = len(ports)

    def port_velocities(self):
        return self.stepper.port_velocities()

    def step(self, h, forces=None, waves=None):
        if waves is not None:
            raise ValueError("waves: the full SPH bar takes port forces only")
        self.stepper.step(h, forces)
        return None

    def energy(self):
        return self.stepper.energy()

    def close(self):
        pass


class LinearBar:
    """The full linear SPH (energy coordinates, 2N states) exact in time as the bar, port forces held."""

    def __init__(self, problem, ports, initial_state_scale=1.0):
        from ...rom.lti import full_linear_system
        from ...sph.ports import port_kernel, port_velocity_rows
        lti = full_linear_system(problem, [0.5])
        n = problem.n
        self.A = lti.A.toarray()
        self.B = np.column_stack([np.concatenate([w / lti.w_v, np.zeros(n)]) for w in port_kernel(problem, ports)])
        self.C = np.hstack([port_velocity_rows(problem, ports) / lti.w_v[None, :], np.zeros((len(ports), n))])
        self.x = initial_state_scale * lti.x0
        self.n_ports = len(ports)
        self.dx = float(problem.neighbours.dx)
        self._maps = {}

    def port_velocities(self):
        return self.C @ self.x

    def step(self, h, forces=None, waves=None):
        from ...rom.exact_linear import propagators
        if waves is not None:
            raise ValueError("waves: the linear bar takes port forces only")
        if h not in self._maps:
            self._maps[h] = propagators(self.A, self.B, h)[:2]
        phi, g0 = self._maps[h]
        self.x = phi @ self.x + g0 @ np.asarray(forces, float)
        return None

    def energy(self, area=1.0):
        return 0.5 * float(self.x @ self.x) * self.dx * area

    def close(self):
        pass


# ---------------------------------------------------------------------------------------------------------------
# the loops
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class LoopRun:
    """Samples of a master loop at the communication points: t (M+1,) [s], v_port (M+1, P) [m s^-1], the springs'
    elongations s (M+1, P) [m] (the wave form: the force at the mass over k), the masses' velocities w (M+1, P)."""

    t: np.ndarray
    v_port: np.ndarray
    s: np.ndarray
    w: np.ndarray
    energy: np.ndarray | None = None          # the components' energy (and the lines') [J]


def run_loop(bar, components, h, n_steps, master="jacobi", energy=None):
    """The master loop ``master`` (:data:`MASTERS`) of ``bar`` and one :class:`MassSpring` per port over
    ``n_steps`` steps of h [s]: a :class:`LoopRun`.  The wave form's line impedance is Z = k h of each spring
    (``bar`` an :class:`FMUBar` with that ``impedance``).  ``energy()``, when given, is added to the components' (the
    bar's energy, for the record)."""
    if master not in MASTERS:
        raise ValueError(f"master: {master!r} (allowed: {', '.join(MASTERS)})")
    P = bar.n_ports
    t = np.arange(n_steps + 1) * h
    v, s, w, e = [bar.port_velocities()], [[c.s for c in components]], [[c.w for c in components]], []
    if master == "wave":
        masses = [WaveMass(c.mass, c.w) for c in components]
        Z = [c.stiffness * h for c in components]
        to_bar = np.array([line_waves(c.stiffness, c.s)[0] for c in components])
        to_mass = np.array([line_waves(c.stiffness, c.s)[1] for c in components])

        def wave_energy():
            line = sum(h / Z[j] * (to_bar[j] ** 2 + to_mass[j] ** 2) for j in range(P))
            return sum(m.energy() for m in masses) + line + (energy() if energy else 0.0)
        e.append(wave_energy())
    else:
        e.append(sum(c.energy() for c in components) + (energy() if energy else 0.0))
    for _ in range(n_steps):
        if master == "wave":
            b_bar = bar.step(h, waves=to_bar)
            b_mass = np.array([m.step(h, to_mass[j], Z[j]) for j, m in enumerate(masses)])
            to_bar, to_mass = b_mass, np.asarray(b_bar, float)
            v.append(bar.port_velocities())
            s.append([(to_bar[j] - to_mass[j]) / components[j].stiffness for j in range(P)])
            w.append([m.w for m in masses])
            e.append(wave_energy())
            continue
        F = np.array([c.force for c in components])
        v0 = bar.port_velocities()
        bar.step(h, forces=F)
        v1 = bar.port_velocities()
        held = v0 if master == "jacobi" else v1
        for j, c in enumerate(components):
            c.step(h, float(held[j]))
        v.append(v1)
        s.append([c.s for c in components])
        w.append([c.w for c in components])
        e.append(sum(c.energy() for c in components) + (energy() if energy else 0.0))
    return LoopRun(t=t, v_port=np.array(v), s=np.array(s), w=np.array(w), energy=np.array(e))


def monolithic(problem, ports, components, h, n_steps, initial_state_scale=1.0):
    """The bar (the full linear SPH) and the masses on their springs as one linear system, integrated exactly in
    time (its matrix exponential over h): a :class:`LoopRun` at the communication points, with the total energy."""
    from ...rom.lti import full_linear_system
    from ...sph.ports import port_kernel, port_velocity_rows
    import scipy.linalg as sla
    lti = full_linear_system(problem, [0.5])
    n, P = problem.n, len(ports)
    B = np.column_stack([np.concatenate([w / lti.w_v, np.zeros(n)]) for w in port_kernel(problem, ports)])
    C = np.hstack([port_velocity_rows(problem, ports) / lti.w_v[None, :], np.zeros((P, n))])
    k = np.array([c.stiffness for c in components])
    m = np.array([c.mass for c in components])
    M = np.zeros((2 * n + 2 * P, 2 * n + 2 * P))
    M[:2 * n, :2 * n] = lti.A.toarray()
    M[:2 * n, 2 * n:2 * n + P] = B * k[None, :]                 # the springs pull the ports with k s
    M[2 * n:2 * n + P, :2 * n] = -C                              # s' = w - v_port
    M[2 * n:2 * n + P, 2 * n + P:] = np.eye(P)
    M[2 * n + P:, 2 * n:2 * n + P] = -np.diag(k / m)            # w' = -k s / m
    phi = sla.expm(M * h)
    y = np.concatenate([initial_state_scale * lti.x0, [c.s for c in components], [c.w for c in components]])
    dx = float(problem.neighbours.dx)
    out_v, out_s, out_w, out_e = [], [], [], []
    for i in range(n_steps + 1):
        if i:
            y = phi @ y
        out_v.append(C @ y[:2 * n])
        out_s.append(y[2 * n:2 * n + P].copy())
        out_w.append(y[2 * n + P:].copy())
        out_e.append(0.5 * float(y[:2 * n] @ y[:2 * n]) * dx + float(np.sum(0.5 * m * y[2 * n + P:] ** 2
                                                                          + 0.5 * k * y[2 * n:2 * n + P] ** 2)))
    return LoopRun(t=np.arange(n_steps + 1) * h, v_port=np.array(out_v), s=np.array(out_s), w=np.array(out_w),
                   energy=np.array(out_e))
