"""Convergence of the continuum references against the exact solution.

:func:`study` runs one reference at a sequence of resolutions (with Δt
refined alongside, :func:`study_dt`) on a scene that has an exact solution
(uniform c, ρ0, d: ``multimode``, ``damped_forced``, ...), measures the
relative L² errors of eq. 3.4 in v and in ρ - ρ0 on the scene's SPH
particles and sample times, and the observed orders between successive
resolutions, log(e_{k-1}/e_k) / log(N_k/N_{k-1}).

:data:`PRODUCT_RESOLUTIONS` are sequences whose finest member reaches 1e-4
in both at T = 10 (the product requirement; measured figures in docs/validation/index.md
and the report that calls this).
"""

from __future__ import annotations

import time as _time

import numpy as np

from ..compare import error_table
from ..scene import Scene, load_scene
from . import fd, pypde_ref, skfem_ref
from .common import max_sound_speed, output_points, output_times
from .exact import exact_solution

SOLVERS = ("skfem1", "skfem2", "pypde", "fd")

# resolutions per solver whose finest reaches <= 1e-4 at T = 10 on multimode and damped_forced
PRODUCT_RESOLUTIONS = {
    "skfem1": (1024, 2048, 4096),
    "skfem2": (128, 256, 512, 1024),
    "pypde": (128, 256, 512, 1024, 2048),
    "fd": (1024, 2048, 4096),
}


def study_dt(scene: Scene, solver, n, T):
    """The time step [s] used with N in a study: refined with the mesh.

    * skfem1: Δt = 0.5 h/c_s (Newmark's O(Δt²) and P1's O(h²) together);
    * skfem2: Δt = 0.064/N s (2.5e-4 s at N = 256): Newmark's O(Δt²) is
      then the smooth scenes' limit (P2 is O(h³)), ~1e-5 at N = 256;
    * pypde: Δt = 0.5 Δx/c_s (RK4, fourth order like the differences);
    * fd: Δt = min(0.5 Δx/c_s, half Heun's stability limit over T), which
      for large N shrinks like N^{-4/3} (Heun's weak instability).
    """
    h = scene.L / n
    cs = max_sound_speed(scene)
    if solver == "skfem1":
        return 0.5 * h / cs
    if solver == "skfem2":
        return min(0.5 * h / cs, 0.064 / n)
    if solver == "pypde":
        return 0.5 * h / cs
    if solver == "fd":
        return min(0.5 * h / cs, 0.5 * fd.stability(scene, n, 1.0, T)["dt_limit"])
    raise ValueError(f"solver must be one of {SOLVERS}")


def run_solver(scene: Scene, solver, n, dt, x, t, progress=False):
    """One reference run: (v, rho, settings) at x, t."""
    if solver in ("skfem1", "skfem2"):
        return skfem_ref.solve(scene, n, dt, x, t, order=int(solver[-1]), progress=progress)
    if solver == "pypde":
        return pypde_ref.solve(scene, n, dt, x, t, progress=progress)
    if solver == "fd":
        return fd.solve(scene, n, dt, x, t, progress=progress)
    raise ValueError(f"solver must be one of {SOLVERS}")


def observed_orders(resolutions, errors):
    """log(e_{k-1}/e_k)/log(N_k/N_{k-1}) for k >= 1 (NaN first)."""
    n = np.asarray(resolutions, dtype=float)
    e = np.asarray(errors, dtype=float)
    out = np.full(e.size, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[1:] = np.log(e[:-1] / e[1:]) / np.log(n[1:] / n[:-1])
    return out


def study(scene_name, solver, resolutions=None, T=10.0, dts=None, progress=False):
    """Errors of a continuum reference against the exact solution, per resolution.

    Parameters
    ----------
    scene_name : str or Scene
        A scene with an exact solution (uniform c, ρ0, d).
    solver : {"skfem1", "skfem2", "pypde", "fd"}
        skfem with P1 / P2 elements, py-pde, or the paper's finite differences.
    resolutions : sequence of int, optional
        Elements / cells, increasing (default PRODUCT_RESOLUTIONS[solver]).
    T : float
        Horizon [s] (the paper's is 10).
    dts : sequence of float, optional
        Time steps [s], one per resolution (default :func:`study_dt`).
    progress : bool
        Progress bars.

    Returns
    -------
    list of dict
        One row per resolution: ``solver``, ``scene``, ``resolution``,
        ``dt`` [s] (the step used), ``v``, ``rho_var``, ``rho`` (relative L²
        errors, square-root form of eq. 3.4), ``order_v``, ``order_rho_var``
        (NaN on the first row) and ``wall_time`` [s] (the whole call: setup,
        time loop, interpolation).
    """
    base = scene_name if isinstance(scene_name, Scene) else load_scene(scene_name)
    scene = base.with_T(T)
    resolutions = list(PRODUCT_RESOLUTIONS[solver] if resolutions is None else resolutions)
    x = output_points(scene)
    t = output_times(scene)
    v_ex, rho_ex = exact_solution(scene, x, t)
    rho0 = scene.field("rho0", x)
    rows = []
    for k, n in enumerate(resolutions):
        dt = study_dt(scene, solver, n, T) if dts is None else dts[k]
        t0 = _time.perf_counter()
        v, rho, settings = run_solver(scene, solver, n, dt, x, t, progress=progress)
        wall = _time.perf_counter() - t0
        err = error_table(v, rho, v_ex, rho_ex, t, rho0)
        rows.append({"solver": solver, "scene": scene.name, "resolution": n, "dt": settings["dt"],
                     "v": err["v"], "rho_var": err["rho_var"], "rho": err["rho"], "wall_time": wall})
    ov = observed_orders(resolutions, [r["v"] for r in rows])
    orr = observed_orders(resolutions, [r["rho_var"] for r in rows])
    for row, a, b in zip(rows, ov, orr):
        row["order_v"], row["order_rho_var"] = float(a), float(b)
    return rows


def format_rows(rows):
    """A plain-text table of :func:`study` rows."""
    lines = [f"{'solver':7s} {'scene':14s} {'N':>6s} {'dt [s]':>9s} {'err v':>10s} {'order':>6s} "
             f"{'err rho-rho0':>12s} {'order':>6s} {'wall [s]':>8s}"]
    for r in rows:
        lines.append(f"{r['solver']:7s} {r['scene']:14s} {r['resolution']:6d} {r['dt']:9.3e} {r['v']:10.3e} "
                     f"{r['order_v']:6.2f} {r['rho_var']:12.3e} {r['order_rho_var']:6.2f} {r['wall_time']:8.2f}")
    return "\n".join(lines)
