"""The original POD-MOR: Galerkin projection (eq. 2.16, Φ = U) of the full SPH
right-hand side (eqs. 2.10-2.11), evaluated at the reconstructed state
v = U^v a^v, ρ = U^ρ a^ρ: O(N k) per step, exact for k = N.
"""

from numba import njit

from ..sph.kernels_numba import rates


@njit(cache=True, nogil=True)
def _original_rates(av, ar, g, Uv, Ur, index, weight, rho0, c, d, profile, flags, dv, dr, v, rho, fv, fr, tmp):
    n, kv = Uv.shape
    kr = Ur.shape[1]
    for i in range(n):
        s = 0.0
        for q in range(kv):
            s += Uv[i, q] * av[q]
        v[i] = s
        s = 0.0
        for q in range(kr):
            s += Ur[i, q] * ar[q]
        rho[i] = s
    rates(v, rho, g, index, weight, rho0, c, d, profile, flags, fv, fr, tmp)   # eqs. 2.10-2.11
    for p in range(kv):                                                          # eq. 2.16, Φ = U
        s = 0.0
        for i in range(n):
            s += Uv[i, p] * fv[i]
        dv[p] = s
    for p in range(kr):
        s = 0.0
        for i in range(n):
            s += Ur[i, p] * fr[i]
        dr[p] = s
