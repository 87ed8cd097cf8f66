"""The FMU's co-simulation, in Python: the reference its outputs must equal.

:func:`cosim_reference` drives the compiled loop of the frozen model
(:func:`sphrom.rom.frozen.frozen_advance`, the same loop as
``get_model("frozen").run``) communication step by communication step,
with the FMU's rules (fmu_src/rom.c ``rom_do_step``):

* the input f is held over each communication step, or, with an input
  derivative (``rate``, fmi2SetRealInputDerivatives), taken as
  f + rate τ at each refresh of the force term, τ = j Δt the time of internal
  step j after the communication point (the shortened step: τ = n_full Δt),
  in the C order of operations: f + rate (τ0 + j h);
* the port forces F_port_j [N] likewise: held, or with their derivatives
  (``port_rates``) F_j + rate_j (τ0 + j h) at each refresh, ports in order,
  divided by the area after (fmu_src/rom_frozen.c ``refresh``); after a step
  a force with a rate reads F_j + rate_j h (the FMU's rule for f);
* a step of length h is ``n_full`` whole internal steps of dt and, when the
  remainder exceeds 1e-12 dt, one shortened step (:func:`split_step`);
* the internal step counter n runs over all internal steps, shortened ones
  included, and the frozen coefficients are refreshed when n % n_freeze == 0.

Probe outputs are summed in the C order (q ascending from 0.0), so equality
with the FMU can be checked bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

STEP_ROUNDING = 1e-9       # fmu_src/rom.h ROM_STEP_ROUNDING
SHORT_STEP_MIN = 1e-12     # ROM_SHORT_STEP_MIN
# The work of one doStep is bounded (fmu_src/rom.h): dt >= dt_floor, at most max_steps_per_call internal steps
DT_MIN = 1e-9              # ROM_DT_MIN [s]: the smallest internal step of a frozen model's resources
DT_FLOOR_RATIO = 1e-3      # ROM_DT_FLOOR_RATIO: the parameter dt is at least this x the model's dt
MAX_WORK_PER_CALL = 2e9    # ROM_MAX_WORK_PER_CALL: multiply-adds of the internal steps of one doStep
STEP_OVERHEAD = 32.0       # ROM_STEP_OVERHEAD: multiply-adds one internal step costs beyond its arithmetic


def dt_floor(model_dt):
    """The smallest internal step [s] a frozen FMU with internal step ``model_dt`` [s] accepts (rom_dt_floor)."""
    return max(DT_MIN, model_dt * DT_FLOOR_RATIO)


def refresh_matrix_work(k_v, k_rho, particles=0):
    """Multiply-adds of M's refresh (fmu_src/rom_frozen.c frozen_step_work): from the tensor, n_pairs (1 + nm), or
    from ``particles`` particles (the particle refresh), N (k_rho + kr_pad + k_v kr_pad) + nm."""
    krp = -(-k_rho // 4) * 4
    nm = -(-(k_v * krp) // 32) * 32
    if particles:
        return particles * (k_rho + krp + k_v * krp) + nm
    return k_rho * (k_rho + 1) // 2 * (1.0 + nm)


def step_work(k_v, k_rho, n_freeze, n_ports=0, damping=True, particles=0):
    """Multiply-adds of one internal step of the frozen model (rom_step_work, fmu_src/rom_frozen.c): the density
    and velocity rates over the padded blocks, the two updates, the runaway check, and 1/n_freeze of a refresh
    (from the tensor, or from ``particles`` particles where the model has the particle refresh)."""
    pad = lambda k: -(-k // 4) * 4                                      # noqa: E731
    kvp, krp = pad(k_v), pad(k_rho)
    step = krp * k_v + kvp * (k_rho + (k_v if damping else 0)) + kvp + krp + k_v + k_rho
    refresh = refresh_matrix_work(k_v, k_rho, particles) + kvp + n_ports * k_v
    return step + refresh / max(int(n_freeze), 1) + STEP_OVERHEAD


def max_steps_per_call(k_v, k_rho, n_freeze, n_ports=0, damping=True, particles=0):
    """The most internal steps one doStep of the frozen FMU takes (rom_max_steps_per_call)."""
    return math.floor(MAX_WORK_PER_CALL / step_work(k_v, k_rho, n_freeze, n_ports, damping, particles))


def split_step(h, dt):
    """(n_full, rest): whole internal steps of ``dt`` in ``h`` and the shortened remainder [s].

    h/dt is taken as a whole number when within 1e-9 max(1, h/dt) of one;
    ``rest`` is 0 when no shortened step is taken.  A ``dt`` above ``h`` gives
    (0, h): one internal step of length h (the FMU warns once), never a no-op.
    """
    ratio = h / dt
    nearest = math.floor(ratio + 0.5)
    if nearest < 1 or (ratio < 1.0 and not abs(ratio - 1.0) <= STEP_ROUNDING):
        return 0, h
    if abs(ratio - nearest) <= STEP_ROUNDING * max(1.0, ratio):
        return int(nearest), 0.0
    n_full = int(math.floor(ratio))
    rest = h - n_full * dt
    return n_full, (rest if rest > SHORT_STEP_MIN * dt else 0.0)


def probe_values(rows, a):
    """rows @ a summed in the C order: 0.0 + rows[:, 0] a_0 + rows[:, 1] a_1 + ..."""
    acc = np.zeros(rows.shape[0])
    for q in range(rows.shape[1]):
        acc = acc + rows[:, q] * a[q]
    return acc


class FrozenCosim:
    """The frozen model stepped like the FMU (see module docstring).

    Parameters
    ----------
    data : sphrom.fmu.resources.ModelData
        The FMU's model (what model.bin holds).
    n_freeze : int, optional
        Refresh period (default the packaged one).
    dt : float, optional
        Internal step [s] (default the packaged one).
    initial_state_scale : float
        a^v(0) = this x a_v0, a^rho(0) = a_rho0 (the FMU parameter; default 1, the scene's initial state,
        where the FMU's own start value is 0, at rest).
    """

    def __init__(self, data, n_freeze=None, dt=None, initial_state_scale=1.0):
        from ...rom.stepping import initial_scale
        from ...rom.frozen import loop_operators
        self.data = data
        self.n_freeze = int(data.n_freeze if n_freeze is None else n_freeze)
        self.dt = float(data.dt if dt is None else dt)
        self.method = {"euler": 0, "symplectic": 1}[data.integrator]
        self.av = initial_scale(initial_state_scale) * np.array(data.a_v0, dtype=float)    # rom.c apply_initial_state
        self.ar = np.array(data.a_rho0, dtype=float)
        self.M = np.zeros((data.k_rho, data.k_v))
        self.F = np.zeros(data.k_v)
        self.n = 0
        self.t = 0.0
        part = data.sections.get("PARTUR")
        if part is None:
            self._ops = loop_operators(data.K, data.b, data.D, data.p, self.n_freeze, T=data.T, refresh="tensor")
        else:                   # the particle refresh (sections PART*), as the FMU's core takes it
            self._ops = loop_operators(data.K, data.b, data.D, data.p, self.n_freeze, T=data.T, U_rho=part,
                                       GU_v=data.sections["PARTGUV"], inv_rho0=data.sections["PARTIR0"][0],
                                       refresh="direct")
        self._no_samples = np.zeros(0, dtype=np.int64)
        self._out = np.zeros((0, 1))
        # mechanical ports (resources sections PORTB, PORTC): F_port [N] held over a step, or going as
        # F_port + port_rates τ [N s^-1] (input derivatives), divided by area
        self.port_B = data.sections.get("PORTB")
        self.port_C = data.sections.get("PORTC")
        self.n_ports = 0 if self.port_B is None else self.port_B.shape[0]
        self.port_forces = np.zeros(self.n_ports)
        self.port_rates = np.zeros(self.n_ports)
        self.area = 1.0

    def _advance(self, count, h, f, rate=0.0, tau0=0.0):
        from ...errors import SimulationError
        from ...rom.frozen import frozen_advance
        if count <= 0:
            return
        # f at each step's time tau0 + j h after the communication point (fmu_src/rom_frozen.c run_steps_kernel)
        tau = tau0 + np.arange(count) * h
        g = np.full(count, float(f)) if rate == 0.0 else float(f) + float(rate) * tau
        status, _, bad = frozen_advance(self.method, self.av, self.ar, self.M, self.F, self.n, self.n + count, h, g,
                                        self._ops, self._no_samples, 0, self._out, self._out, self.data.bound,
                                        *self._port_arguments(tau))
        if status != 0:
            raise SimulationError(f"reference: reduced state failed (status {status}) by internal step {bad}",
                                  step=bad)
        self.n += count

    def do_step(self, h, f, rate=0.0):
        """One communication step of length ``h`` [s] with input ``f`` [m s^-2] held, or going as
        f + ``rate`` τ over the step (``rate`` df/dt [m s^-3], an input derivative)."""
        n_full, rest = split_step(h, self.dt)
        self._advance(n_full, self.dt, f, rate, 0.0)
        if rest > 0.0:
            self._advance(1, rest, f, rate, n_full * self.dt)
        self.t = self.t + h
        if self.n_ports:                                   # a port force with a rate goes on linearly (rom_do_step)
            rates = np.asarray(self.port_rates, float)
            self.port_forces = np.where(rates != 0.0, self.port_forces + rates * h, self.port_forces)

    def outputs(self):
        """(v at the probes [m s^-1], rho at the probes [kg m^-3])."""
        return probe_values(self.data.Pv, self.av), probe_values(self.data.Prho, self.ar)

    def _port_arguments(self, tau):
        """(Bp, the port inputs F(τ)/area per step, (len(τ), P)) for frozen_advance, τ [s] the steps' times after
        the communication point; () without ports.  F(τ) = F + rate τ where the rate is nonzero, else F (held), as
        fmu_src/rom_frozen.c refresh computes it."""
        if not self.n_ports:
            return ()
        forces = np.asarray(self.port_forces, float)[None, :]
        rates = np.asarray(self.port_rates, float)[None, :]
        tau = np.asarray(tau, float)[:, None]
        value = np.where(rates != 0.0, forces + rates * tau, forces)
        return self.port_B, np.ascontiguousarray(value / self.area)

    def port_velocities(self):
        """v_port_j [m s^-1] (as rom_v_port: 0.0 + C[j][0] a_0 + ...); empty without ports."""
        return probe_values(self.port_C, self.av) if self.n_ports else np.zeros(0)


def cosim_reference(data, steps, inputs, n_freeze=None, dt=None, rates=None, initial_state_scale=1.0):
    """Outputs of the FMU's co-simulation computed in Python.

    Parameters
    ----------
    data : ModelData
    steps : sequence of float
        Communication step sizes [s].
    inputs : sequence of float
        f held over each step [m s^-2] (same length as ``steps``), its value at the step's start.
    rates : sequence of float, optional
        df/dt over each step [m s^-3] (input derivatives; default none: f held).
    n_freeze, dt, initial_state_scale
        The FMU's parameters (:class:`FrozenCosim`).

    Returns
    -------
    t : ndarray (M+1,)
        Communication points [s], starting at 0.
    v, rho : ndarray (M+1, P)
        Probe outputs at the communication points.
    """
    sim = FrozenCosim(data, n_freeze=n_freeze, dt=dt, initial_state_scale=initial_state_scale)
    t, v, rho = [0.0], [], []
    v0, r0 = sim.outputs()
    v.append(v0)
    rho.append(r0)
    rates = np.zeros(len(steps)) if rates is None else rates
    for h, f, rate in zip(steps, inputs, rates):
        sim.do_step(h, f, rate)
        t.append(sim.t)
        vi, ri = sim.outputs()
        v.append(vi)
        rho.append(ri)
    return np.array(t), np.array(v), np.array(rho)


def linear_output_rates(data, z, f=0.0):
    """First time derivatives of the probe outputs of a linear model (an ExactData) in state ``z`` (k,) with the
    input ``f`` [m s^-2] now, as fmu_src/rom_exact.c gives them (fmi2GetRealOutputDerivatives).

    dz/dt = A z + B f; dv_j/dt = Pv[j] . (dz/dt)_a; ρ_j = Σ_m w_m ρ0_m / J_m with J_m = 1 + Pe[j][m] . b, so
    dρ_j/dt = -Σ_m w_m ρ0_m (Pe[j][m] . (db/dt)) / J_m².  Returns (dv/dt [m s^-2], dρ/dt [kg m^-3 s^-1]).
    """
    from ...rom.exact_linear import state_rate
    z = np.asarray(z, float)
    zdot = state_rate(data.A, data.B, z, f)
    kv = data.k_v
    dv = data.Pv @ zdot[:kv]
    J = 1.0 + np.einsum("psk,k->ps", data.Pe, z[kv:])
    dJ = np.einsum("psk,k->ps", data.Pe, zdot[kv:])
    drho = -np.sum(data.pw * data.prho0 * dJ / (J * J), axis=1)
    return dv, drho
