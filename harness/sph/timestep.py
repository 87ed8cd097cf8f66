"""The full SPH's explicit time step: its stability, from the scene's own numbers, and the choices made from it.

Linearised about rest, eqs. 2.10-2.11 in the specific volume (eq. A.9) are ė = G v, ρ0 v̇ = G (c e) − ρ0 d v:
every mode is an oscillator of frequency ω in [0, ω_max] damped at a rate between the scene's smallest and largest
d.  An explicit step multiplies a mode by the amplification matrix of :func:`step_matrix`; the step is stable when
no mode grows.  Everything here is a function of ω_max, d and dt (all in the scene's own units), so a steel bar in
SI units and the same bar in unit scaling get the same limits relative to their own time scales.

- :func:`omega_max`: an upper bound of the fastest frequency, sqrt(max c / min ρ0) times the largest symbol of the
  SPH gradient on the uniform lattice (exact for uniform fields).
- :func:`dt_limit`: the largest stable dt of each integrator at ω_max with the largest damping (symplectic Euler
  in closed form, RK4 by bisection; explicit Euler has none on the imaginary axis: its "limit" is the one of its
  imaginary-axis neighbours, 2/ω_max, and its growth below it is said by :func:`growth`).
- :func:`automatic_dt`: ``sph.dt`` when a scene leaves it out (:data:`AUTO_DT_RULE`).
- :func:`refusal` and :func:`warnings`: what the scene loader refuses before any work (a dt above the limit of
  the integrator) and what every command that runs the SPH says before it (explicit Euler's amplification).
"""

from __future__ import annotations

import math

import numpy as np

from .kernel import cubic_spline_gradient

# The integrator of a scene that names none: symplectic Euler (ρ then v) keeps a modified energy of the undamped
# bar, so below its limit no mode grows; explicit Euler (the paper's, kept wherever a scene names it) multiplies
# every undamped mode by (1 + ω² dt²)^½ per step at any dt.
DEFAULT_INTEGRATOR = "symplectic"
# The automatic dt as a fraction of the integrator's limit.  Measured on a graded user scene (c 1 to 10, a local
# force; /work's corpus, `sphrom bench scenes`): symplectic Euler at 0.5, 0.2 and 0.05 of its limit is 4.9e-2,
# 1.5e-2 and 2.1e-3 (relative L2 at the probes) off the same SPH integrated exactly in time; 0.2 keeps the time
# error well below the 1e-1 a reduced model is allowed, at 2.5x the cost of 0.5.
DT_FRACTION = 0.2
# explicit Euler without a dt: the largest dt at which it amplifies its worst mode at most this much over [0, T]
EULER_AUTO_GROWTH = 2.0
# Amplification over a run above which every command warns.  The paper's own settings (explicit Euler) amplify
# the fastest mode by up to 51 (tenmode; 48.6 for high_frequency) while their fast modes hold only rounding error
# and the discrete energy stays within 7 % of the exact dynamics' bound; above 100 the factor is no longer harmless.
GROWTH_WARN = 100.0
# the imaginary-axis stability limits ω_max dt of the undamped schemes
STABILITY_BOUND = {"euler": 2.0, "symplectic": 2.0, "rk4": 2.0 * np.sqrt(2.0)}
INTEGRATORS = tuple(STABILITY_BOUND)
# above this many particles the symbol's maximum is taken over a fine grid of the continuous wavenumber (an upper
# bound of the maximum over the lattice's wavenumbers), not over each of the N/2 + 1 of them
SYMBOL_GRID = 65536
AUTO_DT_RULE = (f"{DT_FRACTION:g} of the stability limit of the scene's integrator at its fastest mode (omega_max "
                "= sqrt(max c / min rho0) times the largest wavenumber symbol of the SPH gradient; with the largest "
                "damping), rounded down so that T is a whole number of steps; explicit Euler, which amplifies "
                f"every undamped mode at any dt, also at most {EULER_AUTO_GROWTH:g}-fold amplification of its worst "
                "mode over [0, T]")
DEFAULT_INTEGRATOR_RULE = (f"{DEFAULT_INTEGRATOR} (rho then v): below its limit no mode grows; the paper's explicit "
                           "Euler amplifies every undamped mode at any dt and is used where a scene names it")


def lattice_symbol(n, alpha):
    """max_κ |D(κ)| Δx: the largest symbol of the SPH gradient (eq. 2.9) on N uniform particles, dimensionless.

    G e^{iκx} = i D(κ) e^{iκx} with D(κ) = −Σ_s Δx ∇W(−sΔx) sin(κ s Δx) over the offsets s of the kernel's
    support (|s| < 2α); the maximum over the lattice's wavenumbers κΔx = 2πk/N, k = 0..N/2 (above
    :data:`SYMBOL_GRID` particles, over a grid of [0, π] 16 times finer than its largest offset needs, which bounds
    it from above to 1e-6).
    """
    s = np.arange(1, int(np.ceil(2.0 * alpha)) + 1, dtype=float)
    g = cubic_spline_gradient(s, float(alpha))        # ∇W(s Δx) Δx² for h = α Δx (W scales as 1/h², r as Δx)
    if n <= SYMBOL_GRID:
        theta = 2.0 * np.pi * np.arange(n // 2 + 1) / n
    else:
        theta = np.linspace(0.0, np.pi, 16 * SYMBOL_GRID + 1)
    values = np.abs(2.0 * np.sin(np.multiply.outer(theta, s)) @ g)
    top = float(values.max())
    return top if n <= SYMBOL_GRID else top * (1.0 + 1e-6)


def omega_max(c_max, rho0_min, L, n, alpha):
    """An upper bound of the fastest angular frequency of the linearised SPH [rad s^-1]: sqrt(max c / min ρ0)
    times :func:`lattice_symbol` / Δx (exact for uniform c and ρ0)."""
    return float(np.sqrt(c_max / rho0_min) * lattice_symbol(n, alpha) / (L / n))


def step_matrix(integrator, omega_dt, d_dt):
    """One step of ``integrator`` on the mode (e, v) with ė = ω v, v̇ = -ω e - d v.

    Parameters
    ----------
    integrator : str
        "euler", "symplectic" (e then v, as in :func:`.loops.advance`) or "rk4".
    omega_dt, d_dt : float
        ω Δt and d Δt (dimensionless).

    Returns
    -------
    ndarray (2, 2)
        The amplification matrix of one step: the linearisation of eqs. 2.10-2.11 about rest in the specific
        volume (eq. A.9), one eigen-pair of the SPH operator at a time.
    """
    a = np.array([[0.0, omega_dt], [-omega_dt, -d_dt]])
    eye = np.eye(2)
    if integrator == "euler":
        return eye + a
    if integrator == "symplectic":
        e_step = np.array([[1.0, omega_dt], [0.0, 1.0]])
        v_step = np.array([[1.0, 0.0], [-omega_dt, 1.0 - d_dt]])
        return v_step @ e_step
    a2 = a @ a
    return eye + a + a2 / 2.0 + a2 @ a / 6.0 + a2 @ a2 / 24.0


def _radius(integrator, omega_dt, d_dt):
    return float(np.max(np.abs(np.linalg.eigvals(step_matrix(integrator, omega_dt, d_dt)))))


def _radii(integrator, omega_dt, d_dt):
    """The spectral radius of :func:`step_matrix` at each ω Δt of the array ``omega_dt`` (one d Δt), vectorised."""
    w = np.asarray(omega_dt, float)
    a = np.zeros(w.shape + (2, 2))
    a[..., 0, 1], a[..., 1, 0], a[..., 1, 1] = w, -w, -float(d_dt)
    eye = np.broadcast_to(np.eye(2), a.shape)
    if integrator == "euler":
        m = eye + a
    elif integrator == "symplectic":
        e_step = eye.copy()
        e_step[..., 0, 1] = w
        v_step = eye.copy()
        v_step[..., 1, 0], v_step[..., 1, 1] = -w, 1.0 - float(d_dt)
        m = v_step @ e_step
    else:
        a2 = a @ a
        m = eye + a + a2 / 2.0 + a2 @ a / 6.0 + a2 @ a2 / 24.0
    return np.max(np.abs(np.linalg.eigvals(m)), axis=-1)


def dt_limit(integrator, omega, d_max=0.0, d_min=0.0):
    """The largest dt [s] at which ``integrator`` amplifies no mode of frequency up to ``omega`` [rad s^-1] with a
    damping between ``d_min`` and ``d_max`` [s^-1].

    symplectic: ω² dt² + 2 d dt <= 4 (trace and determinant of its step matrix), dt = 4 / (d + sqrt(d² + 4ω²)) at
    d = d_max (2/ω undamped, 2/d without stiffness); rk4: bisection on the spectral radius over 257 frequencies in
    [0, ω] at d_min and d_max (2 sqrt 2 / ω undamped); euler: min(2/ω, 2/d_max), the limit of its neighbours
    (it has none of its own when undamped: :func:`growth`).
    """
    omega, d_max, d_min = float(omega), max(0.0, float(d_max)), max(0.0, float(d_min))
    if integrator == "symplectic":
        return 4.0 / (d_max + math.sqrt(d_max * d_max + 4.0 * omega * omega))
    if integrator == "euler":
        return min(STABILITY_BOUND["euler"] / omega, 2.0 / d_max if d_max > 0 else math.inf)
    freqs = np.linspace(0.0, omega, 257)

    def stable(dt):
        return all(np.all(_radii("rk4", freqs * dt, d * dt) <= 1.0 + 1e-12) for d in {d_min, d_max})
    lo, hi = 0.0, STABILITY_BOUND["rk4"] / max(omega, 0.5 * d_max)
    while stable(hi):                   # damping widens the region beside the imaginary axis
        lo, hi = hi, 1.5 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def growth(integrator, omega, d_min, dt, T, samples=257):
    """(factor, ω): the largest factor by which ``integrator`` amplifies a mode of frequency in [0, ``omega``] over
    [0, T] at the smallest damping ``d_min``, r(ω)^n with n = T/dt steps and r the spectral radius of
    :func:`step_matrix` (a float capped at exp(700)), and the ω that attains it."""
    n = T / dt
    freqs = np.linspace(0.0, omega, samples)[1:]
    r = _radii(integrator, freqs * dt, d_min * dt)
    with np.errstate(divide="ignore"):
        log_growth = np.where(r > 0, n * np.log(np.where(r > 0, r, 1.0)), -np.inf)
    i = int(np.argmax(log_growth))              # the first of equal maxima, as the loop over ω took it
    return float(np.exp(min(700.0, float(log_growth[i])))), float(freqs[i])


def automatic_dt(integrator, omega, d_min, d_max, T, max_steps):
    """``sph.dt`` of :data:`AUTO_DT_RULE` [s]: (dt, the limit it came from [s]); None for dt when T needs more
    than ``max_steps`` steps at it."""
    limit = dt_limit(integrator, omega, d_max, d_min)
    dt = DT_FRACTION * limit
    if integrator == "euler":
        # undamped, Euler's growth is exp(T ω² dt / 2) to first order: start there, halve until it holds
        dt = min(dt, 2.0 * math.log(EULER_AUTO_GROWTH) / (T * omega * omega))
        while T / dt <= max_steps and growth(integrator, omega, d_min, dt, T)[0] > EULER_AUTO_GROWTH:
            dt *= 0.5
    n = math.ceil(T / dt * (1.0 - 1e-12))
    if n > max_steps:
        return None, limit
    return T / max(n, 1), limit


def refusal(integrator, dt, omega, d_min, d_max):
    """The reason (one line, no field name) why ``dt`` [s] is impossible for ``integrator``, or None: a dt above
    its :func:`dt_limit`, with the remedy."""
    limit = dt_limit(integrator, omega, d_max, d_min)
    if dt <= limit * (1.0 + 1e-12):
        return None
    others = [f"{name} up to {dt_limit(name, omega, d_max, d_min):.3g} s" for name in INTEGRATORS
              if name != integrator and dt_limit(name, omega, d_max, d_min) >= dt]
    return (f"{dt:g} s is above the stability limit {limit:.3g} s of the {integrator} integrator (the fastest mode, "
            f"omega_max = {omega:.4g} rad/s = sqrt(max c / min rho0) times the kernel's largest wavenumber, "
            f"{'with the largest damping d = ' + f'{d_max:g} 1/s, ' if d_max > 0 else ''}would grow at every step); "
            f"remedy: dt <= {limit:.3g} s, or leave sph.dt out (chosen at {DT_FRACTION:g} of the limit)"
            + (f", or another integrator ({'; '.join(others)})" if others else ""))


def warnings(integrator, dt, omega, d_min, T):
    """One-line warnings (no prefix) about a run's step below its limit: the integrator amplifies some mode more
    than :data:`GROWTH_WARN`-fold over [0, T] (explicit Euler on a lightly damped scene), with the remedy."""
    factor, w = growth(integrator, omega, d_min, dt, T)
    if factor <= GROWTH_WARN:
        return []
    others = [name for name in INTEGRATORS if name != integrator and dt <= dt_limit(name, omega, 0.0, d_min)]
    return [f"'{integrator}' amplifies the mode at omega = {w:.4g} rad/s (omega dt = {w * dt:.3g}, smallest damping "
            f"d = {d_min:g} 1/s) by a factor {growth_figure(factor)} over the run ({T / dt:.0f} steps to T = {T:g} "
            f"s); rounding errors in that mode grow with it: use a smaller dt, a shorter T or "
            + ("integrator " + "/".join(others) if others else "a damped scene")]


def growth_figure(factor):
    """An amplification factor as printed in a warning: 3 digits, or "more than 1e+304" at the exp(700) cap."""
    return "more than 1e+304" if factor >= np.exp(700.0) * (1 - 1e-12) else f"{factor:.3g}"
