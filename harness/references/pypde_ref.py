"""py-pde reference: the density-velocity form (eqs. 2.2-2.3), fourth order.

The state is a py-pde ``FieldCollection`` [ρ, v] on a periodic
``CartesianGrid`` of N cells.  ρ (with c, ρ0) lives on py-pde's own grid
points, the cell centres x_{i+1/2}; v lives on the faces x_i = iΔx (stored in
slot i, half a cell to the left of py-pde's point), so that both derivatives
are centred.  With the fourth-order staggered difference

    (D g)_m = [27 (g_{m+1/2} - g_{m-1/2}) - (g_{m+3/2} - g_{m-3/2})] / (24 Δx)

the right-hand sides are

    ∂t ρ = -(ρ²/ρ0) D v                                           (2.2)  at x_{i+1/2}
    ∂t v = D[c (ρ0/ρ - 1)] / ρ0(x_i) - d(x_i) v + p(x_i) f(t)     (2.3)  at x_i

implemented twice, as py-pde asks of a custom ``PDEBase``: ``evolution_rate``
(numpy, vectorised with ``np.roll``; the ``numpy`` backend) and
``make_evolution_rate`` (plain loops that py-pde compiles with numba; the
``numba`` backend).  Time: py-pde's ``RungeKuttaSolver`` - classical RK4 with
a fixed Δt (the default), or its adaptive Runge-Kutta-Fehlberg 4(5) with an
absolute tolerance; py-pde's default explicit Euler is unstable here and is
never used.  The stepper py-pde builds is driven from here between output
times, so every sample is a step.

Accuracy: fourth order in Δx and Δt for smooth solutions; near the jump of c
(eq. 3.11, on a face for even N) the wide stencil is first order.  The force
f(t) is tabulated at half steps (every RK4 stage time is a table node) and
read by four-point Lagrange interpolation, so both backends see the same f.

Invariants (d = f = 0): Σ ρ0(x_i) v_i Δx telescopes and is kept to round-off;
the total length Σ Δx ρ0/ρ is kept semi-discretely and broken by RK4 at
O(Δt⁴) through the nonlinearity of ρ ↦ ρ0/ρ.
"""

from __future__ import annotations

import time as _time

import numpy as np

from ..errors import FieldError, SimulationError
from ..progress import progress_bar
from ..scene import Scene
from .common import (GROWTH_MAX, NativeRun, Reference, check_dt, coefficient_breaks, damping_range,
                     force_active, largest_stable_dt, max_sound_speed, output_points, output_times,
                     resolution_from, rk_growth, step_plan, to_output, unstable_error)

RK4 = (1.0, 1.0, 0.5, 1.0 / 6.0, 1.0 / 24.0)
DEFAULT_N = 256                  # cells: ~1e-5 relative at T = 10 on the smooth scenes
DEFAULT_CFL = 0.5                # default Δt = 0.5 Δx / c_s (RK4 phase error ~1e-7 per radian)
SYMBOL_MAX = 56.0 / 24.0         # max |symbol| of D times Δx (at the grid scale)
BACKENDS = ("auto", "numpy", "numba")
NUMBA_WORK = 2e7                 # "auto": numba above this many cell-steps (its compile costs seconds)


def _force_reader():
    """f(t) from a table at spacing h: exact on nodes, 4-point Lagrange between."""
    def read(t, table, h):
        s = t / h
        k = int(np.floor(s + 0.5))
        if abs(s - k) < 1e-7:
            k = min(max(k, 0), table.size - 1)
            return table[k]
        i = int(np.floor(s))
        i = min(max(i, 1), table.size - 3)
        r = s - i
        return (-r * (r - 1.0) * (r - 2.0) / 6.0 * table[i - 1] + (r + 1.0) * (r - 1.0) * (r - 2.0) / 2.0 * table[i]
                - (r + 1.0) * r * (r - 2.0) / 2.0 * table[i + 1] + (r + 1.0) * r * (r - 1.0) / 6.0 * table[i + 2])
    return read


def _make_pde_class():
    """The PDEBase subclass (py-pde imported lazily: it is slow to import)."""
    import pde
    from pde.pdes.base import PDEBase

    class DensityVelocityPDE(PDEBase):
        """Eqs. 2.2-2.3 on a staggered periodic grid (see the module docstring)."""

        explicit_time_dependence = True

        def __init__(self, dx, rho0_c, c_c, rho0_f, d_f, prof_f, table, h, forcing):
            super().__init__()
            self.dx = float(dx)
            self.rho0_c, self.c_c = rho0_c, c_c
            self.rho0_f, self.d_f, self.prof_f = rho0_f, d_f, prof_f
            self.table, self.h, self.forcing = table, float(h), bool(forcing)
            self.damping = bool(np.any(d_f != 0))
            self._read = _force_reader()

        def evolution_rate(self, state, t=0.0):
            rho, v = state.data[0], state.data[1]
            k = 1.0 / (24.0 * self.dx)
            dv = k * (27.0 * (np.roll(v, -1) - v) - (np.roll(v, -2) - np.roll(v, 1)))       # D v at x_{i+1/2}
            sigma = self.c_c * (self.rho0_c / rho - 1.0)
            ds = k * (27.0 * (sigma - np.roll(sigma, 1)) - (np.roll(sigma, -1) - np.roll(sigma, 2)))  # at x_i
            out = state.copy()
            out.data[0] = -(rho * rho / self.rho0_c) * dv                                    # (2.2)
            rate = ds / self.rho0_f                                                           # (2.3)
            if self.damping:
                rate = rate - self.d_f * v
            if self.forcing:
                rate = rate + self.prof_f * self._read(t, self.table, self.h)
            out.data[1] = rate
            return out

        def make_evolution_rate(self, state, backend):
            if getattr(backend, "name", backend) != "numba":
                raise NotImplementedError("compiled rates exist for the numba backend only")
            from numba import njit
            read = njit(self._read)
            dx, rho0_c, c_c = self.dx, self.rho0_c, self.c_c
            rho0_f, d_f, prof_f = self.rho0_f, self.d_f, self.prof_f
            table, h, forcing, damping = self.table, self.h, self.forcing, self.damping
            n = rho0_c.size

            def rhs(state_data, t):
                rho = state_data[0]
                v = state_data[1]
                out = np.empty_like(state_data)
                sigma = np.empty(n)
                k = 1.0 / (24.0 * dx)
                for i in range(n):
                    sigma[i] = c_c[i] * (rho0_c[i] / rho[i] - 1.0)
                g = read(t, table, h) if forcing else 0.0
                for i in range(n):
                    dv = k * (27.0 * (v[(i + 1) % n] - v[i]) - (v[(i + 2) % n] - v[(i - 1) % n]))
                    out[0, i] = -(rho[i] * rho[i] / rho0_c[i]) * dv                            # (2.2)
                    ds = k * (27.0 * (sigma[i] - sigma[(i - 1) % n]) - (sigma[(i + 1) % n] - sigma[(i - 2) % n]))
                    r = ds / rho0_f[i]                                                         # (2.3)
                    if damping:
                        r -= d_f[i] * v[i]
                    if forcing:
                        r += prof_f[i] * g
                    out[1, i] = r
                return out

            return rhs

    return pde, DensityVelocityPDE


def stability(scene: Scene, n, dt, T=None):
    """Stability figures of fixed-step RK4 on the N-cell grid.

    Returns ``omega_max`` (c_s · 56/(24Δx), the fastest mode) [rad s^-1],
    ``cfl`` (c_s Δt/Δx), ``growth`` over T, ``dt_limit`` [s] (RK4 is stable
    on the imaginary axis up to ω Δt = 2√2, i.e. CFL 1.21).
    """
    T = scene.T if T is None else T
    dx = scene.L / n
    cs = max_sound_speed(scene)
    omega = cs * SYMBOL_MAX / dx
    drange = damping_range(scene)
    steps = max(1, int(np.ceil(T / dt)))
    return {"omega_max": omega, "cfl": cs * dt / dx, "growth": rk_growth(RK4, omega, drange, dt, steps),
            "dt_limit": largest_stable_dt(RK4, omega, drange, T)}


def default_dt(scene: Scene, n):
    """Δt = DEFAULT_CFL · Δx / c_s [s]."""
    return DEFAULT_CFL * (scene.L / n) / max_sound_speed(scene)


def run(scene: Scene, resolution=None, dt=None, t=None, *, dx=None, adaptive=False, tolerance=1e-11,
        backend="auto", progress=False, check=True):
    """March eqs. 2.2-2.3 with py-pde; samples on the faces (v) and centres (ρ).

    Parameters
    ----------
    scene : Scene
    resolution : int, optional
        Number of cells N (default DEFAULT_N); or give ``dx`` [m].
    dt : float, optional
        Fixed RK4 step [s] (default DEFAULT_CFL Δx/c_s), reduced so that the
        output times are steps; the initial step when ``adaptive``.
    t : ndarray, optional
        Output times [s] (default the scene's SPH sample times).
    adaptive : bool
        py-pde's adaptive Runge-Kutta-Fehlberg instead of fixed RK4.
    tolerance : float
        Absolute error per adaptive step (on ρ [kg m^-3] and v [m s^-1]).
    backend : {"auto", "numpy", "numba"}
        py-pde backend; "auto" takes numba for long runs only (its
        compilation costs seconds).
    check : bool
        Refuse (FieldError ``dt``) a fixed Δt beyond RK4's stability limit.

    Returns
    -------
    NativeRun
    """
    if backend not in BACKENDS:
        raise FieldError("backend", f"{backend!r} is out of range (allowed: {', '.join(BACKENDS)})")
    n = resolution_from(scene, resolution, dx, DEFAULT_N)
    t_out = output_times(scene, t)
    T = float(t_out[-1])
    dt_req = default_dt(scene, n) if dt is None else check_dt(dt, T if T > 0 else np.inf)
    dt_used, sample_steps = step_plan(t_out, dt_req)
    n_steps = int(sample_steps[-1])
    stab = stability(scene, n, dt_used, max(T, dt_used))
    if check and not adaptive and stab["growth"] > GROWTH_MAX:
        raise unstable_error("pypde (RK4)", n, dt_req, dt_used, T, stab)
    if backend == "auto":
        backend = "numba" if n * max(n_steps, 1) > NUMBA_WORK else "numpy"

    pde, DensityVelocityPDE = _make_pde_class()
    dx_ = scene.L / n
    x_f = np.arange(n) * dx_                      # faces: v
    x_c = (np.arange(n) + 0.5) * dx_              # py-pde's grid points: ρ
    rho0_c, c_c = scene.field("rho0", x_c), scene.field("c", x_c)
    rho0_f, d_f, prof_f = scene.field("rho0", x_f), scene.field("d", x_f), scene.field("profile", x_f)
    forcing = force_active(scene, max(T, dt_used))
    h = 0.5 * dt_used if not adaptive else min(0.5 * dt_used, max(T, dt_used) / 200000.0)
    n_table = int(np.ceil(max(T, dt_used) / h)) + 4
    table = scene.force(np.arange(n_table) * h) if forcing else np.zeros(n_table)
    eq = DensityVelocityPDE(dx_, rho0_c, c_c, rho0_f, d_f, prof_f, table, h, forcing)

    grid = pde.CartesianGrid([[0.0, scene.L]], n, periodic=True)
    state = pde.FieldCollection([pde.ScalarField(grid, rho0_c.copy()),
                                 pde.ScalarField(grid, scene.field("v0", x_f))], labels=["rho", "v"])
    solver = pde.solvers.RungeKuttaSolver(eq, backend=backend, adaptive=adaptive, tolerance=tolerance)
    t_compile = _time.perf_counter()
    stepper = solver.make_stepper(state, dt=dt_used)
    t_compile = _time.perf_counter() - t_compile

    out_v = np.empty((sample_steps.size, n))
    out_rho = np.empty((sample_steps.size, n))
    t_now = 0.0
    wall = 0.0
    with progress_bar(total=n_steps, desc=f"pypde {scene.name}", unit="step", enabled=progress) as bar:
        for k, step in enumerate(sample_steps):
            t_next = step * dt_used
            if step > (sample_steps[k - 1] if k else 0):
                t0 = _time.perf_counter()
                stepper(state, t_now, t_next)
                wall += _time.perf_counter() - t0
                bar.update(int(step - (sample_steps[k - 1] if k else 0)))
            t_now = t_next
            rho, v = state.data[0], state.data[1]
            if not (np.all(np.isfinite(v)) and np.all(np.isfinite(rho)) and np.all(rho > 0)):
                raise SimulationError(f"pypde state became non-finite or non-positive density by t = {t_next:.6g} s "
                                      f"(step {step}, dt = {dt_used:g} s, N = {n})", step=int(step), time=t_next)
            out_rho[k], out_v[k] = rho, v
    info = solver.info
    settings = {"method": "py-pde, staggered 4th-order differences on eqs. 2.2-2.3 + "
                          + ("adaptive Runge-Kutta-Fehlberg 4(5)" if adaptive else "classical RK4"),
                "resolution": n, "dx": dx_, "dt": dt_used, "dt_requested": dt_req,
                "steps": int(info.get("steps", n_steps)), "adaptive": int(adaptive),
                "tolerance": tolerance if adaptive else "none", "backend": backend,
                "compile_time_s": t_compile, "cfl": stab["cfl"], "growth": stab["growth"],
                "dt_limit": stab["dt_limit"]}
    return NativeRun(t=sample_steps * dt_used, x_v=x_f, v=out_v, x_j=x_c, j=rho0_c[None, :] / out_rho - 1.0,
                     rho0_j=rho0_c, momentum_weights=rho0_f * dx_, length_weights=np.full(n, dx_),
                     steps=sample_steps, wall_time=wall, settings=settings)


def solve(scene: Scene, resolution=None, dt=None, x=None, t=None, *, dx=None, adaptive=False, tolerance=1e-11,
          backend="auto", progress=False, check=True):
    """The py-pde reference at the output points and times.

    Parameters
    ----------
    scene : Scene
    resolution, dx, dt, t, adaptive, tolerance, backend, progress, check
        See :func:`run`.
    x : ndarray, optional
        Output Lagrangian positions [m] (default the scene's SPH particles).

    Returns
    -------
    Reference
        v (M, N_out) [m s^-1], rho (M, N_out) [kg m^-3], settings.
    """
    x_out = output_points(scene, x)
    native = run(scene, resolution, dt, t, dx=dx, adaptive=adaptive, tolerance=tolerance, backend=backend,
                 progress=progress, check=check)
    breaks = coefficient_breaks(scene)
    v, rho = to_output(native, scene, x_out, breaks)
    settings = {**native.settings, "interpolation": "cubic spline, piecewise between jumps",
                "breaks": ",".join(f"{b:g}" for b in breaks) or "none", "wall_time": native.wall_time}
    return Reference(v, rho, settings)
