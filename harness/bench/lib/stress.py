"""Numerical-stability stress maps: where each method holds and where it breaks.

Settings swept per scene:

* Δt from 0.1x to 2x the explicit limit Δt* = 2/ω_max of the full SPH
  operator (:func:`sphrom.sph.solver.stability`), plus the paper's Δt;
* the initial amplitude x1 ... x1000 (v0 scaled; up to compression where
  ρ -> 0 or J -> 0);
* horizons up to T = 1000 at the paper's settings;
* k up to the number of snapshots;
* random piecewise-constant force inputs of large amplitude.

Each run ends in one of: ``stable`` (energy never above 1.1x its start),
``growing`` (finite, but energy gained more than 10 %), ``unphysical`` (finite,
but the density left (0, ∞): J = ρ0/ρ <= 0 somewhere, a compression beyond
the physical limit that the linear exact model can pass through), or
``blow-up`` (the solver's own non-finite / non-positive-density / runaway
check fired).  The time of a blow-up or of the first unphysical sample is
recorded.  Under a forcing the energy grows physically, so force runs report
their final energy relative to the exact-in-time reduced model instead.  Energy is E = Σ Δx [ρ0 v²/2 + c (J - 1)²/2], J = ρ0/ρ,
conserved by the semi-discrete system when d = f = 0.

Reduced models use the basis of the scene's paper-setting run (x1) and start
from the amplified initial state, so the map shows the stability of the
reduced dynamics themselves; the full SPH runs the amplified scene.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import SimulationError
from ...pod.pipeline import accel_modes, basis_for_scene
from ...rom.registry import MODELS, get_model, pod_model_names
from ...scene import derive_scene
from ...sph.diagnostics import energy
from ...sph.solver import build_problem, run_sph, stability, step_count

from .stress_settings import AMPLITUDES, DT_FACTORS, HORIZONS, MODE_COUNTS
METHODS = ("sph-euler", "sph-symplectic", "sph-rk4") + pod_model_names()  # the full SPH, then every POD model


def classify_energy(e):
    """(outcome "stable" or "growing", max E/E0, (E_end - E0)/E0) of an energy history ``e``."""
    e = np.asarray(e, float)
    growth = float(np.max(e) / e[0]) if e[0] > 0 else float("nan")
    drift = float((e[-1] - e[0]) / e[0]) if e[0] > 0 else float("nan")
    return ("stable" if growth <= 1.1 else "growing"), growth, drift


def model_operators(problem, basis, k, models=None, paper=True, **options):
    """{model: operators} of ``models`` at k modes (``input_direction="needed"``, the FMU's rule, unless
    ``options`` say otherwise): with ``paper`` each model's paper variant (the frozen model with eq. 2.22's b),
    built once per basis kind and shared by the models on it; else the registry's models, the FMUs' (the
    frozen model with b about the projected rest density), built per model."""
    built, out = {}, {}
    for name in pod_model_names() if models is None else models:
        spec = get_model(name)
        key = spec.basis_kind if paper else name
        if key not in built:
            built[key] = spec.build(problem, basis, k, k, **{"input_direction": "needed", **options,
                                                             **(spec.paper_build if paper else {})})
        out[name] = built[key]
    return out


def fmu_operators(ctx, model):
    """The operators the FMU of ``model`` packages in the stress maps: the registry's model (the frozen one with
    b about the projected rest density) on the context's basis and k, as :func:`model_operators` builds them."""
    return model_operators(ctx.problem, ctx.basis, ctx.k, (model,), paper=False)[model]


@dataclasses.dataclass
class Context:
    """What every run of a scene shares: the x1 basis and the operators of every model (``operators``: the paper
    variants, :func:`model_operators`)."""

    scene: object
    problem: object
    basis: object
    k: int
    operators: dict
    dt_limit: float


def context(scene, k=None):
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    k = min(k or max(accel_modes(scene, basis)), *basis.max_modes)
    lim = stability(problem, scene.sph.dt, "euler", scene.T)["dt_limit"]
    return Context(scene, problem, basis, k, model_operators(problem, basis, k), lim)


def run_one(ctx: Context, method, dt, amplitude=1.0, T=None, force=None, n_samples=200, operators=None):
    """One stress run; returns a dict: outcome, blowup_time, energy_growth, energy_drift, energy_end.

    ``method``: ``sph-INTEGRATOR`` (the full SPH of the amplified scene) or a registered model, run from its
    operators in ``operators`` (default the context's, the paper variants) with the velocity coordinates scaled
    by ``amplitude`` and the second block at its start value (the density starts at ρ0); n_freeze = 10 where it
    applies, and a linear model advances with communication step dt, input held over each step (as the FMU does).
    """
    scene = ctx.scene
    T = T or scene.T
    problem = ctx.problem
    n = max(1, step_count(T, dt))
    steps = np.unique(np.linspace(0, n, min(n, n_samples) + 1).astype(np.int64))
    custom_force = force is not None
    force = force or scene.force
    try:
        if method.startswith("sph-"):
            amp_scene = derive_scene(scene, {"domain": {"T": n * dt},
                                             "fields": {"v0": f"{amplitude!r}*({scene.fields['v0'].text})"},
                                             "force": {"f": scene.f.text}})
            amp_scene = amp_scene.with_sph(dt=dt, integrator=method[4:], stable=False)   # beyond the limit too
            if custom_force:
                raise ValueError("the full SPH takes its force from the scene")
            res = run_sph(amp_scene, sample_steps=steps, progress=False)
            t, rho = res.t, res.rho
            e = energy(res.problem, res.v, res.rho)
        else:
            spec = get_model(method)
            ops = (operators or ctx.operators)[method]
            # the velocity coordinates (a linear model: z) scaled, the density at ρ0: as the FMU's initial_state_scale
            options = spec.select_options(n_freeze=10, step=dt, hold="held")
            res = spec.run(ops, problem, n_steps=n, dt=dt, sample_steps=steps, force=force,
                           initial_state_scale=amplitude, options=options)
            t, rho = res.t, res.rho
            e = energy(problem, res.v, rho)
    except SimulationError as exc:
        return {"outcome": "blow-up", "blowup_time": exc.time, "energy_growth": np.inf, "energy_drift": np.inf,
                "energy_end": np.inf}
    if not np.all(np.isfinite(e)) or np.any(e < 0):
        return {"outcome": "blow-up", "blowup_time": float("nan"), "energy_growth": np.inf, "energy_drift": np.inf,
                "energy_end": np.inf}
    outcome, growth, drift = classify_energy(e)
    bad = np.any(~(rho > 0), axis=1)
    if np.any(bad):
        return {"outcome": "unphysical", "blowup_time": float(t[np.argmax(bad)]), "energy_growth": growth,
                "energy_drift": drift, "energy_end": float(e[-1])}
    return {"outcome": outcome, "blowup_time": None, "energy_growth": growth, "energy_drift": drift,
            "energy_end": float(e[-1])}


def dt_amplitude_map(ctx: Context, methods=METHODS, dt_factors=DT_FACTORS, amplitudes=AMPLITUDES, progress=None,
                     extra=None):
    """Rows for every (method, Δt factor, amplitude); ``extra`` adds methods (the FMU)."""
    rows = []
    factors = list(dt_factors) + ["paper"]
    for method in list(methods) + list(extra or {}):
        for f in factors:
            dt = ctx.scene.sph.dt if f == "paper" else f * ctx.dt_limit
            for a in amplitudes:
                runner = (extra or {}).get(method)
                r = runner(ctx, dt, a) if runner else run_one(ctx, method, dt, a)
                rows.append({"scene": ctx.scene.name, "method": method, "dt_factor": f, "dt": dt, "amplitude": a, **r})
                if progress is not None:
                    progress.update(1)
    return rows


def horizon_rows(ctx: Context, methods=METHODS, horizons=HORIZONS, progress=None, extra=None):
    """Stability at the paper's Δt over long horizons."""
    rows = []
    for method in list(methods) + list(extra or {}):
        for T in horizons:
            runner = (extra or {}).get(method)
            r = runner(ctx, ctx.scene.sph.dt, 1.0, T) if runner else run_one(ctx, method, ctx.scene.sph.dt, 1.0, T=T)
            rows.append({"scene": ctx.scene.name, "method": method, "T": T, **r})
            if progress is not None:
                progress.update(1)
    return rows


def modes_rows(ctx: Context, ks=MODE_COUNTS, methods=None):
    """Stability at the paper's Δt with k up to the number of snapshots.

    A model refreshed every n_freeze steps is skipped at a k without its refresh tensor (too large to build).
    """
    rows = []
    methods = pod_model_names() if methods is None else methods
    rank = min(ctx.basis.max_modes)
    for k in sorted({min(k, rank) for k in ks}):
        operators = model_operators(ctx.problem, ctx.basis, k, methods)        # the tensor where it fits ("auto")
        for method in methods:
            if get_model(method).uses_n_freeze and operators[method].T is None:
                continue
            r = run_one(ctx, method, ctx.scene.sph.dt, 1.0, operators=operators)
            rows.append({"scene": ctx.scene.name, "method": method, "k": k, **r})
    return rows


def random_force(amplitude, seed=0, hold=0.05, T=10.0):
    """A seeded piecewise-constant random force of the given amplitude [m s^-2], held ``hold`` s."""
    rng = np.random.default_rng(seed)
    values = amplitude * rng.uniform(-1, 1, int(np.ceil(T / hold)) + 2)

    def f(t):
        return values[np.minimum((np.asarray(t) / hold).astype(np.int64), values.size - 1)]
    return f


def force_rows(ctx: Context, amplitudes=(1e-2, 1.0, 100.0),
               methods=pod_model_names(linear=True) + pod_model_names(linear=False), extra=None):
    """Reduced models under large random forces (the FMU's use: an arbitrary input).

    ``energy_vs_exact`` is the final energy over that of the exact-in-time
    reduced model (the first linear model of ``methods``, which comes first) minus 1.
    """
    rows = []
    for a in amplitudes:
        f = random_force(a, T=ctx.scene.T)
        e_ref = None
        for method in list(methods) + list(extra or {}):
            runner = (extra or {}).get(method)
            r = runner(ctx, ctx.scene.sph.dt, 1.0, None, f) if runner else run_one(ctx, method, ctx.scene.sph.dt,
                                                                                   force=f)
            if e_ref is None and method in MODELS and get_model(method).linear:
                e_ref = r.get("energy_end")
            r["energy_vs_exact"] = (r.get("energy_end", np.inf) / e_ref - 1.0) if e_ref else float("nan")
            rows.append({"scene": ctx.scene.name, "method": method, "force_amplitude": a, **r})
    return rows


def plot_map(rows, path, title, dt_limit):
    """One heat map per method: x = Δt factor, y = amplitude; colour = log10 energy growth, ✕ = blow-up."""
    import matplotlib          # deferred: only a plot loads matplotlib, the measurements never do
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import Normalize

    methods = list(dict.fromkeys(r["method"] for r in rows))
    factors = list(dict.fromkeys(r["dt_factor"] for r in rows))
    amps = list(dict.fromkeys(r["amplitude"] for r in rows))
    cols = min(4, len(methods))
    nrow = int(np.ceil(len(methods) / cols))
    fig, axes = plt.subplots(nrow, cols, figsize=(3.3 * cols, 2.7 * nrow), squeeze=False)
    norm = Normalize(vmin=0, vmax=3)
    for ax, method in zip(axes.flat, methods):
        grid = np.full((len(amps), len(factors)), np.nan)
        for r in rows:
            if r["method"] != method:
                continue
            i, j = amps.index(r["amplitude"]), factors.index(r["dt_factor"])
            grid[i, j] = np.log10(max(r["energy_growth"], 1.0)) if np.isfinite(r["energy_growth"]) else np.nan
            if r["outcome"] in ("blow-up", "unphysical"):
                bt = r["blowup_time"]
                mark = "✕" if r["outcome"] == "blow-up" else "ρ≤0"
                ax.text(j, i, mark if bt is None or not np.isfinite(bt) else f"{mark}\n{bt:.2g}s", ha="center",
                        va="center", fontsize=6, color="w" if r["outcome"] == "blow-up" else "r")
        ax.imshow(grid, origin="lower", cmap="viridis", norm=norm, aspect="auto")
        ax.set_xticks(range(len(factors)), [str(f) for f in factors], fontsize=6, rotation=45)
        ax.set_yticks(range(len(amps)), [f"×{a}" for a in amps], fontsize=7)
        ax.set_title(method, fontsize=9)
    for ax in list(axes.flat)[len(methods):]:
        ax.axis("off")
    fig.suptitle(f"{title}: Δt / Δt* (Δt* = {dt_limit:.3g} s) against v0 amplitude; colour log10(max E / E0), "
                 "✕ blow-up, ρ≤0 unphysical (time)", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(path, dpi=100)
    plt.close(fig)
