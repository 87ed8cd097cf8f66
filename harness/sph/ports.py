"""Mechanical ports of the full SPH model: point forces in, power-conjugate velocities out.

A port j sits at x_j (given in units of L).  Its force F_j(t) [N] is spread
over the particles by the SPH kernel (eq. 2.6) as a force per unit length
F_j W(x - x_j, h) [N m^-1]; divided by the mass per unit length ρ0 A (A the
cross-section ``area`` [m^2]) it is the acceleration of particle i,

    a_i = Σ_j F_j W(x_i - x_j, h) / (ρ0_i A),

added to eq. 2.11 beside the scene's own force profile(x) f(t), which stays.
The velocity of port j is the kernel-weighted velocity

    v_port_j = Σ_i W(x_i - x_j, h) v_i Δx,

the velocity power-conjugate to F_j: the power the port forces put in,
Σ_i (ρ0_i A Δx) v_i a_i, is Σ_j F_j v_port_j.  Distances are periodic
(minimum image), as the neighbour lists of :mod:`.operator`.

Total momentum.  With m_i = ρ0_i A Δx, d/dt Σ m_i v_i = Σ_j F_j S_j + (the
scene's own force and damping), S_j = Σ_i W(x_i - x_j, h) Δx (1 to within the
kernel's discrete partition of unity; the SPH pressure term conserves momentum
on the periodic lattice).

The ports are data of a run (a list of positions given by the caller), not a
change of the scene.  :func:`run_sph_ports` runs the full SPH with port forces
given as functions of time, or coupled to a lumped component (a small ODE
that takes the port velocities and returns the port forces), integrated
together with the SPH by the scene's integrator: the reference of a coupled
co-simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import FieldError, SimulationError
from . import loops
from .kernel import cubic_spline

# fmu_src/rom.h ROM_MAX_PORTS: F_port_1..4 [VR 3000..3003], v_port_1..4 [VR 4000..4003].  Each port adds
# 2 x PORT_KRYLOV_LEVELS + 1 reduced coordinates (sphrom.rom.operators) and its directions at every frequency
# (sphrom.rom.inputs, as many as its tolerance keeps), and the frozen model's refresh tensor grows as k^4
# (docs/fmu/ports.md, "Not done yet": the frozen port FMU's cost).
MAX_PORTS = 4


def parse_ports(text):
    """``0.25,0.75`` (or a sequence) -> a list of positions x/L; FieldError naming the field ``ports``.

    Each position in [0, 1) (periodic: 1 is 0), at most :data:`MAX_PORTS`, no two equal.
    """
    if isinstance(text, str):
        parts = [p.strip() for p in text.split(",")]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise FieldError("ports", f"{text!r} is not a comma-separated list of numbers (allowed: 1 to "
                                      f"{MAX_PORTS} positions x/L in [0, 1))") from None
    else:
        values = [float(p) for p in text]
    if not 1 <= len(values) <= MAX_PORTS:
        raise FieldError("ports", f"{len(values)} ports (allowed: 1 to {MAX_PORTS} positions x/L in [0, 1))")
    for v in values:
        if not (math.isfinite(v) and 0.0 <= v < 1.0):
            raise FieldError("ports", f"{v!r} is out of range (allowed: positions x/L in [0, 1))")
    if len(set(values)) != len(values):
        raise FieldError("ports", f"{', '.join(f'{v:g}' for v in values)}: two ports at the same position "
                                  "(allowed: distinct positions)")
    return values


def check_area(area):
    """The cross-section A [m^2] as a float; FieldError naming ``area`` unless finite and > 0."""
    a = float(area)
    if not (math.isfinite(a) and a > 0):
        raise FieldError("area", f"{area!r} is out of range (allowed: a finite number > 0, m^2)")
    return a


def port_kernel(problem, ports):
    """W(x_i - x_j, h) [m^-1] for port j at x_j = ports[j] L, shape (P, N); periodic (minimum image)."""
    L = problem.scene.L
    xp = np.asarray(ports, float) * L
    r = problem.x[None, :] - xp[:, None]
    r = r - L * np.round(r / L)                         # minimum image
    return cubic_spline(r, problem.neighbours.h)


def port_accelerations(problem, ports, area=1.0):
    """W(x_i - x_j, h) / (ρ0_i A) [m^-1 kg^-1 ... : m s^-2 per N], shape (P, N): particle accelerations per newton."""
    return port_kernel(problem, ports) / (problem.rho0[None, :] * check_area(area))


def port_velocity_rows(problem, ports):
    """Rows R with v_port = R v: W(x_i - x_j, h) Δx [-], shape (P, N)."""
    return port_kernel(problem, ports) * problem.neighbours.dx


def momentum_weights(problem, ports):
    """S_j = Σ_i W(x_i - x_j, h) Δx [-]: d/dt Σ m_i v_i gains Σ_j F_j S_j from the ports (module docstring)."""
    return port_velocity_rows(problem, ports).sum(axis=1)


@dataclass
class Lumped:
    """A lumped component coupled to the ports: y' = rates(y, v_port) with port forces forces(y, v_port) [N].

    Attributes
    ----------
    y0 : ndarray
        Initial state.
    rates : callable
        ``rates(y, v_port) -> dy/dt``.
    forces : callable
        ``forces(y, v_port) -> F`` (P,) [N], the forces the component applies to the ports (a damper's depends
        on the port velocities).
    """

    y0: np.ndarray
    rates: object
    forces: object


def mass_spring(mass, stiffness, port=0, n_ports=1, s0=0.0, damping=0.0):
    """A mass on a spring (and a damper ``damping`` [N s m^-1] beside it) whose other end is port ``port``:
    y = (s, w), s the elongation [m] (mass position minus port displacement), w the mass velocity [m s^-1];
    s' = w - v_port, w' = -(k s + c (w - v_port)) / m, and the pair pulls the port with F = k s + c (w - v_port)
    [N].  Starts with elongation ``s0`` [m] and the mass at rest."""
    def rates(y, v_port):
        rel = y[1] - v_port[port]
        return np.array([rel, -(stiffness * y[0] + damping * rel) / mass])

    def forces(y, v_port):
        out = np.zeros(n_ports)
        out[port] = stiffness * y[0] + damping * (y[1] - v_port[port])
        return out

    return Lumped(y0=np.array([float(s0), 0.0]), rates=rates, forces=forces)


@dataclass
class PortRun:
    """Samples of a full SPH run with ports.

    t (M,) [s], v, rho (M, N), v_port (M, P) [m s^-1], F_port (M, P) [N] (the forces at the sample times),
    y (M, n_y) the lumped component's state (n_y = 0 without one), momentum (M,) Σ m_i v_i [kg m s^-1].
    """

    t: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    v_port: np.ndarray
    F_port: np.ndarray
    y: np.ndarray
    momentum: np.ndarray


def run_sph_ports(scene, ports, *, forces=None, lumped=None, area=1.0, t_end=None, every=1, problem=None,
                  state=None, layout="auto"):
    """The full SPH of ``scene`` with port forces, from t = 0 to ``t_end`` (default the scene's T).

    Parameters
    ----------
    scene : Scene
    ports : sequence of float
        Port positions x/L.
    forces : callable, optional
        ``forces(t) -> F`` (P,) [N] at time t [s], applied as given;
    lumped : Lumped, optional
        A component that sets port forces from its state and is integrated with the SPH (same integrator,
        same steps), added to ``forces``.  Neither: no port force.
    area : float
        Cross-section A [m^2].
    every : int
        Store every ``every`` steps (and the last).
    state : (v, rho), optional
        Initial state instead of (v0, ρ0).
    layout : {"auto", "general"}
        The operator's layout in the compiled rates (:meth:`.solver.SPHProblem.loop_args`); the same bits.

    Notes
    -----
    A Python loop over the steps around the compiled right-hand side of :mod:`.loops` (eqs. 2.10-2.11 with the
    scene's force), plus the port accelerations; the scene's integrator (explicit Euler, symplectic Euler: ρ
    then v and the lumped state, RK4).  The scene's force is evaluated at the stage times as in
    :func:`.solver.run_sph`.
    """
    from .solver import METHODS, build_problem, force_values, step_count

    ports = parse_ports(ports)
    problem = problem or build_problem(scene)
    acc = port_accelerations(problem, ports, area)          # (P, N)
    rows = port_velocity_rows(problem, ports)              # (P, N)
    mass = problem.rho0 * check_area(area) * problem.neighbours.dx
    dt = scene.sph.dt
    method = METHODS[scene.sph.integrator]
    T = scene.T if t_end is None else float(t_end)
    n_steps = step_count(T, dt)
    args, layout_bit = problem.loop_args(layout)
    v = problem.v0.copy() if state is None else np.array(state[0], float)
    rho = problem.rho0.copy() if state is None else np.array(state[1], float)
    y = np.zeros(0) if lumped is None else np.array(lumped.y0, float)
    n = problem.n
    dv, drho, p = np.empty(n), np.empty(n), np.empty(n)
    g_all = force_values(scene, problem, 0, n_steps, dt, method)
    flags = problem.flags(bool(np.any(g_all != 0))) | layout_bit

    def port_forces(t, y, v):
        out = np.zeros(len(ports))
        if forces is not None:
            out = out + np.asarray(forces(t), float).reshape(len(ports))
        if lumped is not None:
            out = out + np.asarray(lumped.forces(y, rows @ v), float)
        return out

    def rates(t, g, v, rho, y):
        """(dv, drho, dy) of the coupled system at one stage."""
        loops.rates(v, rho, g, *args, flags, dv, drho, p)
        F = port_forces(t, y, v)
        a = dv + F @ acc
        dy = lumped.rates(y, rows @ v) if lumped is not None else np.zeros(0)
        return a, drho.copy(), np.asarray(dy, float)

    samples = np.union1d(np.arange(0, n_steps + 1, max(1, int(every))), [n_steps])
    out_t, out_v, out_rho, out_vp, out_F, out_y = [], [], [], [], [], []

    def store(step):
        t = step * dt
        out_t.append(t)
        out_v.append(v.copy())
        out_rho.append(rho.copy())
        out_vp.append(rows @ v)
        out_F.append(port_forces(t, y, v))
        out_y.append(y.copy())

    ptr = 0
    for step in range(n_steps):
        if ptr < samples.size and samples[ptr] == step:
            store(step)
            ptr += 1
        t = step * dt
        g = g_all[step]
        if method == 0:                                      # explicit Euler: every rate from the old state
            a, r, dy = rates(t, g[0], v, rho, y)
            v, rho, y = v + dt * a, rho + dt * r, y + dt * dy
        elif method == 1:                                    # symplectic Euler: ρ first, then v (and y)
            _, r, _ = rates(t, g[0], v, rho, y)
            rho = rho + dt * r
            a, _, dy = rates(t, g[0], v, rho, y)
            v, y = v + dt * a, y + dt * dy
        else:                                                # classical RK4
            k1 = rates(t, g[0], v, rho, y)
            k2 = rates(t + 0.5 * dt, g[1], *(s + 0.5 * dt * k for s, k in zip((v, rho, y), k1)))
            k3 = rates(t + 0.5 * dt, g[1], *(s + 0.5 * dt * k for s, k in zip((v, rho, y), k2)))
            k4 = rates(t + dt, g[2], *(s + dt * k for s, k in zip((v, rho, y), k3)))
            v, rho, y = (s + dt / 6.0 * (a + 2.0 * b + 2.0 * c + d)
                         for s, a, b, c, d in zip((v, rho, y), k1, k2, k3, k4))
        if not (np.all(np.isfinite(v)) and np.all(rho > 0) and np.all(np.isfinite(y))):
            raise SimulationError(f"SPH state with ports became non-finite or non-positive density by step "
                                  f"{step + 1} (t = {(step + 1) * dt:.6g} s)", step=step + 1, time=(step + 1) * dt)
    if ptr < samples.size:
        store(n_steps)
    v_s = np.array(out_v)
    return PortRun(t=np.array(out_t), v=v_s, rho=np.array(out_rho), v_port=np.array(out_vp), F_port=np.array(out_F),
                   y=np.array(out_y), momentum=v_s @ mass)


class PortStepper:
    """The full SPH stepped as an FMU with ports is (a master loop's bar, :mod:`sphrom.fmu.run.master`): each
    :meth:`step` advances over a communication step h with the port forces held, by whole internal steps of the
    scene's dt (h a multiple of it) with ``integrator`` (default symplectic Euler: explicit Euler grows an undamped
    bar's modes that a kernel-wide port force rings); the scene's f as in :func:`run_sph_ports`.

    Parameters
    ----------
    scene : Scene
    ports : sequence of float
        Port positions x/L.
    integrator : {"euler", "symplectic"}
    initial_state_scale : float
        v(0) = this x the scene's v0 (ρ at ρ0): 0 at rest, 1 the scene's initial state.
    area : float
        Cross-section A [m^2].
    """

    def __init__(self, scene, ports, *, integrator="symplectic", initial_state_scale=1.0, area=1.0, problem=None):
        from .solver import METHODS, build_problem
        if integrator not in ("euler", "symplectic"):
            raise FieldError("integrator", f"{integrator!r} (allowed: euler, symplectic)")
        self.scene = scene
        self.ports = parse_ports(ports)
        self.problem = problem or build_problem(scene)
        self.area = check_area(area)
        self.acc = port_accelerations(self.problem, self.ports, area)
        self.rows = port_velocity_rows(self.problem, self.ports)
        self.method = METHODS[integrator]
        self.args, bit = self.problem.loop_args("auto")
        self.flags = self.problem.flags(True) | bit
        self.v = float(initial_state_scale) * self.problem.v0.copy()
        self.rho = self.problem.rho0.copy()
        n = self.problem.n
        self._dv, self._drho, self._p = np.empty(n), np.empty(n), np.empty(n)
        self.t = 0.0
        self.n = 0

    def port_velocities(self):
        """v_port_j now [m s^-1]."""
        return self.rows @ self.v

    def energy(self):
        """½ Σ_i (ρ0_i v_i² + c_i e_i²) Δx A [J], e = ρ0/ρ - 1: the energy of eqs. 2.10-2.11 written in J (the
        linear SPH's, :mod:`sphrom.rom.lti`), which the SPH's own dynamics conserves without damping to first order."""
        p = self.problem
        e = p.rho0 / self.rho - 1.0
        return 0.5 * float(np.sum(p.rho0 * self.v ** 2 + p.c * e ** 2)) * p.neighbours.dx * self.area

    def step(self, h, forces):
        """Advance over h [s] (a whole number of the scene's dt) with the port forces ``forces`` [N] held."""
        dt = self.scene.sph.dt
        count = int(round(h / dt))
        if count < 1 or abs(count * dt - h) > 1e-9 * h:
            raise FieldError("h", f"{h!r} s is not a whole number of the scene's dt = {dt!r} s")
        a_ports = np.asarray(forces, float) @ self.acc
        for _ in range(count):
            g = float(self.scene.force(self.n * dt))
            loops.rates(self.v, self.rho, g, *self.args, self.flags, self._dv, self._drho, self._p)
            if self.method == 1:                              # symplectic Euler: ρ first, then v
                self.rho = self.rho + dt * self._drho
                loops.rates(self.v, self.rho, g, *self.args, self.flags, self._dv, self._drho, self._p)
                self.v = self.v + dt * (self._dv + a_ports)
            else:
                self.v, self.rho = self.v + dt * (self._dv + a_ports), self.rho + dt * self._drho
            self.n += 1
        self.t += h
        if not (np.all(np.isfinite(self.v)) and np.all(self.rho > 0)):
            raise SimulationError(f"SPH state with ports became non-finite or non-positive density by t = "
                                  f"{self.t:.6g} s", step=self.n, time=self.t)
