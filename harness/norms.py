"""The space-time relative L² error of eq. 3.4.

Eq. 3.4 as printed is the ratio of the squared norms,
    ∫∫ (u - u_ref)^2 dx dt / ∫∫ u_ref^2 dx dt,
with no square root.  The headline figure of this project is the usual
relative L² error ||u - u_ref|| / ||u_ref||, the square root of it;
``squared=True`` gives the printed form.  The x integral is the rectangle
rule on the (uniform, periodic) particles, the t integral the trapezoidal
rule on the sample times, so non-uniform samples are weighted correctly.
"""

import numpy as np


def time_weights(t):
    """Trapezoidal weights for samples at times ``t`` (a single sample: 1)."""
    t = np.asarray(t, dtype=float)
    if t.size == 1:
        return np.ones(1)
    w = np.zeros_like(t)
    dt = np.diff(t)
    w[:-1] += 0.5 * dt
    w[1:] += 0.5 * dt
    return w


def relative_l2(u, ref, t=None, squared=False, baseline=None):
    """Space-time relative L² error of ``u`` against ``ref`` (eq. 3.4).

    Parameters
    ----------
    u, ref : ndarray, shape (M, N)
        Samples at M times and N equally spaced points.
    t : ndarray, shape (M,), optional
        Sample times [s]; default equal weights.
    squared : bool
        Return the printed form of eq. 3.4 (ratio of squares) instead of
        its square root.
    baseline : ndarray, shape (N,) or (M, N), optional
        Subtracted from both before the ratio, e.g. ρ0 to measure the error
        of ρ relative to the variation ρ - ρ0 (relative to ρ itself any
        method looks accurate, as ρ ≈ 1).

    Returns
    -------
    float
    """
    u = np.asarray(u, dtype=float)
    ref = np.asarray(ref, dtype=float)
    if u.shape != ref.shape:
        raise ValueError(f"shapes differ: {u.shape} vs {ref.shape}")
    if baseline is not None:
        u = u - baseline
        ref = ref - baseline
    w = np.ones(u.shape[0]) if t is None else time_weights(t)
    num = float(np.sum(w[:, None] * (u - ref) ** 2))
    den = float(np.sum(w[:, None] * ref**2))
    if den == 0.0:
        return 0.0 if num == 0.0 else float("inf")
    ratio = num / den
    return ratio if squared else float(np.sqrt(ratio))


def relative_l2_history(u, ref, t, baseline=None):
    """Eq. 3.4 over [0, t_m] for every sample time t_m (square-root form).

    Parameters
    ----------
    u, ref : ndarray, shape (M, N)
    t : ndarray, shape (M,)
        Sample times [s].
    baseline : ndarray, optional
        Subtracted from both (see :func:`relative_l2`).

    Returns
    -------
    ndarray (M,)
        The relative error of the run cut at each sample time (the first
        entry uses the first sample alone).
    """
    u = np.asarray(u, dtype=float)
    ref = np.asarray(ref, dtype=float)
    if baseline is not None:
        u = u - baseline
        ref = ref - baseline
    t = np.asarray(t, dtype=float)
    num = np.sum((u - ref) ** 2, axis=1)
    den = np.sum(ref**2, axis=1)
    dt = np.diff(t)
    cnum = np.concatenate([[num[0]], np.cumsum(0.5 * dt * (num[1:] + num[:-1]))])
    cden = np.concatenate([[den[0]], np.cumsum(0.5 * dt * (den[1:] + den[:-1]))])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(np.where(cden > 0, cnum / cden, np.where(cnum > 0, np.inf, 0.0)))
