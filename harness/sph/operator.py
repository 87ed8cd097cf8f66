"""The SPH neighbour operator of eqs. 2.8-2.9 in the total Lagrangian frame.

Particles stay at their reference positions (ẋ_i = 0), so the neighbours and
the kernel gradients ∇W_ij = ∇W(x_i - x_j) are computed once.  Periodic
images across the boundary are taken by the minimum image convention (the
support 2h is kept below L/2 by the scene checks).

The operator is stored as dense per-particle neighbour lists ``index[i, k]``
and ``weight[i, k] = (m_j / ρ_j(0)) ∇W_ij`` (padded with weight 0), so that
applying it costs O(N K) for K neighbours per particle, and as a sparse
matrix G for the Galerkin projections of the reduced models:

    [[∇f]]_i = Σ_j (m_j/ρ_j(0)) f_j ∇W_ij = (G f)_i           (eq. 2.9)

Particles keep their neighbours, and on the uniform lattice every row has
them at the same offsets: index[i, k] = (i + offsets[k]) mod N (-2, -1, 1, 2
at α = 1.04).  :func:`fixed_offsets` detects that when the lists are built;
the compiled loops then take the fixed-offset layout (no index loads,
weights by offset; :meth:`Neighbours.loop_arrays`), which computes the same
bits.  Where the rows differ (2h a whole number of spacings, α = 1.5 or 2,
puts a neighbour at the support's edge into some rows only) ``offsets`` is
None and the loops read the lists.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .kernel import cubic_spline_gradient


def particle_positions(L, n):
    """Reference positions x_i = (i + 1/2) L / n, i = 0..n-1 [m].

    Cell-centred, so no particle sits on x = 0 or on x = L/2 where the
    heterogeneous scene's c(x) jumps.
    """
    return (np.arange(n) + 0.5) * (L / n)


@dataclass(frozen=True)
class Neighbours:
    """Neighbour lists of the SPH gradient (eq. 2.9).

    Attributes
    ----------
    index : ndarray of int64, shape (N, K)
        Neighbour j of particle i (i itself where padded).
    weight : ndarray of float, shape (N, K)
        (m_j / ρ_j(0)) ∇W(x_i - x_j) [m^-1] (0 where padded).
    dx : float
        Particle spacing L/N [m].
    h : float
        Smoothing length α Δx [m].
    offsets : ndarray of int64, shape (K,), or None
        index[i, k] = (i + offsets[k]) mod N for every row (:func:`fixed_offsets`), or None when the rows
        differ.
    weight_by_offset : ndarray of float, shape (K, N), or None
        weight transposed (contiguous in i for each offset) when ``offsets`` is set.
    """

    index: np.ndarray
    weight: np.ndarray
    dx: float
    h: float
    offsets: np.ndarray | None = None
    weight_by_offset: np.ndarray | None = None

    @property
    def n(self):
        return self.index.shape[0]

    def loop_arrays(self, layout="auto"):
        """(index, weight, flag bits) as the compiled loops of :mod:`.loops` take the operator.

        ``layout`` "auto": the fixed-offset layout (flag ``loops.STENCIL``: offsets (1, K), weights by offset
        (K, N)) when ``offsets`` is set, else the lists; "general": the lists (N, K) always.
        """
        from .loops import STENCIL
        if layout not in ("auto", "general"):
            raise ValueError(f"layout {layout!r} (allowed: auto, general)")
        if layout == "general" or self.offsets is None:
            return self.index, self.weight, 0
        return self.offsets[None, :], self.weight_by_offset, STENCIL

    def matrix(self):
        """G as a CSR matrix, G @ f = [[∇f]] (eq. 2.9)."""
        n, k = self.index.shape
        rows = np.repeat(np.arange(n), k)
        g = sp.csr_matrix((self.weight.ravel(), (rows, self.index.ravel())), shape=(n, n))
        g.eliminate_zeros()
        return g

    def apply(self, f):
        """[[∇f]]_i for a particle function f (shape (N,) or (N, m))."""
        f = np.asarray(f)
        if f.ndim == 1:
            return np.einsum("ik,ik->i", self.weight, f[self.index])
        return np.einsum("ik,ikm->im", self.weight, f[self.index])


def build_neighbours(x, L, h, volume):
    """Neighbour lists for particles at ``x`` in a periodic domain [0, L).

    Parameters
    ----------
    x : ndarray, shape (N,)
        Sorted reference positions [m].
    L : float
        Period [m].
    h : float
        Smoothing length [m]; 2h must stay below L/2.
    volume : ndarray, shape (N,)
        m_j / ρ_j(0) [m] (the particle "volume", a = 1 m^2).

    Returns
    -------
    Neighbours

    Notes
    -----
    O(N log N) once: candidates come from a binary search in the positions
    extended by one period on each side.
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if 2.0 * h >= 0.5 * L:
        raise ValueError("kernel support 2h must stay below L/2")
    ext = np.concatenate([x - L, x, x + L])
    ext_index = np.tile(np.arange(n), 3)
    lo = np.searchsorted(ext, x - 2.0 * h, side="right")
    hi = np.searchsorted(ext, x + 2.0 * h, side="left")
    counts = hi - lo
    k = int(counts.max())
    offsets = np.arange(k)
    cand = np.minimum(lo[:, None] + offsets[None, :], ext.size - 1)
    valid = offsets[None, :] < counts[:, None]
    j = ext_index[cand]
    r = x[:, None] - ext[cand]
    w = np.where(valid, volume[j] * cubic_spline_gradient(r, h), 0.0)
    index = np.where(valid, j, np.arange(n)[:, None])
    # Drop the self column (∇W(0) = 0) to keep K small.
    keep = np.any(w != 0.0, axis=0)
    index = np.ascontiguousarray(index[:, keep], dtype=np.int64)
    weight = np.ascontiguousarray(w[:, keep])
    fixed = fixed_offsets(index)
    return Neighbours(index=index, weight=weight, dx=L / n, h=h, offsets=fixed,
                      weight_by_offset=None if fixed is None else np.ascontiguousarray(weight.T))


def fixed_offsets(index):
    """The offsets o_k with index[i, k] = (i + o_k) mod N for every row i, or None when the rows differ.

    Parameters
    ----------
    index : ndarray of int, shape (N, K)
        Neighbour lists (:class:`Neighbours`).

    Returns
    -------
    ndarray of int64, shape (K,), or None
        Each o_k taken in (-N/2, N/2] (the minimum image; the support 2h < L/2 keeps real neighbours there).
    """
    n = index.shape[0]
    rel = (index - np.arange(n)[:, None]) % n
    if n == 0 or not np.all(rel == rel[0]):
        return None
    off = rel[0].astype(np.int64)
    return np.where(off > n // 2, off - n, off)


def derivative_factor(alpha):
    """The leading factor 1 + ε of appendix B (eq. B.4), for any α.

    For a uniform lattice the SPH derivative of f = sin(k x) is
    (1 + ε) f' + O(Δx^2) with 1 + ε = -2 Σ_s s Δx^2 ∇W(s Δx) (the sum over
    s >= 1 within the support), which is eq. B.4 for 1 < α < 1.5.
    """
    h = float(alpha)
    s = np.arange(1, int(np.ceil(2 * h)) + 1)
    return float(-2.0 * np.sum(s * cubic_spline_gradient(s.astype(float), h)))


def gradient_symbol(neighbours: Neighbours, L):
    """The symbol D(κ) of the SPH gradient on a uniform periodic lattice.

    G e^{iκx} = i D(κ) e^{iκx}; D is real and odd, D(κ) -> (1 + ε) κ as
    κ Δx -> 0 (appendix B).  Read off particle 0's neighbour weights.
    Returns a function of κ [m^-1] (array) giving D(κ) [m^-1].
    """
    x0 = 0.5 * neighbours.dx
    xj = (neighbours.index[0] + 0.5) * neighbours.dx
    r = np.mod(x0 - xj + 0.5 * L, L) - 0.5 * L        # minimum image x_0 - x_j
    w = neighbours.weight[0]

    def symbol(kappa):
        kappa = np.asarray(kappa, dtype=float)
        return -np.sum(w[None, :] * np.sin(np.multiply.outer(kappa.ravel(), r)), axis=1).reshape(kappa.shape)
    return symbol
