"""Compiled pieces shared by the reduced models' loops, and the structures the loops take.

A leaf module: it imports nothing from :mod:`sphrom.rom`, so the loops of
:mod:`.frozen` and :mod:`.galerkin` and the rates of :mod:`.linearized` build
on it without import cycles.

The loops take their operators as one named tuple (numba passes a
``collections.namedtuple`` of arrays and scalars to an ``@njit`` function as a
struct; the tuple types are defined here, at module level, so the compiled
loops cache): the signature of a loop is (method, state arrays, step range,
dt, forces, operators, sampling arrays, bound).

Status codes of the compiled loops: 0 ok, 1 non-finite, 2 runaway (|a| above
the bound).
"""

from collections import namedtuple

import numpy as np
from numba import njit

# The frozen-coefficient loop (eqs. 2.19-2.24): K, b, D̂, p̂ of eq. 2.19 (D, p dummies when
# has_d / has_f is False), the refresh tensor T with its pair index (use_tensor), or U^ρ, G U^v, 1/ρ0 for
# the O(N k²) refresh, and the refresh period n_freeze [steps].
FrozenOperators = namedtuple("FrozenOperators", ["K", "b", "D", "has_d", "p", "has_f", "T", "pairs", "use_tensor",
                                                 "U_rho", "GU_v", "inv_rho0", "n_freeze"])

# The Galerkin loop of the original (full_rhs: the full SPH right-hand side at the reconstruction,
# eq. 2.16) and the density-linearised model (eqs. 2.17, 2.19-2.20): the reduced operators, the bases,
# and the SPH operator and fields of :mod:`sphrom.sph.loops` (index, weight, packed fields, flags).
GalerkinOperators = namedtuple("GalerkinOperators", ["full_rhs", "K", "b", "D", "has_d", "p", "has_f", "GU_v",
                                                     "inv_rho0", "U_v", "U_rho", "index", "weight", "rho0", "c",
                                                     "d", "profile", "flags"])


@njit(cache=True, nogil=True)
def _check(av, ar, bound):
    for i in range(av.size):
        if not np.isfinite(av[i]):
            return 1
        if abs(av[i]) > bound:
            return 2
    for i in range(ar.size):
        if not np.isfinite(ar[i]):
            return 1
        if abs(ar[i]) > bound:
            return 2
    return 0


@njit(cache=True, nogil=True)
def _velocity_rate(av, ar, K, b, D, has_d, F, dv):
    """ȧ^v = b + F - K a^ρ - D̂ a^v (eq. 2.19), F the projected force."""
    kv, kr = K.shape
    for p in range(kv):
        s = b[p] + F[p]
        for q in range(kr):
            s -= K[p, q] * ar[q]
        if has_d:
            for q in range(kv):
                s -= D[p, q] * av[q]
        dv[p] = s
