"""The full SPH against independent references, and the paper's figures beside ours.

Every reference shares no code with the SPH: the exact Fourier/d'Alembert
solution (uniform c, ρ0, d), scikit-fem (displacement form, P2, Newmark),
py-pde (density-velocity form, RK4) and the paper's own finite differences
at the paper's resolution.  All are sampled on the SPH particles at the SPH
sample times, so every error is eq. 3.4 on the same points.

Units: x in m, t in s, v in m s^-1, ρ in kg m^-3.
"""

from __future__ import annotations

import time

import numpy as np

from ..compare import error_table
from ..errors import UserError
from ..markdown import image, num, table
from ..norms import relative_l2, relative_l2_history
from ..references import fd, pypde_ref, skfem_ref
from ..references.common import coefficient_breaks
from ..references.convergence import study_dt
from ..references.exact import exact_solution, is_available
from ..sph.operator import gradient_symbol
from ..sph.solver import run_sph

DEVIATION = 0.25          # |ours / paper's - 1| above which a figure "differs from the paper"
FE_ELEMENTS = 1024        # scikit-fem P2 elements
PDE_CELLS = 2048          # py-pde cells


AGREEMENT_TARGET = 1e-4   # relative L² difference required of scikit-fem against py-pde on scenes with uniform c
AGREEMENT_TARGET_JUMP = 1e-3   # ... and where a coefficient jumps (heterogeneous), where convergence is first order
MAX_DOUBLINGS = 2         # refinements of the continuum pair beyond FE_ELEMENTS, PDE_CELLS


def continuum_plan(scene, level=0):
    """scikit-fem P2 and py-pde at ``FE_ELEMENTS·2^level`` elements and ``PDE_CELLS·2^level`` cells.

    Returns [(name, label, callable(x, t) -> (v, rho, settings))], with the
    convergence study's time steps (:func:`sphrom.references.convergence.study_dt`).
    """
    n_fe, n_pp = FE_ELEMENTS << level, PDE_CELLS << level
    dt_fe, dt_pp = study_dt(scene, "skfem2", n_fe, scene.T), study_dt(scene, "pypde", n_pp, scene.T)
    return [("skfem", f"scikit-fem P2, N = {n_fe}, Δt = {dt_fe:.3g} s",
             lambda x, t: skfem_ref.solve(scene, n_fe, dt_fe, x, t, order=2)),
            ("pypde", f"py-pde RK4, N = {n_pp}, Δt = {dt_pp:.3g} s",
             lambda x, t: pypde_ref.solve(scene, n_pp, dt_pp, x, t))]


def reference_plan(scene, level=0):
    """The references run for ``scene``: (name, label, callable(x, t) -> (v, rho, settings)).

    The exact solution where there is one; scikit-fem and py-pde at the
    finest resolutions of the convergence study (:mod:`sphrom.references.convergence`),
    refined ``level`` times; the paper's finite differences at the paper's
    Δx, Δt when the scene states them.
    """
    plan = []
    if is_available(scene):
        plan.append(("exact", "exact (Fourier / d'Alembert)",
                     lambda x, t: (*exact_solution(scene, x, t), {})))
    plan += continuum_plan(scene, level)
    dx, dt = scene.paper.get("reference_dx"), scene.paper.get("reference_dt")
    if dx and dt:
        plan.append(("fd", f"paper's FD (RK2), staggered ρ (2nd order), Δx = {dx:g}, Δt = {dt:g}",
                     lambda x, t: fd.solve(scene, None, dt, x, t, dx=dx)))
        plan.append(("fd-collocated", f"paper's FD (RK2), collocated ρ (1st order), Δx = {dx:g}, Δt = {dt:g}",
                     lambda x, t: fd.solve(scene, None, dt, x, t, dx=dx, layout="collocated")))
    return plan


def _run(plan, x, t, progress=None):
    refs = {}
    for name, label, solve in plan:
        t0 = time.perf_counter()
        try:
            v, rho, _ = solve(x, t)
            refs[name] = {"label": label, "v": v, "rho": rho, "wall": time.perf_counter() - t0}
        except UserError as exc:
            refs[name] = {"label": label, "error": str(exc), "wall": time.perf_counter() - t0}
        if progress is not None:
            progress.update(1)
    return refs


def agreement_target(scene):
    """The target of scikit-fem against py-pde: 1e-4 with smooth coefficients, 1e-3 where one jumps.

    A jump of c, ρ0, d or the force profile (:func:`~sphrom.references.common.coefficient_breaks`)
    sends kinks along the characteristics and the references converge at first order there.
    """
    return AGREEMENT_TARGET_JUMP if coefficient_breaks(scene).size else AGREEMENT_TARGET


def run_references(scene, x, t, progress=None, max_doublings=MAX_DOUBLINGS):
    """Run every reference of :func:`reference_plan` at (x, t).

    scikit-fem and py-pde are refined together (resolution and Δt doubled,
    at most ``max_doublings`` times) until they agree to
    :func:`agreement_target` in v and in ρ − ρ0: where v0 has a kink (the
    x(1 − x) factor of eq. 3.8) they converge at about order 1.3 and the
    study's finest pair is not always enough.

    Returns a dict name -> {label, v, rho, wall [s]} (``error`` instead of
    v/rho when a reference refuses the settings, e.g. an unstable FD); the
    pair's entries carry ``refinement``: [(level, labels, v, ρ − ρ0 difference)].
    """
    refs = _run(reference_plan(scene), x, t, progress)
    rho0 = scene.field("rho0", x)
    target = agreement_target(scene)
    history = []
    for level in range(max_doublings + 1):
        if level:
            refs.update(_run(continuum_plan(scene, level), x, t, progress))
        if not all("v" in refs.get(n, {}) for n in ("skfem", "pypde")):
            break
        e = error_table(refs["skfem"]["v"], refs["skfem"]["rho"], refs["pypde"]["v"], refs["pypde"]["rho"], t, rho0)
        history.append((level, refs["skfem"]["label"], refs["pypde"]["label"], e["v"], e["rho_var"]))
        if max(e["v"], e["rho_var"]) <= target:
            break
    for name in ("skfem", "pypde"):
        if name in refs:
            refs[name]["refinement"] = history
    return refs


def best(refs):
    """The most accurate reference present: exact, else scikit-fem."""
    for name in ("exact", "skfem", "pypde"):
        if name in refs and "v" in refs[name]:
            return name
    return None


def sph_errors(v, rho, refs, t, rho0):
    """error_table of the SPH run against every reference that ran."""
    return {name: error_table(v, rho, r["v"], r["rho"], t, rho0) for name, r in refs.items() if "v" in r}


def agreement(refs, t, rho0):
    """Rows (a, b, error table of a against b) for every pair of references."""
    names = [n for n in refs if "v" in refs[n]]
    rows = []
    for i, b in enumerate(names):
        for a in names[i + 1:]:
            rows.append((a, b, error_table(refs[a]["v"], refs[a]["rho"], refs[b]["v"], refs[b]["rho"], t, rho0)))
    return rows


def paper_comparison(scene, errors):
    """The paper's SPH errors beside ours.

    The paper measured against its own reference (analytic, or its FD); we
    give ours against the same kind of reference (``like``) and against the
    most accurate one (``true``), each with the ratio ours/paper.

    Returns
    -------
    list of dict: quantity, paper, like, like_ref, true, true_ref, ratio, flag
    """
    kind = scene.paper.get("reference", "analytic")
    like_ref = "exact" if kind == "analytic" else kind
    true_ref = "exact" if "exact" in errors else ("skfem" if "skfem" in errors else None)
    rows = []
    for quantity, pkey, okey in (("v", "sph_error_v", "v"), ("ρ", "sph_error_rho", "rho")):
        paper = scene.paper.get(pkey)
        if paper is None:
            continue
        like = errors.get(like_ref, {}).get(okey)
        true = errors.get(true_ref, {}).get(okey) if true_ref else None
        ratio = None if like is None else like / paper
        rows.append({"quantity": quantity, "paper": paper, "like": like, "like_ref": like_ref, "true": true,
                     "true_ref": true_ref, "ratio": ratio,
                     "flag": ratio is not None and abs(ratio - 1.0) > DEVIATION})
    return rows


def extra_paper_runs(scene, problem_x, t_steps, progress=None):
    """The paper's other SPH settings of a scene (``[[paper.runs]]``) against the exact solution."""
    rows = []
    for spec in scene.paper.get("runs", []):
        alt = scene.with_sph(n_particles=spec.get("n_particles"), alpha=spec.get("alpha"), dt=spec.get("dt"))
        res = run_sph(alt, progress=False)
        if not is_available(alt):
            continue
        v_ex, rho_ex = exact_solution(alt, res.x, res.t)
        err = error_table(res.v, res.rho, v_ex, rho_ex, res.t, alt.field("rho0", res.x))
        rows.append({"note": spec.get("note", ""), "paper_v": spec.get("sph_error_v"),
                     "paper_rho": spec.get("sph_error_rho"), "v": err["v"], "rho": err["rho"]})
        if progress is not None:
            progress.update(1)
    return rows


def evidence(scene, problem, run, ref, t, out_dir, stem):
    """Measurements that explain an SPH error different from the paper's.

    None of them changes the scene to match the paper; each varies one thing:
    the horizon (error of the same run over [0, T']), the time integrator,
    α = h/Δx, the norm (square root or not), and, when the exact solution
    exists, the error predicted by the SPH operator's own dispersion alone
    (the exact solution of the SPH gradient's symbol D(κ) instead of iκ).

    Parameters
    ----------
    ref : (name, v, rho)
        The reference at the run's points and times ``t``.

    Returns
    -------
    (lines, facts): Markdown lines, and a dict of the numbers behind them.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name, v_ref, rho_ref = ref
    rho0 = problem.rho0
    steps = np.rint(t / scene.sph.dt).astype(np.int64)
    hist_v = relative_l2_history(run.v, v_ref, t)
    hist_r = relative_l2_history(run.rho, rho_ref, t, baseline=rho0)
    facts = {}
    lines = ["#### Error against the horizon", "",
             f"The same run cut at T' (eq. 3.4 over [0, T'], against {name}):", ""]
    rows = []
    for Tp in sorted({1.0, 2.0, 5.0, float(scene.T)}):
        if Tp > t[-1] + 1e-12:
            continue
        m = int(np.searchsorted(t, Tp - 1e-12))
        rows.append([f"{Tp:g}", num(hist_v[m]), num(hist_r[m])])
    lines += table(["T' [s]", "v", "ρ − ρ0"], rows)
    paper_v = scene.paper.get("sph_error_v")
    if paper_v and hist_v[-1] > paper_v and np.any(hist_v[1:] <= paper_v):
        m = int(np.nonzero(hist_v[1:] > paper_v)[0][0]) + 1        # first sample above the paper's figure
        facts["paper_horizon"] = float(np.interp(paper_v, hist_v[m - 1:m + 1], t[m - 1:m + 1]))
        lines += [f"Our error over [0, T'] equals the paper's figure ({paper_v:.3e}) at T' ≈ "
                  f"{facts['paper_horizon']:.2f} s.", ""]
    half = int(np.searchsorted(t, t[-1] / 2 - 1e-12))
    facts["growth_half_to_full"] = hist_v[-1] / hist_v[half] if hist_v[half] > 0 else np.nan

    integ_rows, facts["integrators"] = [], {}
    for integ in ("euler", "symplectic", "rk4"):
        res = run if integ == scene.sph.integrator else run_sph(scene.with_sph(integrator=integ),
                                                                sample_steps=steps, progress=False)
        e = error_table(res.v, res.rho, v_ref, rho_ref, t, rho0)
        facts["integrators"][integ] = e["v"]
        integ_rows.append([integ, num(e["v"]), num(e["rho"]), num(e["rho_var"])])
    lines += ["#### Time integrator", "", f"Same N, α, Δt (against {name}):", ""]
    lines += table(["integrator", "v", "ρ", "ρ − ρ0"], integ_rows)

    alpha_rows, facts["alpha"] = [], {}
    for a in sorted({scene.sph.alpha, 1.2, 1.5}):
        res = run if a == scene.sph.alpha else run_sph(scene.with_sph(alpha=a), sample_steps=steps, progress=False)
        e = error_table(res.v, res.rho, v_ref, rho_ref, t, rho0)
        facts["alpha"][a] = e["v"]
        alpha_rows.append([f"{a:g}", num(e["v"]), num(e["rho"]), num(e["rho_var"])])
    lines += ["#### Smoothing length", "", f"α = h/Δx, same N, Δt, integrator (against {name}):", ""]
    lines += table(["α", "v", "ρ", "ρ − ρ0"], alpha_rows)

    lines += ["#### Norm", "",
              f"v: square-root form {num(relative_l2(run.v, v_ref, t))}, the squared form printed in eq. 3.4 "
              f"{num(relative_l2(run.v, v_ref, t, squared=True))}.", ""]

    fig, ax = plt.subplots(figsize=(6.4, 3.4))
    ax.semilogy(t[1:], hist_v[1:], label="SPH: v")
    ax.semilogy(t[1:], hist_r[1:], label="SPH: ρ − ρ0")
    if name == "exact":
        sym = gradient_symbol(problem.neighbours, scene.L)
        v_mod, rho_mod = exact_solution(scene, problem.x, t, symbol=sym)
        disp = relative_l2(v_mod, v_ref, t)
        facts["dispersion"] = disp
        rk4 = run_sph(scene.with_sph(integrator="rk4"), sample_steps=steps, progress=False)
        facts["rk4_vs_dispersion"] = relative_l2(rk4.v, v_mod, t)
        ax.semilogy(t[1:], relative_l2_history(v_mod, v_ref, t)[1:], "--", label="SPH dispersion alone: v")
        lines += ["#### The SPH operator's dispersion", "",
                  "The SPH system is linear in J = ρ0/ρ (eqs. 2.10-2.11 read ė = G v, ρ0 v̇ = G(c e) − ρ0 d v + "
                  "ρ0 f with e = J − 1, eq. A.9), so the exact solution with the SPH gradient's "
                  f"own symbol D(κ) in place of iκ is what the SPH would give with an exact time integrator. Its "
                  f"error against the exact solution: v {num(disp)} (the SPH's: {num(hist_v[-1])}); RK4-SPH against "
                  f"it: {num(facts['rk4_vs_dispersion'])}.", ""]
    ax.set_xlabel("T' [s]")
    ax.set_ylabel("relative L² error over [0, T']")
    ax.set_title(f"{scene.name}: SPH error against the horizon ({name})", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / f"{stem}_error_history.png", dpi=90)
    plt.close(fig)
    lines += image(f"{out_dir.name}/{stem}_error_history.png", "SPH error against the horizon")
    lines += ["#### Verdict", "", verdict(facts, hist_v[-1]), ""]
    return lines, facts


def verdict(facts, err_v):
    """One paragraph composed from the measured evidence (no typed-in claims)."""
    parts = []
    spread = facts.get("integrators", {})
    if spread:
        lo, hi = min(spread.values()), max(spread.values())
        if hi <= 1.1 * lo:
            parts.append(f"the error does not depend on the time integrator (Euler, symplectic, RK4 within "
                         f"{100 * (hi / lo - 1):.0f} %), so it is not the explicit Euler's")
        else:
            parts.append(f"the integrator matters (v error {lo:.3e} to {hi:.3e})")
    g = facts.get("growth_half_to_full")
    if g is not None and np.isfinite(g):
        parts.append(f"it grows by ×{g:.2f} from T/2 to T ({'about linear in time, a phase error' if g > 1.25 else 'not a phase drift'})")
    if facts.get("paper_horizon") is not None:
        parts.append(f"the paper's figure is our error over [0, {facts['paper_horizon']:.2f} s]")
    disp = facts.get("dispersion")
    if disp is not None:
        parts.append(f"the SPH operator's dispersion alone predicts {disp:.3e}, {100 * disp / err_v:.0f} % of the "
                     f"measured {err_v:.3e}: the error is the SPH spatial discretisation at this N and α")
    alpha = facts.get("alpha", {})
    if alpha:
        parts.append("α = h/Δx changes it to " + ", ".join(f"{v:.3e} (α = {a:g})" for a, v in alpha.items()))
    if not parts:
        return "No evidence could be measured."
    return "Measured: " + "; ".join(parts) + ". The scene is not tuned to match the paper."
