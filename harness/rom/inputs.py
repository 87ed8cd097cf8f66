"""Input directions that hold at every frequency, one set per input channel (the force profile, each port).

A reduced model that takes an input must carry the full model's response to it.  The POD modes hold the
response to the scene's own force over its training run; a port force, a force along the profile at another
frequency, or a constant force (whose response is the static deflection over the whole bar and, without
damping, a rigid motion whose momentum grows without end) lie outside them.  This module computes, per input
channel, the directions of that response at every frequency from s = 0 up through the scene's band, by moment
matching of the full linear SPH (rational Krylov).

Second-order form.  From rest (e(0) = 0) the specific volume is e = G q with q = ∫ v dt the displacement, and
eqs. 2.10-2.11 in J (the exact model's form, :mod:`sphrom.rom.exact_linear`) read

    M q̈ + C q̇ + K q = M b u(t),    M = diag(ρ0),  C = diag(ρ0 d),  K = -G diag(c) G  (= Gᵀ c G >= 0),

b the channel's acceleration per unit input (the profile per m s^-2 of f, W(x - x_j, h)/ρ0 per N of F_port_j
at area 1).  In the Laplace domain q(s) = (s² M + s C + K)⁻¹ M b u(s), v = s q, e = G q: a velocity direction q
goes with the specific-volume direction G q (the density models' U^ρ gets ρ0 G q, δρ = -ρ0 δe).

Directions, in this order (each kept only if the basis before it misses more than ``tol`` of it):

* s = 0, the rigid modes r of ker K (= ker G: the constant, and the alternating particle function for even N)
  that the channel's force moves (rᵀ M b ≠ 0): an undamped bar under a constant force accelerates along r.
* s = 0, the static deflection: the solution q ⊥ ker K of K q = M b - (the load that balances the force's
  rigid part: inertial, M r, without damping, drag, C r, with it), and its first moments
  K⁺(C q) and K⁺(M q) (the next terms of q(s) in s), through the bordered system [[K, R], [Rᵀ, 0]].
* in-band shifts s_k = ω_k (η + i), ω_k log-spaced over the band [ω_1, 2 ω_top] (ω_1 the lowest elastic
  frequency of the bar, ω_top the top frequency of the POD modes), η = 0.2: (s_k² M + s_k C + K) is then
  nonsingular for any d >= 0; the real and imaginary parts of q(s_k) are the directions.
* the channel's dominant modes (:func:`dominant_modes`): the rational moments hold the response's envelope,
  not the ringing after a step.  A port is a kernel-wide point force and excites every mode of the bar about
  equally; without damping each rings for ever, at (φᵢᵀ F)²/ωᵢ in the collocated velocity.  The modes
  K φ = ω² M φ are taken greedily, each the one that removes most of what the basis misses of the channel's
  step response over the scene's horizon (L² in time, with the modal damping φᵀCφ), until the rest is below
  ``modal_tol`` of the whole response (:func:`channel_modes`, :func:`dominant_modes`).

Each solve is a sparse LU of an N x N banded matrix (periodic wrap): O(N) per shift.  The count of directions
per channel is set by ``tol`` (measured: the relative part of each candidate outside the span before it), not
fixed.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..sph.ports import port_accelerations

INPUT_TOL = 1e-4            # a candidate direction is appended when the basis misses more than this of it
MODAL_TOL = 5e-3            # the dominant modes: until the rest of the step response is below this of it
MODAL_APPEND = 1e-7         # a taken mode is appended unless the basis holds it to this (a large, slow mode
                            # nearly in the span can still carry much of what is missed)
MODAL_DENSE_N = 2000        # dense generalized eigensolve up to this N; above it the lowest MODAL_SPARSE modes
MODAL_SPARSE = 300
BAND_SHIFTS = 8             # candidate shifts over the band (each gives up to two directions)
SHIFT_DAMPING = 0.2         # η of s_k = ω_k (η + i)
NULL_TOL = 1e-14            # a rigid candidate is in ker G when max|G k| <= this x N x max|G| (50 x its round-off)


def kernel_tol(n):
    """The relative tolerance of the kernel test of :func:`rigid_modes` for ``n`` particles: max(1e-12,
    :data:`NULL_TOL` n).  G k's round-off grows like eps N (x_j - x_i loses log10 N digits: 2e-16 N of max|G|
    measured up to N = 1e5), so a fixed 1e-12 missed ker G from N = 1e4 on."""
    return max(1e-12, NULL_TOL * int(n))


def rigid_modes(G, tol=None):
    """The particle functions G kills among {1, (-1)^i} (N,) each, as columns (N, m): ker K of the module.  A
    candidate k counts when max|G k| <= ``tol`` x max|G| (default :func:`kernel_tol` of N)."""
    n = G.shape[0]
    tol = kernel_tol(n) if tol is None else float(tol)
    gmax = abs(G).max()
    out = []
    for k in (np.ones(n), (-1.0) ** np.arange(n)):
        if n % 2 and k[0] * k[-1] < 0:
            continue
        if np.max(np.abs(G @ k)) <= tol * gmax:
            out.append(k)
    return np.column_stack(out) if out else np.zeros((n, 0))


def second_order(problem):
    """(M, C, K, G) of the module docstring as sparse matrices (N, N): M = ρ0, C = ρ0 d, K = -G c G."""
    G = problem.neighbours.matrix().tocsc()
    M = sp.diags(problem.rho0)
    C = sp.diags(problem.rho0 * problem.d) if problem.terms["damping"] else sp.csc_matrix(G.shape)
    K = (-(G @ sp.diags(problem.c) @ G)).tocsc()
    return M, C, K, G


def band(problem, U_v=None):
    """(ω_1, ω_top) [rad s^-1]: the bar's lowest elastic frequency (the Rayleigh quotient of sin 2πx/L) and the top
    frequency of the velocity modes ``U_v`` (their largest Rayleigh quotient √(uᵀKu / uᵀMu); default 10 ω_1)."""
    M, _, K, _ = second_order(problem)
    s = np.sin(2 * np.pi * problem.x / problem.scene.L)
    w1 = float(np.sqrt((s @ (K @ s)) / (s @ (M @ s))))
    if U_v is None or U_v.shape[1] == 0:
        return w1, 10.0 * w1
    num = np.einsum("ik,ik->k", U_v, np.asarray(K @ U_v))
    den = np.einsum("ik,ik->k", U_v, np.asarray(M @ U_v))
    return w1, float(max(w1, np.sqrt(np.max(num / den))))


def bar_modes(problem):
    """(ω (m,) [rad s^-1] ascending, Φ (N, m) M-orthonormal): the modes K φ = ω² M φ of the module's second-order
    form; dense up to :data:`MODAL_DENSE_N` particles, else the lowest :data:`MODAL_SPARSE` (shift-invert
    Lanczos)."""
    M, _, K, _ = second_order(problem)
    n = K.shape[0]
    if n <= MODAL_DENSE_N:
        w2, Phi = sla.eigh(K.toarray(), M.toarray())
    else:
        shift = -1e-6 * abs(K).max()
        v0 = np.random.default_rng(0).standard_normal(n)          # (fixed: the same modes from run to run)
        w2, Phi = spla.eigsh(K.tocsc(), k=min(MODAL_SPARSE, n - 2), M=M.tocsc(), sigma=shift, which="LM", v0=v0)
    order = np.argsort(w2)
    w2 = w2[order]
    w2[w2 <= 1e-10 * max(float(w2[-1]), 1e-300)] = 0.0        # the rigid modes (ker K), round-off removed
    return np.sqrt(w2), Phi[:, order]


def channel_modes(problem, b, *, horizon=None, modes=None, samples=None, weight=None):
    """The channel's step response in its modes: (Q, g, rigid).

    From rest, a unit step of the channel (F = M b) moves mode i as (φᵢᵀ F) φᵢ ηᵢ(t), ηᵢ the displacement of
    η'' + φᵢᵀCφᵢ η' + ωᵢ² η = u; the velocity v(t) = Σᵢ qᵢ gᵢ(t), qᵢ = Φᵢ Φᵢᵀ F over the eigenspace of ωᵢ (the
    sine-cosine pairs of a uniform bar are one: one direction), gᵢ = η̇ᵢ = (e^{λ1 t} - e^{λ2 t})/(λ1 - λ2).

    Parameters
    ----------
    b : (N,) array
        The channel's acceleration per unit input.
    horizon : float, optional
        T [s] of the response (default the scene's T).
    modes : (ω, Φ), optional
        :func:`bar_modes` of the problem, if already at hand.
    samples : int, optional
        Time samples of g over [0, T] (default: 16 per period of the top mode, 2000 to 8000).

    Returns
    -------
    Q : (N, m) array
        The elastic eigenspaces' directions qᵢ [m s^-2 per unit input, as F].
    g : (m, S) array
        Their step responses gᵢ at S samples, times the square root of the trapezoid weights (so that
        Σₛ gᵢ gⱼ = ∫₀ᵀ gᵢ gⱼ dt).
    rigid : float
        ∫₀ᵀ |v_rigid|²_W dt of the rigid modes' part (the constant's drift, growing without damping), in the norm of
        ``weight`` W (N,) (default M = ρ0): the norm the elastic part is measured in by :func:`dominant_modes`, so
        that the two add up whatever the units (a Euclidean basis against the M norm weighed the rigid part by ρ0:
        a steel bar, ρ0 = 7850, took other modes than the same bar in unit scaling).
    """
    horizon = float(problem.scene.T if horizon is None else horizon)
    M, C, _, _ = second_order(problem)
    F = M @ np.asarray(b, float)
    n = F.size
    w, Phi = bar_modes(problem) if modes is None else modes
    top = max(float(w[-1]), 1e-300)
    groups = np.split(np.arange(w.size), np.flatnonzero(np.diff(w) > 1e-8 * top) + 1)   # eigenspaces
    parts = [Phi[:, g].T @ F for g in groups]
    sigma = np.array([0.5 * np.mean(np.einsum("ij,ij->j", Phi[:, g], np.asarray(C @ Phi[:, g]))) for g in groups])
    omega = np.array([w[g].mean() for g in groups])
    if samples is None:
        samples = int(np.clip(16 * top * horizon / (2 * np.pi), 2000, 8000))
    t = np.linspace(0.0, horizon, samples)
    quad = np.full(samples, horizon / (samples - 1))
    quad[[0, -1]] *= 0.5
    root = np.sqrt((sigma ** 2 - omega ** 2).astype(complex))[:, None]
    lam1, lam2 = -sigma[:, None] + root, -sigma[:, None] - root
    d = lam1 - lam2
    close = np.abs(d) * horizon < 1e-6                             # a double root: g = t e^{λ t}
    with np.errstate(all="ignore"):
        g = np.where(close, t * np.exp(lam1 * t), (np.exp(lam1 * t) - np.exp(lam2 * t)) / np.where(close, 1, d))
    g = np.real(g) * np.sqrt(quad)
    rigid_i = [i for i in range(len(groups)) if omega[i] == 0.0]
    elastic = [i for i in range(len(groups)) if omega[i] > 0.0]
    W = problem.rho0 if weight is None else np.asarray(weight, float)
    rigid = float(sum(((Phi[:, groups[i]] @ parts[i]) @ (W * (Phi[:, groups[i]] @ parts[i]))) * (g[i] @ g[i])
                      for i in rigid_i))
    Q = np.column_stack([Phi[:, groups[i]] @ parts[i] for i in elastic]) if elastic else np.zeros((n, 0))
    return Q, g[elastic], rigid


def dominant_modes(U, Q, g, rigid, weight, tol):
    """The columns of ``Q`` (the channel's modes, :func:`channel_modes`) that the basis ``U`` (``weight``-orthonormal
    columns) must take so that it misses at most ``tol`` of the step response v(t) = Q g(t), relative L² in time
    of the ``weight`` norm (the rigid part ``rigid`` counted in the whole, and held by U).

    Greedy: each step takes the mode whose part outside the basis removes most of the response's residual
    ∫|v - P v|² dt (modes that move together, as a damped bar's quasi-static ones do, count together: the
    residual is computed with the Gram matrix of their time functions, not mode by mode).  Returns the indices in
    the order taken.
    """
    m = Q.shape[1]
    if not m:
        return []
    w = np.asarray(weight, float)
    norms = np.sqrt(np.einsum("ij,ij->j", Q, w[:, None] * Q))
    ok = norms > 0
    Qh = Q[:, ok] / norms[ok]
    A = g[ok] * norms[ok, None]                                  # v(t) = Qh A(t)
    idx_ok = np.flatnonzero(ok)
    S = Qh.T @ (w[:, None] * Qh)
    B = U.T @ (w[:, None] * Qh) if U.shape[1] else np.zeros((0, Qh.shape[1]))
    Gam = A @ A.T
    total2 = float(np.trace(S @ Gam)) + rigid
    D = S - B.T @ B                                              # the modes' Gram outside span(U)
    H = D @ Gam @ D
    E = float(np.trace(D @ Gam))
    taken = []
    floor = 1e-12 * np.max(np.diag(S))                           # ν > 1e-6 > MODAL_APPEND
    while E > tol ** 2 * total2 and len(taken) < Qh.shape[1]:
        dd = np.diag(D).copy()
        gain = np.where(dd > floor, np.diag(H) / np.where(dd > floor, dd, 1.0), -np.inf)
        gain[taken] = -np.inf
        k = int(np.argmax(gain))
        if not np.isfinite(gain[k]) or gain[k] <= 0:
            break
        c = D[k] / np.sqrt(dd[k])                                  # the new direction's products with the modes
        y = D @ (Gam @ c)
        cgc = float(c @ Gam @ c)
        H = H - np.outer(c, y) - np.outer(y, c) + cgc * np.outer(c, c)
        D = D - np.outer(c, c)
        E -= gain[k]
        taken.append(k)
    return [int(idx_ok[k]) for k in taken]


def candidate_directions(problem, b, *, w_top=None, shifts=None, eta=None):
    """Candidate velocity directions of one channel with acceleration profile ``b`` (N,), in the order of the
    module docstring (rigid, static and its moments, then the in-band shifts low to high): pairs (q, reference),
    q real (N,), reference the vector whose norm the tolerance is relative to (q itself, or the complex q(s_k)
    whose real or imaginary part q is)."""
    shifts = BAND_SHIFTS if shifts is None else int(shifts)
    eta = SHIFT_DAMPING if eta is None else float(eta)
    M, C, K, G = second_order(problem)
    F = M @ np.asarray(b, float)
    R = rigid_modes(G)
    out = []
    moved = [r for r in R.T if abs(r @ F) > 1e-12 * np.linalg.norm(r) * np.linalg.norm(F)]
    out.extend((r, r) for r in moved)
    n, m = K.shape[0], R.shape[1]
    bordered = spla.splu(sp.bmat([[K, sp.csc_matrix(R)], [sp.csc_matrix(R.T), None]], format="csc"))

    def kplus(g):
        """q ⊥ ker K with K q = g - (its part along the balancing loads); g's rigid part is removed first."""
        return bordered.solve(np.concatenate([g, np.zeros(m)]))[:n]

    damped = problem.terms["damping"] and bool(np.any(problem.d > 0))

    def elastic(g):
        """g less its rigid part (Euclidean: K is symmetric, its range is ker K's complement)."""
        return g - R @ np.linalg.lstsq(R, g, rcond=None)[0] if m else g

    scale = np.linalg.norm(F)
    q_static = None
    for g in [F] + [w @ r for r in R.T for w in ((M, C) if damped else (M,))]:   # F and its balancing loads
        g = elastic(g)
        if np.linalg.norm(g) > 1e-12 * scale:
            q = kplus(g)
            out.append((q, q))
            q_static = q if q_static is None else q_static
    if q_static is not None:                      # the next terms of q(s) = K⁺(F - s C q - s² M q) about s = 0
        for w in ((C, M) if damped else (M,)):
            q = kplus(elastic(w @ q_static))
            out.append((q, q))
    w1, wt = band(problem) if w_top is None else (band(problem)[0], float(w_top))
    for w in np.geomspace(w1, 2.0 * max(wt, w1), shifts):
        s = w * (eta + 1j)
        q = spla.spsolve((s * s * M + s * C + K).tocsc().astype(complex), F.astype(complex))
        out.extend([(q.real, q), (q.imag, q)])
    return out


def channel_profiles(problem, ports=(), profile=True):
    """[(name, b)] of the input channels: ``f`` along the scene's profile (if ``profile`` and it is nonzero), then
    ``F_port_j`` with b = W(x - x_j, h)/ρ0 (area 1) per port (:mod:`sphrom.sph.ports`)."""
    out = []
    if profile and np.any(problem.profile != 0):
        out.append(("f", np.asarray(problem.profile, float)))
    if len(ports):
        for j, b in enumerate(port_accelerations(problem, ports)):
            out.append((f"F_port_{j + 1}", b))
    return out


def append_direction(U, d, weight, tol, reference=None):
    """(U', appended?): U with the weight-orthogonal part of ``d`` outside span(U) appended as a weight-unit
    column when it exceeds ``tol`` x |reference|_weight (default |d|); Gram-Schmidt twice (round-off)."""
    w = np.asarray(weight, float)
    ref = d if reference is None else reference
    scale = float(np.sqrt(np.sum(w * np.abs(ref) ** 2)))
    if not scale > 0:
        return U, False
    r = d - U @ (U.T @ (w * d))
    if not np.sqrt(r @ (w * r)) > tol * scale:
        return U, False
    r = r - U @ (U.T @ (w * r))
    return np.column_stack([U, r / np.sqrt(r @ (w * r))]), True


def augment_channels(problem, U_v, U_2, profiles, *, energy, tol=None, w_top=None, modal_tol=None, horizon=None,
                     modes=None):
    """(U_v, U_2, columns added to U_v, columns added to U_2): every candidate direction of each channel
    (:func:`candidate_directions`; ``profiles`` a list of acceleration profiles b) that the bases miss by more
    than ``tol``, with its specific-volume direction G q.

    ``energy``: the exact model's weights (ρ0 for U_v, c for U_2 = U_e); else Euclidean, U_2 = U^ρ and the
    density direction ρ0 G q (δρ = -ρ0 δe).  ``w_top``: the top of the band (default that of ``U_v``,
    :func:`band`).  Then the channel's dominant modes that the bases miss (:func:`dominant_modes`, to
    ``modal_tol`` of the step response over ``horizon``, default :data:`MODAL_TOL` and the scene's T).
    ``modes``: :func:`bar_modes` of the problem when the caller has them (a build with the profile's and the
    ports' channels solves the eigenproblem once).
    """
    tol = INPUT_TOL if tol is None else float(tol)
    G = problem.neighbours.matrix()
    wv = problem.rho0 if energy else np.ones(problem.n)
    we = problem.c if energy else np.ones(problem.n)
    if w_top is None:
        w_top = band(problem, U_v)[1]
    modal_tol = MODAL_TOL if modal_tol is None else float(modal_tol)
    n_v, n_2 = U_v.shape[1], U_2.shape[1]
    gmax = abs(G).max()

    def add(U_v, U_2, q, ref, tol_q):
        """U_v and U_2 with the velocity direction q and its specific-volume direction G q appended."""
        U_v, _ = append_direction(U_v, q, wv, tol_q, ref)
        e, e_ref = np.asarray(G @ q), np.asarray(G @ ref)
        if not np.max(np.abs(e_ref)) > 1e-10 * gmax * np.max(np.abs(ref)):
            return U_v, U_2                       # G q is round-off (q rigid): no specific-volume direction
        if not energy:
            e, e_ref = problem.rho0 * e, problem.rho0 * e_ref
        U_2, _ = append_direction(U_2, e, we, tol_q, e_ref)
        return U_v, U_2

    for b in profiles:
        for q, ref in candidate_directions(problem, b, w_top=w_top):
            U_v, U_2 = add(U_v, U_2, q, ref, tol)
        modes = bar_modes(problem) if modes is None else modes
        Q, g, rigid = channel_modes(problem, b, horizon=horizon, modes=modes, weight=wv)
        for i in dominant_modes(U_v, Q, g, rigid, wv, modal_tol):      # against the basis with the candidates
            U_v, U_2 = add(U_v, U_2, Q[:, i], Q[:, i], MODAL_APPEND)
    return U_v, U_2, U_v.shape[1] - n_v, U_2.shape[1] - n_2
