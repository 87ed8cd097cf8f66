"""The invariant planes of the full linear SPH, and the modes of each plane: what the certified bounds
(:mod:`.bounds`) are built from.

The full SPH of eqs. 2.10-2.11 is exactly linear in J (:mod:`.lti`); in energy coordinates x = [√ρ0 v; √c e] it
is ẋ = A x + B u, A = [[-D, K], [-Kᵀ, 0]], K = ρ0^-½ G c^½ (sparse, banded: G couples particles within the
kernel's reach).  Two decompositions of A into invariant planes (2 x 2 blocks):

- **A uniform damping d** (:func:`singular_planes`): each singular triplet (σ_i, u_i, w_i) of K spans the invariant
  plane S_i = [[u_i, 0], [0, w_i]] with the block Λ_i = [[-d, σ_i], [-σ_i, 0]] (orthonormal planes, any ρ0(x) and
  c(x)).  All of them from the dense singular value decomposition up to :data:`DENSE_LIMIT` particles; above, the
  lowest ``count`` from a sparse shift-invert Lanczos solver on KᵀK (banded), the rest left uncomputed (the
  bounds then bound them through norms, never forming them).
- **A damping that varies** (:func:`eigen_planes`): the eigenvectors of A itself (dense, up to
  :data:`EIGEN_LIMIT` particles): a complex pair λ = -α ± iω spans a real plane V_i = [Re v, Im v] with the block
  [[-α, ω], [-ω, -α]], two real eigenvalues share a plane as a diagonal block; the left basis W = V^-ᵀ (not
  orthonormal: the planes' conditioning enters every coefficient W_iᵀ b and V_iᵀ c).

:func:`plane_modes` splits each 2 x 2 block into its modes in normal form (a complex pair, or two real
eigenvalues), with each mode's decay rate α, |λ| and the transformed coefficients of the rows, inputs and initial
state: in normal form ‖e^{N t}‖ = e^{-α t} exactly, which is what makes every complement term of the bounds decay.
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .inputs import NULL_TOL, rigid_modes  # noqa: F401  (NULL_TOL: its former home)
from .lti import full_linear_system

DENSE_LIMIT = 2500          # particles: the dense singular value decomposition of K up to here
EIGEN_LIMIT = 2500          # particles: the dense eigenvectors of A (a damping that varies) up to here (DENSE_LIMIT's)
DEFECT = 1e-7               # a block whose eigenvalues are closer than this (relative) is treated as defective


@dataclass
class Planes:
    """Invariant planes of the full linear SPH, lowest first (module docstring).

    Attributes
    ----------
    blocks : ndarray (3, n, 2, 2)
        Each plane's block in pieces: Λ_i(c, d) = blocks[0] + c blocks[1] + d blocks[2] for a parametric model
        (uniform c and d, about c_ref), else blocks[0] alone (the others zero) [s^-1].
    Vv, Ve : ndarray (N, n, 2)
        The right basis: plane i is the 2N x 2 matrix [[Vv[:, i]], [Ve[:, i]]] (v rows, e rows).
    Wv, We : ndarray (N, n, 2)
        The left basis (W_iᵀ V_j = δ_ij I); the right one itself for orthonormal planes.
    key : ndarray (n,)
        The ordering frequency (σ_i, or |λ| of the plane's slower mode) [s^-1].
    complete : bool
        Every plane of A (the complement of a shadow is exactly the planes it leaves out); False: the lowest
        ``n`` planes of the singular value decomposition, the rest uncomputed.
    orthonormal : bool
    info : dict
        sigma_cut (the largest computed σ, below every uncomputed one), timings.
    """

    blocks: np.ndarray
    Vv: np.ndarray
    Ve: np.ndarray
    Wv: np.ndarray
    We: np.ndarray
    key: np.ndarray
    complete: bool
    orthonormal: bool
    info: dict = field(default_factory=dict)

    @property
    def count(self):
        return int(self.key.size)

    def right(self, X):
        """Vᵀ X: the coefficients (n, 2, ...) of rows X (2N, ...) (an output row c gives ĉ_i = V_iᵀ c)."""
        n = self.Vv.shape[0]
        X = np.asarray(X, float)
        return np.einsum("jik,j...->ik...", self.Vv, X[:n]) + np.einsum("jik,j...->ik...", self.Ve, X[n:])

    def left(self, X):
        """Wᵀ X: the coordinates (n, 2, ...) of states or input columns X (2N, ...)."""
        if self.orthonormal:
            return self.right(X)
        n = self.Wv.shape[0]
        X = np.asarray(X, float)
        return np.einsum("jik,j...->ik...", self.Wv, X[:n]) + np.einsum("jik,j...->ik...", self.We, X[n:])

    def basis(self, keep):
        """The 2N x 2k right basis of the planes ``keep`` (plane order, two columns each)."""
        keep = np.asarray(keep, np.int64)
        return np.vstack([self.Vv[:, keep].reshape(self.Vv.shape[0], -1),
                          self.Ve[:, keep].reshape(self.Ve.shape[0], -1)])

    def left_basis(self, keep):
        keep = np.asarray(keep, np.int64)
        return np.vstack([self.Wv[:, keep].reshape(self.Wv.shape[0], -1),
                          self.We[:, keep].reshape(self.We.shape[0], -1)])


def gap_cuts(sig, rel=1e-9):
    """The counts n at which the ordering frequencies have a gap (σ_n > σ_{n-1} (1 + rel) + rel σ_max): a
    degenerate pair (a cos and a sin of one wavenumber) is kept or left together."""
    top = float(sig[-1]) if sig.size else 0.0
    return [n for n in range(1, sig.size + 1) if n == sig.size or sig[n] > sig[n - 1] * (1 + rel) + rel * top]


def coupling(problem):
    """K = ρ0^-½ G c^½ as a sparse CSR matrix (N x N) [s^-1]."""
    G = problem.neighbours.matrix().tocsr()
    return (sp.diags(1.0 / np.sqrt(problem.rho0)) @ G @ sp.diags(np.sqrt(problem.c))).tocsr()


def null_rows(problem):
    """Orthonormal bases (N, k) of ker Kᵀ (v side: √ρ0 times the kernels of Gᵀ) and ker K (e side: c^-½ times
    those of G) among the rigid candidates {1, (-1)^i} (:func:`sphrom.rom.inputs.rigid_modes`)."""
    G = problem.neighbours.matrix().tocsr()
    out = []
    for M, weight in ((G.T.tocsr(), np.sqrt(problem.rho0)), (G, 1.0 / np.sqrt(problem.c))):
        k = rigid_modes(M)                                  # inputs.kernel_tol(N)
        if k.size == 0:
            out.append(np.zeros((problem.rho0.size, 0)))
            continue
        Q, _ = np.linalg.qr(weight[:, None] * k)
        out.append(Q)
    return out


def _pieces(problem, sig, parametric):
    """(3, n, 2, 2) block pieces of the singular planes: [[-d, σ], [-σ, 0]] at fixed parameters, or, about
    c_ref with uniform c and d, [[0, 0], [-σ, 0]] + c [[0, σ/c_ref], [0, 0]] + d [[-1, 0], [0, 0]]."""
    n = sig.size
    out = np.zeros((3, n, 2, 2))
    if parametric:
        c_ref = float(problem.c[0])
        out[0, :, 1, 0] = -sig
        out[1, :, 0, 1] = sig / c_ref
        out[2, :, 0, 0] = -1.0
    else:
        out[0, :, 0, 0] = -float(problem.d[0])
        out[0, :, 0, 1] = sig
        out[0, :, 1, 0] = -sig
    return out


def singular_planes(problem, count=None, parametric=False):
    """The planes of the singular triplets of K, lowest σ first (module docstring): all of them (dense) when N <=
    :data:`DENSE_LIMIT` or ``count`` is None and N is small enough, else the lowest ``count`` (sparse, whole
    degenerate clusters: a trailing cluster cut by ``count`` is dropped).  Needs a uniform d (the planes are
    invariant only then)."""
    t0 = time.perf_counter()
    n = problem.rho0.size
    d = np.asarray(problem.d, float)
    if not np.all(d == d[0]):
        raise ValueError("singular planes need a uniform damping d (use eigen_planes)")
    K = coupling(problem)
    if n <= DENSE_LIMIT:
        U, sig, Wt = np.linalg.svd(K.toarray())
        order = np.argsort(sig, kind="stable")
        U, sig, W = U[:, order], sig[order], Wt.T[:, order]
        complete = True
    else:
        U, sig, W = _sparse_triplets(problem, K, int(count or 128))
        complete = False
    Z = np.zeros((n, sig.size))
    pl = Planes(blocks=_pieces(problem, sig, parametric), Vv=np.stack([U, Z], axis=2), Ve=np.stack([Z, W], axis=2),
                Wv=None, We=None, key=sig.copy(), complete=complete, orthonormal=True,
                info={"sigma_cut": float(sig[-1]) if sig.size else 0.0, "seconds": time.perf_counter() - t0,
                      "method": "dense SVD" if complete else "sparse Lanczos (shift-invert, KᵀK)"})
    pl.Wv, pl.We = pl.Vv, pl.Ve
    return pl


def _sparse_triplets(problem, K, count):
    """The lowest ``count`` singular triplets of the sparse K (σ ascending), whole degenerate clusters."""
    n = K.shape[0]
    u_null, w_null = null_rows(problem)
    M = (K.T @ K).tocsc()
    scale = float(abs(M).sum(axis=1).max())
    shift = -1e-8 * scale                                   # below 0: M - shift I is definite
    k = min(count + 8, n - 2)
    lu = spl.splu((M - shift * sp.identity(n, format="csc")).tocsc())
    op = spl.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    # a fixed start vector (ARPACK's default is random): the same planes, so the same model.bin, from run to run
    v0 = np.random.default_rng(0).standard_normal(n)
    vals, W = spl.eigsh(M, k=k, sigma=shift, which="LM", OPinv=op, tol=0.0, v0=v0)
    order = np.argsort(vals)
    vals, W = np.maximum(vals[order], 0.0), W[:, order]
    sig = np.sqrt(vals)
    nz = w_null.shape[1]
    # the null triplets: their own bases (Lanczos returns some basis of ker K; ker Kᵀ is known)
    W = np.column_stack([w_null, W[:, nz:]]) if nz else W
    W, _ = np.linalg.qr(W)                                  # re-orthonormalise (clusters mixed by Lanczos)
    sig = np.concatenate([np.zeros(nz), sig[nz:]])
    # Rayleigh-Ritz on the computed subspace: exact singular vectors of K restricted to it
    KW = K @ W[:, nz:]
    Uh, s, Vt = np.linalg.svd(KW, full_matrices=False)
    order = np.argsort(s)
    U = np.column_stack([u_null, Uh[:, order]])
    W = np.column_stack([W[:, :nz], W[:, nz:] @ Vt.T[:, order]])
    sig = np.concatenate([np.zeros(nz), s[order]])
    cuts = [c for c in gap_cuts(sig) if c <= min(count, sig.size - 1)]
    keep = cuts[-1] if cuts else sig.size
    return U[:, :keep], sig[:keep], W[:, :keep]


# the last eigen-planes computed, by the hash of their A: packaging a scene builds the shadow of each FMU it tries
# (the default, the exact, a cheaper configuration), minutes of the same dense eigenvectors each at N = 2500
_EIGEN_MEMO: dict = {}


def eigen_planes(problem, parametric=False):
    """The eigen-planes of A (any damping d(x), dense, N <= :data:`EIGEN_LIMIT`), slowest |λ| first (module
    docstring).  The null modes (eigenvalue 0, e = c^-½ k with k in ker G: uncontrollable, unobservable in v, not in
    x0) become a diagonal block of their own.

    One real eigendecomposition (LAPACK dgeev, right vectors only, O((2N)^3): the cost that sets the limit) and
    one real inverse for the left basis; ``info`` records the residual ‖A V - V Λ‖ and the condition
    ‖V‖ ‖W‖ (2-norms, estimated by Lanczos: the planes' conditioning enters every coefficient).  The planes of the
    last A are kept (read-only) and returned again for the same A (``info["reused"]``)."""
    if parametric:
        raise ValueError("a parametric shadow needs uniform c and d (singular planes)")
    t0 = time.perf_counter()
    n = problem.rho0.size
    if n > EIGEN_LIMIT:
        raise ValueError(f"n_particles: {n} is out of range for the error bounds of a damping that varies "
                         f"(allowed: up to {EIGEN_LIMIT}; the eigenvectors of A are dense)")
    As = full_linear_system(problem, [0.5]).A.tocsr()
    As.sum_duplicates()
    key = hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes()
                                  for a in (np.asarray(As.shape), As.indptr, As.indices, As.data))).hexdigest()
    if key in _EIGEN_MEMO:
        kept = _EIGEN_MEMO[key]
        return dataclasses.replace(kept, info={**kept.info, "reused": True})
    geev, geev_lwork = sla.get_lapack_funcs(("geev", "geev_lwork"), (np.empty(0),))
    # the optimal workspace (f2py's default is the minimal one: unblocked Hessenberg reduction, several times slower)
    work, info = geev_lwork(2 * n, compute_vl=0, compute_vr=1)
    lwork = max(int(work), 4 * 2 * n) if info == 0 else 66 * 2 * n
    wr, wi, _, vr, info = geev(As.toarray(), lwork=lwork, compute_vl=0, compute_vr=1, overwrite_a=1)
    if info != 0:
        raise RuntimeError(f"the eigenvalues of A did not converge (LAPACK dgeev info {info})")
    t_eig = time.perf_counter() - t0
    # dgeev's real form: a complex pair λ = a ± ib (b > 0 first) is two adjacent columns p, q of vr, the
    # eigenvector p ± iq, so A [p q] = [p q] [[a, b], [-b, a]]; a real eigenvalue has wi exactly 0
    cols, blocks, keys, reals = [], [], [], []
    j = 0
    while j < wr.size:
        if wi[j] != 0.0:
            if not (wi[j] > 0.0 and j + 1 < wr.size and wi[j + 1] == -wi[j] and wr[j + 1] == wr[j]):
                raise RuntimeError("the eigenvalues of A are not in LAPACK's real form (a pair not adjacent)")
            cols.append((j, j + 1))
            blocks.append([[wr[j], wi[j]], [-wi[j], wr[j]]])
            keys.append(float(np.hypot(wr[j], wi[j])))
            j += 2
        else:
            reals.append(j)
            j += 1
    # real eigenvalues: two to a diagonal plane, in order of |λ| (their count is even: 2N minus the pairs')
    reals.sort(key=lambda i: abs(wr[i]))
    for a in range(0, len(reals), 2):
        pair = reals[a:a + 2]
        if len(pair) == 1:
            raise RuntimeError("an odd number of real eigenvalues of A")
        cols.append(tuple(pair))
        blocks.append([[wr[pair[0]], 0.0], [0.0, wr[pair[1]]]])
        keys.append(float(min(abs(wr[pair[0]]), abs(wr[pair[1]]))))
    order = np.argsort(np.asarray(keys), kind="stable")
    V = vr[:, np.asarray([cols[i] for i in order], np.int64).reshape(-1)]      # (2N, 2n): plane order
    del vr
    W = np.ascontiguousarray(sla.inv(V, check_finite=False).T).reshape(2 * n, -1, 2)   # left basis: Wᵀ V = I
    bl = np.zeros((3, order.size, 2, 2))
    bl[0] = np.asarray([blocks[i] for i in order], float)
    Vp = V.reshape(2 * n, order.size, 2)
    resid = As @ V - np.einsum("jik,ikl->jil", Vp, bl[0]).reshape(2 * n, -1)
    out = Planes(blocks=bl, Vv=Vp[:n], Ve=Vp[n:], Wv=W[:n], We=W[n:], key=np.asarray(keys)[order], complete=True,
                 orthonormal=False,
                 info={"sigma_cut": float("inf"), "seconds": time.perf_counter() - t0, "seconds_eig": t_eig,
                       "method": "dense eig(A)", "residual": _norm2(resid),
                       "condition": _norm2(V) * _norm2(W.reshape(2 * n, -1)), "reused": False})
    for a in (out.blocks, out.Vv, out.Ve, out.Wv, out.We, out.key):
        a.flags.writeable = False
    _EIGEN_MEMO.clear()
    _EIGEN_MEMO[key] = out
    return out


def _norm2(X):
    """The 2-norm (largest singular value) of a dense matrix, by Lanczos (a dense SVD of a 5000 x 5000 matrix
    takes minutes)."""
    X = np.asarray(X, float)
    if min(X.shape) < 3 or not np.any(X):
        return float(np.linalg.norm(X, 2)) if X.size else 0.0
    return float(spl.svds(X, k=1, return_singular_vectors=False, tol=1e-8, random_state=0)[0])


# ---------------------------------------------------------------------------------------------------------------
# the modes of 2 x 2 blocks
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class Modes:
    """The modes of a set of planes in normal form (:func:`plane_modes`), one entry per mode.

    Attributes
    ----------
    plane : ndarray (M,) of int
        The plane each mode belongs to.
    alpha : ndarray (M,)
        Decay rate: ‖e^{N t}‖ <= scale e^{-α t} [s^-1] (α >= 0).
    mu : ndarray (M,) of complex
        The exponent of the mode's signals: -α - iω (a complex pair, normal form [[-α, ω], [-ω, -α]]), λ (real).
    absl : ndarray (M,)
        |λ| (inf where the block is singular on a mode that no input reaches) [s^-1].
    gamma : ndarray (rows, M)
        |γ'|: the rows' coefficients on the mode (normal-form coordinates).
    beta : ndarray (M, m)
        |β'|: the inputs' coefficients.
    P : ndarray (rows, M) of complex
        The free response's amplitude: γ'ᵀ e^{N t} η' = Re(P e^{μ t}).
    scale : ndarray (M,)
        1 for a normal mode; the transient growth factor of a defective block's bound (its decay halved).
    eta : ndarray (M,)
        |η'|: the initial state's coefficient.
    exact : ndarray (M,) of bool
        Re(P e^{μ t}) is the mode's free response itself (False: a defective block, P e^{μ t} bounds its size).
    """

    plane: np.ndarray
    alpha: np.ndarray
    mu: np.ndarray
    absl: np.ndarray
    gamma: np.ndarray
    beta: np.ndarray
    P: np.ndarray
    scale: np.ndarray
    eta: np.ndarray
    exact: np.ndarray


def plane_modes(L, chat, bhat, eta):
    """The modes of the 2 x 2 blocks ``L`` (n, 2, 2) with the rows' coefficients ``chat`` (rows, n, 2), the inputs'
    ``bhat`` (n, 2, m) and the initial state's ``eta`` (n, 2) on each plane (:class:`Modes`).

    A complex pair λ = a ± iω: with the eigenvector v = p + iq, T = [p q] gives T^-1 L T = [[a, ω], [-ω, a]]
    (normal: ‖e^{Nt}‖ = e^{a t}); γ' = Tᵀ ĉ, β' = T^-1 b̂, η' = T^-1 η.  Two real eigenvalues: T = [v1 v2]
    diagonalises L, one mode each.  A defective block (eigenvalues within :data:`DEFECT`, relative): no transform;
    ‖e^{Lt}‖ <= (1 + ‖L - a I‖ t) e^{a t} <= scale e^{a t / 2}, one mode of rate -a/2 carrying ‖ĉ‖, ‖b̂‖, ‖η‖.
    """
    L = np.asarray(L, float)
    n = L.shape[0]
    rows, m = chat.shape[0], bhat.shape[2]
    a_, b_, c_, d_ = L[:, 0, 0], L[:, 0, 1], L[:, 1, 0], L[:, 1, 1]
    half = 0.5 * (a_ + d_)
    disc = (0.5 * (a_ - d_)) ** 2 + b_ * c_
    size = np.abs(L).reshape(n, -1).max(axis=1)
    defective = np.abs(disc) <= (DEFECT * np.maximum(size, 1e-300)) ** 2
    out = {k: [] for k in ("plane", "alpha", "mu", "absl", "gamma", "beta", "P", "scale", "eta", "exact")}

    def add(i, alpha, mu, absl, gam, bet, P, scale, et, exact=True):
        out["exact"].append(exact)
        out["plane"].append(i)
        out["alpha"].append(alpha)
        out["mu"].append(mu)
        out["absl"].append(absl)
        out["gamma"].append(gam)
        out["beta"].append(bet)
        out["P"].append(P)
        out["scale"].append(scale)
        out["eta"].append(et)

    for i in range(n):
        Li = L[i]
        if defective[i] or size[i] == 0.0:
            a = half[i]
            N0 = np.linalg.norm(Li - a * np.eye(2), 2)
            gam = np.linalg.norm(chat[:, i], axis=1)
            bet = np.linalg.norm(bhat[i], axis=0)
            et = float(np.linalg.norm(eta[i]))
            sv = np.linalg.svd(Li, compute_uv=False)
            absl = sv[-1] if sv[-1] > 1e-14 * max(sv[0], 1e-300) else 0.0
            if N0 <= 1e-14 * max(size[i], 1e-300):       # L = a I: e^{Lt} = e^{at} I, exact
                add(i, max(-a, 0.0), complex(a), abs(a), gam, bet, chat[:, i] @ eta[i] + 0j, 1.0, et, True)
                continue
            alpha = max(-a, 0.0) / 2.0
            if alpha > 0 and N0 > alpha:
                scale = (N0 / alpha) * np.exp(alpha / N0 - 1.0)
            elif alpha > 0:
                scale = 1.0
            else:
                scale = np.inf                          # undamped and defective: no bound of this kind
            add(i, alpha, complex(-alpha), absl, gam, bet, gam * et * scale + 0j, scale, et, False)
            continue
        if disc[i] < 0:
            w = np.sqrt(-disc[i])
            lam = complex(half[i], w)
            v = np.array([b_[i], lam - a_[i]]) if abs(b_[i]) >= abs(c_[i]) else np.array([lam - d_[i], c_[i]])
            T = np.column_stack([v.real, v.imag])
            Ti = np.linalg.inv(T)
            gam_v = chat[:, i] @ T                      # (rows, 2): Tᵀ ĉ
            bet_v = Ti @ bhat[i]                         # (2, m)
            eta_v = Ti @ eta[i]
            g = np.linalg.norm(gam_v, axis=1)
            P = (gam_v @ eta_v) + 1j * (gam_v[:, 0] * eta_v[1] - gam_v[:, 1] * eta_v[0])
            add(i, max(-half[i], 0.0), complex(half[i], -w), abs(lam), g, np.linalg.norm(bet_v, axis=0), P, 1.0,
                float(np.linalg.norm(eta_v)))
        else:
            r = np.sqrt(disc[i])
            lams = (half[i] + r, half[i] - r)
            vecs = []
            for lam in lams:
                v = np.array([b_[i], lam - a_[i]]) if abs(b_[i]) >= abs(c_[i]) else np.array([lam - d_[i], c_[i]])
                if not np.any(v):                       # diagonal block
                    v = np.array([1.0, 0.0]) if abs(lam - a_[i]) <= abs(lam - d_[i]) else np.array([0.0, 1.0])
                vecs.append(v / np.linalg.norm(v))
            T = np.column_stack(vecs)
            if abs(np.linalg.det(T)) < 1e-12:           # diagonal with b = c = 0 handled above; guard
                T = np.eye(2)
            Ti = np.linalg.inv(T)
            gam_v = chat[:, i] @ T
            bet_v = Ti @ bhat[i]
            eta_v = Ti @ eta[i]
            for k, lam in enumerate(lams):
                add(i, max(-lam, 0.0), complex(lam), abs(lam), np.abs(gam_v[:, k]), np.abs(bet_v[k]),
                    gam_v[:, k] * eta_v[k] + 0j, 1.0, float(abs(eta_v[k])))
    M = len(out["plane"])
    return Modes(plane=np.asarray(out["plane"], np.int64), alpha=np.asarray(out["alpha"], float),
                 mu=np.asarray(out["mu"], complex), absl=np.asarray(out["absl"], float),
                 gamma=np.asarray(out["gamma"], float).T.reshape(rows, M),
                 beta=np.asarray(out["beta"], float).reshape(M, m),
                 P=np.asarray(out["P"], complex).T.reshape(rows, M), scale=np.asarray(out["scale"], float),
                 eta=np.asarray(out["eta"], float), exact=np.asarray(out["exact"], bool))
