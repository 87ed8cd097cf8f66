"""Accelerated POD-MOR with frozen coefficients (eqs. 2.19-2.24).

M(a^ρ) = U^ρᵀ diag(ρ²/ρ0) G U^v (eq. 2.23 projected) and the force
projection p̂ f(t) are refreshed every ``n_freeze`` steps; between refreshes a
step costs O(k²).  The refresh uses the exact tensor of
:mod:`harness.rom.operators` (O(k_ρ³ k_v / 2), no N) or, as the reference, the
straightforward O(N k²) product.

The step is written with plain loops in a fixed order, which the C model core
(fmu_src/rom.c) repeats operation for operation:

    refresh (step % n_freeze == 0):
        M[p][q] = 0;  for each pair (a <= b): s = ar[a]*ar[b]; M[p][q] += s*T[pair][p][q]
        F[p] = pv[p]*g
    dr[p] = 0;            dr[p] -= M[p][q]*av[q]          (q ascending)
    dv[p] = b[p] + F[p];  dv[p] -= K[p][q]*ar[q];  dv[p] -= D[p][q]*av[q]
    euler:      av += h*dv;  ar += h*dr              (dv, dr from the old state)
    symplectic: ar += h*dr, then dv with the new ar, av += h*dv
"""

import numpy as np
from numba import njit

from .common import _check, _velocity_rate


@njit(cache=True, nogil=True)
def _density_rate_frozen(av, M, dr):
    kr, kv = M.shape
    for p in range(kr):
        s = 0.0
        for q in range(kv):
            s -= M[p, q] * av[q]
        dr[p] = s


@njit(cache=True, nogil=True)
def refresh_tensor_path(ar, T, pairs, M):
    """M = Σ_{a<=b} ar[a] ar[b] T[pair] (exact, no N)."""
    kr, kv = M.shape
    for p in range(kr):
        for q in range(kv):
            M[p, q] = 0.0
    for k in range(pairs.shape[0]):
        s = ar[pairs[k, 0]] * ar[pairs[k, 1]]
        for p in range(kr):
            for q in range(kv):
                M[p, q] += s * T[k, p, q]


@njit(cache=True, nogil=True)
def refresh_direct_path(ar, Ur, GUv, inv_rho0, M):
    """M = U^ρᵀ diag(ρ²/ρ0) G U^v with ρ = U^ρ a^ρ: the O(N k²) reference path."""
    n, kr = Ur.shape
    kv = GUv.shape[1]
    for p in range(kr):
        for q in range(kv):
            M[p, q] = 0.0
    for i in range(n):
        rho = 0.0
        for a in range(kr):
            rho += Ur[i, a] * ar[a]
        w = rho * rho * inv_rho0[i]
        for p in range(kr):
            up = w * Ur[i, p]
            for q in range(kv):
                M[p, q] += up * GUv[i, q]


@njit(cache=True, nogil=True)
def frozen_advance(method, av, ar, n0, n1, dt, g, K, b, D, has_d, pv, has_f, T, pairs, use_tensor,
                   Ur, GUv, inv_rho0, n_freeze, M, F, sample_steps, ptr, out_av, out_ar, bound):
    """Frozen-coefficient model from step n0 to n1 (method 0 Euler, 1 symplectic).

    ``M`` and ``F`` carry the frozen coefficients between calls; ``g[row]`` is
    f at step n0 + row.  Returns (status, ptr, step).
    """
    kv, kr = K.shape
    dv = np.empty(kv)
    dr = np.empty(kr)
    for step in range(n0, n1):
        if ptr < sample_steps.size and sample_steps[ptr] == step:
            out_av[ptr, :] = av
            out_ar[ptr, :] = ar
            ptr += 1
        if step % n_freeze == 0:
            if use_tensor:
                refresh_tensor_path(ar, T, pairs, M)
            else:
                refresh_direct_path(ar, Ur, GUv, inv_rho0, M)
            for p in range(kv):
                F[p] = pv[p] * g[step - n0] if has_f else 0.0
        _density_rate_frozen(av, M, dr)
        if method == 0:
            _velocity_rate(av, ar, K, b, D, has_d, F, dv)
            for p in range(kv):
                av[p] += dt * dv[p]
            for p in range(kr):
                ar[p] += dt * dr[p]
        else:
            for p in range(kr):
                ar[p] += dt * dr[p]
            _velocity_rate(av, ar, K, b, D, has_d, F, dv)
            for p in range(kv):
                av[p] += dt * dv[p]
        if (step + 1 - n0) % 64 == 0 or step + 1 == n1:
            status = _check(av, ar, bound)
            if status != 0:
                return status, ptr, step + 1
    if ptr < sample_steps.size and sample_steps[ptr] == n1:
        out_av[ptr, :] = av
        out_ar[ptr, :] = ar
        ptr += 1
    return 0, ptr, n1
