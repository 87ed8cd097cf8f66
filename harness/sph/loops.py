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

    The arrays are taken as views that start at row lo (shifted by each offset), so that the loops index
    from 0 and vectorise.
    """
    k = offsets.size
    m = hi - lo
    rr, a, b = rho[lo:hi], drho[lo:hi], dv[lo:hi]
    r0s = rho0 if ur else rho0[lo:hi]
    r0 = rho0[0]
    if k == 4:                      # α in (1, 1.5): offsets -2, -1, 1, 2; the sums and the finish in one pass
        o0, o1, o2, o3 = offsets[0], offsets[1], offsets[2], offsets[3]
        w0, w1, w2, w3 = weight[0, lo:hi], weight[1, lo:hi], weight[2, lo:hi], weight[3, lo:hi]
        v0, v1, v2, v3 = v[lo + o0:hi + o0], v[lo + o1:hi + o1], v[lo + o2:hi + o2], v[lo + o3:hi + o3]
        p0, p1, p2, p3 = p[lo + o0:hi + o0], p[lo + o1:hi + o1], p[lo + o2:hi + o2], p[lo + o3:hi + o3]
        if ur:
            for t in range(m):
                sv = _sum4(w0[t], w1[t], w2[t], w3[t], v0[t], v1[t], v2[t], v3[t])
                sp_ = _sum4(w0[t], w1[t], w2[t], w3[t], p0[t], p1[t], p2[t], p3[t])
                a[t] = -(rr[t] * rr[t] / r0) * sv              # eq. 2.10
                b[t] = -sp_ / r0                               # eq. 2.11, pressure part
        else:
            for t in range(m):
                sv = _sum4(w0[t], w1[t], w2[t], w3[t], v0[t], v1[t], v2[t], v3[t])
                sp_ = _sum4(w0[t], w1[t], w2[t], w3[t], p0[t], p1[t], p2[t], p3[t])
                a[t] = -(rr[t] * rr[t] / r0s[t]) * sv
                b[t] = -sp_ / r0s[t]
        return
    # any K: the sums of a block of rows in drho, dv (still in L1), one offset at a time, then the finish
    for b0 in range(0, m, STENCIL_BLOCK):
        b1 = min(b0 + STENCIL_BLOCK, m)
        ab, bb = a[b0:b1], b[b0:b1]
        ab[:] = 0.0
        bb[:] = 0.0
        for q in range(k):
            o = offsets[q]
            wq, vq, pq = weight[q, lo + b0:lo + b1], v[lo + b0 + o:lo + b1 + o], p[lo + b0 + o:lo + b1 + o]
            for t in range(b1 - b0):
                ab[t] += wq[t] * vq[t]
                bb[t] += wq[t] * pq[t]
        rb = rr[b0:b1]
        if ur:
            for t in range(b1 - b0):
                ab[t] = -(rb[t] * rb[t] / r0) * ab[t]
                bb[t] = -bb[t] / r0
        else:
            rb0 = r0s[b0:b1]
            for t in range(b1 - b0):
                ab[t] = -(rb[t] * rb[t] / rb0[t]) * ab[t]
                bb[t] = -bb[t] / rb0[t]


@njit(cache=True, nogil=True, error_model="numpy")
def _stencil_wrapped(i, v, rho, offsets, weight, rho0, ur, dv, drho, p):
    """Row i of the fixed-offset layout with periodic wrap-around (the first and last rows)."""
    n = v.size
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
        for i in range(lo):
            _stencil_wrapped(i, v, rho, offsets, weight, rho0, ur, dv, drho, p)
        for i in range(hi, n):
            _stencil_wrapped(i, v, rho, offsets, weight, rho0, ur, dv, drho, p)
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
