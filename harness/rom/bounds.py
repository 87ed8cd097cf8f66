"""Certified a posteriori error bounds of every reduced model's outputs: the modal shadow.

The truth is the full SPH of eqs. 2.10-2.11, exactly linear in the specific volume (:mod:`.lti`): in energy
coordinates x = [√ρ0 v; √c e] it is ẋ = A x + B u, A = J - R, ‖e^{At}‖ <= 1, with the input u the FMU
received (the force f and each port force F_j / area, held or linear over each communication step) from
x(0) = s x0 (s = initial_state_scale).  Every output is a row over x: the probe velocity (v_probe_j), e at
the two particles around each probe (the density), the port velocity (v_port_j).

The shadow.  Let K = ρ0^-½ G c^½ (ẋ_v = K x_e - d x_v + ..., ẋ_e = -Kᵀ x_v) and K = U Σ Wᵀ its singular value
decomposition.  When d is uniform, each singular triplet (σ_i, u_i, w_i) spans an invariant plane of A:
A [u_i; 0] = -d [u_i; 0] - σ_i [0; w_i], A [0; w_i] = σ_i [u_i; 0], so that A is block diagonal with the 2 x 2
blocks Λ_i = [[-d, σ_i], [-σ_i, 0]] in the orthonormal basis S_i = [[u_i, 0], [0, w_i]] (any ρ0(x), c(x);
for a parametric model with uniform c and d the block at (c, d) is [[-d, (c/c_ref) σ_i], [-σ_i, 0]], affine).
The shadow keeps the n lowest-frequency triplets: w' = Λ w + S_sᵀ B u, w(0) = s S_sᵀ x0, stepped exactly
(each block by the exponential of its augmented matrix), O(k_s) per step, no N.

The bound of a row c (an output y = cᵀx) at time t:

    |y_model - y_true| <= |y_model - cᵀ S_s w| + |cᵀ e_s(t)|,   e_s = x - S_s w,
    e_s(t) = s e^{At} y0 + ∫ e^{A(t-τ)} [E w(τ) + B_⊥ u(τ)] dτ,   y0 = x0 - S_s w(0)/s,

with E = A S_s - S_s Λ (round-off for a uniform d) and B_⊥ = B - S_s S_sᵀ B.  The complement of the shadow is
invariant and block diagonal too, so the first term is Σ_{i∉s} ĉ_iᵀ e^{Λ_i t} ŷ_i, bounded (Hölder) by
G(t) = Σ_{i∉s} |ĉ_i| |e^{Λ_i t} ŷ_i|, non-increasing in t (each block is dissipative): a table G(t_b), valid
for t >= t_b.  The input term: with H(τ) = ∫_0^τ cᵀ e^{Aσ} b_⊥ dσ (the complement's step response),
∫_0^t h(t-τ) u(τ) dτ = u(0) H(t) + ∫ H(t-τ) du(τ), so it is at most sup|H| · V(u), V(u) = |u(0)| plus the total
variation of u (the jumps of a held input and ∫|du/dt| of a linear one), and sup|H| <= Σ_{i∉s} |ĉ_i| 2‖Λ_i^-1‖
|b̂_i|; or, by the energy, at most ‖c‖ ∫‖B_⊥ u‖ (the smaller is used).  The residual term is at most
‖c‖ ‖E‖ ∫‖w‖.  A round-off allowance (1e-9 + 1e-15 n) ‖c‖ (‖w‖ + |s| ‖x0‖) covers the floating-point
arithmetic of the shadow and of an exact-in-time reference.  The density ρ = Σ_m pw_m ρ0_m / (1 + e_m) at a
probe follows from the bounds β_m of e at its two particles: |ρ_model - ρ_true| <= |ρ_model - ρ_s| +
Σ_m pw_m ρ0_m β_m / ((1 + e_s,m)(1 + e_s,m - β_m)), infinite when 1 + e_s,m - β_m <= 0 (the certified interval
of J reaches 0: the density is not bounded there).

The shadow's size n is measured: the smallest n (at a gap of the singular values) whose own certified error
on the training run (the scene's initial state and force over T) is at most :data:`SHADOW_TARGET` of the
training run's largest probe velocity, at most :data:`MAX_ORDER` coordinates.  Without a uniform d the planes
are not invariant: the shadow is the Galerkin model on them (one dense block, stepped by the exponential of its
augmented matrix, O(k_s²) per step) and the complement terms fall back to the energy (‖c‖ ‖y0‖, ‖c‖ ∫‖B_⊥ u‖,
and ‖c‖ ∫‖E w‖ with E the true coupling residual, from the exact quadratic form of each step by Van Loan's
exponential: :func:`residual_gram`; certified, looser).  docs/science/error-bounds.md has the derivation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

SHADOW_TARGET = 1e-2        # the shadow's own certified error on the training run / the largest |v_probe| there
MAX_ORDER = 320             # the largest shadow k_s (coordinates)
PORT_ALL_PLANES = 500       # with ports and N <= this, the shadow keeps every plane (build_shadow's docstring)
DENSE_LIMIT = 4000          # N above this: no dense SVD (not supported: ValueError)
N_TABLE = 64                # table times of the damped envelope G(t_b), over [0, T]
ROUNDOFF = 1e-9             # relative round-off allowance
ROUNDOFF_STEP = 1e-15       # ... plus this per step
PIECES = ("const", "c", "d")   # A(c, d) = A_const + c A_c + d A_d


@dataclass
class Shadow:
    """The certified shadow of one FMU (module docstring).  Rows: P v probes, then e at the particles of probe j
    (rows P + 2 j, P + 2 j + 1), then the ports.  Inputs: column 0 the force f [m s^-2], column 1 + j the port
    force F_j / area [N m^-2].

    Attributes
    ----------
    sizes : ndarray (n_blocks,) of int
        Block sizes of Λ (2: one plane each; one dense block without invariant planes).
    A : ndarray (3, Σ b²)
        Λ(c, d) = A[0] + c A[1] + d A[2], the blocks packed row-major one after the other [s^-1].
    B : ndarray (k_s, m)
    C : ndarray (n_rows, k_s)
    w0 : ndarray (k_s,)
        The shadow's state for initial_state_scale 1.
    row_e : ndarray (n_rows,) of bool
        e rows (their dual norm scales with sqrt(c_ref / c) in a parametric model).
    row_norm : ndarray (n_rows,)
        ‖c_r‖ in the energy coordinates at c_ref.
    G : ndarray (n_rows, n_tab)
        The complement's initial-state envelope at t_b = b dt_tab (for t >= t_b; the last for all later t).
    dt_tab : float
    H : ndarray (n_rows, m)
        sup|H| of each input's complement (inf: not available).
    gram : ndarray (m, m)
        B_⊥ᵀ B_⊥.
    y0_norm, x0_norm : float
        ‖y0‖, ‖x0‖.
    E : ndarray (3, 2)
        ‖E_p‖ of each piece, its v rows and its e rows.
    B_norm : float
        ‖B‖₂ of the shadow's inputs.
    pw, prho0 : ndarray (P, 2)
        Each probe's interpolation weights and ρ0 at its two particles.
    parametric : bool
    c_ref : float
        The reference c of a parametric model [kg m^-1 s^-2] (nan otherwise).
    E_gram : ndarray (k_s, k_s) or None
        A dense shadow at fixed parameters (no invariant planes): Eᵀ E of its coupling residual E = A S - S Λ
        (energy coordinates): the residual term is ‖c‖ ∫‖E w‖ (:func:`residual_gram`), not ‖c‖ ‖E‖ ∫‖w‖.
    info : dict
        How it was chosen: order, target, its certified training error, invariance, timings.
    """

    sizes: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    w0: np.ndarray
    row_e: np.ndarray
    row_norm: np.ndarray
    G: np.ndarray
    dt_tab: float
    H: np.ndarray
    gram: np.ndarray
    y0_norm: float
    x0_norm: float
    E: np.ndarray
    B_norm: float
    pw: np.ndarray
    prho0: np.ndarray
    n_ports: int
    parametric: bool = False
    c_ref: float = float("nan")
    E_gram: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    @property
    def order(self):
        return int(self.w0.size)

    @property
    def n_probes(self):
        return int(self.pw.shape[0])

    @property
    def n_rows(self):
        return int(self.C.shape[0])

    @property
    def n_inputs(self):
        return int(self.B.shape[1])

    def blocks(self, c=None, d=None):
        """The blocks Λ_i(c, d) (list of (b, b) arrays); c, d None: the start (the non-parametric shadow)."""
        c, d = self._cd(c, d)
        packed = self.A[0] + c * self.A[1] + d * self.A[2]
        out, at = [], 0
        for b in self.sizes:
            out.append(packed[at:at + b * b].reshape(b, b))
            at += b * b
        return out

    def _cd(self, c, d):
        if not self.parametric:
            return 0.0, 0.0
        return float(c), float(d)

    def dual_norms(self, c=None):
        """‖c_r‖ in the energy norm of the model's c (e rows scale with sqrt(c_ref / c))."""
        if not self.parametric:
            return self.row_norm.copy()
        return np.where(self.row_e, self.row_norm * math.sqrt(self.c_ref / float(c)), self.row_norm)

    def residual_norm(self, c=None, d=None):
        """‖E(c, d)‖ in the energy norm at c (a bound: the pieces' norms summed)."""
        if not self.parametric:
            return float(self.E[0, 0] + self.E[0, 1])
        coef = (1.0, float(c), float(d))
        ratio = math.sqrt(float(c) / self.c_ref)
        return float(sum(coef[p] * (self.E[p, 0] + ratio * self.E[p, 1]) for p in range(3)))


# ---------------------------------------------------------------------------------------------------------------
# construction
# ---------------------------------------------------------------------------------------------------------------

def output_rows(problem, probes, ports=()):
    """(rows (n_rows, 2N) over energy coordinates, row_e, pw (P, 2), prho0 (P, 2)): v at each probe, e at the two
    particles around it, each port's velocity (module docstring)."""
    from ..sph.ports import port_velocity_rows
    from .lti import probe_matrix
    probes = np.asarray(probes, float)
    n = problem.rho0.size
    w_v, w_e = np.sqrt(problem.rho0), np.sqrt(problem.c)
    L = problem.scene.L
    s = np.mod(probes * L - problem.x[0], L) / (L / n)
    i0 = np.floor(s).astype(np.int64) % n
    wt = s - np.floor(s)
    i1 = (i0 + 1) % n
    P = probes.size
    rows = [np.hstack([probe_matrix(problem.x, L, probes, w_v), np.zeros((P, n))])]
    e_rows = np.zeros((2 * P, 2 * n))
    for j in range(P):
        for m, i in enumerate((i0[j], i1[j])):
            e_rows[2 * j + m, n + i] = 1.0 / w_e[i]
    rows.append(e_rows)
    if len(ports):
        rows.append(np.hstack([port_velocity_rows(problem, ports) / w_v[None, :], np.zeros((len(ports), n))]))
    C = np.vstack(rows)
    row_e = np.zeros(C.shape[0], bool)
    row_e[P:3 * P] = True
    pw = np.stack([1.0 - wt, wt], axis=1)
    prho0 = np.stack([problem.rho0[i0], problem.rho0[i1]], axis=1)
    return C, row_e, pw, prho0


def input_columns(problem, ports=()):
    """(2N, 1 + P) input columns over energy coordinates: the force profile √ρ0 profile (per m s^-2), each port's
    W(x - x_j, h)/√ρ0 (per N m^-2, i.e. per unit F_j / area; :mod:`sphrom.sph.ports`)."""
    from ..sph.ports import port_kernel
    n = problem.rho0.size
    w_v = np.sqrt(problem.rho0)
    cols = [np.concatenate([w_v * problem.profile, np.zeros(n)])]
    if len(ports):
        for k in port_kernel(problem, ports):
            cols.append(np.concatenate([k / w_v, np.zeros(n)]))
    return np.column_stack(cols)


def _coupling(problem):
    """K = ρ0^-½ G c^½ (dense, N x N) and its singular triplets sorted by σ ascending (U, σ, W)."""
    n = problem.rho0.size
    if n > DENSE_LIMIT:
        raise ValueError(f"n_particles: {n} is out of range for the error bounds (allowed: up to {DENSE_LIMIT}; "
                         "the shadow's singular value decomposition is dense)")
    G = problem.neighbours.matrix().tocsr()
    w_v, w_e = np.sqrt(problem.rho0), np.sqrt(problem.c)
    K = (G.multiply(1.0 / w_v[:, None]).multiply(w_e[None, :])).toarray()
    U, sig, Wt = np.linalg.svd(K)
    order = np.argsort(sig, kind="stable")
    return K, U[:, order], sig[order], Wt.T[:, order]


def operator_pieces(problem, K, parametric):
    """The pieces (const, per c, per d) of A over energy coordinates at c_ref, as functions x -> A_p x on (2N, m)
    arrays: the full A = [[-D, K], [-Kᵀ, 0]] (non-parametric) or, with uniform c and d, A(c, d) =
    [[-d I, (c/c_ref) K], [-Kᵀ, 0]]."""
    n = K.shape[0]
    d = np.asarray(problem.d, float)
    if not parametric:
        def a0(X):
            return np.vstack([-d[:, None] * X[:n] + K @ X[n:], -K.T @ X[:n]])
        return (a0, None, None)
    c_ref = float(problem.c[0])

    def const(X):
        return np.vstack([np.zeros_like(X[:n]), -K.T @ X[:n]])

    def per_c(X):
        return np.vstack([K @ X[n:] / c_ref, np.zeros_like(X[n:])])

    def per_d(X):
        return np.vstack([-X[:n], np.zeros_like(X[n:])])
    return (const, per_c, per_d)


def _expm2(M):
    """e^M of 2 x 2 matrices M (..., 2, 2), vectorised (e^{tr/2} (cosh Δ I + sinh Δ / Δ (M - tr/2 I)))."""
    M = np.asarray(M, float)
    a, b, c, d = M[..., 0, 0], M[..., 0, 1], M[..., 1, 0], M[..., 1, 1]
    half = 0.5 * (a + d)
    delta = np.sqrt(((0.5 * (a - d)) ** 2 + b * c).astype(complex))
    small = np.abs(delta) < 1e-8
    ratio = np.where(small, 1.0 + delta ** 2 / 6.0, np.sinh(delta) / np.where(small, 1.0, delta))
    ch = np.cosh(delta)
    e = np.exp(half)
    out = np.empty(M.shape)
    out[..., 0, 0] = np.real(e * (ch + ratio * (a - half)))
    out[..., 0, 1] = np.real(e * ratio * b)
    out[..., 1, 0] = np.real(e * ratio * c)
    out[..., 1, 1] = np.real(e * (ch + ratio * (d - half)))
    return out


def gap_cuts(sig, rel=1e-9):
    """The counts n at which the singular values have a gap (σ_n > σ_{n-1} (1 + rel) + rel σ_max): a degenerate
    pair (a cos and a sin of one wavenumber) is kept or left together."""
    top = float(sig[-1]) if sig.size else 0.0
    return [n for n in range(1, sig.size + 1) if n == sig.size or sig[n] > sig[n - 1] * (1 + rel) + rel * top]


def build_shadow(problem, probes, ports=(), *, parametric=False, scale_v=None, force=None, T=None,
                 target=SHADOW_TARGET, order=None, max_order=MAX_ORDER, port_inputs=True):
    """The certified shadow of the FMUs of ``problem`` at ``probes`` (and ``ports``) (module docstring).

    Parameters
    ----------
    problem : SPHProblem
        The scene's problem (its c is c_ref of a parametric model).
    probes, ports : sequence of float
        Positions x/L.
    parametric : bool
        A(c, d) affine for uniform c and d (:mod:`sphrom.rom.parametric`): the blocks and norms in pieces.
    scale_v : float
        The training run's largest |v_probe| [m s^-1] (the size criterion's scale).
    force : callable, optional
        The training force f(t) [m s^-2] (its total variation enters the criterion); default the scene's.
    T : float, optional
        The training horizon [s] (default the scene's T): the envelope table's span.
    target : float
        The criterion: the shadow's certified training error <= target · scale_v.
    order : int, optional
        Force the number of singular triplets (tests); default the criterion's.
    max_order : int
        The largest k_s (without ports, or with ports and N > :data:`PORT_ALL_PLANES`; with ports and N <= that,
        every plane: k_s = 2N).
    port_inputs : bool
        False: the port velocity rows without the port input columns (an FMU whose port channel takes the port
        forces, :mod:`sphrom.rom.port_channel`; the shadow then certifies the response to f and the initial state).

    Returns
    -------
    Shadow
    """
    t_start = time.perf_counter()
    n = problem.rho0.size
    T = float(problem.scene.T if T is None else T)
    force = problem.scene.force if force is None else force
    K, U, sig, W = _coupling(problem)
    t_svd = time.perf_counter() - t_start
    C, row_e, pw, prho0 = output_rows(problem, probes, ports)
    Bcols = input_columns(problem, ports if port_inputs else ())
    x0 = np.concatenate([np.sqrt(problem.rho0) * problem.v0, np.zeros(n)])
    d = np.asarray(problem.d, float)
    uniform_d = bool(np.all(d == d[0]))
    if parametric and not (problem.terms["uniform_c"] and uniform_d):
        raise ValueError("a parametric shadow needs uniform c and d")
    # modal coefficients: rows ĉ (n_rows, N, 2), x0 and inputs on u_i (x0 and B have no e part)
    c_hat = np.stack([C[:, :n] @ U, C[:, n:] @ W], axis=2)
    y_hat = U.T @ x0[:n]
    b_hat = U.T @ Bcols[:n]                                     # (N, m)
    pieces = operator_pieces(problem, K, parametric)
    full_blocks = _plane_blocks(pieces, U, W, sig)              # (3, N, 2, 2) pieces of every plane's block
    invariant = uniform_d
    # the criterion: Hölder sums of the complement from index n on (cumulative from the end)
    cn = np.linalg.norm(c_hat, axis=2)                          # (n_rows, N)
    lam0 = full_blocks[0] + (float(problem.c[0]) * full_blocks[1] + float(d[0]) * full_blocks[2]
                             if parametric else 0.0)
    inv_norm = _inverse_norms(lam0)                             # (N,) 2‖Λ_i^-1‖ (inf when singular)
    tail = lambda a: np.concatenate([np.cumsum(a[..., ::-1], axis=-1)[..., ::-1], np.zeros(a.shape[:-1] + (1,))],
                                    axis=-1)
    G0 = tail(cn * np.abs(y_hat)[None, :])                      # (n_rows, N + 1)
    h_terms = cn[:, :, None] * (inv_norm[:, None] * np.abs(b_hat))[None, :, :]
    with np.errstate(invalid="ignore"):
        h_terms = np.where(np.abs(b_hat)[None] > 0, h_terms, 0.0)
    Hc = np.stack([tail(h_terms[:, :, i]) for i in range(Bcols.shape[1])], axis=2)   # (n_rows, N + 1, m)
    grid = np.linspace(0.0, T, 4097)
    f_train = np.asarray(force(grid), float) * np.ones_like(grid)
    variation = abs(f_train[0]) + float(np.sum(np.abs(np.diff(f_train))))
    P = len(probes)
    v_rows = list(range(P)) + list(range(3 * P, C.shape[0]))
    scale_v = float(scale_v) if scale_v is not None else float(np.max(np.abs(C[:P] @ x0)))
    allowed = target * max(scale_v, 1e-300)
    forced = Hc[v_rows, :, 0] * variation if variation > 0 else 0.0                 # inf x 0: no force, no term
    training = np.max(G0[v_rows] + forced, axis=0)                                  # (N + 1,)
    cuts = gap_cuts(sig)
    limit = max(1, max_order // 2)
    if order is not None:
        chosen = int(order)
    elif len(ports) and port_inputs and n <= PORT_ALL_PLANES and invariant:   # (a dense shadow keeps its own cap)
        # a port's force and velocity are kernel-localized: their complement terms fall only like log(N / k_s)
        # (less than 10x from k_s = 40 to 160 on damped_forced: tests/test_fmu_error_bounds.py), far above any port
        # response; every plane makes the complement empty and the bound |model - truth| up to round-off, at O(N)
        # per step
        chosen = n
    else:
        fits = [c for c in cuts if c <= limit and training[c] <= allowed]
        within = [c for c in cuts if c <= limit] or [cuts[0]]
        chosen = fits[0] if fits else within[-1]
    keep = np.arange(chosen)
    rest = np.arange(chosen, n)
    shadow = _assemble(problem, pieces, full_blocks, keep, U, W, C, Bcols, x0, c_hat, y_hat, b_hat, row_e, pw,
                       prho0, invariant, parametric, T, len(ports), inv_norm)
    shadow.info.update({
        "triplets": int(chosen), "order": shadow.order, "target": float(target), "scale_v": scale_v,
        "training_bound": float(training[chosen]), "training_variation": variation, "invariant": invariant,
        "met": bool(training[chosen] <= allowed), "sigma_cut": float(sig[chosen - 1]) if chosen else 0.0,
        "sigma_next": float(sig[chosen]) if rest.size else float("inf"),
        "timings": {"svd": t_svd, "shadow": time.perf_counter() - t_start}})
    return shadow


def _plane_blocks(pieces, U, W, sig):
    """(3, N, 2, 2): each plane's block of each piece of A, Λ_{p,i} = S_iᵀ A_p S_i (S_i = [[u_i, 0], [0, w_i]])."""
    n = U.shape[0]
    out = np.zeros((3, n, 2, 2))
    Sv = np.vstack([U, np.zeros_like(U)])
    Se = np.vstack([np.zeros_like(W), W])
    for p, piece in enumerate(pieces):
        if piece is None:
            continue
        AV, AE = piece(Sv), piece(Se)
        out[p, :, 0, 0] = np.einsum("ij,ij->j", Sv, AV)
        out[p, :, 0, 1] = np.einsum("ij,ij->j", Sv, AE)
        out[p, :, 1, 0] = np.einsum("ij,ij->j", Se, AV)
        out[p, :, 1, 1] = np.einsum("ij,ij->j", Se, AE)
    return out


def _inverse_norms(blocks):
    """2‖Λ_i^-1‖₂ of 2 x 2 blocks (N, 2, 2): sup_τ ‖Λ^-1 (e^{Λτ} - I)‖ for a dissipative block; inf if singular."""
    s = np.linalg.svd(blocks, compute_uv=False)                  # (N, 2)
    smallest = s[:, -1]
    with np.errstate(divide="ignore"):
        return np.where(smallest > 1e-12 * max(float(np.max(s)), 1e-300), 2.0 / smallest, np.inf)


def _assemble(problem, pieces, full_blocks, keep, U, W, C, Bcols, x0, c_hat, y_hat, b_hat, row_e, pw, prho0,
              invariant, parametric, T, n_ports, inv_norm):
    """The Shadow of the planes ``keep`` (module docstring)."""
    n = U.shape[0]
    ks = 2 * keep.size
    S = np.zeros((2 * n, ks))
    S[:n, 0::2] = U[:, keep]
    S[n:, 1::2] = W[:, keep]
    rest = np.setdiff1d(np.arange(n), keep)
    if invariant:
        # one 2 x 2 block per plane, split into two 1 x 1 blocks where every piece's coupling is zero
        # one 2 x 2 block per plane (the C core steps planes: fmu_src/rom_bound.c)
        sizes = [2] * keep.size
        A = np.array([full_blocks[p, keep].reshape(-1) for p in range(3)], float).reshape(3, -1)
        lam = [sla.block_diag(*[np.asarray(full_blocks[p, i]) for i in keep]) if keep.size else np.zeros((0, 0))
               for p in range(3)]
    else:
        lam = [S.T @ piece(S) if piece is not None else np.zeros((ks, ks)) for piece in pieces]
        sizes = [ks]
        A = np.array([m.ravel() for m in lam])
    # residual pieces E_p = A_p S - S Λ_p: norms of their v rows and e rows
    E = np.zeros((3, 2))
    E_gram = None
    for p, piece in enumerate(pieces):
        if piece is None or ks == 0:
            continue
        Ep = piece(S) - S @ lam[p]
        E[p] = [np.linalg.norm(Ep[:n], 2), np.linalg.norm(Ep[n:], 2)]
        if p == 0 and not invariant and not parametric:
            E_gram = Ep.T @ Ep
    B = S.T @ Bcols
    Bperp = Bcols - S @ B
    w0 = S.T @ x0
    y0 = x0 - S @ w0
    row_norm = np.linalg.norm(C, axis=1)
    Cs = C @ S
    m = Bcols.shape[1]
    if invariant:
        cn = np.linalg.norm(c_hat[:, rest], axis=2)                # (n_rows, rest)
        lam_rest = full_blocks[0, rest] + (0.0 if not parametric else
                                           float(problem.c[0]) * full_blocks[1, rest] +
                                           float(problem.d[0]) * full_blocks[2, rest])
        if parametric:
            G = (cn @ np.abs(y_hat[rest]))[:, None]                 # all-time Hölder bound (any c, d)
            dt_tab = T
            H = np.full((C.shape[0], m), np.inf)
        else:
            dt_tab = T / N_TABLE
            times = np.arange(N_TABLE) * dt_tab
            ystart = np.stack([y_hat[rest], np.zeros(rest.size)], axis=1)        # (rest, 2)
            G = np.empty((C.shape[0], N_TABLE))
            for b, tb in enumerate(times):
                decayed = np.einsum("kij,kj->ki", _expm2(lam_rest * tb), ystart)
                G[:, b] = cn @ np.linalg.norm(decayed, axis=1)
            G = np.minimum.accumulate(G, axis=1)
            contrib = cn[:, :, None] * (inv_norm[rest][:, None] * np.abs(b_hat[rest]))[None]
            contrib = np.where(np.abs(b_hat[rest])[None] > 0, contrib, 0.0)
            H = contrib.sum(axis=1)
    else:
        G = (row_norm * np.linalg.norm(y0))[:, None]
        dt_tab = T
        H = np.full((C.shape[0], m), np.inf)
    G = G * (1.0 + 1e-12)                                          # the sums' own round-off
    return Shadow(sizes=np.array(sizes, np.int64), A=A, B=B, C=Cs, w0=w0, row_e=row_e, row_norm=row_norm, G=G,
                  dt_tab=float(dt_tab), H=H * (1.0 + 1e-12), gram=Bperp.T @ Bperp, y0_norm=float(np.linalg.norm(y0)),
                  x0_norm=float(np.linalg.norm(x0)), E=E, B_norm=float(np.linalg.norm(B, 2)) if B.size else 0.0,
                  pw=pw, prho0=prho0, n_ports=int(n_ports), parametric=bool(parametric),
                  c_ref=float(problem.c[0]) if parametric else float("nan"), E_gram=E_gram,
                  info={"invariant": invariant})


# ---------------------------------------------------------------------------------------------------------------
# the online computation (the C core's rom_bound.c does the same, step for step)
# ---------------------------------------------------------------------------------------------------------------

def block_maps(blocks, B, h):
    """Per block (Φ, Γ0, Γ1) of a step h: the exponential of [[Λ h, B_b h, 0], [0, 0, I], [0, 0, 0]]
    (:func:`sphrom.rom.exact_linear.propagators`; Γ1 multiplies the input's change over the step)."""
    out, at = [], 0
    m = B.shape[1]
    for L in blocks:
        b = L.shape[0]
        M = np.zeros((b + 2 * m, b + 2 * m))
        M[:b, :b] = L * h
        M[:b, b:b + m] = B[at:at + b] * h
        M[b:b + m, b + m:] = np.eye(m)
        E = sla.expm(M)
        out.append((E[:b, :b], E[:b, b:b + m], E[:b, b + m:]))
        at += b
    return out


QUAD_ROUNDOFF = 1e-14       # the residual's quadratic form: + this x (trace(Q) + ‖F12‖₁ ‖F22‖₁) |Y|^2 (its round-off)


def residual_gram(L, B, E_gram, h):
    """Q of a step h of one dense block: ∫_0^h ‖E w(τ)‖² dτ = h Yᵀ Q Y, Y = (w, u, du) at the step's start (u the
    input there, du its change over the step), w' = L w + B u: with M = [[L h, B h, 0], [0, 0, I], [0, 0, 0]] (the
    block's augmented matrix, :func:`block_maps`) Q = ∫_0^1 e^{Mᵀs} diag(EᵀE, 0, 0) e^{Ms} ds, by Van Loan's
    exponential of [[-Mᵀ, diag(EᵀE, 0, 0)], [0, M]] (Q = F22ᵀ F12), symmetrised.  Returns (Q, allowance): the
    form's round-off allowance per |Y|², QUAD_ROUNDOFF (trace(Q) + ‖F12‖₁ ‖F22‖₁) (the product's scale: F12 grows
    with e^{-Mᵀ} where the block is damped, and Q is its cancellation with F22)."""
    b, m = L.shape[0], B.shape[1]
    n = b + 2 * m
    M = np.zeros((n, n))
    M[:b, :b] = L * h
    M[:b, b:b + m] = B * h
    M[b:b + m, b + m:] = np.eye(m)
    V = np.zeros((2 * n, 2 * n))
    V[:n, :n] = -M.T
    V[:b, n:n + b] = E_gram
    V[n:, n:] = M
    F = sla.expm(V)
    Q = F[n:, n:].T @ F[:n, n:]
    Q = 0.5 * (Q + Q.T)
    scale = float(np.trace(Q)) + np.linalg.norm(F[:n, n:], 1) * np.linalg.norm(F[n:, n:], 1)
    return Q, QUAD_ROUNDOFF * scale


def run_shadow(sh: Shadow, h, u, rate, *, scale=1.0, c=None, d=None):
    """The shadow's outputs and certified row errors at the communication points.

    Parameters
    ----------
    sh : Shadow
    h : ndarray (M,)
        Communication step lengths [s] (from the start time).
    u, rate : ndarray (M, m)
        The inputs over each step (f, F_j/area) and their rates (0: held).
    scale : float
        initial_state_scale.
    c, d : float
        A parametric model's parameters.

    Returns
    -------
    (y (M+1, n_rows), cert (M+1, n_rows), norms dict): the shadow's rows and the bound of |row·(x - S w)|.
    """
    h = np.asarray(h, float)
    u = np.atleast_2d(np.asarray(u, float)).reshape(h.size, sh.n_inputs)
    rate = np.atleast_2d(np.asarray(rate, float)).reshape(h.size, sh.n_inputs)
    blocks = sh.blocks(c, d)
    mu = growth_rate(blocks)
    cn = sh.dual_norms(c)
    enorm = sh.residual_norm(c, d)
    gram = sh.gram
    w = float(scale) * sh.w0.copy()
    tv = np.zeros(sh.n_inputs)
    uprev = np.zeros(sh.n_inputs)
    p_int = w_int = 0.0
    cache, grams = {}, {}
    dense = sh.E_gram is not None
    Y, CERT = [], []
    tau = 0.0

    def cert(tau, n):
        b = min(int(math.floor(tau / sh.dt_tab)), sh.G.shape[1] - 1) if sh.dt_tab > 0 else 0
        gtab = sh.G[:, b] * (np.where(sh.row_e, math.sqrt(sh.c_ref / float(c)), 1.0) if sh.parametric else 1.0)
        ginit = abs(scale) * np.minimum(gtab, cn * sh.y0_norm)
        gin = np.minimum(hoelder_input(sh.H, tv), cn * p_int)
        allow = cn * (ROUNDOFF + ROUNDOFF_STEP * n) * (np.linalg.norm(w) + abs(scale) * sh.x0_norm)
        residual = cn * w_int if dense else cn * enorm * w_int      # dense: w_int is ∫‖E w‖
        return ginit + gin + residual + allow

    Y.append(sh.C @ w)
    CERT.append(cert(0.0, 0))
    for k in range(h.size):
        hk = float(h[k])
        if hk not in cache:
            cache[hk] = block_maps(blocks, sh.B, hk)
        u0, r = u[k], rate[k]
        du = r * hk
        tv += np.abs(u0 - uprev) + np.abs(du)
        uprev = u0 + du
        q = hk * (u0 @ gram @ u0) + hk * (u0 @ gram @ du) + hk / 3.0 * (du @ gram @ du)
        p_int += math.sqrt(max(hk * q, 0.0))
        if dense:                       # ∫‖E w‖ <= sqrt(h ∫‖E w‖²) = h sqrt(Yᵀ Q Y) over the step
            if hk not in grams:
                grams[hk] = residual_gram(blocks[0], sh.B, sh.E_gram, hk)
            (Q, allowance), aug = grams[hk], np.concatenate([w, u0, du])
            quad = aug @ Q @ aug + allowance * (aug @ aug)
            w_int += hk * math.sqrt(max(quad, 0.0))
        else:
            w_int += hk * math.exp(mu * hk) * (np.linalg.norm(w) + hk * sh.B_norm * max(np.linalg.norm(u0),
                                                                                          np.linalg.norm(u0 + du)))
        new, at = np.empty_like(w), 0
        for (phi, g0, g1), L in zip(cache[hk], blocks):
            b = L.shape[0]
            new[at:at + b] = phi @ w[at:at + b] + g0 @ u0 + g1 @ du
            at += b
        w = new
        tau += hk
        Y.append(sh.C @ w)
        CERT.append(cert(tau, k + 1))
    return np.array(Y), np.array(CERT)


def hoelder_input(H, tv):
    """Σ_i H[r, i] tv[i] per row, an input whose variation is 0 adding nothing (also where H is inf)."""
    with np.errstate(invalid="ignore"):                 # inf x 0 of an unused input: masked here
        return np.where(np.asarray(tv)[None, :] > 0, H * np.asarray(tv)[None, :], 0.0).sum(axis=1)


def output_bounds(sh: Shadow, y, cert, v_model, rho_model, port_model=None):
    """The bounds of the model's outputs (module docstring) from the shadow's rows ``y`` and their ``cert`` (M, n_rows)
    and the model's v_probe (M, P), rho_probe (M, P), v_port (M, n_ports): (v_bound, rho_bound, port_bound)."""
    P = sh.n_probes
    v_bound = np.abs(np.asarray(v_model) - y[:, :P]) + cert[:, :P]
    e = y[:, P:3 * P].reshape(-1, P, 2)
    beta = cert[:, P:3 * P].reshape(-1, P, 2)
    J = 1.0 + e
    low = J - beta
    rho_s = np.sum(sh.pw * sh.prho0 / J, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        part = np.sum(sh.pw * sh.prho0 * beta / (J * low), axis=2)
    part = np.where(np.all(low > 0, axis=2), part, np.inf)
    rho_bound = np.abs(np.asarray(rho_model) - rho_s) + part + 1e-15 * np.sum(sh.pw * sh.prho0, axis=1)
    port_bound = None
    if sh.n_ports:
        port_bound = np.abs(np.asarray(port_model) - y[:, 3 * P:]) + cert[:, 3 * P:]
    return v_bound, rho_bound, port_bound


# ---------------------------------------------------------------------------------------------------------------
# the FMU's sections (resources/model.bin; fmu_src/rom_bound.c reads them)
# ---------------------------------------------------------------------------------------------------------------

TOLERANCE_FRACTION = 0.05   # error_tolerance's default: this x the training run's largest |v_probe| [m s^-1]
FMU_MAX_PARTICLES = 2000    # above this N the FMU carries no shadow (its dense SVD would dominate the packaging)
DENSE_MAX_ORDER = 160       # the largest k_s of an FMU's dense shadow (its residual's exponential is 2 (k_s + 2 m) square)
N_SCALARS = 12              # columns of section SHSCAL


def fmu_shadow(problem, probes, ports=(), *, parametric=False, scale_v=None, force=None, T=None, port_inputs=True):
    """The shadow of an FMU's outputs, or None where the C core cannot certify it: more than
    :data:`FMU_MAX_PARTICLES` particles (the dense singular value decomposition of the coupling), or a parametric
    model whose c or d is not uniform.  ``parametric``: the shadow of a parametric FMU (:mod:`sphrom.rom.parametric`,
    uniform c and d), its planes in pieces about the scene's c (c_ref).  A damping d that is not uniform gives the
    dense fallback (one Galerkin block on the planes, the complement by the energy; module docstring).
    ``port_inputs`` False: the port rows without the port input columns (the port channel takes the port forces,
    :mod:`sphrom.rom.port_channel`)."""
    d = np.asarray(problem.d, float)
    if d.size > FMU_MAX_PARTICLES:
        return None
    if parametric and not (problem.terms["uniform_c"] and np.all(d == d[0])):
        return None
    uniform_d = bool(np.all(d == d[0]))
    return build_shadow(problem, probes, ports, parametric=parametric, scale_v=scale_v, force=force, T=T,
                        max_order=MAX_ORDER if uniform_d else DENSE_MAX_ORDER, port_inputs=port_inputs)


def growth_rate(blocks):
    """mu: the largest eigenvalue of a block's symmetric part over the blocks, 0 at least (:func:`run_shadow`)."""
    return max([0.0] + [float(np.max(np.linalg.eigvalsh(0.5 * (L + L.T)))) for L in blocks])


def sections(sh: Shadow):
    """{tag: 2-D float64 array} of the shadow for resources/model.bin (fmu_src/rom.h, section SH*):

    SHSCAL (1, 12)   k_s, planes (k_s / 2), inputs m, rows, table length, dt_tab [s], ‖y0‖, ‖x0‖, ‖E‖, ‖B‖,
                     error_tolerance's default [m s^-1], 0
    SHLAM (planes, 4)  each plane's Λ_i row-major [s^-1] (parametric: its constant piece; dense: below)
    SHB (k_s, m), SHC (rows, k_s), SHW0 (1, k_s), SHGRAM (m, m)
    SHROW (rows, 1 + m + table)  per row: ‖c_r‖, sup|H| per input (-1: none), the envelope G(t_b)
    SHPROBE (P, 4)   per probe: the weights and ρ0 of its two particles [kg m^-3]

    A parametric shadow (``sh.parametric``: Λ_i(c, d) = SHLAM_i + c SHPIECE_i[0:4] + d SHPIECE_i[4:8], in this
    order, as :meth:`Shadow.blocks`) adds two sections, and its file needs section PARAMS (the model's c and d):

    SHPIECE (planes, 8)  each plane's piece per unit c [kg^-1 m s], then per unit d [1], row-major
    SHPARAM (1, 7)       c_ref [kg m^-1 s^-2] (the c of the energy coordinates: ‖c_r‖ and G of the e rows at c
                         are SHROW's x sqrt(c_ref / c)), then ‖E_p‖ of the pieces (const, c, d) row-major, of their
                         v rows and e rows (‖E(c, d)‖ = Σ_p coef_p (E_p,v + sqrt(c / c_ref) E_p,e), coef = 1, c, d)

    its SHSCAL's ‖E‖ is 0 (the C core computes it at (c, d)), its table one column (G for all t, dt_tab = T) and
    sup|H| -1 (none).  A shadow without invariant planes (a damping d that is not uniform: one dense block, the
    Galerkin model on the planes) has SHLAM (k_s, k_s), that block row-major, and adds

    SHDENSE (1, 1)   mu [s^-1]: the largest eigenvalue of the block's symmetric part, 0 at least (:func:`growth_rate`)
    SHEGRAM (k_s, k_s)  Eᵀ E of the coupling residual E = A S - S Λ [s^-2] (the residual term ‖c‖ ∫‖E w‖,
                     :func:`residual_gram`)

    its table one column (‖c_r‖ ‖y0‖), sup|H| -1 and ‖E‖ the norm of the coupling residual (information).  A shadow of invariant planes
    at fixed parameters has exactly the first eight sections.
    """
    dense = not sh.info.get("invariant")
    if dense and (sh.parametric or sh.sizes.size != 1):
        raise ValueError("the FMU's dense shadow is one block at fixed parameters")
    if not dense and np.any(sh.sizes != 2):
        raise ValueError("the FMU's shadow needs invariant planes or one dense block")
    m = sh.n_inputs
    H = np.where(np.isfinite(sh.H), sh.H, -1.0)
    tol = TOLERANCE_FRACTION * float(sh.info.get("scale_v", 0.0))
    scal = [sh.order, sh.order // 2, m, sh.n_rows, sh.G.shape[1], sh.dt_tab, sh.y0_norm, sh.x0_norm,
            0.0 if sh.parametric else sh.residual_norm(), sh.B_norm, tol, 0.0]
    out = {"SHSCAL": np.array([scal], float),
           "SHLAM": np.asarray(sh.A[0], float).reshape(-1, sh.order if dense else 4),
           "SHB": np.asarray(sh.B, float).reshape(sh.order, m),
           "SHC": np.asarray(sh.C, float),
           "SHW0": np.asarray(sh.w0, float)[None, :],
           "SHGRAM": np.asarray(sh.gram, float).reshape(m, m),
           "SHROW": np.column_stack([sh.row_norm, H, sh.G]),
           "SHPROBE": np.column_stack([sh.pw, sh.prho0])}
    if sh.parametric:
        out["SHPIECE"] = np.column_stack([np.asarray(sh.A[1], float).reshape(-1, 4),
                                          np.asarray(sh.A[2], float).reshape(-1, 4)])
        out["SHPARAM"] = np.concatenate([[sh.c_ref], np.asarray(sh.E, float).ravel()])[None, :]
    if dense:
        out["SHDENSE"] = np.array([[growth_rate(sh.blocks())]])
        out["SHEGRAM"] = np.asarray(sh.E_gram, float)
    return out
