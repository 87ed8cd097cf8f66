"""Cost per step of the full SPH model against the particle count N.

Each point times a fixed number of steps of the compiled loop (no I/O, no
sampling) at the scene's CFL number (Δt scaled as 1/N), median of repeats.
"""

import numpy as np

from ..scene import derive_scene, load_scene
from ..sph import loops
from ..sph.solver import METHODS, build_problem
from .timing import median_time


def time_per_step(scene_name, n, integrator, repeats=5, target_seconds=0.05):
    """Median µs per step of ``integrator`` at N = n particles (scene's fields)."""
    base = load_scene(scene_name)
    scene = derive_scene(base, {"sph": {"n_particles": n, "integrator": integrator}})
    problem = build_problem(scene)
    dt = base.sph.dt * base.sph.n_particles / n          # the scene's CFL number
    nb = problem.neighbours
    args = (nb.index, nb.weight, problem.packed("rho0"), problem.packed("c"), problem.packed("d"),
            problem.packed("profile"))
    method = METHODS[integrator]
    flags = problem.flags(True)
    empty = np.zeros(0, dtype=np.int64)
    out = np.zeros((0, n))

    def run(steps):
        v, rho = problem.v0.copy(), problem.rho0.copy()
        g = np.zeros((steps, 3))
        status, _, _ = loops.advance(method, v, rho, 0, steps, dt, g, *args, flags, empty, 0, out, out, 64,
                                  np.inf, problem.neighbours.dx)        # energy checked as in run_sph
        assert status == 0

    # size the run to ~target_seconds
    steps = 16
    while True:
        t, _ = median_time(lambda: run(steps), repeats=1, warmup=1 if steps == 16 else 0)
        if t > target_seconds or steps > 10_000_000:
            break
        steps *= 4
    med, times = median_time(lambda: run(steps), repeats=repeats, warmup=0)
    return 1e6 * med / steps, steps, [1e6 * x / steps for x in times]


def scaling_table(scene_name, sizes, integrators, repeats=5, progress=None):
    """Rows (integrator, N, µs/step, ns per particle-step, steps timed)."""
    rows = []
    for integrator in integrators:
        for n in sizes:
            us, steps, _ = time_per_step(scene_name, n, integrator, repeats)
            rows.append({"integrator": integrator, "n": n, "us_per_step": us,
                         "ns_per_particle_step": 1e3 * us / n, "steps": steps})
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
    import matplotlib
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
    from ..runio import save_figure
    save_figure(fig, path, dpi=110)
    plt.close(fig)
