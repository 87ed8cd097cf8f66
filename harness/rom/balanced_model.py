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

from .balanced import BalancedModel, Balancing, balancing, order_from_tolerance, truncate as truncate_balanced
from .balanced import DEFAULT_TOLERANCE
from .exact_linear import INTEGRATORS, advance_linear
from .lti import DEFAULT_PROBES, LTI, full_linear_system
from .model import LinearOptions, ReducedModel
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

    def port_velocity(self, z):
        """v_port = Cp x_r [m s^-1], (M, P) from states (M, r) (:mod:`sphrom.sph.ports`)."""
        return np.atleast_2d(z) @ self.Cp.T

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
        from .balanced import error_bounds
        if not np.array_equal(np.asarray(probes, float), self.lti.probes):
            raise ValueError(f"probes: {list(probes)} (allowed: {list(self.lti.probes)}, the probes the model was "
                             "balanced for)")
        return error_bounds(self.lti, self.reduced, outputs="v", progress=progress)

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



def _operators(lti, bal, reduced, rho0, t_setup, ports=(), lti_ports=None):
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
    return BalancedOperators(reduced=reduced, lti=lti, bal=bal, A=reduced.Ar, B=reduced.Br[:, 0].copy(),
                             z0=reduced.x0.copy(), skew=reduced.skew, schur_Q=Q, schur_T=T, rho0=rho0,
                             timings=timings, **extra)


def with_ports(lti, problem, ports):
    """``lti`` with one input column per port force (energy coordinates, area 1: √ρ0 · W(x - x_j, h)/ρ0 per N) and
    one output row per port velocity (v_port_j = Σ_i W(x_i - x_j, h) Δx v_i, v = x_v / √ρ0) appended: the port
    forces are balanced as inputs and the port velocities as outputs (:mod:`sphrom.sph.ports`)."""
    from ..sph.ports import port_kernel, port_velocity_rows
    n = lti.n
    cols = np.column_stack([np.concatenate([w / lti.w_v, np.zeros(n)]) for w in port_kernel(problem, ports)])
    rows = np.hstack([port_velocity_rows(problem, ports) / lti.w_v[None, :], np.zeros((len(ports), n))])
    return dataclasses.replace(lti, B=np.column_stack([lti.B, cols]), C=np.vstack([lti.C, rows]))


def build(problem, basis, k_v, k_rho, *, order_tolerance=None, method="auto", probes=DEFAULT_PROBES, ports=()):
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

    Raises ValueError naming ``order`` or ``order_tolerance`` when out of range.
    """
    t0 = time.perf_counter()
    lti = full_linear_system(problem, probes)
    if order_tolerance is not None and not (np.isfinite(order_tolerance) and 0 < order_tolerance < 1):
        raise ValueError(f"order_tolerance: {order_tolerance} is out of range (allowed: 0 < order_tolerance < 1)")
    if order_tolerance is None and k_v is not None and not 1 <= int(k_v) < lti.order:
        raise ValueError(f"order: {k_v} is out of range (allowed: 1 to {lti.order - 1}, below 2N)")
    balanced = with_ports(lti, problem, ports) if len(ports) else lti
    t_setup = time.perf_counter() - t0
    bal = balancing(balanced, method=method)      # every input column per its unit (m s^-2 of f, N of F_port_j)
    if order_tolerance is not None or k_v is None:
        r = max(1, order_from_tolerance(bal.hsv, DEFAULT_TOLERANCE if order_tolerance is None else order_tolerance))
    else:
        r = int(k_v)
    return _operators(lti, bal, truncate_balanced(balanced, bal, r), problem.rho0, t_setup, ports,
                      balanced if len(ports) else None)


def truncate(problem, ops: BalancedOperators, k_v, k_rho):
    """The model of order ``k_v`` (<= ops.order) from the same Gramians (equal to ``build`` at that order)."""
    if not 1 <= k_v <= ops.order:
        raise ValueError(f"order: {k_v} is out of range (allowed: 1 to {ops.order})")
    balanced = ops.lti_ports if ops.ports else ops.lti
    return _operators(ops.lti, ops.bal, truncate_balanced(balanced, ops.bal, k_v), ops.rho0, 0.0, ops.ports,
                      ops.lti_ports)


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
