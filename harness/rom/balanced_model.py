"""The balanced reduced model (:mod:`sphrom.rom.balanced`) as an entry of the registry.

It needs no POD basis: ``build`` takes the full linear SPH of the problem
(:func:`sphrom.rom.lti.full_linear_system`, probes at
:data:`sphrom.rom.lti.DEFAULT_PROBES`), balances it and keeps the order r
(the mode-count argument ``k_v``, i.e. ``sphrom rom --modes R``, or the
smallest r meeting ``order_tolerance``); the ``basis`` argument is ignored.
Balanced truncation on damped scenes (d > 0 everywhere), the
structure-preserving Galerkin projection on the Gramian trial space otherwise
(:func:`sphrom.rom.balanced.balanced_reduce`, method ``auto``).

The state x_r (r numbers) does not split into a velocity and a second block:
every balanced coordinate mixes v and e, so its operators name one block of
z, ``state`` (:mod:`sphrom.rom.protocol`), and the run's :class:`ReducedResult`
holds it as ``z`` (M, r).  The fields are the reconstruction through the trial
basis, x ≈ V x_r in energy coordinates, v = (V x_r)_v / √ρ0, e = (V x_r)_e / √c,
ρ = ρ0 / (1 + e).  BT
balances the probe outputs, not the fields, so the fields away from the
probes are only as good as V's span; the model's own outputs are the probe
values ``y = Cr x_r`` (``ReducedResult.y``, the operators' ``outputs``), equal to the reconstruction
interpolated at the probes to round-off.  Time: exact, by the matrix
exponential of :mod:`sphrom.rom.exact_linear` (any communication step, input
held or linear over a step); undamped, the free response is evaluated from
the real Schur form of the skew Ar at each sample time.

As an FMU (``sphrom fmu --model balanced``) it is resource kind 2, the exact
model's C code with these matrices (:func:`sphrom.fmu.resources.balanced_data`:
probe rows over the whole state, k_v = r, k_e = 0), with its certified error
bounds as calculated parameters (the operators' ``error_bounds``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.integrate import simpson

from ..sph.ports import port_kernel, port_velocity_rows
from .balanced import BalancedModel, Balancing, balancing, error_bounds, order_from_tolerance
from .balanced import DEFAULT_TOLERANCE, truncate as truncate_balanced
from .exact_linear import INTEGRATORS, advance_linear
from .lti import DEFAULT_PROBES, LTI, full_linear_system, input_norm, sample_outputs
from .model import LinearOptions, ReducedModel
from .probes import probe_rows
from .protocol import Operators
from .result import ReducedResult
from .stepping import sample_grid

NAME = "balanced"
METHOD_TITLES = {"bt": "square-root balanced truncation",
                 "galerkin": "structure-preserving Galerkin projection on the shifted-Gramian trial space",
                 "bt_shifted": "balanced truncation of the shifted system"}


@dataclass
class BalancedOperators(Operators):
    """A balanced reduced model ready to run (module docstring; the protocol of :mod:`sphrom.rom.protocol`:
    one block ``state``, x_r).

    Attributes
    ----------
    reduced : BalancedModel
        Ar, Br, Cr, V, W, the method and the Hankel singular values.
    lti : LTI
        The full linear SPH it reduces (for the bounds and the reconstruction).
    bal : Balancing
        The Gramian factors and their SVD (``truncate`` re-cuts them).
    A : ndarray (r, r)
        Ar [s^-1].
    B : ndarray (r,)
        The force input column Br[:, 0] (per m s^-2).
    z0 : ndarray (r,)
        The reduced initial state Br[:, 1] = Wᵀ x0.
    skew : bool
        Ar exactly skew (undamped, Galerkin): the free response uses the Schur form.
    schur_Q, schur_T : ndarray or None
        Real Schur form of Ar (skew case).
    rho0 : ndarray (N,)
        ρ0 at the particles [kg m^-3] (the density reconstruction).
    timings : dict
        Offline times [s]: ``lyapunov``, ``svd``, ``projection``, ``operators`` (their sum).
    """

    reduced: BalancedModel
    lti: LTI
    bal: Balancing
    A: np.ndarray
    B: np.ndarray
    z0: np.ndarray
    skew: bool
    schur_Q: np.ndarray | None
    schur_T: np.ndarray | None
    rho0: np.ndarray = None
    timings: dict = field(default_factory=dict)
    input_error: float = float("nan")        # no POD basis: the force column enters exactly (Br = Wᵀ B)
    augmented: bool = False
    ports: tuple = ()
    Bp: np.ndarray | None = None             # (P, r): Wᵀ of each port's input column (area 1)
    Cp: np.ndarray | None = None             # (P, r): v_port_j = Cp[j] x_r
    port_errors: tuple = ()
    lti_ports: LTI | None = None             # the LTI balanced: lti with the port columns and rows appended
    channel: object = None                   # the port channel (sphrom.rom.port_channel.attach)

    @property
    def has_force_input(self):
        return self.B is not None

    @property
    def slices(self):
        return {"state": slice(0, self.A.shape[0])}

    @property
    def method(self):
        return self.reduced.method

    @property
    def output_probes(self):
        """The probes x/L the model was balanced for: its outputs y = Cr x_r."""
        return self.lti.probes.copy()

    @property
    def hsv(self):
        """The Hankel singular values of the balancing, largest first (the order's choice)."""
        return self.reduced.hsv

    def fields(self, z):
        """(v, ρ) at the particles from states (M, r): the reconstruction through V."""
        return self.velocity(z), self.density(z)

    def project(self, v, rho, problem):
        """x_r = Wᵀ x of full fields, x = [√ρ0 v; √c e] (e = ρ0/ρ - 1), (M, r)."""
        e = np.asarray(problem.rho0, float)[None, :] / rho - 1.0
        return self.lti.state(v, e) @ self.reduced.W

    def outputs(self, z, problem, probes):
        """y = Cr x_r at the model's own probes (``problem`` not needed), else the fields interpolated
        (:class:`~sphrom.rom.protocol.Operators`)."""
        if np.array_equal(np.asarray(probes, float), self.lti.probes):
            return np.atleast_2d(z) @ self.reduced.Cr.T
        return super().outputs(z, problem, probes)

    def error_bounds(self, problem, probes, progress=None):
        """The certified bounds at the probes the model was balanced for (:func:`sphrom.rom.balanced.error_bounds`);
        ValueError for other ``probes``."""
        if not np.array_equal(np.asarray(probes, float), self.lti.probes):
            raise ValueError(f"probes: {list(probes)} (allowed: {list(self.lti.probes)}, the probes the model was "
                             "balanced for)")
        return error_bounds(self.lti, self.reduced, outputs="v", progress=progress)

    def port_velocity_rows(self, problem, ports):
        """Rows (P, r): v_port at ``ports`` (x/L) = rows @ x_r: the balanced port rows where the model was balanced
        for them (``Cp``), else through the reconstruction V (as :meth:`velocity`)."""
        if self.Cp is not None and tuple(float(x) for x in ports) == tuple(self.ports):
            return self.Cp
        return port_velocity_rows(problem, ports) @ (self.reduced.V[:self.lti.n] / self.lti.w_v[:, None])

    def velocity_probe_rows(self, problem, probes):
        """Rows (P, r): v at ``probes`` (x/L) = rows @ x_r, through the reconstruction V (as :meth:`velocity`)."""
        return probe_rows(self.reduced.V[:self.lti.n] / self.lti.w_v[:, None], problem.x, problem.scene.L, probes)

    def _x(self, z):
        return np.atleast_2d(z) @ self.reduced.V.T

    def velocity(self, z):
        """v = (V x_r)_v / √ρ0 at the particles, (M, N) [m s^-1] from states (M, r)."""
        return self._x(z)[:, :self.lti.n] / self.lti.w_v

    def specific_volume(self, z):
        """e = (V x_r)_e / √c at the particles, (M, N) (dimensionless) from states (M, r)."""
        return self._x(z)[:, self.lti.n:] / self.lti.w_e

    def density(self, z):
        """ρ = ρ0 / (1 + e) at the particles, (M, N) [kg m^-3] from states (M, r)."""
        return self.rho0[None, :] / (1.0 + self.specific_volume(z))



MEASURE_SAMPLES = 4000      # at least T/4000 between samples of the measured errors (h |A|_1 <= 0.05 up to 40000)


def measured_errors(ops: BalancedOperators, T, force, samples=MEASURE_SAMPLES):
    """What the certified bounds bound (:meth:`BalancedOperators.error_bounds`), measured at the model's probes.

    The full linear SPH and the model are both sampled exactly in time on a grid of step h fine against the
    fastest rate of A (h |A|_1 <= 0.05, at least ``samples`` and at most 40000 steps over [0, T] [s]); the L²
    norms over [0, T] by Simpson's rule at h and 2h on the same samples, extrapolated (Romberg, O(h^6)).

    Returns
    -------
    h : float
        The grid step [s].
    measured : ndarray (P,)
        The L² error of each probe velocity in the free responses from the initial state [m s^-1 s^1/2] (what
        ``initial_state_error_bound`` bounds).
    gain : ndarray (P,)
        The L² error of each probe velocity in the responses from rest to ``force`` (f(t) [m s^-2], linear
        between the samples, the same input to both) per unit of the input's L² norm [s] (what
        ``force_error_bound`` bounds); nan where f is 0 on every sample.
    """
    lti, red = ops.lti, ops.reduced
    P = lti.n_probes
    A = lti.dense()
    k = int(min(40000, max(samples, np.ceil(T * np.max(np.sum(np.abs(A), axis=0)) / 0.05))))
    k += -k % 4                                                   # Simpson at h and 2h on the same samples
    h = T / k
    zero = np.zeros(k + 1)

    def l2(full, reduced):
        """‖full - reduced‖_L2(0,T) per probe: Simpson's rule at h and 2h, extrapolated (Romberg, O(h^6))."""
        e2 = (full - reduced) ** 2
        fine, coarse = simpson(e2, dx=h, axis=0), simpson(e2[::2], dx=2 * h, axis=0)
        return np.sqrt(np.maximum(fine + (fine - coarse) / 15.0, 0.0))

    measured = l2(sample_outputs(A, None, lti.C[:P], lti.x0, h, zero),
                  sample_outputs(red.Ar, None, red.Cr[:P], red.x0, h, zero))
    f = np.asarray(force(np.arange(k + 1) * h), float)
    gain = np.full(P, np.nan)
    if np.any(f):                   # the scene's force from rest, linear between the samples: the same input to both
        gain = l2(sample_outputs(A, lti.B[:, 0], lti.C[:P], np.zeros(lti.order), h, f),
                  sample_outputs(red.Ar, red.Br[:, 0], red.Cr[:P], np.zeros(red.order), h, f)) / input_norm(h, f)
    return h, measured, gain


def _operators(lti, bal, reduced, rho0, t_setup, ports=(), lti_ports=None, port_outputs=()):
    t0 = time.perf_counter()
    Q = T = None
    if reduced.skew:
        T, Q = sla.schur(reduced.Ar, output="real")
    timings = dict(reduced.timings)
    timings["operators"] = t_setup + sum(timings.values()) + time.perf_counter() - t0
    extra = {}
    if ports:                       # the port columns of Br and rows of Cr, sliced off the model's own
        n_out = lti.C.shape[0]
        extra = dict(ports=tuple(float(x) for x in ports), Bp=np.ascontiguousarray(reduced.Br[:, 2:].T),
                     Cp=np.ascontiguousarray(reduced.Cr[n_out:]), port_errors=tuple(0.0 for _ in ports),
                     lti_ports=lti_ports)
        reduced = dataclasses.replace(reduced, Br=reduced.Br[:, :2], Cr=reduced.Cr[:n_out])
    elif port_outputs:              # the port velocity rows only: the port channel takes the port forces
        n_out = lti.C.shape[0]
        extra = dict(ports=tuple(float(x) for x in port_outputs), Bp=None, Cp=np.ascontiguousarray(reduced.Cr[n_out:]),
                     lti_ports=lti_ports)
        reduced = dataclasses.replace(reduced, Cr=reduced.Cr[:n_out])
    return BalancedOperators(reduced=reduced, lti=lti, bal=bal, A=reduced.Ar, B=reduced.Br[:, 0].copy(),
                             z0=reduced.x0.copy(), skew=reduced.skew, schur_Q=Q, schur_T=T, rho0=rho0,
                             timings=timings, **extra)


def with_ports(lti, problem, ports, inputs=True):
    """``lti`` with one input column per port force (energy coordinates, area 1: √ρ0 · W(x - x_j, h)/ρ0 per N) and
    one output row per port velocity (v_port_j = Σ_i W(x_i - x_j, h) Δx v_i, v = x_v / √ρ0) appended: the port
    forces are balanced as inputs and the port velocities as outputs (:mod:`sphrom.sph.ports`); ``inputs`` False:
    the rows only (the port channel takes the port forces, :mod:`sphrom.rom.port_channel`)."""
    n = lti.n
    rows = np.hstack([port_velocity_rows(problem, ports) / lti.w_v[None, :], np.zeros((len(ports), n))])
    if not inputs:
        return dataclasses.replace(lti, C=np.vstack([lti.C, rows]))
    cols = np.column_stack([np.concatenate([w / lti.w_v, np.zeros(n)]) for w in port_kernel(problem, ports)])
    return dataclasses.replace(lti, B=np.column_stack([lti.B, cols]), C=np.vstack([lti.C, rows]))


def build(problem, basis, k_v, k_rho, *, order_tolerance=None, method="auto", probes=DEFAULT_PROBES, ports=(),
          port_outputs=()):
    """Balance the full linear SPH of ``problem`` and keep order r (the model's builder, :mod:`sphrom.rom.model`).

    Parameters
    ----------
    problem : SPHProblem
    basis : ignored
        The model needs no POD basis.
    k_v : int or None
        The order r (1 <= r < 2N); ``k_rho`` is ignored.
    order_tolerance : float, optional
        Instead of ``k_v``: the smallest r with 2 Σ_{i>r} σ_i <= order_tolerance · 2 Σ σ_i
        (0 < order_tolerance < 1; default :data:`sphrom.defaults.ORDER_TOLERANCE` when neither is given).
    method : {"auto", "bt", "galerkin", "bt_shifted"}
    probes : sequence of float
        The output probes x/L.
    ports : sequence of float
        Port positions x/L: the port forces are inputs and the port velocities outputs of the balanced system
        (:func:`with_ports`), so the reduction keeps what passes from each port force to each port velocity.
    port_outputs : sequence of float
        Port positions x/L whose velocities are outputs of the balanced system, without their forces as inputs
        (an FMU whose port channel takes the port forces: ``Cp`` the model's own part of v_port, ``Bp`` None).

    Raises ValueError naming ``order`` or ``order_tolerance`` when out of range.
    """
    t0 = time.perf_counter()
    lti = full_linear_system(problem, probes)
    if order_tolerance is not None and not (np.isfinite(order_tolerance) and 0 < order_tolerance < 1):
        raise ValueError(f"order_tolerance: {order_tolerance} is out of range (allowed: 0 < order_tolerance < 1)")
    if order_tolerance is None and k_v is not None and not 1 <= int(k_v) < lti.order:
        raise ValueError(f"order: {k_v} is out of range (allowed: 1 to {lti.order - 1}, below 2N)")
    balanced = with_ports(lti, problem, ports) if len(ports) else lti
    if len(port_outputs) and not len(ports):
        balanced = with_ports(lti, problem, port_outputs, inputs=False)
    t_setup = time.perf_counter() - t0
    bal = balancing(balanced, method=method)      # every input column per its unit (m s^-2 of f, N of F_port_j)
    if order_tolerance is not None or k_v is None:
        r = max(1, order_from_tolerance(bal.hsv, DEFAULT_TOLERANCE if order_tolerance is None else order_tolerance))
    else:
        r = int(k_v)
    return _operators(lti, bal, truncate_balanced(balanced, bal, r), problem.rho0, t_setup, ports,
                      balanced if len(ports) or len(port_outputs) else None, port_outputs=port_outputs)


def truncate(problem, ops: BalancedOperators, k_v, k_rho):
    """The model of order ``k_v`` (<= ops.order) from the same Gramians (equal to ``build`` at that order)."""
    if not 1 <= k_v <= ops.order:
        raise ValueError(f"order: {k_v} is out of range (allowed: 1 to {ops.order})")
    balanced = ops.lti_ports if ops.ports else ops.lti
    inputs = ops.Bp is not None                      # the port forces were balanced inputs (no port channel)
    return _operators(ops.lti, ops.bal, truncate_balanced(balanced, ops.bal, k_v), ops.rho0, 0.0,
                      ops.ports if inputs else (), ops.lti_ports, port_outputs=() if inputs else ops.ports)


def run(ops: BalancedOperators, problem, *, dt, n_steps, sample_steps, every, force, state, initial_state_scale,
        bound, progress, options, port_forces=None, area=1.0):
    """Run the balanced model to ``n_steps * dt`` (the shared arguments of :mod:`sphrom.rom.model`;
    ``options`` a :class:`~sphrom.rom.model.LinearOptions`).

    As :func:`sphrom.rom.exact_linear.run`: exact in time, communication step
    ``options.step`` H [s] (default the sample spacing), input ``options.hold`` linear or held;
    ``state`` (x_r) replaces the initial state Wᵀ x0; ``initial_state_scale`` multiplies it
    (x_r = 0 is rest).  The result's ``y`` holds the probe outputs Cr x_r and ``probes`` their positions x/L.
    ``port_forces``, ``area``: as :func:`sphrom.rom.exact_linear.run_exact` (operators built with ports).
    """
    if port_forces is not None and ops.Bp is None:
        raise ValueError("port_forces: the operators have no ports (build them with ports=...)")
    steps = sample_grid(n_steps, sample_steps, every)
    if state is not None:
        ops = dataclasses.replace(ops, z0=ops.as_state(state))
    z, wall, step = advance_linear(ops, steps * dt, options.step, force or problem.scene.force, options.hold, bound,
                                   initial_state_scale, port_forces=port_forces, area=area)
    return ReducedResult(model=NAME, t=steps * dt, steps=steps, z=z, ops=ops, wall_time=wall,
                         offline=dict(ops.timings),
                         settings={"model": NAME, "dt": dt, "step": step, "hold": options.hold, "order": ops.order,
                                   "method": ops.method, "k_v": ops.order, "k_e": 0})


MODEL = ReducedModel(
    name=NAME,
    description="beyond the paper: balanced reduction of the full linear SPH in J = ρ0/ρ (no POD basis; "
                "--modes R is the order r), with certified error bounds at the probes",
    title="Balanced reduced model of the linear SPH in the specific volume J = rho0/rho (beyond Fang et al.)",
    linear=True, integrators=INTEGRATORS, ports=True,
    basis_kind=None,            # needs no POD basis: build ignores it
    fmu_kind=2,                 # resources/model.bin kind 2: the linear models' C path (its matrices, rows over z)
    builder=build, solver=run, truncate=truncate, options_type=LinearOptions)
