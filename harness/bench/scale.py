"""Offline time and accuracy of the balanced model and its certified bounds from N = 400 to 10⁴ particles.

For each scene and particle count N this builds the full linear SPH (:func:`sphrom.rom.lti.full_linear_system`),
balances it through its Fourier modes (:mod:`sphrom.rom.modal`: the Galerkin projection on the modes |k| <= K,
dense balancing there, the model lifted back; ``structure="modal"`` at every N so that the rows compare one path),
keeps the order the default tolerance gives, and computes the certified bounds (the intermediate model's plus the
dropped modes' tail).  Accuracy: the bounds, the tail's share of them, and the model's measured L² error of the
free response from the scene's initial state against the full system's, computed exactly through every one of
its N modes (:func:`sphrom.rom.modal.free_outputs`, Simpson's rule on ``--samples`` points) - the effectivity
is bound / measured.  With ``--dense N,...`` the dense path (:func:`sphrom.rom.balanced.balancing` and
:func:`sphrom.rom.balanced.error_bounds`, ``structure="dense"``) is timed at those N as well and its bounds
compared (it is O(N³): minutes at N = 400 on a loaded 2-core machine).

Times are wall seconds, the median of ``--repeats`` (default 1: the steps take seconds to minutes).

Run as::

    python -m sphrom.bench.scale [--scenes tenmode,damped_forced] [--sizes 400,1000,2000,5000,10000]
        [--wavenumbers 100] [--dense 400] [--repeats 1] [--out validation/benchmarks] [--report BENCHMARKS.md]

It writes ``scale.csv`` and ``scale.png`` into ``--out`` and the section "Scale: the balanced model and its bounds
to N = 10⁴" of the report.
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from ..options import int_at_least, int_list
from ..progress import progress_bar
from ..runio import atomic_path
from ..scene import load_scene
from . import program_parser
from .lib.document import program_outputs, publish
from .lib.tables import write_csv
from .lib.timing import cpu_model, load_average

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## Scale: the balanced model and its bounds to N = 10⁴"


def _timed(fn, repeats):
    """(result of the last call, median wall time [s]) over ``repeats`` calls."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times)


def measured_free_error(ms, reduced, rows, horizon, samples):
    """‖y_j - y_r,j‖_L2(0,T) of the free responses from x0 (Simpson's rule on ``samples`` points), the full system's
    through every mode; and its L² norm."""
    from scipy.integrate import simpson
    from ..rom.modal import free_outputs
    t = np.linspace(0.0, horizon, samples)
    y = free_outputs(ms, rows, t)
    yr = reduced.free_response(t) @ reduced.Cr[rows].T
    h = t[1] - t[0]
    return np.sqrt(simpson((y - yr) ** 2, dx=h, axis=0)), np.sqrt(simpson(y ** 2, dx=h, axis=0))


def numerical_rank(L, tol=1e-12):
    """The numerical rank of the Gramian L Lᵀ: its eigenvalues (the squared column norms of the factor
    :func:`sphrom.rom.balanced._factor` returns) above ``tol`` times the largest."""
    lam = np.sum(np.asarray(L) ** 2, axis=0)
    return int(np.sum(lam > tol * lam.max())) if lam.size and lam.max() > 0 else 0


def exact_row(row, scene, problem, lti, ms, samples, repeats):
    """The exact POD model's row beside the balanced one's: its POD basis from the scene's full SPH training run at
    this N (cached; the run is timed as ``t_system``), k = the scene's ``rom.modes``, its bounds through the modes."""
    from ..rom import balanced as bl, modal
    from ..pod.pipeline import basis_for_scene
    from ..rom.balanced import reduced_from_exact
    from ..rom.registry import get_model
    spec = get_model("exact")
    (basis, _), t_pod = _timed(lambda: basis_for_scene(scene, progress=False, problem=problem), 1)
    k = int(scene.rom.get("modes", 12))
    ops, t_build = _timed(lambda: spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction),
                          repeats)
    red = reduced_from_exact(lti, ops)
    bounds, t_bounds = _timed(lambda: modal.error_bounds(lti, red, bl.error_bounds, ms=ms), repeats)
    err, _ = measured_free_error(ms, red, bounds["rows"], lti.T, samples)
    init = bounds["initial_state_error_bound"]
    return dict(row, path="modal", method="exact POD", order=red.order, rank_P="-", rank_Q="-", t_system=t_pod,
                t_balancing=t_build, t_truncate=0.0, t_bounds=t_bounds,
                t_total=t_pod + row["t_modal"] + t_build + t_bounds,
                force_bound=float(np.max(bounds["force_error_bound"])), force_tail=float(np.max(bounds["force_tail"])),
                initial_bound=float(np.max(init)), initial_tail=float(np.max(bounds["initial_state_tail"])),
                measured_error=float(np.max(err)), effectivity=float(np.min(init / np.maximum(err, 1e-300))))


def measure_one(scene_name, n, wavenumbers, repeats, samples, dense=False, exact=False, progress=None):
    """The rows at N = ``n`` for the scene: the balanced model on the modal path, the dense path when ``dense``,
    the exact POD model when ``exact`` (:func:`exact_row`)."""
    from ..rom import balanced as bl, modal
    from ..rom.lti import full_linear_system
    from ..sph.solver import build_problem
    scene = load_scene(scene_name).with_sph(n_particles=n)
    problem = build_problem(scene)
    lti, t_lti = _timed(lambda: full_linear_system(problem), repeats)
    ms, t_modal = _timed(lambda: modal.modal_system(lti, wavenumbers), repeats)
    sub = ms.system

    def balance():
        bal = bl.balancing(sub, structure="dense")
        return dataclasses.replace(bal, basis=ms.basis, system=sub)

    bal, t_bal = _timed(balance, repeats)
    order = max(1, bl.order_from_tolerance(bal.hsv, bl.DEFAULT_TOLERANCE))
    rank_p, rank_q = (numerical_rank(L) for L in (bal.LP, bal.LQ))
    red, t_trunc = _timed(lambda: bl.truncate(lti, bal, order), repeats)
    bounds, t_bounds = _timed(lambda: modal.error_bounds(lti, red, bl.error_bounds, ms=ms), repeats)
    rows = bounds["rows"]
    err, norm = measured_free_error(ms, red, rows, lti.T, samples)
    init = bounds["initial_state_error_bound"]
    row = {"scene": scene_name, "n": n, "path": "modal", "wavenumbers": ms.wavenumbers,
           "intermediate_order": sub.order, "method": bal.method, "order": red.order, "rank_P": rank_p,
           "rank_Q": rank_q,
           "t_system": t_lti, "t_modal": t_modal, "t_balancing": t_bal, "t_truncate": t_trunc, "t_bounds": t_bounds,
           "t_total": t_lti + t_modal + t_bal + t_trunc + t_bounds,
           "force_bound": float(np.max(bounds["force_error_bound"])),
           "force_tail": float(np.max(bounds["force_tail"])),
           "initial_bound": float(np.max(init)), "initial_tail": float(np.max(bounds["initial_state_tail"])),
           "measured_error": float(np.max(err)), "output_norm": float(np.max(norm)),
           "effectivity": float(np.min(init / np.maximum(err, 1e-300))),
           "roundoff": float(sub.info["dropped_roundoff"]), "circulant_defect": ms.circulant_defect}
    if progress is not None:
        progress.update(1)
    out = [row]
    if exact:
        out.append(exact_row(row, scene, problem, lti, ms, samples, repeats))
    if dense:
        dbal, t_dbal = _timed(lambda: bl.balancing(lti, structure="dense"), repeats)
        dorder = max(1, bl.order_from_tolerance(dbal.hsv, bl.DEFAULT_TOLERANCE))
        drank = [numerical_rank(L) for L in (dbal.LP, dbal.LQ)]
        dred, t_dtr = _timed(lambda: bl.truncate(lti, dbal, dorder), repeats)
        dbounds, t_db = _timed(lambda: bl.error_bounds(lti, dred, structure="dense"), repeats)
        derr, _ = measured_free_error(ms, dred, rows, lti.T, samples)
        dinit = dbounds["initial_state_error_bound"]
        out.append(dict(row, path="dense", wavenumbers=(n - 1) // 2, intermediate_order=lti.order,
                        method=dbal.method, order=dred.order, rank_P=drank[0], rank_Q=drank[1], t_modal=0.0, t_balancing=t_dbal, t_truncate=t_dtr,
                        t_bounds=t_db, t_total=t_lti + t_dbal + t_dtr + t_db,
                        force_bound=float(np.max(dbounds["force_error_bound"])), force_tail=0.0,
                        initial_bound=float(np.max(dinit)), initial_tail=0.0, measured_error=float(np.max(derr)),
                        effectivity=float(np.min(dinit / np.maximum(derr, 1e-300)))))
        if progress is not None:
            progress.update(1)
    return out


def section(rows, info, command, wall, csv_path, image):
    """The report's section (Markdown lines)."""
    load = lambda x: "n/a" if x is None else " / ".join(f"{v:.2f}" for v in x)      # noqa: E731
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({wall:.0f} s wall, {info['date']}; `{csv_path}`). Machine: {info['cpu']}; "
             f"load average (1 / 5 / 15 min) {load(info['load_start'])} at the start, "
             f"{load(info['load_end'])} at the end (a shared machine: other work runs beside this, and the times "
             "follow its load). *Modal*: the full linear SPH projected on its Fourier modes |k| <= K "
             "(`harness/rom/modal.py`), balanced there (2m states), the model lifted back; the certified bounds "
             "are the intermediate model's plus the dropped modes' tail. *Dense*: today's O(N³) path. *exact "
             "POD*: the exact model on the scene's POD basis (its *system* time is the full SPH training run and the "
             "POD, *balancing* its operators). Times in seconds (median of the repeats): *system* builds the full LTI, *modes* projects it, *balancing* "
             "solves the Gramians of the intermediate model, *bounds* is the H∞ bisection, the initial-state "
             "energy and the tail. *Bound* columns: the largest over the velocity probes (force [s], initial "
             "state [m s⁻¹ s½]); *tail*: the dropped modes' share; *measured*: the model's L² error of the free "
             "response against the full system's, computed through all N modes; *effectivity*: initial-state "
             "bound / measured (smallest over the probes; >= 1 is the certificate holding). *rank P, Q*: the "
             "numerical ranks (eigenvalues above 1e-12 of the largest) of the two Gramians of the 2m-state "
             "system: a low-rank factor (ADI) of Q, whose point-probe outputs reach every mode, would need "
             "almost all of its states.", "",
             "| scene | N | path | 2m | rank P, Q | method | r | system | modes | balancing | bounds | total | force bound | "
             "force tail | initial bound | initial tail | measured | effectivity |",
             "| --- | ---: | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
             "---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['n']} | {r['path']} | {r['intermediate_order']} | "
                     f"{r['rank_P']}, {r['rank_Q']} | {r['method']} | "
                     f"{r['order']} | {r['t_system']:.2f} | {r['t_modal']:.2f} | {r['t_balancing']:.1f} | "
                     f"{r['t_bounds']:.1f} | {r['t_total']:.1f} | {r['force_bound']:.3e} | {r['force_tail']:.1e} | "
                     f"{r['initial_bound']:.3e} | {r['initial_tail']:.1e} | {r['measured_error']:.3e} | "
                     f"{r['effectivity']:.2f} |")
    modal_rows = [r for r in rows if r["path"] == "modal"]
    if modal_rows:
        worst = max(modal_rows, key=lambda r: r["t_total"])
        lines += ["", f"Largest offline time on the modal path: {worst['t_total']:.0f} s ({worst['scene']}, N = "
                      f"{worst['n']}); the lattice's round-off dropped from the intermediate model: at most "
                      f"{max(r['roundoff'] for r in modal_rows):.1e} of its largest entry."]
    lines += ["", f"![offline time against N]({image})", ""]
    return lines


def plot(rows, path):
    """Offline time and the initial-state bound against N, per scene and path (log-log), as PNG at ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9, 3.6))
    for key in dict.fromkeys((r["scene"], r["path"]) for r in rows):
        sel = [r for r in rows if (r["scene"], r["path"]) == key]
        n = [r["n"] for r in sel]
        ax.plot(n, [r["t_total"] for r in sel], "o-", label=f"{key[0]} {key[1]}")
        bx.plot(n, [r["initial_bound"] for r in sel], "o-", label=f"{key[0]} bound ({key[1]})")
        bx.plot(n, [r["measured_error"] for r in sel], "x--", label=f"{key[0]} measured ({key[1]})")
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel("particles N")
        a.legend(fontsize=7)
    ax.set_ylabel("offline time [s]")
    ax.set_title("balanced model + certified bounds")
    bx.set_ylabel("free-response L² error [m s⁻¹ s½]")
    bx.set_title("initial-state bound and measured error")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def main(argv=None):
    p = program_parser("scale", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="tenmode,damped_forced", help="uniform scenes, comma-separated (default "
                                                                     "%(default)s)")
    p.add_argument("--sizes", type=int_list(lo=16), default=[400, 1000, 2000, 5000, 10_000], metavar="N,...",
                   help="particle counts (default 400,1000,2000,5000,10000)")
    p.add_argument("--wavenumbers", type=int_at_least(1), default=None, metavar="K",
                   help="modes kept, |k| <= K (default sphrom.rom.modal.DEFAULT_WAVENUMBERS)")
    p.add_argument("--dense", type=int_list(lo=16), default=[], metavar="N,...",
                   help="also time the dense path at these N (of --sizes)")
    p.add_argument("--exact", action="store_true", help="the exact POD model as well (a full SPH training run at "
                                                        "each N, cached)")
    p.add_argument("--samples", type=int_at_least(3), default=4001, help="time samples of the measured error "
                                                                       "(default %(default)s)")
    p.add_argument("--repeats", type=int_at_least(1), default=1, help="repeats, the median kept (default %(default)s)")
    p.add_argument("--out", default="validation/benchmarks", help="folder for scale.csv and .png "
                                                                  "(default %(default)s)")
    p.add_argument("--report", default="BENCHMARKS.md", help="the Markdown report whose section is replaced")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    from ..rom.modal import DEFAULT_WAVENUMBERS
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    for name in scenes:
        load_scene(name)                            # a bad name: one line, before any work
    K = args.wavenumbers or DEFAULT_WAVENUMBERS
    info = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "cpu": cpu_model(),
            "load_start": load_average()}
    t0 = time.perf_counter()
    rows = []
    total = len(scenes) * (len(args.sizes) + len([n for n in args.dense if n in args.sizes]))
    with progress_bar(total=total, desc="scale", enabled=not args.quiet) as bar:
        for name in scenes:
            for n in args.sizes:
                rows += measure_one(name, n, K, args.repeats, args.samples, dense=n in args.dense,
                                    exact=args.exact, progress=bar)
    info["load_end"] = load_average()
    wall = time.perf_counter() - t0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "scale.csv"
    write_csv(csv_path, rows)
    with atomic_path(out / "scale.png") as tmp:
        plot(rows, tmp)
    command, (image, shown_csv) = program_outputs("scale", argv, args.report, out / "scale.png", csv_path)
    publish(args.report, SECTION_HEADING, section(rows, info, command, wall, shown_csv, image),
            [csv_path, out / "scale.png"], wall)
    return 0


if __name__ == "__main__":
    sys.exit(main())
