"""Convergence of the continuum references, for the validation report.

* :func:`convergence_section`: each reference against the exact solution at
  increasing resolution (:func:`sphrom.references.convergence.study`), with
  the observed orders, on a scene with an exact solution;
* :func:`agreement_section`: scikit-fem against py-pde at increasing
  resolution on a scene without one (``heterogeneous``): the difference and
  its observed order.
"""

from __future__ import annotations

from ..compare import error_table
from ..markdown import image, num, table
from ..references import pypde_ref, skfem_ref
from ..references.common import BREAK_FIELDS, field_jumps, output_points, output_times
from ..references.convergence import SOLVERS, observed_orders, study

TARGET = 1e-4                 # the product requirement at the finest resolution
LABELS = {"skfem1": "scikit-fem P1", "skfem2": "scikit-fem P2", "pypde": "py-pde RK4", "fd": "paper's FD (staggered)"}


def _plot(series, path, title, xlabel="resolution N"):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    for i, (label, n, ev, er) in enumerate(series):
        ax.loglog(n, ev, "o-", color=f"C{i}", label=f"{label}: v")
        ax.loglog(n, er, "s--", color=f"C{i}", label=f"{label}: ρ − ρ0")
    ax.axhline(TARGET, color="gray", lw=0.8, ls=":")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relative L² error")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def convergence_section(scene_name, out_dir, stem, solvers=SOLVERS, progress=None):
    """Markdown lines and {solver: (finest v, finest ρ−ρ0, passes)} for one scene."""
    lines = ["## Convergence of the references against the exact solution", "",
             "Each reference at increasing resolution (Δt refined with the mesh, "
             "`sphrom.references.convergence.study_dt`), T = 10 s, errors on the SPH particles and sample times; "
             "observed order log(e_{k−1}/e_k)/log(N_k/N_{k−1}).", ""]
    rows, series, summary = [], [], {}
    for solver in solvers:
        res = study(scene_name, solver)
        for r in res:
            rows.append([LABELS[solver], r["resolution"], num(r["dt"], ".2e"), num(r["v"]), num(r["order_v"], ".2f"),
                         num(r["rho_var"]), num(r["order_rho_var"], ".2f"), num(r["wall_time"], ".1f")])
        last = res[-1]
        summary[solver] = (last["v"], last["rho_var"], last["v"] <= TARGET and last["rho_var"] <= TARGET)
        series.append((LABELS[solver], [r["resolution"] for r in res], [r["v"] for r in res],
                       [r["rho_var"] for r in res]))
        if progress is not None:
            progress.update(1)
    lines += table(["reference", "N", "Δt [s]", "v", "order", "ρ − ρ0", "order", "wall [s]"], rows)
    _plot(series, out_dir / f"{stem}_convergence.png", f"{scene_name}: references against the exact solution")
    lines += image(f"{out_dir.name}/{stem}_convergence.png", "convergence")
    ok = [LABELS[s] for s, v in summary.items() if v[2]]
    lines += [f"At the finest resolution {len(ok)} of {len(summary)} references reach ≤ {TARGET:g} in v and in "
              f"ρ − ρ0: {', '.join(ok) or 'none'}.", ""]
    return lines, summary


def _order_reason(scene):
    """Why the references converge as they do, from what the scene has (a jump or none)."""
    jumps = {name: field_jumps(lambda x, name=name: scene.field(name, x), scene.L) for name in BREAK_FIELDS}
    jumps = {name: pos for name, pos in jumps.items() if pos}
    if not jumps:
        return ": c, ρ0, d and the force profile have no jump in this scene"
    label = {"c": "c", "rho0": "ρ0", "d": "d", "profile": "the force profile"}
    where = "; ".join(f"{label[n]} at x = {', '.join(f'{p:g}' for p in sorted(pos))} m" for n, pos in jumps.items())
    return (f": jumps ({where}) send kinks along the characteristics, so the references converge at about "
            "first order here")


def agreement_section(scene, out_dir, stem, resolutions=(256, 512, 1024, 2048), progress=None):
    """scikit-fem P2 against py-pde at the same N, with the observed order of the difference.

    Returns (lines, (finest v difference, finest ρ−ρ0 difference, orders of the last pair)).
    """
    x = output_points(scene)
    t = output_times(scene)
    rho0 = scene.field("rho0", x)
    diffs = []
    for n in resolutions:
        a = skfem_ref.solve(scene, n, None, x, t, order=2)
        b = pypde_ref.solve(scene, n, None, x, t)
        e = error_table(a.v, a.rho, b.v, b.rho, t, rho0)
        diffs.append((n, e["v"], e["rho_var"]))
        if progress is not None:
            progress.update(1)
    n = [d[0] for d in diffs]
    ov = observed_orders(n, [d[1] for d in diffs])
    orr = observed_orders(n, [d[2] for d in diffs])
    lines = ["## scikit-fem against py-pde", "",
             "No exact solution exists here; the two references share no code (displacement form with P2 "
             "elements and Newmark; density–velocity form with finite differences and RK4). Their difference at the "
             "same N, and its observed order:", ""]
    lines += table(["N", "v", "order", "ρ − ρ0", "order"],
                   [[d[0], num(d[1]), num(a, ".2f"), num(d[2]), num(b, ".2f")] for d, a, b in zip(diffs, ov, orr)])
    _plot([("scikit-fem − py-pde", n, [d[1] for d in diffs], [d[2] for d in diffs])],
          out_dir / f"{stem}_agreement.png", f"{scene.name}: scikit-fem P2 against py-pde")
    lines += image(f"{out_dir.name}/{stem}_agreement.png", "scikit-fem against py-pde")
    last = diffs[-1]
    lines += [f"Finest difference: v {num(last[1])}, ρ − ρ0 {num(last[2])} (observed order {num(ov[-1], '.2f')} / "
              f"{num(orr[-1], '.2f')}{_order_reason(scene)}).", ""]
    return lines, (last[1], last[2], float(ov[-1]), float(orr[-1]))

