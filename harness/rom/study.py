"""Mode sweeps and snapshot studies: the paper's Figs. 3.3-3.16, 3.19-3.27, C.4, C.8.

For a scene and a snapshot strategy: the singular values, and the relative
L² error of a reduced model against the full SPH for k = 1..kmax, beside the
SPH's own error against the reference (exact solution, or a continuum
reference for ``heterogeneous``).  The *mode threshold* is the smallest k
from which the POD error stays below the SPH error.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..compare import error_table, reference_fields
from ..errors import SimulationError
from ..pod.pipeline import basis_for_scene, error_steps, on_steps
from ..pod.snapshots import describe
from ..progress import progress_bar
from ..sph.solver import step_count
from .registry import MODEL_NAMES, get_model

# The paper's mode thresholds and snapshot studies are those of its original POD-MOR.
PAPER_MODEL = "original"
LINE_STYLES = ("-", "--", ":", "-.")        # one per registered model, in registry order


def mode_sweep(scene, spec=None, kmax=None, models=(PAPER_MODEL,), n_freeze=10, progress=True, reference=None):
    """Errors of reduced models against the full SPH for k = 1..kmax.

    Parameters
    ----------
    scene : Scene
    spec : dict, optional
        Snapshot strategy (default the scene's).
    kmax : int, optional
        Largest k (default min(rank, max(20, paper threshold + 8))).
    models : tuple of str
        Registered reduced models to sweep, each in its paper variant (``paper_build``: the frozen model with
        eq. 2.22's b), its operators built once per k and per basis kind (the density-mode models share theirs).
    reference : (v, rho, label), optional
        Reference fields at the error steps; computed when not given.

    Returns
    -------
    dict with ``sigma_v``, ``sigma_rho``, ``rows`` (one per model and k:
    k, model, v, rho, rho_var, online [s]), ``sph_error`` (dict of
    error_table or None), ``reference`` (label), ``strategy`` and
    ``sph_time`` [s].
    """
    basis, run = basis_for_scene(scene, spec, progress=progress)
    problem = run.problem
    steps = error_steps(scene)
    v_sph, rho_sph = on_steps(run, steps)
    t = steps * scene.sph.dt
    if reference is None:
        reference = reference_fields(scene, problem.x, t)
    sph_error = None
    if reference is not None:
        sph_error = error_table(v_sph, rho_sph, reference[0], reference[1], t, problem.rho0)
    rv, rr = basis.max_modes
    rank = max(rv, rr)               # k_v and k_rho are each capped at their own rank below
    if kmax is None:
        kmax = min(rank, max(20, scene.paper.get("mode_threshold", 12) + 8))
    kmax = min(kmax, rank)
    n = step_count(scene.T, scene.sph.dt)
    rows = []
    specs = [get_model(model) for model in models]
    with progress_bar(total=kmax * len(models), desc=f"modes {scene.name}", enabled=progress) as bar:
        for k in range(1, kmax + 1):
            built = {}                                # basis kind -> the paper variants' operators at this k
            for model, entry in zip(models, specs):
                if entry.basis_kind not in built:
                    # k_v and k_rho capped at their own rank
                    k_v, k_r = (min(k, m) for m in entry.available_modes(basis))
                    built[entry.basis_kind] = entry.build(problem, basis, k_v, k_r, **entry.paper_build)
                ops = built[entry.basis_kind]
                try:
                    res = entry.run(ops, problem, n_steps=n, dt=scene.sph.dt, sample_steps=steps,
                                    options=entry.select_options(integrator=scene.sph.integrator,
                                                                 n_freeze=n_freeze))
                    err = error_table(res.v, res.rho, v_sph, rho_sph, t, problem.rho0)
                    online = res.wall_time
                except SimulationError:               # a blow-up is a result here, not a failure
                    err = {key: float("inf") for key in ("v", "rho", "rho_var", "v_sq", "rho_sq")}
                    online = float("nan")
                rows.append({"k": k, "model": model, **{key: err[key] for key in ("v", "rho", "rho_var")},
                             "online": online})
                bar.update(1)
    return {"scene": scene.name, "sigma_v": basis.sigma_v, "sigma_rho": basis.sigma_rho, "rows": rows,
            "sph_error": sph_error, "reference": None if reference is None else reference[2],
            "strategy": describe(spec or scene.snapshots), "sph_time": run.wall_time, "kmax": kmax}


def threshold(rows, sph_error, model=PAPER_MODEL, keys=("v", "rho_var")):
    """Smallest k from which the POD error stays below the SPH error in every key.

    Returns None when no such k exists up to the sweep's kmax (or no SPH error).
    """
    if sph_error is None:
        return None
    ks = sorted(r["k"] for r in rows if r["model"] == model)
    below = {r["k"]: all(r[key] < sph_error[key] for key in keys) for r in rows if r["model"] == model}
    best = None
    for k in reversed(ks):
        if below[k]:
            best = k
        else:
            break
    return best


def outcome(sweep, model=PAPER_MODEL):
    """'works' when a threshold exists within the sweep, else 'fails'."""
    return "works" if threshold(sweep["rows"], sweep["sph_error"], model) is not None else "fails"


def study_spec(study):
    """The snapshot strategy of one of the paper's snapshot studies."""
    return {k: study[k] for k in ("count", "window", "times", "times_v", "times_rho", "random") if k in study}


def plot_sweep(sweep, path, paper_threshold=None):
    """Singular values (left) and error against k with the SPH error line (right), as PNG."""
    import matplotlib               # deferred: start-up time (a mode sweep without a figure needs no matplotlib)
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(9.5, 3.6))
    sv, sr = sweep["sigma_v"], sweep["sigma_rho"]
    a.semilogy(np.arange(1, sv.size + 1), sv / sv[0], "o-", ms=3, label="velocity")
    a.semilogy(np.arange(1, sr.size + 1), sr / sr[0], "s-", ms=3, label="density")
    a.set_xlabel("mode")
    a.set_ylabel("σ / σ₁")
    a.set_title("singular values")
    a.legend()
    for model, style in zip(MODEL_NAMES, itertools.cycle(LINE_STYLES)):
        rows = [r for r in sweep["rows"] if r["model"] == model]
        if not rows:
            continue
        ks = [r["k"] for r in rows]
        b.semilogy(ks, [r["v"] for r in rows], "o" + style, ms=3, label=f"{model}: v")
        b.semilogy(ks, [r["rho_var"] for r in rows], "s" + style, ms=3, label=f"{model}: ρ−ρ0")
    if sweep["sph_error"] is not None:
        b.axhline(sweep["sph_error"]["v"], color="C0", lw=0.8, ls="-.", label="SPH error: v")
        b.axhline(sweep["sph_error"]["rho_var"], color="C1", lw=0.8, ls="-.", label="SPH error: ρ−ρ0")
    if paper_threshold:
        b.axvline(paper_threshold, color="gray", lw=0.8, ls=":", label=f"paper: k = {paper_threshold}")
    b.set_xlabel("modes k")
    b.set_ylabel("relative L² error vs full SPH")
    b.set_title(f"{sweep['scene']}: {sweep['strategy']}", fontsize=9)
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def snapshot_study(scene, study, base, sweep_fn):
    """Our outcome of one of the paper's snapshot studies (§3.1.2-3.1.3, §3.2.1).

    Parameters
    ----------
    scene : Scene
    study : dict
        One ``[[paper.snapshot_studies]]`` entry: the strategy, the paper's
        ``outcome`` (works, fails, critical, larger_error) and figure.
    base : dict
        The mode sweep with the scene's own snapshots (for ``larger_error``).
    sweep_fn : callable
        ``sweep_fn(spec, tag_suffix) -> (sweep, thresholds)``: runs and
        records one mode sweep for a snapshot strategy.

    Returns
    -------
    dict
        ``figure``, ``snapshots`` (description), ``paper``, ``ours``,
        ``detail`` and ``agrees`` (bool).
    """
    spec = study_spec(study)
    paper = study["outcome"]
    if paper == "critical":
        # the smallest uniform count in [count-1, count+4] that works
        found = None
        for count in range(study["count"] - 1, study["count"] + 5):
            sweep, ths = sweep_fn({**spec, "count": count}, f"-count{count}")
            if ths[PAPER_MODEL] is not None:
                found = (count, ths[PAPER_MODEL])
                break
        ours = f"critical count {found[0]} (k = {found[1]})" if found else "no count works"
        detail = f"searched counts {study['count'] - 1}..{study['count'] + 4}"
        agrees = found is not None and abs(found[0] - study["count"]) <= 1
    else:
        sweep, ths = sweep_fn(spec, "")
        if paper == "larger_error":
            kk = min(5, sweep["kmax"], base["kmax"])
            ev = [r["v"] for r in sweep["rows"] if r["k"] == kk and r["model"] == PAPER_MODEL][0]
            eb = [r["v"] for r in base["rows"] if r["k"] == kk and r["model"] == PAPER_MODEL][0]
            ours = "larger_error" if ev > eb else "not larger"
            detail = f"v error at k = {kk}: {ev:.3e} vs {eb:.3e} with the scene's snapshots"
        else:
            ours = outcome(sweep)
            detail = f"threshold k = {ths[PAPER_MODEL]}" if ths[PAPER_MODEL] else f"no k <= {sweep['kmax']} works"
            if study.get("mode_threshold"):
                detail += f" (paper k = {study['mode_threshold']})"
        agrees = ours == paper
    return {"figure": study.get("figure", ""), "snapshots": describe(spec), "paper": paper, "ours": ours,
            "detail": detail, "agrees": agrees}
