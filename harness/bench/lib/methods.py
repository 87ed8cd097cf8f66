"""Run time against error for every method on one scene, measured in one run.

Each method's online time is the median of ``repeats`` runs; the full SPH is
timed in the same invocation, so speed-ups are ratios measured side by side
on the same (shared, noisy) machine.  Offline times (the SPH run that makes
the snapshots, the SVD, the operators) are reported separately.

Errors are relative L² (square-root form of eq. 3.4): reduced models against
the full SPH with the same integrator (the paper's "POD error"), the full
SPH against the reference (exact, or a continuum reference).
"""

from __future__ import annotations

import numpy as np

from ...compare import error_table, reference_fields
from ...pod.pipeline import accel_modes, basis_for_scene, error_steps, on_steps
from ...rom.registry import MODEL_NAMES, get_model, model_names, pod_model_names
from ...sph.solver import run_sph, step_count
from .timing import median_time

N_FREEZE = (1, 2, 5, 10, 20, 50)


def bench_row(scene, method, k, n_freeze, online, offline, err_sph, err_ref, note=""):
    """One row of the time-against-error table: times [s], errors (dicts of :func:`sphrom.compare.error_table`
    against the full SPH and the reference, or None) flattened to v and ρ − ρ0."""
    return {"scene": scene.name, "method": method, "k": k, "n_freeze": n_freeze, "online_s": online,
            "offline_s": offline,
            "err_v_sph": np.nan if err_sph is None else err_sph["v"],
            "err_rho_sph": np.nan if err_sph is None else err_sph["rho_var"],
            "err_v_ref": np.nan if err_ref is None else err_ref["v"],
            "err_rho_ref": np.nan if err_ref is None else err_ref["rho_var"], "note": note}


def bench_python(scene, ks=None, n_freezes=N_FREEZE, repeats=5, models=None, progress=None, extra=None):
    """Time and error of the full SPH and the Python reduced models on ``scene``.

    Parameters
    ----------
    ks : list of int, optional
        Mode counts (default the scene's acceleration study k, e.g. [12]).
    n_freezes : tuple of int
        Refresh periods of the models refreshed every n_freeze steps (the frozen model).
    models : tuple of str
        Registered reduced models (default all on a POD basis), each in its paper variant (``paper_build``:
        the frozen model with eq. 2.22's b) on the basis kind it needs; one whose modes the basis lacks is
        left out.
    repeats : int
        Median of this many timed runs per point.
    extra : callable, optional
        ``extra(context) -> rows`` adds methods timed in the same run (the
        FMU entries); ``context`` holds the scene, basis, run, steps and SPH time.

    Returns
    -------
    rows : list of dict
        scene, method, k, n_freeze, online_s, offline_s, err_v_sph,
        err_rho_sph (ρ - ρ0), err_v_ref, err_rho_ref, speedup (SPH time / online).
    """
    ks = list(ks or accel_modes(scene, progress=False))
    basis, run = basis_for_scene(scene, progress=False)
    problem = run.problem
    steps = error_steps(scene)
    t = steps * scene.sph.dt
    n = step_count(scene.T, scene.sph.dt)
    v_sph, rho_sph = on_steps(run, steps)
    ref = reference_fields(scene, problem.x, t)
    rows = []

    def tick():
        if progress is not None:
            progress.update(1)

    sph_time, _ = median_time(lambda: run_sph(scene, sample_steps=steps, progress=False, problem=problem),
                              repeats=repeats)
    err_ref = None if ref is None else error_table(v_sph, rho_sph, ref[0], ref[1], t, problem.rho0)
    rows.append(bench_row(scene, "full SPH", problem.n, None, sph_time, 0.0, None, err_ref,
                     f"N = {problem.n}, {scene.sph.integrator}"))
    tick()
    offline_pod = basis.timings.get("svd", 0.0) + run.wall_time
    models = pod_model_names() if models is None else models
    available = [m for m in models if get_model(m).available_modes(basis) is not None]
    for k in ks:
        built = {}                                  # one set of operators per basis kind, shared by its models
        for model in available:
            spec = get_model(model)
            if spec.basis_kind not in built:
                built[spec.basis_kind] = spec.build(problem, basis, k, k, **spec.paper_build)
            ops = built[spec.basis_kind]
            # the offline time: the snapshots' SPH run and SVD, the energy-weighted SVD for energy modes, and
            # the operators (with the refresh tensor where built)
            offline = (offline_pod + (basis.timings.get("svd_energy", 0.0) if spec.basis_kind == "energy" else 0.0)
                       + sum(ops.timings.values()))
            for nf in (n_freezes if spec.uses_n_freeze else (None,)):
                # a linear model is advanced exactly in time (no integrator), by the smallest sample spacing
                kwargs = dict(n_steps=n, dt=scene.sph.dt, sample_steps=steps,
                              options=spec.select_options(integrator=scene.sph.integrator, n_freeze=nf or 1))
                result = {}

                def go():
                    result["r"] = spec.run(ops, problem, **kwargs)
                online, _ = median_time(go, repeats=repeats)
                r = result["r"]
                err_sph = error_table(r.v, r.rho, v_sph, rho_sph, t, problem.rho0)
                err_r = None if ref is None else error_table(r.v, r.rho, ref[0], ref[1], t, problem.rho0)
                rows.append(bench_row(scene, model, k, nf, online, offline, err_sph, err_r,
                                      f"H = {r.settings['step']:g} s" if spec.linear else ""))
                tick()
    if extra is not None:
        rows += extra({"scene": scene, "basis": basis, "run": run, "steps": steps, "sph_time": sph_time,
                       "v_sph": v_sph, "rho_sph": rho_sph, "reference": ref, "ks": ks, "repeats": repeats})
    for row in rows:
        row["speedup"] = sph_time / row["online_s"] if row["online_s"] > 0 else np.nan
    return rows


def savings_by_k(rows, scene, n_freeze=10):
    """{k: CPU saving 1 - t_frozen / t_SPH} of the frozen model at ``n_freeze``, per k of the study."""
    sph = [r for r in rows if r["method"] == "full SPH"][0]["online_s"]
    frozen = model_names(uses_n_freeze=True)
    return {r["k"]: 1.0 - r["online_s"] / sph for r in rows if r["method"] in frozen and r["n_freeze"] == n_freeze}


def paper_saving(rows, scene):
    """Our CPU saving of the frozen model (n_freeze = 10) against the full SPH, "up to" as the paper
    words it: the best over the k of the scene's acceleration study (None without frozen rows)."""
    s = savings_by_k(rows, scene)
    return max(s.values()) if s else None


def plot_time_error(rows, path, title):
    """Log-log error against online time, v (left) and ρ - ρ0 (right), as in Figs. 3.17/3.21."""
    import matplotlib          # deferred: only a plot loads matplotlib, the measurements never do
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    markers = {"full SPH": "*", "C full SPH": "p", **dict(zip(MODEL_NAMES, "PXoDv<>8")), "FMU (fmpy)": "s",
               "FMU exact (fmpy)": "h", "FMU core (C)": "^"}
    dashed = model_names(uses_n_freeze=True)         # one line per k through the n_freeze points
    full = ("full SPH", "C full SPH")           # plotted with their error against the reference
    for ax, key, ref_key, label in ((axes[0], "err_v_sph", "err_v_ref", "v"),
                                    (axes[1], "err_rho_sph", "err_rho_ref", "ρ − ρ0")):
        for method, marker in markers.items():
            sel = [r for r in rows if r["method"] == method]
            if not sel:
                continue
            for k in sorted({r["k"] for r in sel}):
                pts = sorted([(r["online_s"], r[ref_key] if method in full else r[key]) for r in sel
                              if r["k"] == k and np.isfinite(r[ref_key] if method in full else r[key])])
                if not pts:
                    continue
                lab = method if method in full else f"{method}, k = {k}"
                ax.loglog(*zip(*pts), marker + ("--" if method in dashed else ""), ms=7, label=lab)
        ax.set_xlabel("online CPU time [s] (median)")
        ax.set_ylabel(f"relative L² error of {label}")
        ax.set_title(f"{title}: {label}", fontsize=10)
    axes[0].legend(fontsize=7)
    fig.text(0.01, 0.01, "full SPH (numba, C): error vs reference; reduced models and FMUs: error vs full SPH "
             "(frozen: n_freeze 1 → 50 right to left; FMUs through the FMU driver's loop, 10 ms steps)", fontsize=7)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    fig.savefig(path, dpi=100)
    plt.close(fig)
