"""Cost per step of the full SPH model against the particle count N.

Each point is a slope: runs of M and 2M steps of the compiled loop (no I/O,
no sampling) at the scene's CFL number (Δt scaled as 1/N), timed back to
back, give (t(2M) - t(M)) / M, so the call's fixed cost cancels instead of
being subtracted; the median over the repeats.  M is sized so that the
shorter run takes about ``target_seconds``.  A run longer than the scene's
horizon T restarts from the initial state every T (:func:`chunks`): explicit
Euler grows without bound past it, and a blown-up state would stop the loop.
"""

import statistics
import time

import numpy as np

from ...errors import SimulationError
from ...runio import save_figure
from ...scene import derive_scene, load_scene
from ...scene_schema import key
from ...sph import loops
from ...sph.solver import METHODS, build_problem, step_count

INTEGRATORS = key("sph.integrator").range.choices      # the table's integrators: every one the full SPH has
SPH_STEP_HEADING = "## The full SPH step against N (as `sphrom bench-sph`)"


def chunks(steps, horizon):
    """``steps`` split into runs of at most ``horizon`` steps (each from the initial state)."""
    out = [horizon] * (steps // horizon)
    return out + ([steps % horizon] if steps % horizon else [])


def slope_per_step(run, steps, repeats):
    """Per-step times [s] of ``run(steps)`` as slopes: ``run(steps)`` then ``run(2 steps)`` per repeat,
    (t2 - t1) / steps.  Returns (median, the slopes)."""
    slopes = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run(steps)
        t1 = time.perf_counter()
        run(2 * steps)
        t2 = time.perf_counter()
        slopes.append(((t2 - t1) - (t1 - t0)) / steps)
    return statistics.median(slopes), slopes


def time_per_step(scene_name, n, integrator, repeats=5, target_seconds=0.05, layout="auto"):
    """Median µs per step of ``integrator`` at N = n particles (scene's fields), a slope (module docstring).

    ``layout``: the operator's layout in the loop (:meth:`sphrom.sph.solver.SPHProblem.loop_args`).
    Returns (µs per step, M, the per-repeat slopes in µs).
    """
    base = load_scene(scene_name)
    scene = derive_scene(base, {"sph": {"n_particles": n, "integrator": integrator}})
    problem = build_problem(scene)
    dt = base.sph.dt * base.sph.n_particles / n          # the scene's CFL number
    horizon = max(1, step_count(base.T, dt))
    args, bit = problem.loop_args(layout)
    method = METHODS[integrator]
    flags = problem.flags(True) | bit
    empty = np.zeros(0, dtype=np.int64)
    out = np.zeros((0, n))

    def run(steps):
        g = np.zeros((min(steps, horizon), 3))
        for k in chunks(steps, horizon):
            v, rho = problem.v0.copy(), problem.rho0.copy()
            status, _, _ = loops.advance(method, v, rho, 0, k, dt, g, *args, flags, empty, 0, out, out, 64,
                                         np.inf, problem.neighbours.dx)        # energy checked as in run_sph
            if status != 0:
                raise SimulationError(f"bench-sph: the {integrator} run of {scene_name} at N = {n} failed its state "
                                      f"check (status {status}) within the scene's horizon")

    run(16)                                              # compile or load the loop
    steps = 16                                           # size the shorter run to ~target_seconds
    while steps < 10_000_000:
        t0 = time.perf_counter()
        run(steps)
        if time.perf_counter() - t0 > target_seconds:
            break
        steps *= 4
    med, slopes = slope_per_step(run, steps, repeats)
    return 1e6 * med, steps, [1e6 * x for x in slopes]


def scaling_table(scene_name, sizes, integrators, repeats=5, progress=None, layout="auto"):
    """Rows (integrator, N, µs/step, ns per particle-step, M, the slopes' min and max)."""
    rows = []
    for integrator in integrators:
        for n in sizes:
            us, steps, slopes = time_per_step(scene_name, n, integrator, repeats, layout=layout)
            rows.append({"integrator": integrator, "n": n, "us_per_step": us,
                         "ns_per_particle_step": 1e3 * us / n, "steps": steps, "us_min": min(slopes),
                         "us_max": max(slopes)})
            if progress:
                progress.update(1)
    return rows


def growth_exponent(rows, integrator, n_min=1000):
    """Slope of log(time) against log(N) for N >= n_min (1 = linear)."""
    pts = [(r["n"], r["us_per_step"]) for r in rows if r["integrator"] == integrator and r["n"] >= n_min]
    if len(pts) < 2:
        return float("nan")
    n, t = np.array(pts).T
    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def plot_scaling(rows, integrators, path, scene_name):
    """µs per step against N per integrator (log-log) with a linear guide, as PNG at ``path``."""
    import matplotlib          # deferred: only a plot loads matplotlib, the measurements never do
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3.6))
    for integrator in integrators:
        pts = [(r["n"], r["us_per_step"]) for r in rows if r["integrator"] == integrator]
        ax.loglog(*zip(*pts), "o-", label=integrator)
    n = [r["n"] for r in rows]
    ref = rows[0]["us_per_step"] * max(n) / min(n)
    ax.loglog([min(n), max(n)], [rows[0]["us_per_step"], ref], "k:", label="linear")
    ax.set_xlabel("particles N")
    ax.set_ylabel("µs per step")
    ax.set_title(f"full SPH step, scene {scene_name}")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def sph_step_section(sph_steps, sizes, repeats, integrators=INTEGRATORS, produced=None, image=None):
    """The full SPH step against N per integrator (rows of :func:`scaling_table`);
    ``produced``: a sentence naming the command, the machine and its load, ``image``: the plot's path from the
    report (``sphrom bench sph-step --report``)."""
    lines = [SPH_STEP_HEADING, "",
             (produced + " " if produced else "")
             + "µs per step of the numba loop (one thread) in the layout `sphrom sph` takes (the fixed-offset "
             "stencil where the neighbour lists allow it, as in every built-in scene), tenmode's fields at the "
             "scene's CFL number; each figure the slope between runs of M and 2M steps (the call's fixed cost "
             f"cancels), the median of {repeats} repeats; growth exponent of time against N for N ≥ 1000 "
             "(1 = linear). Target: ≤ 10 µs per step at N = 400 (explicit Euler).", "",
             "| integrator | " + " | ".join(f"N = {n}" for n in sizes) + " | growth exponent |",
             "| --- |" + " ---: |" * (len(sizes) + 1)]
    for integrator in integrators:
        cells = [next(f"{r['us_per_step']:.3g} µs" for r in sph_steps if r["integrator"] == integrator and r["n"] == n)
                 for n in sizes]
        lines.append(f"| {integrator} | " + " | ".join(cells) + f" | {growth_exponent(sph_steps, integrator):.2f} |")
    return lines + [""] + ([f"![full SPH step against N]({image})", ""] if image else [])
