"""Values of fields at probe positions, linear between the particles around each probe as the FMU interpolates.

A leaf module of :mod:`sphrom.rom` (numpy only), so the protocol, the operators and the result share it.
"""

from __future__ import annotations

import numpy as np


def probe_pairs(x, L, probes):
    """The particles around each probe and the weight of the second one, as the FMU interpolates.

    Parameters
    ----------
    x : ndarray (N,)
        Uniform, cell-centred particle positions [m].
    L : float
        Period [m].
    probes : array_like
        Probe positions in units of L, in [0, 1].

    Returns
    -------
    (i0, i1, w) : ndarray (P,) int, ndarray (P,) int, ndarray (P,)
        A field at probe j is (1 - w_j) f[i0_j] + w_j f[i1_j].
    """
    probes = np.asarray(probes, float)
    n = x.size
    dx = L / n
    s = np.mod(probes * L - x[0], L) / dx        # fractional index from particle 0
    i0 = np.floor(s).astype(np.int64) % n
    w = s - np.floor(s)
    return i0, (i0 + 1) % n, w


def probe_rows(U, x, L, probes):
    """Rows that interpolate U a linearly between particles at ``probes``.

    Parameters
    ----------
    U : ndarray (N, k)
        Basis; the field is U a at the particles x.
    x : ndarray (N,)
        Uniform, cell-centred particle positions [m].
    L : float
        Period [m].
    probes : array_like
        Probe positions in units of L, in [0, 1].

    Returns
    -------
    ndarray (P, k): row j gives the field at probe j as row @ a.
    """
    i0, i1, w = probe_pairs(x, L, probes)
    return (1.0 - w)[:, None] * U[i0] + w[:, None] * U[i1]


def probe_values(v, rho, rho0, x, L, probes):
    """Fields (M, N) at ``probes`` (x/L), linear between particles as the FMU does, (M, 2P): v [m s^-1], then
    e = ρ0/ρ - 1 (the rows of :func:`sphrom.rom.lti.full_linear_system`'s C)."""
    e = np.asarray(rho0)[None, :] / np.asarray(rho) - 1.0
    return np.concatenate([probe_rows(np.asarray(v).T, x, L, probes).T, probe_rows(e.T, x, L, probes).T], axis=1)
