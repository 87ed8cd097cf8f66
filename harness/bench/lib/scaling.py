"""How each method's cost per step grows with N (particles) and k (modes).

For N in a list, a tenmode-like scene (the scene's fields, Δt scaled to keep
its CFL number) gives a POD basis from a short run; each method is then timed
for a fixed number of steps.  Expected: the full SPH, the original and the
linearised POD-MOR grow like N (O(N k) per step); the frozen model and the
exact model do not depend on N at all.
"""

from __future__ import annotations

import numpy as np

from ...pod.pipeline import basis_for_scene
from ...rom.registry import get_model, pod_model_names
from ...scene import derive_scene, load_scene
from ...sph.solver import run_sph
from .timing import median_time


def scaled_scene(name, n, T=0.2):
    """The scene ``name`` at N = n particles, Δt scaled to keep the CFL number, horizon T."""
    base = load_scene(name)
    dt = base.sph.dt * base.sph.n_particles / n
    steps = max(1, int(round(T / dt)))
    every = max(1, steps // 40)
    return derive_scene(base, {"domain": {"T": steps * dt}, "sph": {"n_particles": n, "dt": dt, "every": every},
                               "snapshots": {"count": 40, "window": [0.0, steps * dt]}})


def per_step_costs(name="tenmode", sizes=(100, 400, 1600, 6400, 10000), ks=(12,), steps=2000, n_freeze=10,
                   repeats=5, progress=None):
    """Rows (method, N, k, µs per step) for the full SPH and every reduced model."""
    rows = []
    for n in sizes:
        scene = scaled_scene(name, n)
        basis, run = basis_for_scene(scene, progress=False)
        problem = run.problem
        dt = scene.sph.dt
        timed = scene.with_T(steps * dt)
        t_sph, _ = median_time(lambda: run_sph(timed, sample_steps=[steps], progress=False, problem=problem),
                               repeats=repeats)
        rows.append({"method": "full SPH", "n": n, "k": 0, "us_per_step": 1e6 * t_sph / steps})
        for k in ks:
            k = min(k, *basis.max_modes)
            built = {}                              # one set of operators per basis kind, shared by its models
            for model in pod_model_names():
                spec = get_model(model)
                if spec.basis_kind not in built:
                    built[spec.basis_kind] = spec.build(problem, basis, k, k, **spec.paper_build)
                ops = built[spec.basis_kind]
                # a linear model advances by its communication step H = dt, sampled once at the end
                options = spec.select_options(n_freeze=n_freeze, step=dt)
                t, _ = median_time(lambda: spec.run(ops, problem, n_steps=steps, dt=dt, sample_steps=[steps],
                                                    options=options), repeats=repeats)
                label = (f"{model} (per step H = dt)" if spec.linear else
                         f"{model} (n_freeze = {n_freeze})" if spec.uses_n_freeze else model)
                rows.append({"method": label, "n": n, "k": k, "us_per_step": 1e6 * t / steps})
            if progress is not None:
                progress.update(1)
    return rows


def growth(rows, method, key="n"):
    """Slope of log(cost) against log(key) (1 = linear, 0 = flat)."""
    pts = [(r[key], r["us_per_step"]) for r in rows if r["method"] == method]
    if len(pts) < 2:
        return float("nan")
    x, y = np.array(pts, float).T
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def plot_costs(rows, path, key="n"):
    import matplotlib          # deferred: only a plot loads matplotlib, the measurements never do
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for method in dict.fromkeys(r["method"] for r in rows):
        pts = sorted((r[key], r["us_per_step"]) for r in rows if r["method"] == method)
        ax.loglog(*zip(*pts), "o-", label=f"{method} (slope {growth(rows, method, key):.2f})")
    ax.set_xlabel("particles N" if key == "n" else "modes k")
    ax.set_ylabel("µs per step (median)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
