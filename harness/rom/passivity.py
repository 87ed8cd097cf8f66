"""Passive ports: the reduced models' maps from port forces to port velocities, checked.

The full SPH, linear in J (eqs. 2.10-2.11 as :mod:`sphrom.rom.lti` writes them), stores energy
E = ½ Σ_i ρ0_i Δx v_i² + ½ Σ_i c_i Δx e_i² per unit area, dissipates it through the damping d >= 0, and a point
force F_j at port j (spread by the kernel, :mod:`sphrom.sph.ports`) does the work F_j v_port_j on it, v_port_j
being the same kernel's average of v: the port input and output are collocated, so the port map is passive,
dE/dt <= Σ_j F_j v_port_j / area.  A reduced model (A, B, C) of the port map (dz/dt = A z + B u, y = C z,
u_j = F_j / area, y_j = v_port_j) is passive when it has a storage function ½ zᵀ Q z, Q > 0, with

    Aᵀ Q + Q A <= 0   and   Q B = Cᵀ                     (the positive-real / KYP lemma)

Then coupling it to any passive component (a spring, a mass, a damper, another such model) gives a coupled
system whose total energy never grows.  Two checks:

- :func:`storage_certificate` tries Q = α I (the Galerkin models in energy coordinates: the exact POD model, whose
  U_v is ρ0-orthonormal and U_e c-orthonormal, and the balanced model's structure-preserving projection):
  α from least squares on Q B = Cᵀ, then the collocation residual ‖C − α Bᵀ‖ / ‖C‖ and the largest eigenvalue
  of the symmetric part of A; both at round-off is a proof of passivity up to round-off.
- :func:`block_storage_certificate` tries Q = α diag(I, βI) over two blocks: the frozen model linearised at rest
  (:func:`frozen_port_system`), passive by structure with β = c/ρ0³ where ρ0 and c are uniform.
- :func:`positive_real_margin` checks H(iω) + H(iω)ᴴ >= 0 on a frequency grid (log-spaced, plus each pole's
  frequency from both sides): the test for a model without that structure (balanced truncation on a damped
  scene, a Petrov-Galerkin projection; the frozen model on a scene with non-uniform c or ρ0), necessary, not a
  proof between grid points.

:func:`port_passivity` runs them in that order on a model with ports (packaging: every port FMU's line).

:func:`coupled_energy` integrates a model coupled at each port to a lumped mass-spring-damper exactly in time
(the matrix exponential of the coupled linear system) and returns the total energy over time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True)
class PortSystem:
    """The port map of a reduced model: dz/dt = A z + B u, y = C z (u_j = F_j / area [N m^-2], y_j = v_port_j
    [m s^-1])."""

    A: np.ndarray
    B: np.ndarray          # (k, P)
    C: np.ndarray          # (P, k)


def port_system(ops):
    """The :class:`PortSystem` of linear operators with ports (the exact POD model's
    :class:`~sphrom.rom.exact_linear.LinearOperators`, the balanced model's operators): A, the port columns
    ``ops.Bp`` (stored as rows) and the port rows ``ops.Cp`` (the velocity block only, for the exact model)."""
    if ops.Bp is None or ops.Cp is None:
        raise ValueError("the model has no ports (build it with ports=(x/L, ...))")
    A = np.asarray(ops.A, float)
    B = np.asarray(ops.Bp, float).T
    C = np.zeros((B.shape[1], A.shape[0]))
    Cp = np.asarray(ops.Cp, float)
    C[:, :Cp.shape[1]] = Cp
    return PortSystem(A=A, B=B, C=C)


def frozen_port_system(ops):
    """The :class:`PortSystem` of the frozen model (eqs. 2.19-2.20 with ports) linearised at rest: z = (a^v,
    δa^ρ), ȧ^v = -D̂ a^v - K δa^ρ + Bp u, δȧ^ρ = -M(a^ρ_0) a^v, y = Cp a^v, M at the projected rest density
    U^ρ a^ρ_0 (the frozen coefficient a component at rest starts with).  In the energy inner products (a port
    FMU's, build option ``inner``) passive by structure on every scene; in the paper's Euclidean projection only
    where ρ0 and c are uniform (:func:`block_storage_certificate`), elsewhere its M is not K's adjoint in any
    diagonal weight and :func:`positive_real_margin` checks it."""
    if ops.Bp is None or ops.Cp is None:
        raise ValueError("the model has no ports (build it with ports=(x/L, ...))")
    kv, kr = ops.k_v, ops.k_rho
    rho = np.asarray(ops.U_rho) @ np.asarray(ops.a_rho0)
    M0 = np.asarray(ops.U_rho).T @ ((rho ** 2 * np.asarray(ops.inv_rho0))[:, None] * np.asarray(ops.GU_v))
    D = np.zeros((kv, kv)) if ops.D is None else np.asarray(ops.D, float).reshape(kv, kv)
    A = np.block([[-D, -np.asarray(ops.K, float)], [-M0, np.zeros((kr, kr))]])
    B = np.vstack([np.asarray(ops.Bp, float).T, np.zeros((kr, ops.Bp.shape[0]))])
    C = np.hstack([np.asarray(ops.Cp, float), np.zeros((ops.Cp.shape[0], kr))])
    return PortSystem(A=A, B=B, C=C)


def storage_certificate(system: PortSystem):
    """(α, collocation, dissipation) of the storage ½ α |z|² [J m^-2]: α the least-squares solution of
    α B = Cᵀ (for the exact POD model the particle spacing Δx [m]: its U_v is ρ0-orthonormal without Δx),
    ``collocation`` = ‖C − α Bᵀ‖_F / ‖C‖_F, ``dissipation`` = the largest eigenvalue of (A + Aᵀ)/2 over ‖A‖₂
    (<= 0 for a dissipative A).  α > 0 with both at round-off (say below 1e-10) proves the port map passive."""
    return _certificate(system, np.ones(system.A.shape[0]))


def _certificate(system, q):
    """(α, collocation, dissipation) of the storage ½ α zᵀ diag(q) z: α from least squares on α diag(q) B = Cᵀ,
    the collocation residual over ‖C‖_F and the largest eigenvalue of the symmetric part of diag(q) A over its
    norm."""
    B, C, A = system.B, system.C, system.A
    QB = q[:, None] * B
    alpha = float(np.sum(C.T * QB) / np.sum(QB * QB))
    collocation = float(np.linalg.norm(C - alpha * QB.T) / np.linalg.norm(C))
    QA = q[:, None] * A
    dissipation = float(np.max(np.linalg.eigvalsh(0.5 * (QA + QA.T))) / max(np.linalg.norm(QA, 2), 1e-300))
    return alpha, collocation, dissipation


def block_storage_certificate(system: PortSystem, k1):
    """(α, β, collocation, dissipation) of the storage ½ α (|z₁|² + β |z₂|²) [J m^-2], z₁ the first ``k1``
    coordinates (the frozen model's a^v), z₂ the rest (its δa^ρ).

    β from least squares on the coupling's skew symmetry, A₁₂ + β A₂₁ᵀ = 0 (the part of A between the blocks
    then stores no energy), α from least squares on α diag(I, βI) B = Cᵀ (the KYP lemma's Q B = Cᵀ).
    ``collocation`` = ‖C − α Bᵀ diag(I, βI)‖_F / ‖C‖_F, ``dissipation`` the largest eigenvalue of the symmetric
    part of diag(I, βI) A over its norm.  β > 0, α > 0 with both at round-off proves the port map passive.

    The frozen model linearised at rest (:func:`frozen_port_system`) has ȧ^v = -D̂ a^v - K δa^ρ, δȧ^ρ = -M₀ a^v
    with K = U^vᵀ ρ0⁻¹ G diag(c/ρ0) U^ρ (eq. 2.21) and M₀ = U^ρᵀ diag(ρ0) G U^v (eq. 2.23 at ρ = ρ0).  Where
    ρ0 and c are uniform and G is skew (periodic particles at a uniform spacing), M₀ᵀ = -(ρ0³/c) K: β = c/ρ0³
    makes the coupling lossless whatever the bases, and the collocated ports (Bp and Cp both the port's kernel
    on U^v) make the map passive by structure.  Non-uniform ρ0 or c put different diagonal weights inside K and
    M₀: no such β, and :func:`positive_real_margin` is the check.  The energy inner products (the build option
    ``inner="energy"``, a port FMU's frozen model) make M₀ᵀ = -K on every scene: β = 1.
    """
    A = system.A
    k1 = int(k1)
    A12, A21 = A[:k1, k1:], A[k1:, :k1]
    den = float(np.sum(A21 * A21))
    beta = float(-np.sum(A12 * A21.T) / den) if den > 0 else 1.0
    alpha, collocation, dissipation = _certificate(system, np.concatenate([np.ones(k1),
                                                                          np.full(A.shape[0] - k1, beta)]))
    return alpha, beta, collocation, dissipation


def frequency_grid(A, points=400, decades=(-3.0, 2.0)):
    """Angular frequencies [rad s^-1]: log-spaced from 10^decades[0] to 10^decades[1] times the largest pole
    frequency (at least 1), plus each pole's frequency at ±1e-6 relative (where H peaks); a pole at ω = 0 (a
    rigid motion: its imaginary part round-off) adds no point, H is singular there."""
    poles = np.abs(np.linalg.eigvals(A).imag)
    top = max(float(poles.max(initial=0.0)), 1.0)
    grid = np.logspace(decades[0], np.log10(top) + decades[1], points)
    peaks = poles[poles > 1e-9 * top]
    return np.unique(np.concatenate([grid, peaks * (1 - 1e-6), peaks * (1 + 1e-6)]))


def positive_real_margin(system: PortSystem, omegas=None):
    """min over the grid of λ_min(H(iω) + H(iω)ᴴ) / ‖H(iω)‖₂ (>= −round-off for a positive-real H), H(s) =
    C (sI − A)⁻¹ B, and the frequency where it is reached [rad s^-1]."""
    A, B, C = system.A, system.B, system.C
    omegas = frequency_grid(A) if omegas is None else np.asarray(omegas, float)
    # one Schur form, then a triangular solve per frequency
    T, Z = sla.schur(A.astype(complex), output="complex")
    Bz, Cz = Z.conj().T @ B, C @ Z
    worst, at = np.inf, float("nan")
    eye = np.eye(A.shape[0])
    for w in omegas:
        X = sla.solve_triangular(1j * w * eye - T, Bz)
        H = Cz @ X
        norm = np.linalg.norm(H, 2)
        if not np.isfinite(norm) or norm == 0:
            continue
        m = float(np.min(np.linalg.eigvalsh(H + H.conj().T))) / norm
        if m < worst:
            worst, at = m, float(w)
    return worst, at


def coupled_matrix(system: PortSystem, *, mass, stiffness, damping=0.0, area=1.0):
    """The coupled system's matrix over the state (z, s, w) (:func:`coupled_energy`'s coupling): its eigenvalues
    lie in the closed left half-plane when the model is passive."""
    A, B, C = system.A, system.B, system.C
    k, P = A.shape[0], B.shape[1]
    m = np.broadcast_to(np.asarray(mass, float), (P,))
    ks = np.broadcast_to(np.asarray(stiffness, float), (P,))
    cd = np.broadcast_to(np.asarray(damping, float), (P,))
    n = k + 2 * P
    M = np.zeros((n, n))                       # state (z, s, w)
    M[:k, :k] = A
    for j in range(P):
        s, w = k + j, k + P + j
        # F_j / area = (k s + c (w - C_j z)) / area into z
        M[:k, s] += B[:, j] * ks[j] / area
        M[:k, w] += B[:, j] * cd[j] / area
        M[:k, :k] -= np.outer(B[:, j], C[j]) * cd[j] / area
        M[s, w] = 1.0
        M[s, :k] = -C[j]
        M[w, s] = -ks[j] / m[j]
        M[w, w] = -cd[j] / m[j]
        M[w, :k] = cd[j] / m[j] * C[j]
    return M


def coupled_energy(system: PortSystem, z0, t, *, mass, stiffness, damping=0.0, area=1.0, s0=None, w0=None,
                   storage=None):
    """Energies of the model coupled at each port j to a lumped mass-spring-damper (mass m_j [kg] on a spring
    k_j [N m^-1] and a damper c_j [N s m^-1] whose other end is the bar at port j), integrated exactly in time.

    The coupling (docs/fmu/coupling.md's convention): spring elongation s_j, s_j' = w_j − v_port_j;
    m_j w_j' = −k_j s_j − c_j (w_j − v_port_j); the bar receives F_port_j = k_j s_j + c_j (w_j − v_port_j).

    Returns (model energy ½ α |z|² area [J], lumped energy Σ ½ m w² + ½ k s² [J]) at the times ``t`` [s], α the
    ``storage`` weight (default :func:`storage_certificate`'s).
    """
    alpha = storage_certificate(system)[0] if storage is None else float(storage)
    k, P = system.A.shape[0], system.B.shape[1]
    m = np.broadcast_to(np.asarray(mass, float), (P,))
    ks = np.broadcast_to(np.asarray(stiffness, float), (P,))
    M = coupled_matrix(system, mass=mass, stiffness=stiffness, damping=damping, area=area)
    x = np.concatenate([np.asarray(z0, float), np.zeros(P) if s0 is None else s0,
                        np.zeros(P) if w0 is None else w0])
    t = np.asarray(t, float)
    bar, lumped = np.empty(t.size), np.empty(t.size)
    prev, maps = 0.0, {}
    for i, ti in enumerate(t):
        h = float(ti - prev)
        if h not in maps:
            maps[h] = sla.expm(M * h)
        x = maps[h] @ x
        prev = ti
        z, s, w = x[:k], x[k:k + P], x[k + P:]
        bar[i] = 0.5 * alpha * area * float(z @ z)
        lumped[i] = float(np.sum(0.5 * m * w * w + 0.5 * ks * s * s))
    return bar, lumped


def hamiltonian_test(system: PortSystem, feedthrough):
    """Whether H(s) + ε I is positive real, ε = ``feedthrough`` [m s^-1 / (N m^-2)] > 0 (a proof for a stable A,
    between the grid points too): the Hamiltonian matrix of the positive-real lemma,

        N = [[A − B R⁻¹ C, −B R⁻¹ Bᵀ], [Cᵀ R⁻¹ C, −(A − B R⁻¹ C)ᵀ]],   R = 2 ε I,

    has no eigenvalue on the imaginary axis exactly when H(iω) + H(iω)ᴴ + 2 ε I is nonsingular at every ω, and
    then (being positive at ω → ∞) positive definite.  Returns (passes, the smallest |Re λ| / ‖N‖₂ over the
    eigenvalues, the stability margin max Re λ(A)); passes when that distance exceeds 1e-12 (an eigenvalue on
    the axis computes at about 1e-15; at ε = 1e-6 ‖H‖∞ a passive model's stays near 1e-8, measured on the
    balanced models of damped_forced and mild_damped_forced, tests/test_passivity.py) and A is stable."""
    A, B, C = system.A, system.B, system.C
    eps = float(feedthrough)
    if not eps > 0:
        raise ValueError(f"feedthrough = {feedthrough!r} is out of range (allowed: > 0)")
    Ab = A - B @ C / (2 * eps)
    N = np.block([[Ab, -B @ B.T / (2 * eps)], [C.T @ C / (2 * eps), -Ab.T]])
    lam = np.linalg.eigvals(N)
    closest = float(np.min(np.abs(lam.real)) / np.linalg.norm(N, 2))
    stable = float(np.max(np.linalg.eigvals(A).real))
    return bool(closest > 1e-12 and stable < 0), closest, stable


PASSIVE_ROUNDOFF = 1e-10     # a storage certificate's residuals at round-off: passive by structure
MARGIN_ROUNDOFF = -1e-8      # a positive-real margin above this: passes the grid check
MARGIN_WARN = -1e-3          # below this the packaging warns: coupled to a passive part the model can gain energy


@dataclass(frozen=True)
class PortPassivity:
    """What a port model's passivity check found (:func:`port_passivity`).

    ``verdict``: ``"structure"`` (a storage with residuals at round-off: passive by structure), ``"grid"``
    (no such storage, positive real on the frequency grid), ``"near"`` (a negative margin above
    :data:`MARGIN_WARN`), ``"not passive"``; ``margin`` the grid's min λ(H + Hᴴ)/‖H‖ and ``at`` its frequency
    [rad s^-1]; ``storage`` the certificate's numbers (α, β, collocation, dissipation; β = 1 for Q = α I)."""

    verdict: str
    margin: float
    at: float
    storage: tuple

    def line(self):
        """One line for ``sphrom fmu``."""
        a, b, coll, diss = self.storage
        if self.verdict == "structure":
            form = "½ α |z|²" if abs(b - 1.0) <= 1e-8 else f"½ α (|a_v|² + β |δa_ρ|²), β = {b:.4g}"
            return (f"passive by structure (storage {form}: its collocation and dissipation residuals below "
                    f"{PASSIVE_ROUNDOFF:g}, round-off)")
        where = f"min λ(H + Hᴴ)/‖H‖ = {self.margin:.2e} at ω = {self.at:.3g} rad/s"
        if self.verdict == "grid":
            return f"positive real on the frequency grid ({where}); no storage of the simple form"
        if self.verdict == "near":
            return f"passive to {abs(self.margin):.1e} of ‖H‖ ({where})"
        return (f"NOT passive ({where}): coupled to a passive component (a spring, a mass) it can return more "
                "energy than it took")


def channel_port_system(channel):
    """The :class:`PortSystem` of a port channel (:class:`sphrom.rom.port_channel.PortChannel`): its planes
    (p_i, q_i) in order, A = blockdiag(Λ_i), B = [β_i; 0] per plane, C the port rows over p.  Collocated by
    construction (C = Δx Bᵀ) and dissipative (Λ_i + Λ_iᵀ = diag(-2d, 0)): the full linear SPH's port map on the
    planes it keeps."""
    n, P = channel.planes, channel.n_ports
    A = sla.block_diag(*channel.lam) if n else np.zeros((0, 0))
    B = np.zeros((2 * n, P))
    B[0::2] = channel.beta
    C = np.zeros((P, 2 * n))
    C[:, 0::2] = channel.rows[3 * channel.n_probes:]
    return PortSystem(A=A, B=B, C=C)


def port_passivity(ops, linear):
    """:class:`PortPassivity` of a model with ports: the port channel's (:func:`channel_port_system`: the port map
    of every model with the channel, whatever the model) or the linear models' :func:`port_system` with the storage
    Q = α I (:func:`storage_certificate`), the frozen model linearised at rest (:func:`frozen_port_system`) with
    the block storage (:func:`block_storage_certificate`); when the storage's residuals are not at round-off,
    the frequency-grid margin (:func:`positive_real_margin`)."""
    if ops.channel is not None:
        system = channel_port_system(ops.channel)
        alpha, coll, diss = storage_certificate(system)
        storage = (alpha, 1.0, coll, diss)
    elif linear:
        system = port_system(ops)
        alpha, coll, diss = storage_certificate(system)
        storage = (alpha, 1.0, coll, diss)
    else:
        system = frozen_port_system(ops)
        storage = block_storage_certificate(system, ops.k_v)
    alpha, beta, coll, diss = storage
    if alpha > 0 and beta > 0 and coll < PASSIVE_ROUNDOFF and diss < PASSIVE_ROUNDOFF:
        return PortPassivity("structure", float("nan"), float("nan"), storage)
    margin, at = positive_real_margin(system)
    verdict = "grid" if margin >= MARGIN_ROUNDOFF else "near" if margin >= MARGIN_WARN else "not passive"
    return PortPassivity(verdict, margin, at, storage)
