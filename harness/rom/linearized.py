"""POD-MOR with density linearisation (eq. 2.17).

Eq. 2.19 for the velocity with the precomputed K, b, D̂, p̂, and eq. 2.20 for
the density with ρ² recomputed from the reconstruction ρ = U^ρ a^ρ at every
evaluation: O(N k) per step.  The frozen model with n_freeze = 1 is this model.
"""

from numba import njit

from .common import _velocity_rate


@njit(cache=True, nogil=True)
def _linearized_rates(av, ar, g, K, b, D, has_d, pv, has_f, Ur, GUv, inv_rho0, F, dv, dr, rho, w):
    kv, kr = K.shape
    n = Ur.shape[0]
    for p in range(kv):
        F[p] = pv[p] * g if has_f else 0.0
    _velocity_rate(av, ar, K, b, D, has_d, F, dv)                   # eq. 2.19
    for i in range(n):                                              # eq. 2.20, ρ² from U^ρ a^ρ
        r = 0.0
        for a in range(kr):
            r += Ur[i, a] * ar[a]
        s = 0.0
        for q in range(kv):
            s += GUv[i, q] * av[q]
        w[i] = r * r * inv_rho0[i] * s
    for p in range(kr):
        s = 0.0
        for i in range(n):
            s -= Ur[i, p] * w[i]
        dr[p] = s
