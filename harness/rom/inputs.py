"""Input directions that hold at every frequency, one set per input channel (the force profile, each port).

A reduced model that takes an input must carry the full model's response to it.  The POD modes hold the
response to the scene's own force over its training run; a port force, a force along the profile at another
frequency, or a constant force (whose response is the static deflection over the whole bar and, without
damping, a rigid motion whose momentum grows without end) lie outside them.  This module computes, per input
channel, the directions of that response at every frequency from s = 0 up through the scene's band, by moment
matching of the full linear SPH (rational Krylov).

Second-order form.  From rest (e(0) = 0) the specific volume is e = G q with q = ∫ v dt the displacement, and
eqs. 2.10-2.11 in J (the exact model's form, :mod:`harness.rom.exact_linear`) read

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

Each solve is a sparse LU of an N x N banded matrix (periodic wrap): O(N) per shift.  The count of directions
per channel is set by ``tol`` (measured: the relative part of each candidate outside the span before it), not
fixed.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

INPUT_TOL = 1e-4            # a candidate direction is appended when the basis misses more than this of it
BAND_SHIFTS = 8             # candidate shifts over the band (each gives up to two directions)
SHIFT_DAMPING = 0.2         # η of s_k = ω_k (η + i)


def rigid_modes(G, tol=1e-12):
    """The particle functions G kills among {1, (-1)^i} (N,) each, as columns (N, m): ker K of the module."""
    n = G.shape[0]
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
    ``F_port_j`` with b = W(x - x_j, h)/ρ0 (area 1) per port (:mod:`harness.sph.ports`)."""
    from ..sph.ports import port_accelerations
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


def augment_channels(problem, U_v, U_2, profiles, *, energy, tol=None, w_top=None):
    """(U_v, U_2, columns added to U_v, columns added to U_2): every candidate direction of each channel
    (:func:`candidate_directions`; ``profiles`` a list of acceleration profiles b) that the bases miss by more
    than ``tol``, with its specific-volume direction G q.

    ``energy``: the exact model's weights (ρ0 for U_v, c for U_2 = U_e); else Euclidean, U_2 = U^ρ and the
    density direction ρ0 G q (δρ = -ρ0 δe).  ``w_top``: the top of the band (default that of ``U_v``,
    :func:`band`).
    """
    tol = INPUT_TOL if tol is None else float(tol)
    G = problem.neighbours.matrix()
    wv = problem.rho0 if energy else np.ones(problem.n)
    we = problem.c if energy else np.ones(problem.n)
    if w_top is None:
        w_top = band(problem, U_v if not energy else U_v)[1]
    n_v, n_2 = U_v.shape[1], U_2.shape[1]
    gmax = abs(G).max()
    for b in profiles:
        for q, ref in candidate_directions(problem, b, w_top=w_top):
            U_v, _ = append_direction(U_v, q, wv, tol, ref)
            e, e_ref = np.asarray(G @ q), np.asarray(G @ ref)
            if not np.max(np.abs(e_ref)) > 1e-10 * gmax * np.max(np.abs(ref)):
                continue                          # G q is round-off (q rigid): no specific-volume direction
            if not energy:
                e, e_ref = problem.rho0 * e, problem.rho0 * e_ref
            U_2, _ = append_direction(U_2, e, we, tol, e_ref)
    return U_v, U_2, U_v.shape[1] - n_v, U_2.shape[1] - n_2
