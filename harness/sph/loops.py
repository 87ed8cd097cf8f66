"""The compiled right-hand side and time loops of the full SPH model (eqs. 2.10-2.11).

The SPH kernel itself (eqs. 2.6-2.7) is :mod:`.kernel`.

numba is used because a step of the explicit schemes is ~20 vector
operations of length N: in numpy each costs ~1 µs of call overhead at
N = 400, in a compiled loop the whole step costs about that (README: "why
numba").  The loops read the neighbour lists of :mod:`.operator`.

Which terms exist is passed as flags, and each flag removes its work from the
loop (no damping multiply when d ≡ 0, no force when f ≡ 0, a scalar instead
of a per-particle load when c, ρ0 or d is uniform).  Arrays of length 1
carry the scalar of a uniform field.
"""

import numpy as np
from numba import njit

# flag bits
DAMPING = 1
FORCE = 2
UNIFORM_C = 4
UNIFORM_RHO0 = 8
UNIFORM_D = 16
UNIFORM_PROFILE = 32


@njit(cache=True, nogil=True)
def rates(v, rho, g, index, weight, rho0, c, d, profile, flags, dv, drho, p):
    """Right-hand sides of eqs. 2.10-2.11 into ``dv`` and ``drho``.

    g is the force time history f(t) at this stage [m s^-2]; ``p`` is scratch.
    """
    n, k = index.shape
    uc = (flags & UNIFORM_C) != 0
    ur = (flags & UNIFORM_RHO0) != 0
    # p_j = c_j (1 - ρ_j(0)/ρ_j), the inner bracket of eq. 2.11
    for j in range(n):
        r0 = rho0[0] if ur else rho0[j]
        cj = c[0] if uc else c[j]
        p[j] = cj * (1.0 - r0 / rho[j])
    for i in range(n):
        sv = 0.0
        sp_ = 0.0
        for m in range(k):
            j = index[i, m]
            w = weight[i, m]
            sv += w * v[j]
            sp_ += w * p[j]
        r0 = rho0[0] if ur else rho0[i]
        drho[i] = -(rho[i] * rho[i] / r0) * sv          # eq. 2.10
        dv[i] = -sp_ / r0                                # eq. 2.11, pressure part
    if flags & DAMPING:
        if flags & UNIFORM_D:
            d0 = d[0]
            for i in range(n):
                dv[i] -= d0 * v[i]
        else:
            for i in range(n):
                dv[i] -= d[i] * v[i]
    if flags & FORCE:
        if flags & UNIFORM_PROFILE:
            f0 = profile[0] * g
            for i in range(n):
                dv[i] += f0
        else:
            for i in range(n):
                dv[i] += profile[i] * g


@njit(cache=True, nogil=True)
def _finite_positive(v, rho):
    for i in range(v.size):
        if not (np.isfinite(v[i]) and np.isfinite(rho[i]) and rho[i] > 0.0):
            return False
    return True


@njit(cache=True, nogil=True)
def energy(v, rho, rho0, c, flags, dx):
    """½ Σ ρ0 v² Δx + ½ Σ c e² Δx with e = ρ0/ρ − 1 (see ``solver.energy``)."""
    uc = (flags & UNIFORM_C) != 0
    ur = (flags & UNIFORM_RHO0) != 0
    s = 0.0
    for i in range(v.size):
        r0 = rho0[0] if ur else rho0[i]
        ci = c[0] if uc else c[i]
        e = r0 / rho[i] - 1.0
        s += r0 * v[i] * v[i] + ci * e * e
    return 0.5 * dx * s


@njit(cache=True, nogil=True)
def advance(method, v, rho, n0, n1, dt, gvals, index, weight, rho0, c, d, profile, flags,
            sample_steps, ptr, out_v, out_rho, check_every, energy_max, dx):
    """Advance (v, ρ) from step n0 to step n1 in place.

    Parameters
    ----------
    method : int
        0 explicit Euler (the paper's), 1 symplectic Euler (ρ then v),
        2 classical RK4.
    gvals : ndarray, shape (n1 - n0, 3)
        f at t_n, t_n + dt/2, t_n + dt for each step (only column 0 is read
        by the Euler schemes).
    sample_steps, ptr, out_v, out_rho
        Samples are stored at the steps listed in ``sample_steps`` (sorted);
        ``ptr`` is the next one to store.
    check_every : int
        The state is checked every ``check_every`` steps and at n1.
    energy_max : float
        A state whose :func:`energy` exceeds this has blown up (np.inf: no
        check); ``dx`` is the particle spacing [m].

    Returns
    -------
    (status, ptr, step)
        status 0 when every state stayed finite with ρ > 0 and energy at most
        ``energy_max``; 1 (non-finite or ρ <= 0) or 2 (energy) and the step at
        which the check failed.
    """
    n = v.size
    dv = np.empty(n)
    drho = np.empty(n)
    p = np.empty(n)
    if method == 2:
        k1v = np.empty(n); k1r = np.empty(n); k2v = np.empty(n); k2r = np.empty(n)
        k3v = np.empty(n); k3r = np.empty(n); tv = np.empty(n); tr = np.empty(n)
    for step in range(n0, n1):
        if ptr < sample_steps.size and sample_steps[ptr] == step:
            out_v[ptr, :] = v
            out_rho[ptr, :] = rho
            ptr += 1
        row = step - n0
        if method == 0:
            rates(v, rho, gvals[row, 0], index, weight, rho0, c, d, profile, flags, dv, drho, p)
            for i in range(n):
                v[i] += dt * dv[i]
                rho[i] += dt * drho[i]
        elif method == 1:
            rates(v, rho, gvals[row, 0], index, weight, rho0, c, d, profile, flags, dv, drho, p)
            for i in range(n):
                rho[i] += dt * drho[i]
            rates(v, rho, gvals[row, 0], index, weight, rho0, c, d, profile, flags, dv, drho, p)
            for i in range(n):
                v[i] += dt * dv[i]
        else:
            rates(v, rho, gvals[row, 0], index, weight, rho0, c, d, profile, flags, k1v, k1r, p)
            for i in range(n):
                tv[i] = v[i] + 0.5 * dt * k1v[i]
                tr[i] = rho[i] + 0.5 * dt * k1r[i]
            rates(tv, tr, gvals[row, 1], index, weight, rho0, c, d, profile, flags, k2v, k2r, p)
            for i in range(n):
                tv[i] = v[i] + 0.5 * dt * k2v[i]
                tr[i] = rho[i] + 0.5 * dt * k2r[i]
            rates(tv, tr, gvals[row, 1], index, weight, rho0, c, d, profile, flags, k3v, k3r, p)
            for i in range(n):
                tv[i] = v[i] + dt * k3v[i]
                tr[i] = rho[i] + dt * k3r[i]
            rates(tv, tr, gvals[row, 2], index, weight, rho0, c, d, profile, flags, dv, drho, p)
            for i in range(n):
                v[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + dv[i])
                rho[i] += dt / 6.0 * (k1r[i] + 2.0 * k2r[i] + 2.0 * k3r[i] + drho[i])
        if (step + 1 - n0) % check_every == 0 or step + 1 == n1:
            if not _finite_positive(v, rho):
                return 1, ptr, step + 1
            if energy(v, rho, rho0, c, flags, dx) > energy_max:
                return 2, ptr, step + 1
    if ptr < sample_steps.size and sample_steps[ptr] == n1:
        out_v[ptr, :] = v
        out_rho[ptr, :] = rho
        ptr += 1
    return 0, ptr, n1
