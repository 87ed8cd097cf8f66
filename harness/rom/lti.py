"""The full SPH as a linear time-invariant system in the specific volume.

With J_i = ρ_i(0)/ρ_i (eq. A.9) and e = J - 1, eqs. 2.10-2.11 are exactly
linear (m_j/ρ_j(0) = Δx, G the SPH gradient of eq. 2.9):

    ė = G v,    ρ0 v̇ = G (c e) - ρ0 d v + ρ0 profile f(t).

Energy coordinates.  x = [x_v; x_e] = [√ρ0 v; √c e] (W_v = diag(ρ0),
W_e = diag(c), scaled by the square roots of the weights), so the energy per
Δx is ½|x|².  Then

    ẋ = A x + B u,    A = J - R,
    J = [[0, ρ0^-½ G c^½], [c^½ G ρ0^-½, 0]]  (skew, as G is on the periodic
        uniform lattice),   R = [[diag(d), 0], [0, 0]]  (symmetric, >= 0),

a port-Hamiltonian system with Hamiltonian ½|x|².  Inputs u = [f; δ]:
column 0 of B is the force profile √ρ0 profile (per m s^-2 of f(t)); column 1
is the scene's initial state x0 = [√ρ0 v0; 0], so that the free response from
x0 equals the impulse response of that column.  Outputs y = C x: the probe
velocities, linear between the two particles around each probe exactly as
the FMU does (:func:`sphrom.rom.operators.probe_rows`), then the probe
values of e.

Null modes.  G kills the constant and, for even N, the alternating
particle function, so A has the eigenvalue 0 on x_e = c^-½ k for k in
ker G, with the same left eigenvectors.  Both are uncontrollable (B has no
e part and ė = G v has no component along them) and x0 has none of them:
they never move.  ``LTI.null`` holds an orthonormal basis; A - γ null nullᵀ
(γ > 0) has the same transfer function and the same free response from x0,
and is asymptotically stable when d > 0 everywhere (the Lyapunov solves of
balanced truncation need that).

This module also integrates LTI systems exactly in time for a piecewise
linear input (:func:`output_energy`, :func:`sample_outputs`): the input is a
state of an augmented autonomous system, and the L² norm of every output
over each step is a quadratic form of the augmented state (Van Loan's
matrix exponential), so no quadrature error enters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .. import defaults
from ..sph import loops
from .inputs import rigid_modes

DEFAULT_PROBES = defaults.PROBES       # the FMU's default probes (x/L)


@dataclass
class LTI:
    """The full SPH in the specific volume as ẋ = A x + B u, y = C x (module docstring).

    Attributes
    ----------
    A : scipy.sparse.csr_matrix (2N, 2N)
        J - R in energy coordinates [s^-1].
    J, R : scipy.sparse.csr_matrix (2N, 2N)
        The skew and the symmetric (damping) parts of A.
    B : ndarray (2N, 2)
        Column 0: √ρ0 profile (per unit f [m s^-2]); column 1: x0.
    C : ndarray (2 P, 2N)
        Rows 0..P-1: probe velocities [m s^-1]; rows P..2P-1: probe values of e.
    x0 : ndarray (2N,)
        Initial state [√ρ0 v0; 0] (= B[:, 1]).
    w_v, w_e : ndarray (N,)
        √ρ0 and √c: x_v = w_v v, x_e = w_e e.
    null : ndarray (2N, m)
        Orthonormal basis of the decoupled null modes (module docstring).
    probes : ndarray (P,)
        Probe positions x/L.
    damped : bool
        d > 0 at every particle: A - γ null nullᵀ is asymptotically stable.
    T : float
        The scene's horizon [s].
    """

    A: sp.csr_matrix
    J: sp.csr_matrix
    R: sp.csr_matrix
    B: np.ndarray
    C: np.ndarray
    x0: np.ndarray
    w_v: np.ndarray
    w_e: np.ndarray
    null: np.ndarray
    probes: np.ndarray
    damped: bool
    T: float
    info: dict = field(default_factory=dict)

    @property
    def n(self):
        """Number of particles N."""
        return self.w_v.size

    @property
    def order(self):
        """State dimension 2N."""
        return 2 * self.n

    @property
    def n_probes(self):
        return self.probes.size

    def dense(self, deflate=0.0, shift=0.0):
        """A as a dense array, minus ``deflate`` · null nullᵀ and ``shift`` · I."""
        A = self.A.toarray()
        if deflate:
            A -= deflate * (self.null @ self.null.T)
        if shift:
            A[np.diag_indices_from(A)] -= shift
        return A

    def state(self, v, e):
        """Energy coordinates x = [√ρ0 v; √c e] of (v, e) of shape (..., N)."""
        return np.concatenate([self.w_v * np.asarray(v, float), self.w_e * np.asarray(e, float)], axis=-1)

    def fields(self, x):
        """(v, e) of energy coordinates x of shape (..., 2N)."""
        x = np.asarray(x, float)
        n = self.n
        return x[..., :n] / self.w_v, x[..., n:] / self.w_e

    def rhs(self, x, f=0.0):
        """ẋ = A x + B[:, 0] f (eqs. 2.10-2.11 in energy coordinates)."""
        return self.A @ np.asarray(x, float) + self.B[:, 0] * f

    def energy(self, x):
        """½|x|², the physical energy over Δx [kg s^-2]."""
        x = np.atleast_2d(x)
        return 0.5 * np.sum(x * x, axis=-1)


def probe_matrix(x, L, probes, w):
    """Rows interpolating a particle field linearly at the probes, as sphrom.rom.operators.probe_rows.

    Returns a (P, N) sparse matrix M with M (x_field / w) = probe values, i.e.
    the rows act on energy coordinates scaled by 1/w.
    """
    probes = np.asarray(probes, float)
    n = x.size
    dx = L / n
    s = np.mod(probes * L - x[0], L) / dx        # fractional index from particle 0 (as probe_rows)
    i0 = np.floor(s).astype(np.int64) % n
    wt = s - np.floor(s)
    i1 = (i0 + 1) % n
    rows = np.concatenate([np.arange(probes.size)] * 2)
    cols = np.concatenate([i0, i1])
    vals = np.concatenate([(1.0 - wt) / w[i0], wt / w[i1]])
    return sp.csr_matrix((vals, (rows, cols)), shape=(probes.size, n)).toarray()


def null_modes(G, w_e, tol=None):
    """Orthonormal basis of the e-null modes [0; c^-½ k], k in ker G among {1, (-1)^i} (module docstring).

    A candidate counts when |G k|_∞ <= tol · max|G| (default :func:`sphrom.rom.inputs.kernel_tol` of N); on the periodic uniform
    lattice both are exact kernels (the alternating one for even N only).
    """
    n = w_e.size
    vecs = [np.concatenate([np.zeros(n), k / w_e]) for k in rigid_modes(G, tol).T]
    if not vecs:
        return np.zeros((2 * n, 0))
    Q, _ = np.linalg.qr(np.column_stack(vecs))
    return Q


def full_linear_system(problem, probes=DEFAULT_PROBES) -> LTI:
    """The full SPH of ``problem`` as an LTI system in energy coordinates (module docstring).

    Parameters
    ----------
    problem : sphrom.sph.solver.SPHProblem
    probes : sequence of float
        Probe positions x/L in [0, 1].

    Returns
    -------
    LTI
    """
    probes = np.asarray(probes, float)
    if probes.ndim != 1 or probes.size == 0 or np.any(~np.isfinite(probes)) or np.any((probes < 0) | (probes > 1)):
        raise ValueError("probes: allowed: one or more positions x/L in [0, 1]")
    rho0, c, d = problem.rho0, problem.c, problem.d
    G = problem.neighbours.matrix().tocsr()
    w_v, w_e = np.sqrt(rho0), np.sqrt(c)
    n = rho0.size
    K = sp.diags(1.0 / w_v) @ G @ sp.diags(w_e)              # ρ0^-½ G c^½ : ẋ_v from x_e (eq. 2.11)
    M = sp.diags(w_e) @ G @ sp.diags(1.0 / w_v)              # c^½ G ρ0^-½ : ẋ_e from x_v (eq. 2.10)
    J = sp.bmat([[None, K], [M, None]], format="csr")
    R = sp.bmat([[sp.diags(d), None], [None, sp.csr_matrix((n, n))]], format="csr")
    A = (J - R).tocsr()
    x0 = np.concatenate([w_v * problem.v0, np.zeros(n)])
    B = np.column_stack([np.concatenate([w_v * problem.profile, np.zeros(n)]), x0])
    L = problem.scene.L
    Pv = probe_matrix(problem.x, L, probes, w_v)
    Pe = probe_matrix(problem.x, L, probes, w_e)
    C = np.block([[Pv, np.zeros_like(Pe)], [np.zeros_like(Pv), Pe]])
    skew = abs(J + J.T).max() if J.nnz else 0.0
    return LTI(A=A, J=J, R=R, B=B, C=C, x0=x0, w_v=w_v, w_e=w_e, null=null_modes(G, w_e), probes=probes,
               damped=bool(np.all(d > 0)), T=float(problem.scene.T),
               info={"skew_defect": float(skew), "scene": problem.scene.name})


def skew_growth(lti: LTI) -> float:
    """ω [s^-1] at least the largest eigenvalue of (A + Aᵀ)/2, so that ‖e^{A t}‖₂ <= e^{ω t} in energy coordinates.

    In exact arithmetic J is skew (module docstring) and A + Aᵀ = -2 diag(d, 0): e^{A t} is a contraction.  The
    computed blocks K = ρ0^-½ G c^½ and M = c^½ G ρ0^-½ are each rounded on their own (and G's entries at x_i - x_j
    and x_j - x_i), so the matrix the truth integrates has M + Kᵀ of round-off size, not 0 ((A + Aᵀ)/2 may have a
    positive eigenvalue of that size: tests/test_port_rows_sizing.py checks that ω bounds it), and e^{A t} may grow
    by that rate.  With A = [[-D, K], [M, 0]], D = diag(d) >= 0: xᵀ A x = -x_vᵀ D x_v + x_vᵀ (K + Mᵀ) x_e <= ‖K + Mᵀ‖₂ |x_v|
    |x_e| <= ‖K + Mᵀ‖₂ |x|² / 2, so ω = ‖K + Mᵀ‖_F / 2 (>= ‖K + Mᵀ‖₂ / 2; plus the largest -d, were any d < 0).
    K + Mᵀ is exact where its terms nearly cancel (a difference of doubles within a factor 2 of each other is exact),
    else within the unit round-off of each entry; the squares' sum is math.fsum's and the margin 1e-12 covers the
    rest.  The error bounds' decomposition drift (:func:`sphrom.rom.bounds.run_shadow`'s residual term,
    :class:`sphrom.rom.port_channel.ChannelState`'s drift) is a Duhamel integral of e^{A (t - τ)}: it carries e^{ω t}."""
    n = lti.w_v.size
    A = sp.csr_matrix(lti.A)
    X = sp.csr_matrix(A[:n, n:] + A[n:, :n].T)
    sq = np.asarray(X.data, float) ** 2
    norm = math.sqrt(math.fsum(sq.tolist())) if sq.size else 0.0
    d = -np.asarray(A[:n, :n].diagonal(), float)
    return float(0.5 * norm * (1.0 + 1e-12) + max(0.0, -float(d.min(initial=0.0))))


@dataclass(frozen=True)
class Truth:
    """The truth's matrix as the certified error bounds read it (:func:`truth_matrix`): the full linear SPH
    (:func:`full_linear_system` with one probe at 0.5: its A, the same whatever the probes) and its growth rate
    ω = :func:`skew_growth` [s^-1].  A packaging builds it once and passes it to the shadow
    (:func:`sphrom.rom.bounds.build_shadow`, its :func:`sphrom.rom.bounds.tail_table`) and the port channel
    (:func:`sphrom.rom.port_channel.build_channel`); each builds its own where it is not given."""

    lti: LTI
    growth: float


def truth_matrix(problem) -> Truth:
    """The :class:`Truth` of ``problem``: :func:`full_linear_system` at the probe 0.5 and its :func:`skew_growth`."""
    lti = full_linear_system(problem, [0.5])
    return Truth(lti=lti, growth=skew_growth(lti))


def growth_factor(omega, t):
    """An upper bound of e^{ω t} (ω t >= 0), as the C core computes it (fmu_src/rom_numerics.c
    rom_growth_factor, for the shadow's and the port channel's drifts): 1 + x + x² for x = ω t <= 1 (e^x - 1 - x = Σ_{k>=2} x^k/k! <= (e - 2) x² there; no libm call
    per step), else e^x; exactly 1 at ω = 0.

    Parameters
    ----------
    omega : float
        ω [s^-1].
    t : float or array_like
        Times [s] (negative ones count as 0).

    Returns
    -------
    float, or an array of t's shape: each element by the same operations as a float t (the same bits; e^x by
    libm's exp, math.exp, as the C core's: numpy's own exp may differ in the last bit).
    """
    if np.ndim(t) == 0:
        x = float(omega) * max(float(t), 0.0)
        return 1.0 + x * (1.0 + x) if x <= 1.0 else math.exp(x)
    x = float(omega) * np.maximum(np.asarray(t, float), 0.0)
    out = 1.0 + x * (1.0 + x)
    big = x > 1.0
    if np.any(big):
        out[big] = [math.exp(v) for v in x[big].tolist()]
    return out


def sph_rates(problem, v, rho, f=0.0):
    """The full SPH's right-hand side (eqs. 2.10-2.11, the compiled loop) expressed in (v, e).

    Returns (v̇, ė) with ė = -ρ0 ρ̇ / ρ² (e = ρ0/ρ - 1).
    """
    v = np.ascontiguousarray(v, float)
    rho = np.ascontiguousarray(rho, float)
    nb = problem.neighbours
    dv, drho, scratch = np.empty_like(v), np.empty_like(v), np.empty_like(v)
    loops.rates(v, rho, float(f), nb.index, nb.weight, problem.packed("rho0"), problem.packed("c"),
             problem.packed("d"), problem.packed("profile"), problem.flags(f != 0), dv, drho, scratch)
    return dv, -problem.rho0 * drho / (rho * rho)


# ---------------------------------------------------------------------------
# exact time integration for piecewise-linear inputs
# ---------------------------------------------------------------------------
def _augmented(A, b):
    """[[A, b, 0], [0, 0, 1], [0, 0, 0]]: the state with the input and its slope."""
    n = A.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = A
    M[:n, n] = b
    M[n, n + 1] = 1.0
    return M


def step_maps(A, b, C, h):
    """Exact maps over one step h of ẋ = A x + b u, u linear over the step.

    With z = [x; u(0); u'] (u' the slope), z(h) = Φ z(0) and
    ∫_0^h y_j(s)² ds = zᵀ Q_j z (y = C x), from the exponential of
    [[-Mᵀ, C̃ᵀC̃_j], [0, M]] h (Van Loan, 1978).

    Returns (Φ (n+2, n+2), Q (P, n+2, n+2)).
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    M = _augmented(A, np.zeros(n) if b is None else b)
    m = n + 2
    Ct = np.zeros((C.shape[0], m))
    Ct[:, :n] = C
    Q = np.empty((C.shape[0], m, m))
    phi = None
    for j in range(C.shape[0]):
        H = np.zeros((2 * m, 2 * m))
        H[:m, :m] = -M.T * h
        H[:m, m:] = np.outer(Ct[j], Ct[j]) * h
        H[m:, m:] = M * h
        E = sla.expm(H)
        phi = E[m:, m:]
        Qj = phi.T @ E[:m, m:]
        Q[j] = 0.5 * (Qj + Qj.T)
    if phi is None:
        phi = sla.expm(M * h)
    return phi, Q


def output_energy(A, b, C, x0, h, u, hold="linear"):
    """Exact ∫_0^T y_j(t)² dt of ẋ = A x + b u(t), y = C x, for u linear between samples (or held).

    Parameters
    ----------
    A : ndarray (n, n)
    b : ndarray (n,) or None
    C : ndarray (P, n)
    x0 : ndarray (n,) or (n, m)
        Initial state(s); m columns are m runs at once.
    h : float
        Sample spacing [s]; T = h · (len(u) - 1).
    u : ndarray (K+1,) or (K+1, m)
        Input at t_k = k h (zeros for a free response).
    hold : {"linear", "zero"}
        u linear between samples, or held at u_k over [t_k, t_k+1) (piecewise constant).

    Returns
    -------
    ndarray (P,) or (P, m)
        The output energies over [0, T].

    Notes
    -----
    Each step multiplies the augmented state by Φ and adds zᵀ Q_j z, so the
    result is exact up to round-off (the matrix exponentials); the steps
    should keep ‖e^{-Mᵀ h}‖ moderate (h times the largest decay rate ≲ 1),
    as the Van Loan block grows like it.
    """
    single, X, U = _columns(x0, u)
    if hold not in ("linear", "zero"):
        raise ValueError(f"hold: {hold!r} (allowed: linear, zero)")
    phi, Q = step_maps(A, b, C, h)
    n = X.shape[0]
    out = np.zeros((C.shape[0], X.shape[1]))
    Z = np.vstack([X, U[:1], np.zeros((1, X.shape[1]))])
    for k in range(U.shape[0] - 1):
        Z[n] = U[k]
        Z[n + 1] = (U[k + 1] - U[k]) / h if hold == "linear" else 0.0
        for j in range(C.shape[0]):
            out[j] += np.einsum("im,im->m", Z, Q[j] @ Z)
        Z = phi @ Z
    return out[:, 0] if single else out


def _columns(x0, u):
    """(single, X (n, m), U (K+1, m)): initial states and input samples as columns, one per case."""
    x0 = np.asarray(x0, float)
    single = x0.ndim == 1
    X = x0[:, None] if single else x0
    U = np.asarray(u, float)
    U = U[:, None] if U.ndim == 1 else U
    if U.shape[1] != X.shape[1]:
        U = np.broadcast_to(U, (U.shape[0], X.shape[1]))
    return single, X, U


def sample_outputs(A, b, C, x0, h, u):
    """y(t_k) = C x(t_k) at t_k = k h, exactly for u linear between samples.

    Shapes as :func:`output_energy`; returns (K+1, P) or (K+1, P, m).
    """
    single, X, U = _columns(x0, u)
    n = X.shape[0]
    phi = sla.expm(_augmented(np.asarray(A, float), np.zeros(n) if b is None else b) * h)
    out = np.empty((U.shape[0], C.shape[0], X.shape[1]))
    Z = np.vstack([X, U[:1], np.zeros((1, X.shape[1]))])
    for k in range(U.shape[0]):
        out[k] = C @ Z[:n]
        if k + 1 < U.shape[0]:
            Z[n] = U[k]
            Z[n + 1] = (U[k + 1] - U[k]) / h
            Z = phi @ Z
    return out[:, :, 0] if single else out


def input_norm(h, u, hold="linear"):
    """‖u‖_L2(0,T) of samples u (K+1,) or (K+1, m) at spacing h, linear between them or held (exact)."""
    u = np.asarray(u, float)
    if hold == "zero":
        return np.sqrt(h * np.sum(u[:-1] ** 2, axis=0))
    a, b = u[:-1], u[1:]
    return np.sqrt(h / 3.0 * np.sum(a * a + a * b + b * b, axis=0))
