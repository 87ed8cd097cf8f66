"""The time loop shared by the original and the density-linearised POD-MOR.

Both are Galerkin models whose rate needs the full state, so they share
Euler, symplectic Euler (ρ then v) and RK4; ``model`` 0 is the original
(:mod:`.original`), 1 the linearised (:mod:`.linearized`).
"""

import numpy as np
from numba import njit

from .common import _check
from .linearized import _linearized_rates
from .original import _original_rates


@njit(cache=True, nogil=True)
def galerkin_advance(model, method, av, ar, n0, n1, dt, g,
                     K, b, D, has_d, pv, has_f, GUv, inv_rho0,
                     Uv, Ur, index, weight, rho0, c, d, profile, flags,
                     sample_steps, ptr, out_av, out_ar, bound):
    """Original (model 0) or linearised (model 1) POD-MOR from step n0 to n1.

    method 0 Euler, 1 symplectic Euler (ρ then v), 2 RK4; g[row] holds f at
    the stage times t_n, t_n + dt/2, t_n + dt.
    """
    n = Uv.shape[0]
    kv, kr = av.size, ar.size
    dv = np.empty(kv); dr = np.empty(kr); F = np.empty(kv)
    v = np.empty(n); rho = np.empty(n); fv = np.empty(n); fr = np.empty(n); tmp = np.empty(n)
    k1v = np.empty(kv); k1r = np.empty(kr); k2v = np.empty(kv); k2r = np.empty(kr)
    k3v = np.empty(kv); k3r = np.empty(kr); tv = np.empty(kv); tr = np.empty(kr)

    for step in range(n0, n1):
        if ptr < sample_steps.size and sample_steps[ptr] == step:
            out_av[ptr, :] = av
            out_ar[ptr, :] = ar
            ptr += 1
        row = step - n0
        if method == 2:
            for stage in range(4):
                if stage == 0:
                    tv[:] = av; tr[:] = ar; gs = g[row, 0]
                elif stage == 1:
                    for p in range(kv): tv[p] = av[p] + 0.5 * dt * k1v[p]
                    for p in range(kr): tr[p] = ar[p] + 0.5 * dt * k1r[p]
                    gs = g[row, 1]
                elif stage == 2:
                    for p in range(kv): tv[p] = av[p] + 0.5 * dt * k2v[p]
                    for p in range(kr): tr[p] = ar[p] + 0.5 * dt * k2r[p]
                    gs = g[row, 1]
                else:
                    for p in range(kv): tv[p] = av[p] + dt * k3v[p]
                    for p in range(kr): tr[p] = ar[p] + dt * k3r[p]
                    gs = g[row, 2]
                if model == 0:
                    _original_rates(tv, tr, gs, Uv, Ur, index, weight, rho0, c, d, profile, flags,
                                    dv, dr, v, rho, fv, fr, tmp)
                else:
                    _linearized_rates(tv, tr, gs, K, b, D, has_d, pv, has_f, Ur, GUv, inv_rho0, F, dv, dr, rho, tmp)
                if stage == 0:
                    k1v[:] = dv; k1r[:] = dr
                elif stage == 1:
                    k2v[:] = dv; k2r[:] = dr
                elif stage == 2:
                    k3v[:] = dv; k3r[:] = dr
            for p in range(kv):
                av[p] += dt / 6.0 * (k1v[p] + 2.0 * k2v[p] + 2.0 * k3v[p] + dv[p])
            for p in range(kr):
                ar[p] += dt / 6.0 * (k1r[p] + 2.0 * k2r[p] + 2.0 * k3r[p] + dr[p])
        else:
            gs = g[row, 0]
            if model == 0:
                _original_rates(av, ar, gs, Uv, Ur, index, weight, rho0, c, d, profile, flags,
                                dv, dr, v, rho, fv, fr, tmp)
            else:
                _linearized_rates(av, ar, gs, K, b, D, has_d, pv, has_f, Ur, GUv, inv_rho0, F, dv, dr, rho, tmp)
            if method == 0:
                for p in range(kv):
                    av[p] += dt * dv[p]
                for p in range(kr):
                    ar[p] += dt * dr[p]
            else:
                for p in range(kr):
                    ar[p] += dt * dr[p]
                if model == 0:
                    _original_rates(av, ar, gs, Uv, Ur, index, weight, rho0, c, d, profile, flags,
                                    dv, dr, v, rho, fv, fr, tmp)
                else:
                    _linearized_rates(av, ar, gs, K, b, D, has_d, pv, has_f, Ur, GUv, inv_rho0, F, dv, dr, rho, tmp)
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

