"""Beyond the paper: the full linear SPH of a uniform scene in its Fourier modes (the scalable Gramian layer).

On the uniform periodic lattice with constant ρ0, c and d, the SPH gradient G of eq. 2.9 is circulant, so the
discrete Fourier transform splits the full linear system of :mod:`sphrom.rom.lti` (ẋ_v = s G x_e - d x_v + b u,
ẋ_e = s G x_v, s = √(c/ρ0), energy coordinates) into N decoupled 2 × 2 systems, one per wavenumber k:

    d/dt [x̂_v; x̂_e]_k = A_k [x̂_v; x̂_e]_k + b̂_k u,   A_k = [[-d, s g_k], [s g_k, 0]],

g_k = the k-th eigenvalue of G (the FFT of its first column; imaginary, G being skew), and
y_j = Σ_k ĉ_jkᴴ x̂_k (Parseval, the unitary DFT).  This gives reduce-then-balance with a certified loss:

intermediate model (:func:`modal_system`)
    The Galerkin projection of the full LTI on the real Fourier modes of wavenumbers |k| <= K (cosines and
    sines, orthonormal; V_m = blockdiag(F, F), 2m = 2(2K + 1) states), computed with the sparse A (O(N m)), so
    it keeps the port-Hamiltonian structure (J_m skew, R_m >= 0) and is an exact sub-sum of the modal
    decomposition up to round-off.  The dense balancing of :mod:`sphrom.rom.balanced` runs on it at the cost
    of a 2m-state system, whatever N; the reduced model is lifted back (V = V_m V_b, W = V_m W_b), so it is a
    (Petrov-)Galerkin model of the full system.
tail bounds (:func:`tail_bounds`)
    G - G_m is the sum of the dropped modes' 2 × 2 transfer functions, so by the triangle inequality
    ‖G - G_r‖ <= ‖G_m - G_r‖ + Σ_{k dropped} ‖ĉ_kᴴ (sI - A_k + σI)^-1 b̂_k‖_H∞, each term bounded in closed
    form from its two poles (partial fractions); the free responses' L² error likewise gets
    Σ_k ‖ĉ_kᴴ e^{A_k t} x̂0_k‖_L2(0,T) <= Σ_k √T |ĉ_k| |x̂0_k| (e^{A_k t} is a contraction in energy
    coordinates).  :func:`error_bounds` adds them to the certified bounds of the intermediate model
    (:func:`sphrom.rom.balanced.error_bounds` at 2m states): certified bounds against the full system at
    N = 10⁴ in the time the dense path takes at N ≈ m.

Why not low-rank Gramians (pyMOR's ADI): the outputs are point probes, whose rows reach every Fourier mode with
the same weight, so the observability Gramian Q of the (shifted, lightly damped) system has nearly full numerical
rank (``sphrom bench scale`` measures it on the modal system); a low-rank factor of Q does not exist, and the shifted spectrum lies along a
vertical line, where ADI shifts converge slowly.  The modal structure costs one FFT.

Scenes that are not uniform (a jump in c, a varying ρ0 or d) keep the dense path (:func:`applies` is False).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .lti import LTI

DENSE_ORDER = 2000          # 2N above this (N > 1000) takes the modal path in "auto" (every built-in scene is <= 1000)
DEFAULT_WAVENUMBERS = 100   # K: the intermediate model keeps |k| <= K, 2(2K + 1) = 402 states (the dense N = 200)
CIRCULANT_TOLERANCE = 1e-10  # max |G - circ(G[:, 0])| relative to max |G|: uniform lattice (round-off of positions)
STRUCTURES = ("auto", "dense", "modal")
NULL_TOLERANCE = 1e-9       # |g_k| <= this · max |g|: a null wavenumber (k = 0, N/2); the smallest other is ~π/N of it


@dataclasses.dataclass
class ModalSystem:
    """The Fourier split of a uniform full LTI and its intermediate model (:func:`modal_system`).

    Attributes
    ----------
    system : LTI
        The intermediate model on the kept real modes (2m states; ``w_v``, ``w_e`` are ones: its states are
        modal coordinates, not particle values).
    basis : ndarray (2N, 2m)
        V_m = blockdiag(F, F), orthonormal: x ≈ V_m x_m.
    wavenumbers : int
        K.
    g : ndarray (N,) complex
        Eigenvalues of G [m^-1 ...: the units of G], index k of the unitary DFT.
    s, d : float
        √(c/ρ0) and the damping [s^-1].
    B_hat : ndarray (N, 2, 2) complex
        b̂_k per column of B (v and e parts), [k, part, column].
    C_hat : ndarray (N, 2, rows) complex
        ĉ_jk per row of C.
    dropped : ndarray of int
        DFT indices outside |k| <= K.
    circulant_defect : float
        max |G - circ(G[:, 0])| / max |G| (round-off on a uniform lattice).
    timings : dict
    """

    system: LTI
    basis: np.ndarray
    wavenumbers: int
    g: np.ndarray
    s: float
    d: float
    B_hat: np.ndarray
    C_hat: np.ndarray
    dropped: np.ndarray
    circulant_defect: float
    timings: dict


def _gradient(lti: LTI):
    """(G, s): the SPH gradient and s = √(c/ρ0) of a uniform LTI (K = ρ0^-½ G c^½ = s G), or (None, nan)."""
    n = lti.n
    wv, we = lti.w_v, lti.w_e
    if not (np.all(wv == wv[0]) and np.all(we == we[0])):
        return None, float("nan")
    s = float(we[0] / wv[0])
    return (lti.J[:n, n:] / s).tocsr(), s


def circulant_defect(G):
    """max |G - circ(G[:, 0])| / max |G| for a sparse G (0 for an exactly circulant G)."""
    n = G.shape[0]
    coo = G.tocoo()
    first = np.asarray(G[:, [0]].todense()).ravel()
    gmax = float(abs(coo.data).max()) if coo.nnz else 0.0
    if gmax == 0.0:
        return 0.0
    defect = np.abs(coo.data - first[(coo.row - coo.col) % n])
    # entries of circ(first) that G lacks (zeros in G's pattern)
    missing = np.count_nonzero(first) * n - coo.nnz
    worst = float(defect.max()) if defect.size else 0.0
    if missing > 0:
        worst = max(worst, float(np.abs(first[first != 0]).min()))
    return worst / gmax


def applies(lti: LTI, structure="auto"):
    """Whether :func:`modal_system` is used for ``lti``: ``structure`` "modal" (ValueError naming it when the scene
    is not uniform), "dense" (never), "auto" (uniform and 2N > :data:`DENSE_ORDER`)."""
    if structure not in STRUCTURES:
        raise ValueError(f"structure: {structure!r} (allowed: {', '.join(STRUCTURES)})")
    if structure == "dense" or (structure == "auto" and lti.order <= DENSE_ORDER):
        return False
    G, _ = _gradient(lti)
    d = lti.R.diagonal()[:lti.n]
    uniform = (G is not None and np.all(d == d[0]) and lti.n >= 8
               and circulant_defect(G) <= CIRCULANT_TOLERANCE)
    if structure == "modal" and not uniform:
        raise ValueError("structure: 'modal' needs a uniform scene (constant rho0, c, d on the uniform periodic "
                         "lattice; allowed here: 'dense', 'auto')")
    return bool(uniform)


def fourier_basis(n, K):
    """Real orthonormal Fourier modes (n, 2K + 1): 1/√n, then √(2/n) cos(2πkj/n), √(2/n) sin(2πkj/n), k = 1..K."""
    if not 0 <= K < (n - 1) / 2:
        raise ValueError(f"wavenumbers: {K} is out of range (allowed: 0 to {(n - 2) // 2}, below N/2 = {n / 2:g})")
    j = np.arange(n)
    F = np.empty((n, 2 * K + 1))
    F[:, 0] = 1.0 / np.sqrt(n)
    phase = 2.0 * np.pi * np.outer(j, np.arange(1, K + 1)) / n
    F[:, 1::2] = np.sqrt(2.0 / n) * np.cos(phase)
    F[:, 2::2] = np.sqrt(2.0 / n) * np.sin(phase)
    return F


def modal_system(lti: LTI, wavenumbers=DEFAULT_WAVENUMBERS) -> ModalSystem:
    """The Fourier split of a uniform ``lti`` and its Galerkin projection on the modes |k| <= ``wavenumbers``
    (module docstring).  Raises ValueError naming ``structure`` for a scene that is not uniform."""
    t0 = time.perf_counter()
    n = lti.n
    G, s = _gradient(lti)
    d_all = lti.R.diagonal()[:n]
    if G is None or not np.all(d_all == d_all[0]):
        raise ValueError("structure: 'modal' needs a uniform scene (constant rho0, c, d; allowed here: 'dense')")
    defect = circulant_defect(G)
    if defect > CIRCULANT_TOLERANCE:
        raise ValueError(f"structure: 'modal' needs a circulant G (defect {defect:.1e} > {CIRCULANT_TOLERANCE:g})")
    K = min(int(wavenumbers), (n - 2) // 2)
    F = fourier_basis(n, K)
    m = F.shape[1]
    zero = np.zeros((m, m))

    def project(M):                                                    # Fᵀ M F of an N × N block
        return F.T @ np.asarray(M @ F)

    Jm = np.block([[zero, project(lti.J[:n, n:])], [project(lti.J[n:, :n]), zero]])
    Rm = np.block([[project(lti.R[:n, :n]), zero], [zero, zero]])
    Jm = 0.5 * (Jm - Jm.T)                                             # skew and symmetric to the last bit
    Rm = 0.5 * (Rm + Rm.T)
    # the modes decouple: each real mode's v part couples only to the e part of its partner (cos <-> sin) and
    # R is diagonal; the other entries are round-off of the lattice's positions (<= CIRCULANT_TOLERANCE of the
    # largest), dropped so that the intermediate model's frequency responses are sparse solves
    scale = max(float(np.abs(Jm).max()), float(np.abs(Rm).max()), 1e-300)
    small_J, small_R = np.abs(Jm) <= CIRCULANT_TOLERANCE * scale, np.abs(Rm) <= CIRCULANT_TOLERANCE * scale
    roundoff = max(float(np.abs(Jm[small_J]).max(initial=0.0)), float(np.abs(Rm[small_R]).max(initial=0.0)))
    Jm[small_J] = 0.0
    Rm[small_R] = 0.0
    V = np.block([[F, np.zeros_like(F)], [np.zeros_like(F), F]])     # 2N × 2m, orthonormal
    Am = Jm - Rm
    B, C, x0 = V.T @ lti.B, lti.C @ V, V.T @ lti.x0
    # the null modes from the structure: the constant e-mode (k = 0, G's columns sum to zero) is kept (column m
    # of V); lti.null's test |G 1| <= 1e-12 max|G| misses it at N = 10⁴, where the sums' round-off is 2e-12
    null = np.zeros((2 * m, 1))
    null[m, 0] = 1.0
    system = LTI(A=sp.csr_matrix(Am), J=sp.csr_matrix(Jm), R=sp.csr_matrix(Rm), B=B, C=C, x0=x0, w_v=np.ones(m), w_e=np.ones(m), null=null, probes=lti.probes,
                 damped=lti.damped, T=lti.T, info={"scene": lti.info.get("scene"), "modal_of": lti.order, "dropped_roundoff": roundoff / scale})
    g = np.fft.fft(np.asarray(G[:, [0]].todense()).ravel())           # G = Fᴴ diag(g) F (unitary DFT F)

    def hat(X):                                                        # (2N, cols) -> (N, 2, cols), unitary DFT
        X = np.asarray(X, float)
        return np.stack([np.fft.fft(X[:n], axis=0, norm="ortho"), np.fft.fft(X[n:], axis=0, norm="ortho")], axis=1)

    k = np.arange(n)
    kept = (k <= K) | (k >= n - K)
    return ModalSystem(system=system, basis=V, wavenumbers=K, g=g, s=s, d=float(d_all[0]), B_hat=hat(lti.B),
                       C_hat=hat(lti.C.T), dropped=k[~kept], circulant_defect=defect,
                       timings={"modal_system": time.perf_counter() - t0})


def block_matrices(ms: ModalSystem, index, shift=0.0, deflate=0.0):
    """A_k - shift I for the DFT indices ``index``, (len, 2, 2) complex; a null e-mode (g_k = 0) gets -deflate on
    its diagonal as in :meth:`sphrom.rom.lti.LTI.dense` (it is uncontrollable: its term vanishes anyway)."""
    null = np.abs(ms.g[index]) <= NULL_TOLERANCE * np.max(np.abs(ms.g))   # g_k = 0 to round-off: decoupled
    sg = np.where(null, 0.0, ms.s * ms.g[index])
    A = np.zeros((len(index), 2, 2), complex)
    A[:, 0, 0] = -ms.d - shift
    A[:, 0, 1] = A[:, 1, 0] = sg
    A[:, 1, 1] = -shift - np.where(null, deflate, 0.0)
    return A


def full_abscissa(ms: ModalSystem, deflate):
    """max Re λ of the full A with the null modes moved to -``deflate`` (every block's eigenvalues)."""
    ev = np.linalg.eigvals(block_matrices(ms, np.arange(ms.g.size), deflate=deflate))
    return float(np.max(ev.real))


def tail_hinf(ms: ModalSystem, rows, column=0, shift=0.0, deflate=0.0):
    """Σ over the dropped modes of a certified upper bound on ‖ĉ_jkᴴ (sI - A_k + shift I)^-1 b̂_k‖_H∞, per row j
    of C in ``rows``, input ``column`` of B (module docstring).

    Each term c (sI - A)^-1 b = r1/(s - λ1) + r2/(s - λ2) (residues r_i); on the axis either |ω - Im λ1| or
    |ω - Im λ2| is at least Δ/2 (Δ = |Im λ1 - Im λ2|), so its modulus is at most
    max(|r1|/μ1 + |r2|/√(Δ²/4 + μ2²), |r1|/√(Δ²/4 + μ1²) + |r2|/μ2), μ_i = -Re λ_i > 0.  Raises RuntimeError
    for a nearly defective block (|λ1 - λ2| below 1e-8 |λ|: critically damped), which the bound cannot take.
    """
    idx = ms.dropped
    if idx.size == 0:
        return np.zeros(len(rows))
    A = block_matrices(ms, idx, shift, deflate)
    b = ms.B_hat[idx, :, column]                                        # (n, 2)
    c = ms.C_hat[idx][:, :, rows]                                       # (n, 2, R)
    diagonal = (A[:, 0, 1] == 0) & (A[:, 1, 0] == 0)                   # g_k = 0: the two parts decouple
    out = np.zeros(len(rows))
    if np.any(diagonal):
        Ad, bd, cd = A[diagonal], b[diagonal], c[diagonal]
        if np.any(-Ad[:, [0, 1], [0, 1]].real <= 0):
            raise RuntimeError("tail bound: a dropped mode is not asymptotically stable after the shift")
        out += np.sum(np.abs(cd[:, 0] * bd[:, [0]]) / -Ad[:, 0, [0]].real
                      + np.abs(cd[:, 1] * bd[:, [1]]) / -Ad[:, 1, [1]].real, axis=0)
    A, b, c = A[~diagonal], b[~diagonal], c[~diagonal]
    tr = A[:, 0, 0] + A[:, 1, 1]
    det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    root = np.sqrt(tr * tr / 4 - det + 0j)
    lam = np.stack([tr / 2 + root, tr / 2 - root], axis=1)             # (n, 2)
    gap = np.abs(lam[:, 0] - lam[:, 1])
    if np.any(gap <= 1e-8 * np.maximum(np.abs(lam).max(axis=1), 1e-300)):
        raise RuntimeError("tail bound: a nearly defective (critically damped) mode block; use structure='dense'")
    mu = -lam.real
    if np.any(mu <= 0):
        raise RuntimeError("tail bound: a dropped mode is not asymptotically stable after the shift")
    residues = []
    for i in range(2):                  # residue of cᴴ adj(sI - A) b / ((s - λ1)(s - λ2)) at λ_i
        s_ = lam[:, i]
        adj_b = np.stack([(s_ - A[:, 1, 1]) * b[:, 0] + A[:, 0, 1] * b[:, 1],
                          A[:, 1, 0] * b[:, 0] + (s_ - A[:, 0, 0]) * b[:, 1]], axis=1)   # (n, 2)
        residues.append(np.abs(np.einsum("nar,na->nr", c.conj(), adj_b)) / gap[:, None])
    r0, r1 = residues
    half = 0.5 * np.abs(lam[:, 0].imag - lam[:, 1].imag)
    near0 = r0 / mu[:, [0]] + r1 / np.sqrt(half * half + mu[:, 1] ** 2)[:, None]
    near1 = r0 / np.sqrt(half * half + mu[:, 0] ** 2)[:, None] + r1 / mu[:, [1]]
    out += np.sum(np.maximum(near0, near1), axis=0)
    return out * (1.0 + 1e-10)


def tail_free(ms: ModalSystem, rows, horizon):
    """Σ over the dropped modes of √T |ĉ_jk| |x̂0_k|, per row j in ``rows``: a certified bound on the L²(0, T)
    norm of the dropped modes' free response at output j (e^{A_k t} is a contraction in energy coordinates)."""
    idx = ms.dropped
    if idx.size == 0:
        return np.zeros(len(rows))
    x = np.linalg.norm(ms.B_hat[idx, :, 1], axis=1)                    # column 1 of B: x0
    c = np.linalg.norm(ms.C_hat[idx][:, :, rows], axis=1)              # (n, R)
    return np.sqrt(float(horizon)) * (x @ c) * (1.0 + 1e-10)


def lift(reduced, basis):
    """The reduced model of the intermediate system as one of the full system: V = V_m V_b, W = V_m W_b (Ar, Br,
    Cr unchanged: they are the same projections)."""
    V = None if reduced.V is None else basis @ reduced.V
    W = None if reduced.W is None else (V if reduced.W is reduced.V else basis @ reduced.W)
    return dataclasses.replace(reduced, V=V, W=W)


def restrict(reduced):
    """A reduced model of the full system as one of the intermediate system: Ar, Br, Cr are what the bounds use;
    V, W are dropped (the bounds never read them)."""
    return dataclasses.replace(reduced, V=None, W=None)


def error_bounds(lti: LTI, reduced, dense_bounds, horizon=None, sigma=None, outputs="v", tol=1e-4, progress=None,
                 wavenumbers=DEFAULT_WAVENUMBERS, ms: ModalSystem | None = None) -> dict:
    """The certified bounds of :func:`sphrom.rom.balanced.error_bounds` through the modes (module docstring): the
    intermediate model's bounds against ``reduced`` plus the dropped modes' tail, per velocity probe.

    Returns the dict of :func:`sphrom.rom.balanced.error_bounds` (``force_error_bound`` and
    ``initial_state_error_bound`` with the tail added, ``hinf`` the intermediate's bisection ends) and
    ``force_tail`` [s], ``initial_state_tail`` [m s^-1 s^½], ``wavenumbers`` K, ``intermediate_order`` 2m.
    ``dense_bounds`` is the dense bound function (:func:`sphrom.rom.balanced.error_bounds`, which passes
    itself), applied to the intermediate model with ``structure="dense"``.
    """
    t0 = time.perf_counter()
    T = float(lti.T if horizon is None else horizon)
    ms = ms or modal_system(lti, wavenumbers)
    system = ms.system
    gamma = float(np.min(lti.R.diagonal()[:lti.n]))
    system.info["abscissa"] = max(full_abscissa(ms, gamma), _dense_abscissa(system, gamma))
    t1 = time.perf_counter()
    out = dense_bounds(system, restrict(reduced), horizon=T, sigma=sigma, outputs=outputs, tol=tol, progress=progress,
                      structure="dense")
    t2 = time.perf_counter()
    shift = out["sigma"]
    deflate = gamma if shift == 0.0 else 0.0
    rows = out["rows"]
    force_tail = out["factor"] * tail_hinf(ms, rows, 0, shift, deflate)
    init_tail = tail_free(ms, rows, T)
    out["force_error_bound"] = out["force_error_bound"] + force_tail
    out["initial_state_error_bound"] = out["initial_state_error_bound"] + init_tail
    out.update(force_tail=force_tail, initial_state_tail=init_tail, wavenumbers=ms.wavenumbers,
               intermediate_order=system.order)
    out["timings"] = dict(out["timings"], modal=t1 - t0 + ms.timings["modal_system"], tail=time.perf_counter() - t2)
    return out


def _dense_abscissa(system: LTI, gamma):
    return float(np.max(np.linalg.eigvals(system.dense(deflate=gamma)).real))


def block_exponentials(A, t):
    """e^{A_k t} of 2 × 2 blocks A (n, 2, 2) at times t (M,), (M, n, 2, 2): e^{τt}[cosh(δt) I + sinh(δt)/δ (A - τI)],
    τ = tr/2, δ² = τ² - det (exact; sinh(δt)/δ -> t as δ -> 0, so a critically damped block needs no care)."""
    tau = 0.5 * (A[:, 0, 0] + A[:, 1, 1])
    det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    delta = np.sqrt(tau * tau - det + 0j)
    t = np.asarray(t, float)[:, None]
    dt = delta[None, :] * t
    small = np.abs(dt) < 1e-8
    sinhc = np.where(small, t + 0j, np.sinh(np.where(small, 1.0, dt)) / np.where(delta == 0, 1.0, delta)[None, :])
    e = np.exp(tau[None, :] * t)
    M = A - tau[:, None, None] * np.eye(2)
    return e[..., None, None] * (np.cosh(dt)[..., None, None] * np.eye(2) + sinhc[..., None, None] * M[None])


def free_outputs(ms: ModalSystem, rows, t, chunk=256):
    """The full system's free response from x0 at outputs ``rows`` and times ``t``, (M, len(rows)), exactly through
    every mode (y_j(t) = Σ_k ĉ_jkᴴ e^{A_k t} x̂0_k; an independent reference for the reduced models' errors)."""
    A = block_matrices(ms, np.arange(ms.g.size))
    x = ms.B_hat[:, :, 1]
    c = ms.C_hat[:, :, rows].conj()
    t = np.asarray(t, float)
    out = np.empty((t.size, len(rows)))
    for i in range(0, t.size, chunk):
        E = block_exponentials(A, t[i:i + chunk])                      # (m, n, 2, 2)
        state = np.einsum("mnab,nb->mna", E, x)
        out[i:i + chunk] = np.einsum("mna,nar->mr", state, c).real
    return out


# ---------------------------------------------------------------------------------------------------------------
# a reduced linear model in its real eigen-coordinates (the linear FMUs' block-diagonal form)
# ---------------------------------------------------------------------------------------------------------------

BLOCK_CONDITION = 1e6       # κ(V) of the eigenvector transform above this: the dense form is kept
BLOCK_RESIDUAL = 1e-10      # ‖A V - V Λ‖ / ‖A‖ above this: the dense form is kept (a defective or unstable solve)


@dataclasses.dataclass
class RealBlocks:
    """A = V Λ V⁻¹ with Λ block diagonal in real coordinates: 1 x 1 blocks (real eigenvalues) and 2 x 2 blocks
    [[α, ω], [-ω, α]] (a pair α ± iω, ω > 0; Λ[i + 1, i] = -ω != 0 starts one), V's columns of unit norm.

    Attributes
    ----------
    L, V, V_inv : ndarray (k, k)
    condition : float
        κ₂(V) (1 for a normal A: its real Schur form is block diagonal and V orthogonal).
    residual : float
        ‖A V - V Λ‖₂ / ‖A‖₂.
    sizes : ndarray of int
        The blocks' sizes in order.
    """

    L: np.ndarray
    V: np.ndarray
    V_inv: np.ndarray
    condition: float
    residual: float
    sizes: np.ndarray

    @property
    def usable(self):
        """The transform is well enough conditioned to step the model in it (:data:`BLOCK_CONDITION`)."""
        return bool(self.condition <= BLOCK_CONDITION and self.residual <= BLOCK_RESIDUAL)


def real_blocks(A, skew=None):
    """The :class:`RealBlocks` of a real square A: from the real Schur form where A is normal (a skew A: the undamped
    Galerkin models; V = Q orthogonal), else from its eigenvectors (a conjugate pair's v = v_r + i v_i gives the
    columns v_r, v_i: A [v_r, v_i] = [v_r, v_i] [[α, ω], [-ω, α]]), pairs and real eigenvalues ordered by |λ|."""
    A = np.asarray(A, float)
    k = A.shape[0]
    norm = max(float(np.linalg.norm(A, 2)), 1e-300)
    skew = bool(np.abs(A + A.T).max() <= 1e-14 * norm) if skew is None else skew
    if skew:
        T, Q = sla.schur(A, output="real")
        L = np.zeros_like(T)
        sizes, i = [], 0
        while i < k:
            b = 2 if i + 1 < k and abs(T[i + 1, i]) > 1e-14 * norm else 1
            if b == 2:                                  # exactly [[0, ω], [-ω, 0]] (a 1 x 1 block: exactly 0)
                w = 0.5 * (T[i, i + 1] - T[i + 1, i])
                L[i:i + 2, i:i + 2] = [[0.0, w], [-w, 0.0]]
            sizes.append(b)
            i += b
        V, V_inv = Q, Q.T
    else:
        lam, vec = np.linalg.eig(A)
        order = np.lexsort((-lam.imag, np.abs(lam)))
        cols, blocks, sizes, used = [], [], [], np.zeros(k, bool)
        for i in order:
            if used[i]:
                continue
            used[i] = True
            if abs(lam[i].imag) <= 1e-12 * norm:
                v = np.real(vec[:, i])
                cols.append(v / np.linalg.norm(v))
                blocks.append(np.array([[lam[i].real]]))
                sizes.append(1)
                continue
            j = next(j for j in order if not used[j] and abs(lam[j] - np.conj(lam[i])) <= 1e-9 * max(abs(lam[i]), 1))
            used[j] = True
            z = vec[:, i] if lam[i].imag > 0 else vec[:, j]
            a, w = float(lam[i].real), abs(float(lam[i].imag))
            vr, vi = np.real(z), np.imag(z)
            s = max(np.linalg.norm(vr), np.linalg.norm(vi))
            cols += [vr / s, vi / s]
            blocks.append(np.array([[a, w], [-w, a]]))
            sizes.append(2)
        V = np.column_stack(cols)
        L = sla.block_diag(*blocks)
        try:
            V_inv = np.linalg.inv(V)
        except np.linalg.LinAlgError:            # eigenvectors exactly dependent (a defective A): not usable
            return RealBlocks(L=L, V=V, V_inv=np.full_like(V, np.nan), condition=math.inf, residual=math.inf,
                              sizes=np.array(sizes, np.int64))
    condition = float(np.linalg.cond(V))
    residual = float(np.linalg.norm(A @ V - V @ L, 2) / norm)
    return RealBlocks(L=L, V=V, V_inv=V_inv, condition=condition, residual=residual, sizes=np.array(sizes, np.int64))
