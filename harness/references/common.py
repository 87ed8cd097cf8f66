"""What the three continuum references of eqs. 2.2-2.4 share.

The references (:mod:`.skfem_ref`, :mod:`.pypde_ref`, :mod:`.fd`) each march
their own discretisation on their own points and hand back a
:class:`NativeRun`; this module turns it into samples at the requested
Lagrangian points and times (by default the scene's SPH particles
x_i = (i + 1/2) L/N and its SPH sample times), checks the user's
resolution and time step, and plans the time steps so that every output time
is reached exactly.

Interpolation in space is a cubic spline (error O(h^4), below every scheme's
own error): periodic where the coefficients are smooth, and piecewise between
the points where c, ρ0, d or the force profile jump (§3.5: c jumps at x = L/2
and, periodically, at x = 0), where ρ is discontinuous and v has a kink.  The
strain J - 1 = ρ0/ρ - 1 (= u_x, eq. A.9) is interpolated, not ρ, and
ρ = ρ0(x)/J is formed with the exact ρ0 at the output point.

Units: x, L in m; t, dt in s; v in m s^-1; ρ in kg m^-3.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import FieldError
from ..scene import MAX_STEPS, MAX_STEPS_TEXT, Scene
from ..sph.operator import particle_positions
from ..sph.solver import default_sample_steps, step_count

MIN_RESOLUTION = 8
MAX_RESOLUTION = 2**22
GROWTH_MAX = 10.0        # explicit schemes: the largest growth of any linear mode over a run
BREAK_FIELDS = ("c", "rho0", "d", "profile")


class Reference(NamedTuple):
    """A reference on the requested points: v, rho of shape (M, N_out) and its settings."""

    v: np.ndarray
    rho: np.ndarray
    settings: dict


@dataclass
class NativeRun:
    """Samples of a reference on its own points.

    Attributes
    ----------
    t : ndarray (M,)
        Sample times [s].
    x_v : ndarray (P,)
        Where the velocity lives [m], sorted, in [0, L).
    v : ndarray (M, P)
        Velocity [m s^-1].
    x_j : ndarray (Q,)
        Where the strain lives [m], sorted, in [0, L).
    j : ndarray (M, Q)
        Strain J - 1 = ρ0/ρ - 1 = u_x (eq. A.9), dimensionless.
    rho0_j : ndarray (Q,)
        ρ0 at ``x_j`` [kg m^-3]; ρ = rho0_j / (1 + j).
    momentum_weights : ndarray (P,)
        w with Σ w v = ∫ ρ0 v dx for the scheme's own quadrature [kg m^-2].
    length_weights : ndarray (Q,)
        w with Σ w (1 + j) = ∫ ρ0/ρ dx [m].
    steps : ndarray (M,)
        Time-step index of each sample.
    wall_time : float
        Wall time of the time loop [s].
    settings : dict
        The solver's settings (``solver.*`` attributes without the prefix).
    """

    t: np.ndarray
    x_v: np.ndarray
    v: np.ndarray
    x_j: np.ndarray
    j: np.ndarray
    rho0_j: np.ndarray
    momentum_weights: np.ndarray
    length_weights: np.ndarray
    steps: np.ndarray
    wall_time: float
    settings: dict = field(default_factory=dict)

    @property
    def rho(self):
        """ρ = ρ0/(1 + u_x) at ``x_j`` (eq. A.3) [kg m^-3], shape (M, Q)."""
        return self.rho0_j[None, :] / (1.0 + self.j)

    def momentum(self):
        """Total momentum ∫ ρ0 v dx per sample [kg m^-2 · m s^-1]."""
        return self.v @ self.momentum_weights

    def length(self):
        """Total length ∫ ρ0/ρ dx per sample [m]."""
        return (1.0 + self.j) @ self.length_weights


# --------------------------------------------------------------------------
# output points and times
# --------------------------------------------------------------------------
def output_points(scene: Scene, x=None):
    """The output positions [m]: ``x`` or the scene's SPH particles."""
    if x is None:
        return particle_positions(scene.L, scene.sph.n_particles)
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError("output x must be a non-empty 1D array of finite positions")
    return x


def output_times(scene: Scene, t=None):
    """The output times [s]: ``t`` or the scene's SPH sample times (every ``sph.every`` steps and T)."""
    if t is None:
        n = step_count(scene.T, scene.sph.dt)
        return default_sample_steps(n, scene.sph.every) * scene.sph.dt
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) <= 0):
        raise ValueError("output times must be a non-empty, strictly increasing array of times >= 0")
    return t


def step_plan(t_out, dt_max):
    """Time step and step indices that land exactly on every output time.

    The output times must be integer multiples of a common spacing g (the
    smallest positive gap, or a fraction 1/k of it, k <= 1000).  The step is
    dt = g / ceil(g / dt_max) <= dt_max.

    Returns
    -------
    dt : float
        The time step used [s].
    steps : ndarray of int64
        Step index of each output time (t_out = steps · dt).
    """
    t_out = np.asarray(t_out, dtype=float)
    if dt_max <= 0:
        raise ValueError("dt must be > 0")
    pts = np.concatenate([[0.0], t_out])
    gaps = np.diff(np.unique(pts))
    if gaps.size == 0:            # a single output at t = 0
        return float(dt_max), np.zeros(t_out.size, dtype=np.int64)
    g0 = gaps.min()
    for k in range(1, 1001):
        g = g0 / k
        ratio = t_out / g
        if np.all(np.abs(ratio - np.round(ratio)) <= 1e-7 * np.maximum(1.0, ratio)):
            per = max(1, int(np.ceil(g / dt_max - 1e-9)))
            dt = g / per
            return float(dt), (np.round(ratio).astype(np.int64) * per)
    raise ValueError("output times must be multiples of a common spacing (e.g. uniform samples)")


# --------------------------------------------------------------------------
# coefficients
# --------------------------------------------------------------------------
JUMP_NEIGHBOUR_RATIO = 10.0   # a jump's step against the largest of its 4 neighbouring steps
JUMP_RANGE_FRACTION = 1e-3    # ... and against the field's range (max - min) on [0, L)
JUMP_REFINE_KEEP = 0.5        # ... and the fraction of it that must survive a 4x finer grid


def _cell_steps(g):
    """|g_{k+1} - g_k| around the periodic seam (the last one crosses x = L ~ 0)."""
    return np.abs(np.diff(np.append(g, g[0])))


def _locate_jump(field, a, b, L):
    """Bisect [a, b] (a jump between the values at a and b) to round-off [m]."""
    ga, gb = field(np.array([a % L]))[0], field(np.array([b % L]))[0]
    for _ in range(80):
        m = 0.5 * (a + b)
        if m <= a or m >= b:
            break
        gm = field(np.array([m % L]))[0]
        # the jump is on the side whose end value is farther from the midpoint's
        if abs(gm - ga) <= abs(gb - gm):
            a, ga = m, gm
        else:
            b, gb = m, gm
    pos = b % L
    return 0.0 if min(pos, L - pos) < 1e-12 * L else pos


def field_jumps(field, L, n=4096):
    """Positions in [0, L) where the periodic field ``field(x)`` jumps [m].

    A step between neighbouring cells (of n, and across the seam x = L ~ 0)
    is a jump only when all three hold:

    - it exceeds :data:`JUMP_NEIGHBOUR_RATIO` times each of its two
      neighbouring steps on either side (on a smooth field neighbouring steps
      agree to O(Δx), however steep or localised the field is);
    - it is at least :data:`JUMP_RANGE_FRACTION` of the field's range (a
      discontinuity of the data, not rounding);
    - it persists under refinement: on grids 2x and 4x finer the largest step
      inside the cell keeps at least :data:`JUMP_REFINE_KEEP` of it (a smooth
      variation halves with each halving of the cell; a jump does not).

    Each jump is then located to round-off by bisection.
    """
    dx = L / n
    x = (np.arange(n) + 0.5) * dx
    g = field(x)
    steps = _cell_steps(g)
    span = float(np.max(g) - np.min(g))
    if span == 0.0 or not np.all(np.isfinite(g)):
        return []
    neighbours = np.max(np.stack([np.roll(steps, s) for s in (-2, -1, 1, 2)]), axis=0)
    cand = np.nonzero((steps > JUMP_NEIGHBOUR_RATIO * neighbours) & (steps >= JUMP_RANGE_FRACTION * span))[0]
    found = []
    for k in cand:
        a = x[k]
        keep = True
        for refine in (2, 4):
            xf = a + (np.arange(refine + 1)) * (dx / refine)
            if float(np.max(np.abs(np.diff(field(np.mod(xf, L)))))) < JUMP_REFINE_KEEP * steps[k]:
                keep = False
                break
        if keep:
            found.append(_locate_jump(field, a, a + dx, L))
    return found


def coefficient_breaks(scene: Scene, n=4096, names=BREAK_FIELDS):
    """Positions in [0, L) where a coefficient field jumps [m].

    c, ρ0, d and the force profile are checked by :func:`field_jumps`, which
    takes a smooth localised field (a narrow Gaussian) for no jump at all.
    For the heterogeneous scene (eq. 3.11) this returns [0, L/2].
    """
    L = scene.L
    found = []
    for name in names:
        found += field_jumps(lambda x, name=name: scene.field(name, x), L, n)
    if not found:
        return np.zeros(0)
    found = np.sort(np.asarray(found))
    keep = np.concatenate([[True], np.diff(found) > 1e-9 * L])
    out = found[keep]
    if out.size > 1 and L - out[-1] + out[0] <= 1e-9 * L:
        out = out[:-1]
    return out


def max_sound_speed(scene: Scene, n=4096):
    """max sqrt(c/ρ0) (eq. 2.5 at rest) [m s^-1], on n cells."""
    x = (np.arange(n) + 0.5) * (scene.L / n)
    return float(np.sqrt(np.max(scene.field("c", x) / scene.field("rho0", x))))


def damping_range(scene: Scene, n=4096):
    """(min d, max d) [s^-1] on n cells."""
    x = (np.arange(n) + 0.5) * (scene.L / n)
    d = scene.field("d", x)
    return float(d.min()), float(d.max())


def force_active(scene: Scene, t_end, n=2049):
    """Whether f(t)·profile(x) is not identically zero on [0, t_end]."""
    x = (np.arange(256) + 0.5) * (scene.L / 256)
    return bool(np.any(scene.force(np.linspace(0.0, t_end, n)) != 0)
                and np.any(scene.field("profile", x) != 0))


# --------------------------------------------------------------------------
# interpolation
# --------------------------------------------------------------------------
def _segment_spline(xs, ys, xq):
    if xs.size >= 4:
        return CubicSpline(xs, ys, axis=1, bc_type="not-a-knot", extrapolate=True)(xq)
    if xs.size >= 2:
        return np.stack([np.interp(xq, xs, row) for row in ys])
    return np.repeat(ys[:, :1], xq.size, axis=1)


def interpolate(xs, ys, x_out, L, breaks=()):
    """Cubic-spline interpolation of periodic samples, piecewise between breaks.

    Parameters
    ----------
    xs : ndarray (P,)
        Sample positions [m], sorted, in [0, L).
    ys : ndarray (M, P)
        Samples (one row per time).
    x_out : ndarray (N,)
        Where to evaluate [m] (taken modulo L).
    L : float
        Period [m].
    breaks : array_like
        Positions in [0, L) where the function may jump or kink.  Without
        breaks the spline is periodic; with breaks each piece between two
        breaks has its own (not-a-knot) spline through the samples in it,
        samples on a break belonging to both sides.

    Returns
    -------
    ndarray (M, N)
    """
    xs = np.asarray(xs, dtype=float)
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    xq = np.mod(np.asarray(x_out, dtype=float), L)
    breaks = np.sort(np.asarray(breaks, dtype=float))
    if breaks.size == 0:
        xe = np.append(xs, xs[0] + L)
        ye = np.concatenate([ys, ys[:, :1]], axis=1)
        spline = CubicSpline(xe, ye, axis=1, bc_type="periodic")
        return spline(np.where(xq < xs[0], xq + L, xq))
    out = np.empty((ys.shape[0], xq.size))
    tol = 1e-12 * L
    nb = breaks.size
    for k in range(nb):
        a = breaks[k]
        b = breaks[k + 1] if k + 1 < nb else breaks[0] + L
        # unwrap the samples and queries into [a, b]
        xs_u = np.where(xs < a - tol, xs + L, xs)
        sel = (xs_u >= a - tol) & (xs_u <= b + tol)
        order = np.argsort(xs_u[sel])
        px, py = xs_u[sel][order], ys[:, sel][:, order]
        xq_u = np.where(xq < a - tol, xq + L, xq)
        qsel = (xq_u >= a - tol) & (xq_u < b - tol) if nb > 1 else np.ones(xq.size, bool)
        if np.any(qsel) and px.size == 0:
            # breaks closer than the sample spacing: linear between the samples around them
            out[:, qsel] = np.stack([np.interp(xq[qsel], xs, row, period=L) for row in ys])
        elif np.any(qsel):
            out[:, qsel] = _segment_spline(px, py, xq_u[qsel])
    return out


def to_output(native: NativeRun, scene: Scene, x_out, breaks):
    """(v, ρ) of a native run at the output points: shapes (M, N_out).

    v and the strain J - 1 are interpolated (see :func:`interpolate`), and
    ρ = ρ0(x)/(1 + (J - 1)) with the exact ρ0 at the output points (A.3).
    """
    v = interpolate(native.x_v, native.v, x_out, scene.L, breaks)
    j = interpolate(native.x_j, native.j, x_out, scene.L, breaks)
    rho = scene.field("rho0", np.mod(x_out, scene.L))[None, :] / (1.0 + j)
    return v, rho


# --------------------------------------------------------------------------
# checks of user input (messages name the field: resolution, dt)
# --------------------------------------------------------------------------
def check_resolution(n):
    """The resolution as an int in [MIN_RESOLUTION, MAX_RESOLUTION], else FieldError ``resolution``."""
    if isinstance(n, (bool, np.bool_)) or int(n) != n or not (MIN_RESOLUTION <= n <= MAX_RESOLUTION):
        raise FieldError("resolution", f"{n!r} is out of range "
                                       f"(allowed: an integer in [{MIN_RESOLUTION}, {MAX_RESOLUTION}])")
    return int(n)


def resolution_from(scene: Scene, resolution=None, dx=None, default=None):
    """N from ``resolution`` or a cell size ``dx`` [m] (N = round(L/dx)), else ``default``."""
    if resolution is not None and dx is not None:
        raise ValueError("give resolution or dx, not both")
    if dx is not None:
        if not (np.isfinite(dx) and dx > 0):
            raise FieldError("resolution", f"dx = {dx!r} is out of range (allowed: a number > 0)")
        resolution = int(round(scene.L / dx))
    if resolution is None:
        resolution = default
    return check_resolution(resolution)


def check_dt(dt, T):
    """dt as a float in (0, T] with at most sphrom.scene.MAX_STEPS steps T/dt, else FieldError ``dt``."""
    if dt is None or not (np.isfinite(dt) and dt > 0):
        raise FieldError("dt", f"{dt!r} is out of range (allowed: a number > 0)")
    if dt > T:
        raise FieldError("dt", f"{dt:g} is out of range (allowed: 0 < dt <= T = {T:g})")
    if T / dt > MAX_STEPS:              # the same bound as the SPH's steps (sphrom.scene.MAX_STEPS)
        raise FieldError("dt", f"{dt:g} is out of range (allowed: dt >= T / {MAX_STEPS_TEXT} = {T / MAX_STEPS:g} s "
                               f"for T = {T:g} s, at most {MAX_STEPS_TEXT} steps)")
    return float(dt)


def rk_growth(coefficients, omega_max, d_range, dt, n_steps, samples=400):
    """Largest growth over n_steps of a linear mode under an explicit RK method.

    The semi-discrete system linearised about rest is, per mode, a damped
    oscillator with eigenvalues λ = -d/2 ± sqrt(d²/4 - ω²), ω in
    [0, ω_max]; an explicit Runge-Kutta method multiplies it by
    R(λΔt) = Σ_k coefficients[k] (λΔt)^k per step.

    Returns max |R|^n_steps over ω and d in ``d_range`` (min, max).
    """
    omega = np.linspace(0.0, omega_max, samples)
    worst = 0.0
    for d in set(d_range):
        lam = -0.5 * d + np.sqrt((0.25 * d * d - omega**2).astype(complex))
        for z in (lam * dt, np.conj(lam) * dt, (-d - lam) * dt):
            r = np.abs(np.polyval(list(coefficients)[::-1], z))
            worst = max(worst, float(np.max(r)))
    if worst <= 1.0:
        return worst ** n_steps
    return float(np.exp(min(700.0, n_steps * np.log(worst))))


def unstable_error(solver, n, dt_requested, dt_used, T, stab):
    """FieldError ``dt`` for a Δt beyond an explicit scheme's limit (its range and the CFL number)."""
    growth = stab["growth"]
    grows = "without bound" if growth >= 1e300 else f"{growth:.3g}x"
    used = "" if dt_used == dt_requested else f" (step used {dt_used:g} s)"
    return FieldError("dt", f"{dt_requested:g}{used} is out of range (allowed: 0 < dt <= {stab['dt_limit']:.3g} s "
                            f"for {solver} at N = {n} over t = {T:g} s; CFL number c_s dt/dx = {stab['cfl']:.3g}, "
                            f"the fastest mode would grow {grows})")


def largest_stable_dt(coefficients, omega_max, d_range, T, growth=GROWTH_MAX, hi=None):
    """The largest Δt [s] (to 1 %) for which :func:`rk_growth` over T stays <= growth."""
    hi = hi or 4.0 / max(omega_max, 1e-300)
    lo = 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        n = max(1, int(np.ceil(T / mid)))
        if rk_growth(coefficients, omega_max, d_range, mid, n) <= growth:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 0.01 * hi:
            break
    return lo
