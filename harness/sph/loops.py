"""The compiled right-hand side and time loops of the full SPH model (eqs. 2.10-2.11).

The SPH kernel itself (eqs. 2.6-2.7) is :mod:`.kernel`.

numba is used because a step of the explicit schemes is ~20 vector
operations of length N: in numpy each costs ~1 µs of call overhead at
N = 400, in a compiled loop the whole step costs about that (docs/internals/numerics.md: "why
numba").  The loops read the neighbour lists of :mod:`.operator`.

Which terms exist is passed as flags, and each flag removes its work from the
loop (no damping multiply when d ≡ 0, no force when f ≡ 0, a scalar instead
of a per-particle load when c, ρ0 or d is uniform).  Arrays of length 1
carry the scalar of a uniform field.

Two layouts of the operator (eq. 2.9), the same sums:

* general: ``index`` (N, K) and ``weight`` (N, K), neighbour j = index[i, m];
* fixed offsets (flag :data:`STENCIL`, :meth:`.operator.Neighbours.loop_arrays`):
  every row has its neighbours at the same offsets, j = (i + offsets[m]) mod N,
  so ``index`` is the (1, K) row of offsets and ``weight`` the (K, N) weights
  by offset, contiguous in i.  No index is loaded, the wrap-around touches
  only the first and last rows, and the loop over i vectorises.

Both add the K products of a row in the same order m = 0..K-1 from 0.0 and
finish each row with the same operations, so they give the same bits
(tests/test_sph_stencil.py).

``error_model="numpy"``: a division by zero gives inf or nan (caught by the
state checks, status 1) instead of raising, so that the divisions vectorise.
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
STENCIL = 64            # operator layout: fixed offsets (index (1, K) offsets, weight (K, N))

# rows of a block of the general-K stencil (its partial sums stay in L1)
STENCIL_BLOCK = 256


@njit(cache=True, nogil=True, error_model="numpy")
def _pressure(rho, rho0, c, flags, p):
    """p_j = c_j (1 - ρ_j(0)/ρ_j), the inner bracket of eq. 2.11."""
    uc = (flags & UNIFORM_C) != 0
    ur = (flags & UNIFORM_RHO0) != 0
    for j in range(rho.size):
        r0 = rho0[0] if ur else rho0[j]
        cj = c[0] if uc else c[j]
        p[j] = cj * (1.0 - r0 / rho[j])


@njit(cache=True, nogil=True, error_model="numpy")
def _sum4(w0, w1, w2, w3, f0, f1, f2, f3):
    """Σ_m w_m f_m from 0.0 in the order m = 0..3, as the general loop adds a row."""
    s = 0.0
    s += w0 * f0
    s += w1 * f1
    s += w2 * f2
    s += w3 * f3
    return s


@njit(cache=True, nogil=True, error_model="numpy")
def _stencil_rows(lo, hi, v, rho, offsets, weight, rho0, ur, dv, drho, p):
    """Rows lo..hi-1 of the fixed-offset layout, every neighbour inside [0, N) (no wrap-around).

    The indices are unsigned (i = lo + t, j = lo + offset + t, all >= 0): numba then needs no negative-index
    check and no array views (whose reference counts cost more than the rows at small N), and the loop over t
    vectorises.
    """
    k = offsets.size
    ulo, m = np.uint64(lo), np.uint64(hi - lo)
    r0 = rho0[0]
    if k == 4:                      # α in (1, 1.5): offsets -2, -1, 1, 2; the sums and the finish in one pass
        s0, s1 = np.uint64(lo + offsets[0]), np.uint64(lo + offsets[1])
        s2, s3 = np.uint64(lo + offsets[2]), np.uint64(lo + offsets[3])
        q0, q1, q2, q3 = np.uint64(0), np.uint64(1), np.uint64(2), np.uint64(3)
        if ur:
            for t in range(m):
                i = ulo + t
                w0, w1, w2, w3 = weight[q0, i], weight[q1, i], weight[q2, i], weight[q3, i]
                sv = _sum4(w0, w1, w2, w3, v[s0 + t], v[s1 + t], v[s2 + t], v[s3 + t])
                sp_ = _sum4(w0, w1, w2, w3, p[s0 + t], p[s1 + t], p[s2 + t], p[s3 + t])
                drho[i] = -(rho[i] * rho[i] / r0) * sv           # eq. 2.10
                dv[i] = -sp_ / r0                                # eq. 2.11, pressure part
        else:
            for t in range(m):
                i = ulo + t
                w0, w1, w2, w3 = weight[q0, i], weight[q1, i], weight[q2, i], weight[q3, i]
                sv = _sum4(w0, w1, w2, w3, v[s0 + t], v[s1 + t], v[s2 + t], v[s3 + t])
                sp_ = _sum4(w0, w1, w2, w3, p[s0 + t], p[s1 + t], p[s2 + t], p[s3 + t])
                drho[i] = -(rho[i] * rho[i] / rho0[i]) * sv
                dv[i] = -sp_ / rho0[i]
        return
    # any K: the sums of a block of rows in drho, dv (still in L1), one offset at a time, then the finish
    for b0 in range(lo, hi, STENCIL_BLOCK):
        ub0, bm = np.uint64(b0), np.uint64(min(STENCIL_BLOCK, hi - b0))
        for t in range(bm):
            drho[ub0 + t] = 0.0
            dv[ub0 + t] = 0.0
        for q in range(k):
            uq, sq = np.uint64(q), np.uint64(b0 + offsets[q])
            for t in range(bm):
                i = ub0 + t
                drho[i] += weight[uq, i] * v[sq + t]
                dv[i] += weight[uq, i] * p[sq + t]
        for t in range(bm):
            i = ub0 + t
            ri = r0 if ur else rho0[i]
            drho[i] = -(rho[i] * rho[i] / ri) * drho[i]
            dv[i] = -dv[i] / ri


@njit(cache=True, nogil=True, error_model="numpy")
def _stencil_wrapped(lo, hi, v, rho, offsets, weight, rho0, ur, dv, drho, p):
    """Rows 0..lo-1 and hi..N-1 of the fixed-offset layout: the periodic wrap-around (eq. 2.9's minimum image)."""
    n = v.size
    for t in range(lo + n - hi):
        i = t if t < lo else hi + (t - lo)
        sv = 0.0
        sp_ = 0.0
        for m in range(offsets.size):
            j = i + offsets[m]
            if j < 0:
                j += n
            elif j >= n:
                j -= n
            sv += weight[m, i] * v[j]
            sp_ += weight[m, i] * p[j]
        r0 = rho0[0] if ur else rho0[i]
        drho[i] = -(rho[i] * rho[i] / r0) * sv
        dv[i] = -sp_ / r0


@njit(cache=True, nogil=True, error_model="numpy")
def rates(v, rho, g, index, weight, rho0, c, d, profile, flags, dv, drho, p):
    """Right-hand sides of eqs. 2.10-2.11 into ``dv`` and ``drho``.

    g is the force time history f(t) at this stage [m s^-2]; ``p`` is scratch.
    ``index``, ``weight``: the general layout (N, K), or with flag
    :data:`STENCIL` the offsets (1, K) and the weights by offset (K, N).
    """
    n = v.size
    ur = (flags & UNIFORM_RHO0) != 0
    _pressure(rho, rho0, c, flags, p)
    if flags & STENCIL:
        offsets = index[0]
        lo, hi = 0, n                    # rows whose neighbours need no wrap-around
        for m in range(offsets.size):
            lo = max(lo, -offsets[m])
            hi = min(hi, n - offsets[m])
        hi = max(hi, lo)
        _stencil_rows(lo, hi, v, rho, offsets, weight, rho0, ur, dv, drho, p)
        _stencil_wrapped(lo, hi, v, rho, offsets, weight, rho0, ur, dv, drho, p)
    else:
        k = index.shape[1]
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


@njit(cache=True, nogil=True, error_model="numpy")
def _finite_positive(v, rho):
    for i in range(v.size):
        if not (np.isfinite(v[i]) and np.isfinite(rho[i]) and rho[i] > 0.0):
            return False
    return True


@njit(cache=True, nogil=True, error_model="numpy")
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


@njit(cache=True, nogil=True, error_model="numpy")
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
