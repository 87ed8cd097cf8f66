"""Exact solution of eqs. 2.2-2.4 when c, ρ0 and d are uniform.

In the displacement form of appendix A (eqs. A.1-A.3), with u = z - x,

    u_tt = (c/ρ0) u_xx - d u_t + profile(x) f(t),   u(x,0) = 0, u_t(x,0) = v0(x),
    v = u_t,   ρ = ρ0 / (1 + u_x)                                 (A.3)

is linear with constant coefficients.  Two independent paths evaluate it:

* **d'Alembert** (d = 0): v = [v0(x + c_s t) + v0(x - c_s t)]/2 and
  u_x = [v0(x + c_s t) - v0(x - c_s t)]/(2 c_s), exact at every point, even
  where v0 has a kink (the tenmode profile) - no Gibbs oscillations.
* **Fourier** (any d): every mode k of v0 is a damped oscillator
  û'' + d û' + ω_k² û = 0, ω_k = 2π|k| c_s / L, with the closed form
  û = v̂_k S_k(t), S = (e^{λ+ t} - e^{λ- t})/(λ+ - λ-), λ± = -d/2 ± iμ,
  μ = sqrt(ω² - d²/4) (eqs. 3.2-3.3 and C.3-C.4 are special cases).
  The written exponentials never overflow, whatever d and t.

The force adds, per Fourier mode of the profile (only the mean mode for a
uniform profile), the Duhamel integral ∫_0^t S_k(t-s) p̂_k f(s) ds, advanced
between samples by the exact 2x2 propagator with 16-point Gauss-Legendre
quadrature on pieces short against every time scale (machine precision for a
smooth f).  c_s = sqrt(c/ρ0) is the sound speed of eq. 2.5 at rest.
"""

from __future__ import annotations

import numpy as np

from ..scene import Scene

FFT_POINTS_MAX = 2**16
MODE_TOL = 1e-15


class ExactUnavailable(Exception):
    """The scene has no exact solution (non-uniform c, ρ0 or d)."""


def check_available(scene: Scene, n_check=4096):
    """Raise ExactUnavailable unless c, ρ0 and d are uniform in x."""
    x = (np.arange(n_check) + 0.5) * scene.L / n_check
    for name in ("c", "rho0", "d"):
        values = scene.field(name, x)
        if not np.all(values == values[0]):
            raise ExactUnavailable(f"scene '{scene.name}': {name}(x) is not uniform, so there is no exact "
                                   "solution; use a continuum reference (sphrom reference)")
    return {name: float(scene.field(name, x[:1])[0]) for name in ("c", "rho0", "d")}


def is_available(scene: Scene) -> bool:
    try:
        check_available(scene)
        return True
    except ExactUnavailable:
        return False


def _fourier(fn, L, tol=MODE_TOL):
    """Fourier coefficients a_k of a periodic function, f = Σ a_k e^{2πikx/L}.

    Doubles the sample count until the top octave holds less than tol of the
    amplitude, or FFT_POINTS_MAX points.  Returns (k, a_k) of the kept modes.
    """
    m = 256
    while True:
        x = np.arange(m) * (L / m)
        a = np.fft.fft(fn(x)) / m
        k = np.fft.fftfreq(m, d=1.0 / m).astype(np.int64)
        amax = np.abs(a).max()
        top = np.abs(a[np.abs(k) > m // 4])
        if amax == 0.0:
            return k[:0], a[:0]
        if top.size == 0 or top.max() <= tol * amax or m >= FFT_POINTS_MAX:
            keep = np.abs(a) > tol * amax
            return k[keep], a[keep]
        m *= 2


def _lambdas(k, L, cs, d, symbol=None):
    kappa = 2.0 * np.pi * k / L
    omega = cs * (np.abs(kappa) if symbol is None else np.abs(symbol(kappa)))
    mu = np.sqrt(omega.astype(complex) ** 2 - 0.25 * d * d)
    return omega, mu, -0.5 * d + 1j * mu, -0.5 * d - 1j * mu


def _s_and_ds(mu, lp, lm, d, t):
    """S(t) and S'(t) for S'' + d S' + ω² S = 0, S(0) = 0, S'(0) = 1.

    Shapes: mu, lp, lm (K,); t (M,) -> (M, K).
    """
    t = np.asarray(t, dtype=float)[:, None]
    mu = mu[None, :]
    ep, em = np.exp(lp[None, :] * t), np.exp(lm[None, :] * t)
    small = np.abs(mu * t) < 1e-3
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (ep - em) / (lp - lm)[None, :]
        ds = (lp[None, :] * ep - lm[None, :] * em) / (lp - lm)[None, :]
    if np.any(small):
        z2 = (mu * t) ** 2
        decay = np.exp(-0.5 * d * t)
        s_ser = t * decay * (1.0 - z2 / 6.0 + z2**2 / 120.0)
        ds_ser = decay * ((1.0 - z2 / 2.0 + z2**2 / 24.0) - 0.5 * d * t * (1.0 - z2 / 6.0 + z2**2 / 120.0))
        s = np.where(small, s_ser, s)
        ds = np.where(small, ds_ser, ds)
    return s, ds


def _synthesize(coef, k, x, L):
    """Σ_k coef[m, k] e^{2πikx/L} at points x, shape (M, N) (real part).

    On a uniform lattice x_i = x_0 + i L/N the modes are folded onto N bins
    and summed by one inverse FFT per sample; otherwise a direct sum.
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    # uniform to the lattice's own rounding (a few ulps of L: relative to L/N that grows with N, and at N = 32000
    # the direct sum took an array of (modes, N) = 31 GiB)
    uniform = n > 1 and np.allclose(np.diff(x), L / n, rtol=0, atol=1e-12 * L)
    if not uniform:
        return np.real(coef @ np.exp(2j * np.pi * np.outer(k, x) / L))
    phase = np.exp(2j * np.pi * k * x[0] / L)
    bins = np.zeros((coef.shape[0], n), dtype=complex)
    np.add.at(bins.T, np.mod(k, n), (coef * phase[None, :]).T)
    return np.real(np.fft.ifft(bins, axis=1) * n)


def _derivative(k, L, symbol):
    """The factor of d/dx on mode k: i κ, or i D(κ) for a discrete symbol."""
    kappa = 2.0 * np.pi * k / L
    return 1j * (kappa if symbol is None else symbol(kappa))


def _homogeneous_fourier(v0, L, cs, d, x, t, symbol=None):
    k, a = _fourier(v0, L)
    _, mu, lp, lm = _lambdas(k, L, cs, d, symbol)
    v = np.empty((t.size, x.size))
    ux = np.empty((t.size, x.size))
    chunk = max(1, int(4e6 // max(k.size, 1)))
    for m0 in range(0, t.size, chunk):
        s, ds = _s_and_ds(mu, lp, lm, d, t[m0:m0 + chunk])
        v[m0:m0 + chunk] = _synthesize(ds * a[None, :], k, x, L)
        ux[m0:m0 + chunk] = _synthesize(s * (a * _derivative(k, L, symbol))[None, :], k, x, L)
    return v, ux


def _homogeneous_dalembert(v0, L, cs, x, t):
    """d'Alembert for d = 0, evaluated pointwise (periodic wrap)."""
    tt = np.asarray(t, dtype=float)[:, None]
    xp = np.mod(x[None, :] + cs * tt, L)
    xm = np.mod(x[None, :] - cs * tt, L)
    fp, fm = v0(xp), v0(xm)
    return 0.5 * (fp + fm), 0.5 * (fp - fm) / cs


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)


def _forced(profile, force, L, T, cs, d, x, t, symbol=None):
    """Response to profile(x) f(t) from rest: (v, u_x) at samples t."""
    k, p = _fourier(profile, L)
    v = np.zeros((t.size, x.size))
    ux = np.zeros((t.size, x.size))
    if k.size == 0:
        return v, ux
    omega, mu, lp, lm = _lambdas(k, L, cs, d, symbol)
    rate = float(np.max(np.abs(lp))) + 1e-300
    h_max = min(T / 2000.0, 1.0 / rate) if rate > 0 else T / 2000.0
    y_u = np.zeros(k.size, dtype=complex)
    y_v = np.zeros(k.size, dtype=complex)
    coef_v = np.zeros((t.size, k.size), dtype=complex)
    coef_u = np.zeros((t.size, k.size), dtype=complex)
    t_prev = 0.0
    for m, tm in enumerate(t):
        span = tm - t_prev
        pieces = int(np.ceil(span / h_max)) if span > 0 else 0
        edges = np.linspace(t_prev, tm, pieces + 1)
        for a, b in zip(edges[:-1], edges[1:]):
            tau = b - a
            s_tau, ds_tau = _s_and_ds(mu, lp, lm, d, np.array([tau]))
            c_tau = ds_tau[0] + d * s_tau[0]
            y_u, y_v = c_tau * y_u + s_tau[0] * y_v, -(omega**2) * s_tau[0] * y_u + ds_tau[0] * y_v
            nodes = a + 0.5 * tau * (_GL_NODES + 1.0)
            wts = 0.5 * tau * _GL_WEIGHTS * force(nodes)
            s_q, ds_q = _s_and_ds(mu, lp, lm, d, b - nodes)
            y_u = y_u + p * (wts @ s_q)
            y_v = y_v + p * (wts @ ds_q)
        coef_u[m], coef_v[m] = y_u, y_v
        t_prev = tm
    v = _synthesize(coef_v, k, x, L)
    ux = _synthesize(coef_u * _derivative(k, L, symbol)[None, :], k, x, L)
    return v, ux


def exact_solution(scene: Scene, x, t, method="auto", symbol=None):
    """The exact (v, ρ) of ``scene`` at positions ``x`` [m] and times ``t`` [s].

    Parameters
    ----------
    scene : Scene
        Must have uniform c, ρ0 and d (else :class:`ExactUnavailable`).
    x : ndarray (N,)
        Lagrangian (reference) positions in [0, L).
    t : ndarray (M,)
        Increasing times >= 0.
    method : {"auto", "fourier", "dalembert"}
        ``auto`` uses d'Alembert when d = 0, Fourier otherwise.
    symbol : callable, optional
        Replace the derivative's symbol iκ by i symbol(κ) (real, odd in κ):
        the *modified* reference of eq. C.5 (``lambda k: beta * k``) or the
        linearised SPH operator's own dispersion
        (:func:`sphrom.sph.operator.gradient_symbol`).  Fourier path only.

    Returns
    -------
    v : ndarray (M, N) [m s^-1]
    rho : ndarray (M, N) [kg m^-3]
    """
    params = check_available(scene)
    c, rho0, d = params["c"], params["rho0"], params["d"]
    cs = float(np.sqrt(c / rho0))
    x = np.asarray(x, dtype=float)
    t = np.asarray(t, dtype=float)
    if t.size and (np.any(np.diff(t) < 0) or t[0] < 0):
        raise ValueError("times must be increasing and >= 0")
    L = scene.L

    def v0(xx):
        return scene.field("v0", xx)

    if method == "auto":
        method = "dalembert" if (d == 0 and symbol is None) else "fourier"
    if method == "dalembert":
        if d != 0 or symbol is not None:
            raise ValueError("d'Alembert needs d = 0 and the continuum symbol")
        v, ux = _homogeneous_dalembert(v0, L, cs, x, t)
    elif method == "fourier":
        v, ux = _homogeneous_fourier(v0, L, cs, d, x, t, symbol)
    else:
        raise ValueError(method)

    tq = np.linspace(0.0, scene.T, 2049)
    if np.any(scene.force(tq) != 0):
        def profile(xx):
            return scene.field("profile", xx)
        fv, fux = _forced(profile, scene.force, L, max(scene.T, float(t.max()) if t.size else 0.0),
                          cs, d, x, t, symbol)
        v, ux = v + fv, ux + fux
    return v, rho0 / (1.0 + ux)
