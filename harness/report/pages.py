"""The report page of one scene and the index of ``sphrom validate``."""

from __future__ import annotations

import platform
import time
from importlib import metadata

import numpy as np

from .. import __version__
from ..pod.pipeline import error_steps
from ..sph.solver import build_problem, run_sph
from . import accuracy
from .convergence import agreement_section, convergence_section
from .exact_model import exact_section
from ..markdown import image, num, table, write_text
from .reduced import pod_section

CONVERGENCE_SCENES = ("multimode", "damped_forced")     # the convergence studies: undamped, damped and forced
PACKAGES = ("numpy", "scipy", "numba", "scikit-fem", "py-pde", "h5py", "fmpy", "matplotlib")


def versions():
    """'package version' for the packages every figure depends on."""
    out = [f"sphrom {__version__}", f"Python {platform.python_version()}"]
    for p in PACKAGES:
        try:
            out.append(f"{p} {metadata.version(p)}")
        except metadata.PackageNotFoundError:
            out.append(f"{p} (not installed)")
    return ", ".join(out)


def plot_fields(scene, x, t, run, ref, path):
    """v(x) and ρ(x) − ρ0 of the SPH and the reference at three times, as PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name, v_ref, rho_ref = ref
    rho0 = scene.field("rho0", x)
    picks = [int(np.searchsorted(t, s * t[-1] - 1e-12)) for s in (0.1, 0.5, 1.0)]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
    for j, m in enumerate(picks):
        axes[0].plot(x, v_ref[m], "-", color=f"C{j}", lw=1.0, label=f"{name}, t = {t[m]:.3g} s")
        axes[0].plot(x, run.v[m], ".", color=f"C{j}", ms=3, label=f"SPH, t = {t[m]:.3g} s")
        axes[1].plot(x, rho_ref[m] - rho0, "-", color=f"C{j}", lw=1.0)
        axes[1].plot(x, run.rho[m] - rho0, ".", color=f"C{j}", ms=3)
    axes[0].set_ylabel("v [m/s]")
    axes[1].set_ylabel("ρ − ρ0 [kg/m³]")
    for ax in axes:
        ax.set_xlabel("x [m]")
    axes[0].legend(fontsize=6, ncol=2)
    fig.suptitle(f"{scene.name}: full SPH (dots) and {name} (lines)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def scene_page(scene, out, repeats=3, progress=True, bar=None, convergence=None, agreement_resolutions=None):
    """Write ``out/<scene>.md`` (PNGs in ``out/<scene>/``); return its summary dict.

    Parameters
    ----------
    scene : Scene
    out : Path
        Report folder.
    repeats : int
        Timed runs per point of the time-against-error study.
    convergence : bool, optional
        Run the references' convergence study (default: for the scenes of
        :data:`CONVERGENCE_SCENES`; it always runs at T = 10 s).
    agreement_resolutions : sequence of int, optional
        Resolutions of scikit-fem against py-pde when there is no exact solution.
    """
    started = time.perf_counter()
    img = out / scene.name
    img.mkdir(parents=True, exist_ok=True)
    stem = scene.name
    lines = [f"# {scene.name}: {scene.title}", "",
             (f"Paper §{scene.section}. {scene.summary}" if scene.section else
              f"Not a scene of the paper. {scene.summary}".rstrip()), "",
             f"Produced by `sphrom validate {scene.name}` ({versions()}).", ""]
    summary = {"scene": scene.name}

    problem = build_problem(scene)
    steps = error_steps(scene)
    t0 = time.perf_counter()
    run = run_sph(scene, sample_steps=steps, progress=progress, problem=problem)
    sph_wall = time.perf_counter() - t0
    t = run.t
    refs = accuracy.run_references(scene, problem.x, t, progress=bar)
    best = accuracy.best(refs)
    lines += ["## The references", "",
              f"Full SPH: N = {problem.n}, α = {scene.sph.alpha:g}, Δt = {scene.sph.dt:g} s, "
              f"{scene.sph.integrator}, T = {scene.T:g} s ({sph_wall:.2f} s). Errors: relative L² of eq. 3.4 in the "
              "square-root form (the headline; the paper's printed squared form where stated), on the SPH particles "
              "at every stored sample; ρ both relative to ρ and relative to ρ − ρ0 (the first is near zero for any "
              "method, as ρ ≈ 1).", ""]
    lines += table(["reference", "settings", "wall [s]", "status"],
                   [[n, r["label"], num(r["wall"], ".1f"), r.get("error", "ok")] for n, r in refs.items()])

    errors = accuracy.sph_errors(run.v, run.rho, refs, t, problem.rho0)
    lines += ["### The full SPH against each reference", ""]
    lines += table(["reference", "v", "ρ", "ρ − ρ0", "v (squared form)"],
                   [[n, num(e["v"]), num(e["rho"]), num(e["rho_var"]), num(e["v_sq"])] for n, e in errors.items()])
    pairs = accuracy.agreement(refs, t, problem.rho0)
    lines += ["### The references against each other", "", "Error of the first against the second:", ""]
    lines += table(["reference", "against", "v", "ρ", "ρ − ρ0"],
                   [[a, b, num(e["v"]), num(e["rho"]), num(e["rho_var"])] for a, b, e in pairs])
    summary["pairs"] = {(a, b): e for a, b, e in pairs}
    refinement = refs.get("skfem", {}).get("refinement", [])
    if refinement:
        target = accuracy.agreement_target(scene)
        summary["agreement_target"] = target
        lines += [f"scikit-fem and py-pde are refined together until they agree to {target:g} in v and in ρ − ρ0 "
                  f"(at most {accuracy.MAX_DOUBLINGS} doublings of the resolution and Δt; the table above uses the "
                  "last pair):", ""]
        lines += table(["level", "scikit-fem", "py-pde", "v", "ρ − ρ0", f"≤ {target:g}"],
                       [[lv, a, b, num(ev), num(er), "yes" if max(ev, er) <= target else "**no**"]
                        for lv, a, b, ev, er in refinement])
        summary["refinement"] = refinement
    if best:
        plot_fields(scene, problem.x, t, run, (best, refs[best]["v"], refs[best]["rho"]), img / f"{stem}_fields.png")
        lines += image(f"{img.name}/{stem}_fields.png", "SPH and reference fields")

    comp = accuracy.paper_comparison(scene, errors)
    summary["paper"] = comp
    summary["sph"] = errors.get(best)
    summary["best"] = best
    if not comp:
        lines += ["## The paper's SPH errors beside ours", "", "Not a scene of the paper: it reports no figure for it.",
                  ""]
    else:
        lines += ["## The paper's SPH errors beside ours", "",
                  f"The paper measured against its {scene.paper.get('reference', 'analytic')} reference; `like` is "
                  "ours against the same kind of reference (for FD: the paper's scheme at the paper's Δx, Δt), `true` "
                  f"against the most accurate one we have. Ratio = like / paper; flagged when it differs from 1 by "
                  f"more than {100 * accuracy.DEVIATION:.0f} %.", ""]
        lines += table(["quantity", "paper", "ours (like)", "ratio", "ours (true)", "flag"],
                       [[c["quantity"], num(c["paper"]), f"{num(c['like'])} ({c['like_ref']})",
                         num(c["ratio"], ".2f"), f"{num(c['true'])} ({c['true_ref']})",
                         "**> 25 %**" if c["flag"] else ""] for c in comp])
    extra = accuracy.extra_paper_runs(scene, problem.x, t)
    if extra:
        lines += ["The paper's other settings of this scene, against the exact solution:", ""]
        lines += table(["setting", "paper v", "ours v", "ratio", "paper ρ", "ours ρ", "ratio"],
                       [[r["note"], num(r["paper_v"]), num(r["v"]), num(r["v"] / r["paper_v"], ".2f"),
                         num(r["paper_rho"]), num(r["rho"]), num(r["rho"] / r["paper_rho"], ".2f")] for r in extra])
        summary["extra_runs"] = extra
    if any(c["flag"] for c in comp) and best:
        lines += ["### Evidence for the difference", ""]
        ev_lines, facts = accuracy.evidence(scene, problem, run, (best, refs[best]["v"], refs[best]["rho"]), t,
                                            img, stem)
        lines += ev_lines
        summary["evidence"] = facts

    if scene.name in CONVERGENCE_SCENES if convergence is None else convergence:
        conv_lines, conv = convergence_section(scene.name, img, stem, progress=bar)
        lines += conv_lines
        summary["convergence"] = conv
    if best != "exact":
        kw = {} if agreement_resolutions is None else {"resolutions": agreement_resolutions}
        agr_lines, agr = agreement_section(scene, img, stem, progress=bar, **kw)
        lines += agr_lines
        summary["agreement"] = agr

    reference = (refs[best]["v"], refs[best]["rho"], refs[best]["label"]) if best else None
    pod_lines, pod = pod_section(scene, reference, img, stem, repeats=repeats, progress=progress)
    lines += pod_lines
    summary.update(pod)
    exact_lines, summary["exact_model"] = exact_section(scene)
    lines += exact_lines
    wall = time.perf_counter() - started
    summary["wall"] = wall
    lines += [f"Wall time of this page: {wall:.0f} s.", ""]
    write_text(out / f"{scene.name}.md", "\n".join(lines))
    return summary


def index_page(summaries, out, command, wall):
    """Write ``out/README.md``: one line per scene and the cross-scene checks."""
    lines = ["# Validation reports", "",
             f"Produced by `{command}` ({versions()}; {wall:.0f} s wall on a shared 2-core machine). One page per "
             "scene; errors are relative L² (square-root form of eq. 3.4) on the SPH particles and samples.", "",
             "## The full SPH and the paper", ""]
    rows = []
    for s in summaries:
        pv = next((c for c in s.get("paper", []) if c["quantity"] == "v"), None)
        sph = s.get("sph") or {}
        rows.append([f"[{s['scene']}]({s['scene']}.md)", s.get("best") or "—", num(sph.get("v")),
                     num(sph.get("rho_var")), num(pv["paper"]) if pv else "—",
                     f"{num(pv['like'])} ({pv['like_ref']})" if pv else "—",
                     num(pv["ratio"], ".2f") if pv else "—",
                     ("explained below" if s.get("evidence") else "flagged") if pv and pv["flag"] else ""])
    lines += table(["scene", "reference", "SPH v", "SPH ρ − ρ0", "paper v", "ours like the paper", "ratio",
                    "> 25 %"], rows)
    lines += ["## POD", ""]
    rows = []
    for s in summaries:
        st = s.get("studies")
        rows.append([s["scene"], s.get("threshold") or "—", s.get("paper_threshold") or "—",
                     f"{st[0]} of {st[1]}" if st else "—",
                     ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in s["saving_by_k"].items())
                     if s.get("saving_by_k") else "—",
                     num(None if s.get("paper_saving") is None else 100 * s["paper_saving"], ".0f") + " %"
                     if s.get("paper_saving") else "—"])
    lines += table(["scene", "mode threshold (ours)", "paper", "snapshot studies agreeing", "frozen CPU saving",
                    "paper (up to)"], rows)
    lines += ["## scikit-fem against py-pde", "",
              "The two continuum references on every scene, refined together (from scikit-fem P2 at N = "
              f"{accuracy.FE_ELEMENTS} and py-pde at N = {accuracy.PDE_CELLS}, resolution and Δt doubled at most "
              f"{accuracy.MAX_DOUBLINGS} times) until they agree to the target: ≤ {accuracy.AGREEMENT_TARGET:g} on "
              f"scenes with smooth coefficients, ≤ {accuracy.AGREEMENT_TARGET_JUMP:g} where c, ρ0, d or the force "
              "profile jumps (`heterogeneous`: c), "
              "whose page also has the observed order of the pair's convergence study.", ""]
    rows = []
    for s in summaries:
        ref = s.get("refinement")
        if not ref:
            continue
        _, fe, pp, ev, er = ref[-1]
        a = s.get("agreement")
        order = f"{num(a[2], '.2f')} / {num(a[3], '.2f')}" if a else "—"
        target = s.get("agreement_target", accuracy.AGREEMENT_TARGET)
        rows.append([s["scene"], fe.split(",")[1].strip(), pp.split(",")[1].strip(), num(ev), num(er), order,
                     "yes" if max(ev, er) <= target else "**no**"])
    lines += table(["scene", "scikit-fem", "py-pde", "v", "ρ − ρ0", "observed order (v / ρ−ρ0)", "within target"],
                   rows)
    rows = []
    for s in summaries:
        for r in s.get("exact_model", []):
            rows.append([s["scene"], r["k"], f"{num(r['orig_v'])} / {num(r['orig_rho'])}",
                         f"{num(r['pure_v'])} / {num(r['pure_rho'])}", f"{num(r['time_v'])} / {num(r['time_rho'])}"])
    if rows:
        lines += ["## The exact linear model against the original POD-MOR", "",
                  "POD errors (v / ρ − ρ0): the original against the full SPH (same Euler scheme), the exact model "
                  "against the full SPH solved exactly in time; and the SPH's own time error. Details on each page.",
                  ""]
        lines += table(["scene", "k", "original", "exact", "SPH time error"], rows)
    conv = [(s["scene"], s["convergence"]) for s in summaries if "convergence" in s]
    if conv:
        lines += ["## Convergence against the exact solution (finest resolution)", ""]
        rows = [[name, solver, num(v[0]), num(v[1]), "yes" if v[2] else "**no**"]
                for name, c in conv for solver, v in c.items()]
        lines += table(["scene", "reference", "v", "ρ − ρ0", "≤ 1e-4"], rows)
    write_text(out / "README.md", "\n".join(lines))

