"""Beyond the paper: an exact linear reduced model in the specific volume.

With J_i = ρ_i(0)/ρ_i (the Jacobian of eq. A.9) and e = J - 1, eqs. 2.10-2.11
are exactly linear (m_j/ρ_j(0) = Δx, G the SPH gradient of eq. 2.9):

    ė = G v,    ρ0 v̇ = G (c e) - ρ0 d v + ρ0 profile f(t).

Energy inner products.  Let W_v = diag(ρ0), W_e = diag(c).  The energy is
E = ½ (vᵀ W_v v + eᵀ W_e e) Δx, and on a uniform periodic lattice G is
skew-symmetric, so dE/dt = 0 when d = f = 0 - for any ρ0(x) and c(x),
including the jump of section 3.5.  POD in these inner products (modes with
U_vᵀ W_v U_v = I, U_eᵀ W_e U_e = I) and a Galerkin projection in the same
inner products give, with v = U_v a, e = U_e b,

    ȧ = -D̂ a + P b + p̂ f,    ḃ = -Pᵀ a,
    P = U_vᵀ G W_e U_e,  D̂ = U_vᵀ W_v D U_v,  p̂ = U_vᵀ W_v profile,

a block-skew system (plus the symmetric damping): the reduced energy
½(|a|² + |b|²) is conserved exactly when d = f = 0, for a nonuniform c too.
(The Euclidean inner product would lose the skew structure when c or ρ0
varies.)  There is no linearisation error and no frozen coefficient.

In time the model is advanced exactly over any step H by the matrix
exponential of the augmented system (input held or linear over the step).
When d = 0 the free response is evaluated at t = n H directly from the real
Schur form A = Q blockdiag(rotations) Qᵀ, never accumulated, so its energy
stays exact to round-off whatever the horizon; only the forced response is
propagated step by step.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from ..errors import SimulationError
from ..sph.ports import port_kernel
from .balanced import error_bounds, reduced_from_exact
from .lti import full_linear_system
from .model import LinearOptions, ReducedModel, basis_modes
from .operators import (ROUNDOFF_TOLERANCE, augment_ports, input_mode, port_rows, profile_moments,
                        shared_modes)
from .protocol import Operators, two_blocks
from .result import ReducedResult
from .stepping import RUNAWAY_FACTOR, initial_scale, sample_grid

NAME = "exact"


@dataclass
class LinearOperators(Operators):
    """The exact linear reduced model (module docstring; the protocol of :mod:`sphrom.rom.protocol`:
    z = [a, b], blocks ``velocity`` and ``specific_volume``).

    Attributes
    ----------
    U_v : ndarray (N, k_v)
        Velocity modes, ρ0-orthonormal (the input direction appended when needed).
    U_e : ndarray (N, k_e)
        Specific-volume modes (e = J - 1), c-orthonormal.
    A : ndarray (k, k), k = k_v + k_e
        [[-D̂, P], [-Pᵀ, 0]].
    B : ndarray (k,) or None
        [p̂; 0], the input column; None without an input.
    z0 : ndarray (k,)
        Initial reduced state [U_vᵀ W_v v0; 0].
    rho0 : ndarray (N,)
    skew : bool
        d ≡ 0: A is skew and the free response uses the Schur form.
    schur_Q, schur_T : ndarray
        Real Schur form of A (skew case): A = Q T Qᵀ, T block diagonal.
    input_error : float
        W_v-relative projection error of the force profile in the POD modes.
    augmented : bool
    timings : dict
    input_mode : {"project", "augment", "never"}
        How the force entered, and ``input_tolerance`` the augmentation
        threshold (repeated by :func:`truncate_linear_operators`).
    ports : tuple of float
        Port positions x/L (:mod:`sphrom.sph.ports`); empty without ports.
    Bp : ndarray (P, k) or None
        The port forces' input columns (as rows) at area A = 1: [U_vᵀ W(x - x_j, h); 0] (ρ0 cancels in the ρ0
        inner product); dz/dt = A z + B f + Σ_j Bp[j] F_j / A.
    Cp : ndarray (P, k_v) or None
        v_port_j = Cp[j] a.
    port_added, port_added_2, port_errors
        Columns appended to U_v and U_e for the ports (after the force profile's: each port's profile and its
        Krylov directions, :func:`sphrom.rom.operators.port_directions`) and each port profile's
        ρ0-relative projection error before its column.
    input_added, input_added_2 : int
        Columns appended to U_v and U_e for the force profile's response at every frequency (build option
        ``input_moments``, :func:`sphrom.rom.inputs.augment_channels`).
    """

    U_v: np.ndarray
    U_e: np.ndarray
    A: np.ndarray
    B: np.ndarray | None
    z0: np.ndarray
    rho0: np.ndarray
    skew: bool
    schur_Q: np.ndarray | None
    schur_T: np.ndarray | None
    input_error: float
    augmented: bool
    timings: dict = field(default_factory=dict)
    input_mode: str = "project"
    input_tolerance: float = ROUNDOFF_TOLERANCE
    ports: tuple = ()
    Bp: np.ndarray | None = None
    Cp: np.ndarray | None = None
    port_added: int = 0
    port_errors: tuple = ()
    port_added_2: int = 0
    input_added: int = 0
    input_added_2: int = 0
    channel: object = None          # the port channel (sphrom.rom.port_channel.attach): Bp None, Cp its own part

    @property
    def k_v(self):
        return self.U_v.shape[1]

    @property
    def has_force_input(self):
        return self.B is not None

    @property
    def k_e(self):
        return self.U_e.shape[1]

    @property
    def k_rho(self):
        """The size of the second block of coordinates (specific volume), as for the density models."""
        return self.U_e.shape[1]

    @property
    def a_v0(self):
        """Initial velocity coordinates (k_v,), as :class:`~sphrom.rom.operators.ReducedOperators` has them."""
        return self.z0[:self.k_v]

    @property
    def a_rho0(self):
        """Initial coordinates of the second block (specific volume, zero at the start), (k_e,)."""
        return self.z0[self.k_v:]

    def velocity(self, a_v):
        """v = U_v a at the particles, (M, N) [m s^-1] from coordinates (M, k_v)."""
        return a_v @ self.U_v.T

    def density(self, a_e):
        """ρ = ρ0 / (1 + e), e = U_e b, at the particles, (M, N) [kg m^-3] from coordinates (M, k_e)."""
        e = a_e @ self.U_e.T
        return self.rho0[None, :] / (1.0 + e)

    def strain(self, a_e):
        """e = U_e b = J − 1 at the particles, (M, N) from coordinates (M, k_e)."""
        return a_e @ self.U_e.T

    @property
    def slices(self):
        return two_blocks("velocity", "specific_volume", self.k_v, self.k_e)

    def fields(self, z):
        """(v, ρ) at the particles from reduced states z of shape (M, k)."""
        z = np.atleast_2d(z)
        return self.velocity(z[:, :self.k_v]), self.density(z[:, self.k_v:])

    def project(self, v, rho, problem):
        """[U_vᵀ W_v v, U_eᵀ W_e e] per sample, e = ρ0/ρ - 1 (the energy inner products), (M, k)."""
        rho0 = np.asarray(problem.rho0, float)
        e = rho0[None, :] / rho - 1.0
        return np.hstack([(v * rho0) @ self.U_v, (e * np.asarray(problem.c, float)) @ self.U_e])

    def error_bounds(self, problem, probes, progress=None):
        """The certified bounds of the model as a Galerkin model of the full linear SPH with outputs at
        ``probes`` (:func:`sphrom.rom.balanced.reduced_from_exact`, :func:`sphrom.rom.balanced.error_bounds`)."""
        lti = full_linear_system(problem, probes)
        return error_bounds(lti, reduced_from_exact(lti, self), outputs="v", progress=progress)

    def energy(self, z):
        """Reduced energy ½|z|² (= the physical energy / Δx for the reduced fields)."""
        z = np.atleast_2d(z)
        return 0.5 * np.sum(z * z, axis=1)


def augment_weighted(U, direction, weight, tol=1e-10):
    """Append the W-orthogonal part of ``direction`` outside span(U) (W = diag(weight))."""
    d = np.asarray(direction, float)
    w = np.asarray(weight, float)
    norm = np.sqrt(d @ (w * d))
    if norm == 0:
        return U, float("nan"), False
    r = d - U @ (U.T @ (w * d))
    error = float(np.sqrt(r @ (w * r)) / norm)
    if error <= tol:
        return U, error, False
    r = r - U @ (U.T @ (w * r))
    return np.column_stack([U, r / np.sqrt(r @ (w * r))]), error, True


def build_linear_operators(problem, U_v, U_e, input_direction="auto", input_tolerance=None, ports=(),
                           input_moments=True):
    """The exact linear model's operators from energy-weighted bases.

    Parameters
    ----------
    problem : SPHProblem
    U_v : ndarray (N, k_v)
        ρ0-orthonormal velocity modes (``Basis.U_ve[:, :k]``).
    U_e : ndarray (N, k_e)
        c-orthonormal specific-volume modes (``Basis.U_e[:, :k]``).
    input_direction : {"auto", "project", "augment", "always", "needed", "never"}
    input_tolerance : float, optional
        As in :func:`sphrom.rom.operators.build_operators` (W_v-weighted).
    ports : sequence of float
        Port positions x/L: each port's acceleration profile W(x - x_j, h)/ρ0 is appended to U_v (its
        ρ0-orthogonal part outside the modes), so every port force enters exactly, as the force profile.
    input_moments : bool
        As in :func:`sphrom.rom.operators.build_operators`: with the profile appended, also its response at
        every frequency (energy inner products).
    """
    t0 = time.perf_counter()
    rho0, c, d, profile = problem.rho0, problem.c, problem.d, problem.profile
    scene = problem.scene
    has_force = problem.terms["force_profile"] and bool(np.any(scene.force(np.linspace(0, scene.T, 1025)) != 0))
    mode, tol = input_mode(input_direction, has_force, input_tolerance)
    want_input = mode != "never" and bool(np.any(profile != 0))
    input_error, augmented = float("nan"), False
    U_v = np.asarray(U_v, float)
    if want_input:
        U_aug, input_error, added = augment_weighted(U_v, profile, rho0, tol=tol)
        if mode == "augment":
            U_v, augmented = U_aug, added
    wanted = want_input and input_moments and mode == "augment"
    modes = shared_modes(problem, wanted, ports, input_moments)
    U_v, U_e, input_added, input_added_2 = profile_moments(problem, U_v, np.asarray(U_e, float), wanted,
                                                           energy=True, tol=tol, modes=modes)
    U_v, U_e, port_added, port_added_e, port_errors = augment_ports(problem, U_v, np.asarray(U_e, float), ports,
                                                                    energy=True, moments=input_moments, modes=modes)
    G = problem.neighbours.matrix()
    P = U_v.T @ np.asarray(G @ (c[:, None] * U_e))
    k_v, k_e = U_v.shape[1], U_e.shape[1]
    damping = problem.terms["damping"]
    D = U_v.T @ ((rho0 * d)[:, None] * U_v) if damping else np.zeros((k_v, k_v))
    A = np.block([[-D, P], [-P.T, np.zeros((k_e, k_e))]])
    B = np.concatenate([U_v.T @ (rho0 * profile), np.zeros(k_e)]) if want_input else None
    z0 = np.concatenate([U_v.T @ (rho0 * problem.v0), np.zeros(k_e)])
    Q = T = None
    if not damping:
        T, Q = sla.schur(A, output="real")
    extra = port_rows(problem, U_v, ports, port_added, port_errors, port_added_e)
    if extra:                        # ρ0 Bp_v = U_vᵀ ρ0 (W/ρ0): the rows over a, zeros over b
        extra["Bp"] = np.ascontiguousarray(np.hstack([port_weighted(problem, U_v, ports),
                                                      np.zeros((len(ports), k_e))]))
    return LinearOperators(U_v=U_v, U_e=np.asarray(U_e, float), A=A, B=B, z0=z0, rho0=rho0, skew=not damping,
                           schur_Q=Q, schur_T=T, input_error=input_error, augmented=augmented,
                           timings={"operators": time.perf_counter() - t0}, input_mode=mode, input_tolerance=tol,
                           input_added=input_added, input_added_2=input_added_2, **extra)


def port_weighted(problem, U_v, ports):
    """U_vᵀ W_v (W(x - x_j, h)/ρ0) = U_vᵀ W(x - x_j, h), one row per port (P, k_v): the port input in the ρ0
    inner product (area 1)."""
    return port_kernel(problem, ports) @ U_v


def build_from_basis(problem, basis, k_v, k_rho, *, input_direction="auto", input_tolerance=None, ports=(),
                     input_moments=True):
    """:func:`build_linear_operators` on the first k_v, k_rho energy-weighted modes of ``basis``
    (``Basis.U_ve``, ``Basis.U_e``): the model's builder (:mod:`sphrom.rom.model`)."""
    U_v, U_e = basis_modes(basis, "energy", k_v, k_rho)
    return build_linear_operators(problem, U_v, U_e, input_direction=input_direction, input_tolerance=input_tolerance,
                                  ports=ports, input_moments=input_moments)


def truncate_linear_operators(problem, ops: LinearOperators, k_v, k_e):
    """The operators of the first ``k_v`` POD velocity and ``k_e`` specific-volume modes of ``ops``.

    P, D̂ (the blocks of A), p̂ (of B) and z0 are slices of the larger ones, so
    A and B equal :func:`build_linear_operators` at the smaller counts to
    round-off (each entry is the same weighted sum over the particles; the
    dense products may group it differently); the energy inner products need no
    care, since the modes stay W-orthonormal.  Rebuilt: the Schur form of the
    smaller A (O(k³)), the input direction's projection error, and, when the
    force profile is appended to U_v (``input_mode`` augment), the appended
    column (the profile's W_v-part outside the first k_v modes, not outside all
    of them) with its rows of P, D̂, p̂ and z0, at O(N k).
    """
    t0 = time.perf_counter()
    kv_pod = ops.k_v - int(ops.augmented) - ops.port_added - ops.input_added
    ke_pod = ops.k_e - ops.port_added_2 - ops.input_added_2
    if not (1 <= k_v <= kv_pod and 1 <= k_e <= ke_pod):
        raise ValueError(f"k_v, k_e = {k_v}, {k_e} out of range (allowed: 1 to {kv_pod}, 1 to {ke_pod})")
    if ops.ports or ops.input_added or ops.input_added_2:    # input columns depend on every mode before them
        return build_linear_operators(problem, ops.U_v[:, :k_v], ops.U_e[:, :k_e],
                                      input_direction=ops.input_mode if ops.B is not None else "never",
                                      input_tolerance=ops.input_tolerance, ports=ops.ports)
    rho0, c, d, profile = problem.rho0, problem.c, problem.d, problem.profile
    k0 = ops.k_v
    U_pod = ops.U_v[:, :k_v]
    U_e = ops.U_e[:, :k_e]
    input_error, augmented, U_v = float("nan"), False, U_pod
    if ops.B is not None:
        U_aug, input_error, added = augment_weighted(U_pod, profile, rho0, tol=ops.input_tolerance)
        if ops.input_mode == "augment":
            U_v, augmented = U_aug, added
    P = ops.A[:k_v, k0:k0 + k_e]
    D = -ops.A[:k_v, :k_v]
    pv = None if ops.B is None else ops.B[:k_v]
    a0 = ops.z0[:k_v]
    if augmented:                                  # the appended column u and its rows, as build_linear_operators
        u = U_v[:, -1]
        G = problem.neighbours.matrix()
        P = np.vstack([P, u @ np.asarray(G @ (c[:, None] * U_e))])
        if problem.terms["damping"]:
            D = np.vstack([np.column_stack([D, U_pod.T @ (rho0 * d * u)]), u @ ((rho0 * d)[:, None] * U_v)])
        else:
            D = np.zeros((k_v + 1, k_v + 1))
        if pv is not None:
            pv = np.append(pv, u @ (rho0 * profile))
        a0 = np.append(a0, u @ (rho0 * problem.v0))
    A = np.block([[-D, P], [-P.T, np.zeros((k_e, k_e))]])
    B = None if pv is None else np.concatenate([pv, np.zeros(k_e)])
    z0 = np.concatenate([a0, np.zeros(k_e)])
    Q = T = None
    if ops.skew:
        T, Q = sla.schur(A, output="real")
    return LinearOperators(U_v=U_v, U_e=U_e, A=A, B=B, z0=z0, rho0=rho0, skew=ops.skew, schur_Q=Q, schur_T=T,
                           input_error=input_error, augmented=augmented,
                           timings={"operators": time.perf_counter() - t0}, input_mode=ops.input_mode,
                           input_tolerance=ops.input_tolerance)


def propagators(A, B, h):
    """Exact one-step maps over a step h for input held or linear over the step.

    z(h) = Φ z(0) + Γ0 f(0) + Γ1 (f(h) - f(0)), from the exponential of the
    augmented matrix [[A, B, 0], [0, 0, 1/h], [0, 0, 0]] h.
    Returns (Φ, Γ0, Γ1); Γ0 = Γ1 = 0 without an input.  A 2-D ``B`` (k, m)
    holds m input columns (the force f and the port forces): Γ0, Γ1 are then
    (k, m), from [[A, B, 0], [0, 0, I/h], [0, 0, 0]] h.
    """
    k = A.shape[0]
    if B is None:
        return sla.expm(A * h), np.zeros(k), np.zeros(k)
    if np.ndim(B) == 2:
        m = B.shape[1]
        M = np.zeros((k + 2 * m, k + 2 * m))
        M[:k, :k] = A * h
        M[:k, k:k + m] = B * h
        M[k:k + m, k + m:] = np.eye(m)
        E = sla.expm(M)
        return E[:k, :k], E[:k, k:k + m], E[:k, k + m:]
    M = np.zeros((k + 2, k + 2))
    M[:k, :k] = A * h
    M[:k, k] = B * h
    M[k, k + 1] = 1.0
    E = sla.expm(M)
    return E[:k, :k], E[:k, k], E[:k, k + 1]


def state_rate(A, B, z, f=0.0):
    """dz/dt = A z + B f (B None: no input) [per s], the linear models' right-hand side at one state."""
    rate = np.asarray(A, float) @ np.asarray(z, float)
    return rate if B is None else rate + np.asarray(B, float) * float(f)


def free_response(ops: LinearOperators, t):
    """e^{A t} z0 at times t, shape (M, k).

    Skew case (d = 0): from the Schur form, evaluated at each t directly.
    Otherwise by the matrix exponential at each t.
    """
    t = np.atleast_1d(np.asarray(t, float))
    if not ops.skew:
        return np.array([sla.expm(ops.A * ti) @ ops.z0 for ti in t])
    Q, T = ops.schur_Q, ops.schur_T
    y0 = Q.T @ ops.z0
    out = np.empty((t.size, y0.size))
    k = y0.size
    i = 0
    blocks = []
    while i < k:
        if i + 1 < k and T[i + 1, i] != 0.0:
            blocks.append((i, T[i, i + 1]))       # [[0, w], [-w, 0]]: rotation by w t
            i += 2
        else:
            blocks.append((i, None))
            i += 1
    for m, ti in enumerate(t):
        y = y0.copy()
        for j, w in blocks:
            if w is None:
                continue
            cs, sn = np.cos(w * ti), np.sin(w * ti)
            a, b = y0[j], y0[j + 1]
            y[j], y[j + 1] = cs * a + sn * b, -sn * a + cs * b
        out[m] = Q @ y
    return out


def run_exact(ops: LinearOperators, t_samples, step=None, force=None, hold="linear", bound=None,
              initial_state_scale=1.0, port_forces=None, area=1.0):
    """Advance the exact linear model and sample it at any times (a ReducedResult with ``steps`` None).

    The exact model's own kernel for samples off a step grid (an importer's communication points, as the FMU
    takes them); a run on the step grid, of this model or any other, is ``get_model(name).run``
    (:mod:`sphrom.rom.model`), which shares its stepping (:func:`advance_linear`).

    Parameters
    ----------
    ops : LinearOperators
    t_samples : ndarray (M,)
        Increasing sample times >= 0 [s].
    step : float, optional
        Communication step H [s] (default the smallest spacing of the samples).
        Steps run on t_n = n H; a sample between grid points is reached by a
        shortened step from the grid point before it, as the FMU does.
    force : callable, optional
        f(t) [m s^-2], vectorised.
    hold : {"linear", "held"}
        Input over a step: linear between its end values, or held at the start value.
    bound : float, optional
        |z| above this raises SimulationError (default :func:`linear_runaway_bound`, of the unscaled z0).
    initial_state_scale : float
        z(0) = this x z0 (z = 0 is rest: v = 0, e = 0), as the FMU parameter; 1 leaves the run bit for bit.
    port_forces : callable, optional
        F(t) -> (len(t), P) [N], the port forces (operators built with ports), divided by the cross-section
        ``area`` [m^2]; held or linear over a step as f.
    """
    z, wall, step = advance_linear(ops, t_samples, step, force, hold, bound, initial_state_scale,
                                   port_forces=port_forces, area=area)
    return ReducedResult(model=NAME, t=np.asarray(t_samples, float), steps=None, z=z, ops=ops, wall_time=wall,
                         offline=dict(ops.timings),
                         settings={"model": NAME, "step": step, "hold": hold, "k_v": ops.k_v, "k_e": ops.k_e})


def linear_runaway_bound(ops, f_integral):
    """|z| above this is a runaway: 10⁶ (|z0| + |B| ∫|f| dt) (``f_integral`` = ∫|f| dt over the run [m s^-1]).

    For the exact model in its energy coordinates e^{At} is a contraction
    (A skew plus the symmetric damping), so |z(t)| <= |z0| + |B| ∫|f| dt
    exactly; the factor 10⁶ leaves room for the balanced model's coordinates.
    A run from rest under a force is therefore not a runaway (10⁶ |z0| alone
    was 0 there and stopped every forced run from rest at its first sample).
    """
    scale = float(np.linalg.norm(ops.z0))
    if ops.B is not None:
        scale += float(np.linalg.norm(ops.B)) * f_integral
    return RUNAWAY_FACTOR * max(scale, 1e-300)


def advance_linear(ops, t_samples, step, force, hold, bound, initial_state_scale=1.0, port_forces=None,
                   area=1.0):
    """The reduced states z (M, k) at ``t_samples``, the wall time [s] and the step H (:func:`run_exact`).

    Shared by every linear model (exact, balanced): their operators differ, the stepping does not.  With
    ``port_forces`` (operators with port columns ``Bp``) the inputs are u = [f, F_1/A, ..., F_P/A] over the
    columns [B, Bp[0], ...] (f only when the model has B and a force is given)."""
    t_samples = np.asarray(t_samples, float)
    if step is None:
        gaps = np.diff(t_samples)
        step = float(np.min(gaps[gaps > 0])) if np.any(gaps > 0) else 1.0
    has_input = ops.B is not None and force is not None
    if port_forces is not None and ops.Bp is not None:
        ops, force = _with_port_inputs(ops, force if has_input else None, port_forces, area)
        has_input = True
    t0 = time.perf_counter()
    cache = {}

    def maps(h):
        key = round(h / step, 12)
        if key not in cache:
            phi, g0, g1 = propagators(ops.A, ops.B, h)
            cache[key] = (phi, g0, np.zeros_like(g1) if hold == "held" else g1)
        return cache[key]

    n_last = int(np.floor(t_samples[-1] / step + 1e-9)) if t_samples.size else 0
    f_grid = force(np.arange(n_last + 2) * step) if has_input else None       # f at t_n = n H
    f_samples = force(t_samples) if has_input else None
    if bound is None:
        bound = linear_runaway_bound(ops, step * float(np.sum(np.abs(f_grid))) if has_input else 0.0)

    def advance(x, h, fa, fb):
        """One exact step of length h with the input going from fa to fb."""
        if h <= 0:
            return x
        phi, g0, g1 = maps(h)
        x = phi @ x
        if has_input and np.ndim(g0) == 2:                     # several inputs (ports)
            x = x + g0 @ fa + g1 @ (fb - fa)
        elif has_input:
            x = x + g0 * fa + g1 * (fb - fa)
        return x

    scale = initial_scale(initial_state_scale)                    # z(0) = scale z0 (fmu_src/rom.c, the same order)
    free_at = free_response(ops, t_samples) if ops.skew else None
    z = np.empty((t_samples.size, ops.z0.size))
    x = np.zeros_like(ops.z0) if ops.skew else scale * ops.z0     # forced part (skew) or the whole state
    n = 0                                                         # grid index: the state is at t_n = n H
    for m, ts in enumerate(t_samples):
        n_target = int(np.floor(ts / step + 1e-9))
        while n < n_target:                                       # t_n = n H, never accumulated
            x = advance(x, step, *((f_grid[n], f_grid[n + 1]) if has_input else (0.0, 0.0)))
            n += 1
        y = advance(x, ts - n * step,                               # shortened step to an off-grid sample
                    *((f_grid[n], f_samples[m]) if has_input else (0.0, 0.0)))
        z[m] = (scale * free_at[m] + y) if ops.skew else y
        if not np.all(np.isfinite(z[m])) or np.max(np.abs(z[m])) > bound:
            raise SimulationError(f"exact reduced state became non-finite or runaway at t = {ts:.6g} s",
                                  step=m, time=ts)
    return z, time.perf_counter() - t0, step


def _with_port_inputs(ops, force, port_forces, area):
    """(ops with B the input matrix [B, Bp[0], ...] (k, m), u(t) -> (len(t), m) = [f, F_1/A, ...]) for
    :func:`advance_linear`."""
    columns = ([ops.B] if force is not None else []) + list(ops.Bp)
    n_ports = ops.Bp.shape[0]

    def inputs(t):
        t = np.atleast_1d(np.asarray(t, float))
        parts = [np.asarray(force(t), float).reshape(t.size, 1)] if force is not None else []
        parts.append(np.asarray(port_forces(t), float).reshape(t.size, n_ports) / area)
        return np.hstack(parts)

    return dataclasses.replace(ops, B=np.column_stack(columns)), inputs


INTEGRATORS = ("exponential",)


def run(ops, problem, *, dt, n_steps, sample_steps, every, force, state, initial_state_scale, bound, progress,
        options, port_forces=None, area=1.0):
    """Run the exact linear model to ``n_steps * dt`` (the shared arguments of :mod:`sphrom.rom.model`;
    ``options`` a :class:`~sphrom.rom.model.LinearOptions`).

    Samples at ``sample_steps * dt``; the communication step ``options.step`` H [s] (default the smallest sample
    spacing) and the input ``options.hold`` as in :func:`run_exact`; ``state`` (z) replaces z0;
    ``initial_state_scale`` multiplies it; ``port_forces``, ``area`` as in :func:`run_exact`.  ``progress`` does
    not apply (no time loop to show).
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
                         settings={"model": NAME, "dt": dt, "step": step, "hold": options.hold, "k_v": ops.k_v,
                                   "k_e": ops.k_e})


MODEL = ReducedModel(
    name=NAME,
    description="beyond the paper: exactly linear in the specific volume J = ρ0/ρ (energy inner products), "
                "advanced by the matrix exponential",
    title="Exact linear POD reduced model in the specific volume J = rho0/rho (energy inner product; beyond "
          "Fang et al.)",
    linear=True, integrators=INTEGRATORS, basis_kind="energy", ports=True,
    fmu_kind=2,                 # resources/model.bin kind 2 (sphrom.fmu.resources.MODEL_EXACT_LINEAR)
    builder=build_from_basis, solver=run, truncate=truncate_linear_operators, options_type=LinearOptions,
    # the force profile is always part of the velocity basis: for a linear model a projected input is a real
    # error (tenmode: the modes miss 0.39 % of the uniform profile and the forced response came out 10 % low)
    fmu_input_direction="always")
