"""The 1D cubic-spline kernel of eq. 2.6 and its derivative, eq. 2.7.

The cross-section is a = 1 m^2, so W has units m^-1 and ∇W units m^-2.
"""

import numpy as np


def cubic_spline(r, h):
    """W_h(r), eq. 2.6.

    Parameters
    ----------
    r : array_like
        Signed distance x_i - x_j [m].
    h : float
        Smoothing length [m].

    Returns
    -------
    ndarray
        Kernel values [m^-1]; support |r| < 2h, integral 1.
    """
    q = np.abs(np.asarray(r, dtype=float)) / h
    w = np.where(q <= 1.0, 1.0 - 1.5 * q**2 + 0.75 * q**3,
                 np.where(q <= 2.0, 0.25 * (2.0 - q) ** 3, 0.0))
    return 2.0 / (3.0 * h) * w


def cubic_spline_gradient(r, h):
    """dW_h/dr at signed distance r, eq. 2.7 [m^-2].

    Odd in r: negative for 0 < r < 2h.
    """
    r = np.asarray(r, dtype=float)
    q = np.abs(r) / h
    g = np.where(q <= 1.0, -3.0 * q + 2.25 * q**2,
                 np.where(q <= 2.0, -0.75 * (2.0 - q) ** 2, 0.0))
    return 2.0 / (3.0 * h**2) * g * np.sign(r)
