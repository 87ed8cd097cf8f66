"""The paper's own reference: finite differences in space, RK2 in time (§3.2-3.5).

The density-velocity form (eqs. 2.2-2.3) on N cells of width Δx = L/N,

    dρ_i/dt = -(ρ_i² / ρ0_i) (v_{i+1} - v_i) / Δx                    (2.2)
    dv_i/dt = (σ_i - σ_{i-1}) / (ρ0(x_i) Δx) - d(x_i) v_i + p(x_i) f(t)  (2.3)
    σ_i = c_i (ρ0_i / ρ_i - 1)

a forward difference for eq. 2.2 and a backward one for eq. 2.3, marched with
Heun's second-order Runge-Kutta method, as in the paper ("first-order finite
difference in space, second-order Runge-Kutta in time").

**Where the unknowns live.**  The pair is a staggered scheme: v_i sits on the
node x_i = iΔx and ρ_i, σ_i, c_i = c(x_{i+1/2}), ρ0_i = ρ0(x_{i+1/2}) on the
cell centre x_{i+1/2}.  Read that way each difference is centred and the
scheme is second order in Δx (``layout="staggered"``, the default; the same
as P1 finite elements with a lumped mass).  Read as collocated (ρ_i taken at
x_i, ``layout="collocated"``, what "first-order" suggests the paper did) the
density is half a cell off and converges at first order only; v is
second order either way.  With N even the jump of c at x = L/2 (eq. 3.11)
falls on a node, between two cells, and is represented exactly.

Both invariants of eqs. 2.2-2.3 with d = f = 0 telescope: Σ ρ0(x_i) v_i Δx is
kept to round-off by any Runge-Kutta method, and Σ Δx ρ0_i/ρ_i (the total
length) semi-discretely, broken by Heun at O(Δt²) through the nonlinearity of
ρ ↦ ρ0/ρ.

**Stability.**  Heun's amplification on the imaginary axis is
|R(iz)|² = 1 + z⁴/4 > 1: every undamped mode grows a little.  A Δt is taken
as stable when no linear mode (ω up to 2 c_s/Δx) grows by more than
:data:`~.common.GROWTH_MAX` over the run (:func:`stability`); the paper's
settings (c_s Δt/Δx ≈ 0.006) are far inside.
"""

from __future__ import annotations

import time as _time

import numpy as np
from numba import njit

from ..errors import SimulationError
from ..progress import progress_bar
from ..scene import Scene
from .common import (GROWTH_MAX, NativeRun, Reference, check_dt, coefficient_breaks, damping_range,
                     force_active, largest_stable_dt, max_sound_speed, output_points, output_times,
                     resolution_from, rk_growth, step_plan, to_output, unstable_error)

HEUN = (1.0, 1.0, 0.5)          # R(z) = 1 + z + z²/2
DEFAULT_N = 2048                 # cells, when the scene gives no paper reference_dx (~1e-4 at T = 10)
LAYOUTS = ("staggered", "collocated")


@njit(cache=True, nogil=True)
def _rates(v, rho, g, inv_dx, inv_rho0_c, c_c, rho0_c, inv_rho0_n_dx, d_n, prof_n, damping, forcing,
           dv, drho, sigma):
    """Right-hand sides of eqs. 2.2-2.3 (forward / backward differences)."""
    n = v.size
    for i in range(n):
        sigma[i] = c_c[i] * (rho0_c[i] / rho[i] - 1.0)
    for i in range(n - 1):
        drho[i] = -(rho[i] * rho[i] * inv_rho0_c[i]) * (v[i + 1] - v[i]) * inv_dx     # (2.2), forward
    drho[n - 1] = -(rho[n - 1] * rho[n - 1] * inv_rho0_c[n - 1]) * (v[0] - v[n - 1]) * inv_dx
    dv[0] = (sigma[0] - sigma[n - 1]) * inv_rho0_n_dx[0]                                  # (2.3), backward
    for i in range(1, n):
        dv[i] = (sigma[i] - sigma[i - 1]) * inv_rho0_n_dx[i]
    if damping:
        for i in range(n):
            dv[i] -= d_n[i] * v[i]
    if forcing:
        for i in range(n):
            dv[i] += prof_n[i] * g


@njit(cache=True, nogil=True)
def _advance(v, rho, n0, n1, dt, gvals, inv_dx, inv_rho0_c, c_c, rho0_c, inv_rho0_n_dx, d_n, prof_n,
             damping, forcing, sample_steps, ptr, out_v, out_rho):
    """Heun steps n0 -> n1 in place; stores samples; returns (status, ptr, bad step)."""
    n = v.size
    k1v = np.empty(n)
    k1r = np.empty(n)
    k2v = np.empty(n)
    k2r = np.empty(n)
    vs = np.empty(n)
    rs = np.empty(n)
    sigma = np.empty(n)
    half = 0.5 * dt
    for step in range(n0, n1):
        _rates(v, rho, gvals[step - n0, 0], inv_dx, inv_rho0_c, c_c, rho0_c, inv_rho0_n_dx, d_n, prof_n,
               damping, forcing, k1v, k1r, sigma)
        for i in range(n):
            vs[i] = v[i] + dt * k1v[i]
            rs[i] = rho[i] + dt * k1r[i]
        _rates(vs, rs, gvals[step - n0, 1], inv_dx, inv_rho0_c, c_c, rho0_c, inv_rho0_n_dx, d_n, prof_n,
               damping, forcing, k2v, k2r, sigma)
        for i in range(n):
            v[i] += half * (k1v[i] + k2v[i])
            rho[i] += half * (k1r[i] + k2r[i])
        if (step & 63) == 63 or step == n1 - 1:
            for i in range(n):
                if not (np.isfinite(v[i]) and np.isfinite(rho[i]) and rho[i] > 0.0):
                    return 1, ptr, step + 1
        while ptr < sample_steps.size and sample_steps[ptr] == step + 1:
            out_v[ptr, :] = v
            out_rho[ptr, :] = rho
            ptr += 1
    return 0, ptr, n1


def grid(scene: Scene, n):
    """Nodes x_i = iΔx (v) and cell centres x_{i+1/2} (ρ) [m] of an N-cell grid."""
    dx = scene.L / n
    return np.arange(n) * dx, (np.arange(n) + 0.5) * dx


def default_resolution(scene: Scene):
    """The paper's reference_dx when the scene has one, else :data:`DEFAULT_N` cells."""
    dx = scene.paper.get("reference_dx")
    return int(round(scene.L / dx)) if dx else DEFAULT_N


def stability(scene: Scene, n, dt, T=None):
    """Stability figures of Heun on the N-cell grid.

    Returns a dict: ``omega_max`` (2 c_s/Δx, the fastest mode) [rad s^-1],
    ``cfl`` (c_s Δt/Δx), ``growth`` (largest growth of a linear mode over T),
    ``dt_limit`` (largest Δt with growth <= GROWTH_MAX) [s].
    """
    T = scene.T if T is None else T
    dx = scene.L / n
    cs = max_sound_speed(scene)
    omega = 2.0 * cs / dx
    drange = damping_range(scene)
    steps = max(1, int(np.ceil(T / dt)))
    return {"omega_max": omega, "cfl": cs * dt / dx, "growth": rk_growth(HEUN, omega, drange, dt, steps),
            "dt_limit": largest_stable_dt(HEUN, omega, drange, T)}


def default_dt(scene: Scene, n, T=None):
    """The paper's reference_dt when it is given and stable; else 1/4 of the stability limit [s]."""
    T = scene.T if T is None else T
    dt = scene.paper.get("reference_dt")
    limit = stability(scene, n, dt or 1.0, T)["dt_limit"]
    if dt and dt <= limit:
        return float(dt)
    return 0.25 * limit


def run(scene: Scene, resolution=None, dt=None, t=None, *, dx=None, layout="staggered", progress=False,
        check=True):
    """March the finite-difference scheme and return its samples on its own grid.

    Parameters
    ----------
    scene : Scene
    resolution : int, optional
        Number of cells N (default :func:`default_resolution`); or give ``dx`` [m].
    dt : float, optional
        Largest time step [s] (default :func:`default_dt`); reduced so that
        the output times are steps.
    t : ndarray, optional
        Output times [s] (default the scene's SPH sample times).
    progress : bool
        Progress bar on long runs.
    check : bool
        Refuse (FieldError ``dt``) a Δt whose fastest mode grows by more than
        GROWTH_MAX over the run.
    layout : {"staggered", "collocated"}
        Where ρ_i, c_i and ρ0_i live: the cell centre x_{i+1/2} (second
        order), or the node x_i (the collocated reading: first order in ρ).

    Returns
    -------
    NativeRun
        v on the nodes, the strain ρ0/ρ - 1 on the cell centres (nodes when
        collocated).
    """
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}")
    n = resolution_from(scene, resolution, dx, default_resolution(scene))
    t_out = output_times(scene, t)
    T = float(t_out[-1])
    dt_req = default_dt(scene, n, max(T, 1e-300)) if dt is None else check_dt(dt, T if T > 0 else np.inf)
    dt_used, sample_steps = step_plan(t_out, dt_req)
    n_steps = int(sample_steps[-1])
    stab = stability(scene, n, dt_used, max(T, dt_used))
    if check and stab["growth"] > GROWTH_MAX:
        raise unstable_error("fd (Heun)", n, dt_req, dt_used, T, stab)
    x_v, x_c = grid(scene, n)
    if layout == "collocated":
        x_c = x_v
    dx_ = scene.L / n
    rho0_c, c_c = scene.field("rho0", x_c), scene.field("c", x_c)
    rho0_n, d_n, prof_n = scene.field("rho0", x_v), scene.field("d", x_v), scene.field("profile", x_v)
    damping = bool(np.any(d_n != 0))
    forcing = force_active(scene, max(T, dt_used))
    v = scene.field("v0", x_v).copy()
    rho = rho0_c.copy()
    out_v = np.empty((sample_steps.size, n))
    out_rho = np.empty((sample_steps.size, n))
    ptr = 0
    while ptr < sample_steps.size and sample_steps[ptr] == 0:
        out_v[ptr], out_rho[ptr] = v, rho
        ptr += 1
    chunk = max(1, min(max(n_steps, 1), int(4e6 // n)))
    wall = 0.0
    with progress_bar(total=n_steps, desc=f"fd {scene.name}", unit="step", enabled=progress) as bar:
        n0 = 0
        while n0 < n_steps:
            n1 = min(n_steps, n0 + chunk)
            tn = np.arange(n0, n1) * dt_used
            g = np.zeros((n1 - n0, 2))
            if forcing:
                g[:, 0] = scene.force(tn)
                g[:, 1] = scene.force(tn + dt_used)
            t0 = _time.perf_counter()
            status, ptr, bad = _advance(v, rho, n0, n1, dt_used, g, 1.0 / dx_, 1.0 / rho0_c, c_c, rho0_c,
                                        1.0 / (rho0_n * dx_), d_n, prof_n, damping, forcing, sample_steps, ptr,
                                        out_v, out_rho)
            wall += _time.perf_counter() - t0
            if status != 0:
                raise SimulationError(f"fd state became non-finite or non-positive density by step {bad} "
                                      f"(t = {bad * dt_used:.6g} s, dt = {dt_used:g} s, N = {n})",
                                      step=bad, time=bad * dt_used)
            bar.update(n1 - n0)
            n0 = n1
    settings = {"method": "finite differences (forward for eq. 2.2, backward for eq. 2.3) + Heun RK2",
                "layout": layout, "resolution": n, "dx": dx_, "dt": dt_used, "dt_requested": dt_req, "steps": n_steps,
                "cfl": stab["cfl"], "growth": stab["growth"], "dt_limit": stab["dt_limit"]}
    return NativeRun(t=sample_steps * dt_used, x_v=x_v, v=out_v, x_j=x_c, j=rho0_c[None, :] / out_rho - 1.0,
                     rho0_j=rho0_c, momentum_weights=rho0_n * dx_, length_weights=np.full(n, dx_),
                     steps=sample_steps, wall_time=wall, settings=settings)


def solve(scene: Scene, resolution=None, dt=None, x=None, t=None, *, dx=None, layout="staggered",
          progress=False, check=True):
    """The finite-difference reference at the output points and times.

    Parameters
    ----------
    scene : Scene
    resolution, dx, dt, t, progress, check
        See :func:`run`.
    x : ndarray, optional
        Output Lagrangian positions [m] (default the scene's SPH particles).
    layout : {"staggered", "collocated"}
        Where ρ_i is taken to live: x_{i+1/2} (second order) or x_i (the
        collocated reading, first order in ρ).

    Returns
    -------
    Reference
        v (M, N_out) [m s^-1], rho (M, N_out) [kg m^-3], settings.
    """
    x_out = output_points(scene, x)
    native = run(scene, resolution, dt, t, dx=dx, layout=layout, progress=progress, check=check)
    breaks = coefficient_breaks(scene)
    v, rho = to_output(native, scene, x_out, breaks)
    settings = {**native.settings, "interpolation": "cubic spline, piecewise between jumps",
                "breaks": ",".join(f"{b:g}" for b in breaks) or "none", "wall_time": native.wall_time}
    return Reference(v, rho, settings)
