"""Measure the balanced reduced models against the full linear SPH and the exact POD model.

    python3 -m sphrom.bench.balanced_measure --out DIR [--sections headline,orders,forces,cost]

Sections (tables on stdout, ``balanced_orders.png`` in DIR):

headline  damped_forced at r = 12 and tenmode at r = 24 on the scene's own
          force and initial state: the probe-velocity error against the full
          linear model, both integrated exactly in time (matrix exponentials,
          the force sampled every 1 ms and linear in between), eq. 3.4 in its
          square-root form (harness/norms.py) over the probes and the samples;
          stability, skewness and the energy drift over T = 1000 s (d = f = 0).
orders    Hankel singular values and the error against the order (PNG).
forces    20 random forces from rest (10 smooth: four random sines up to
          3 Hz, linear between 10 ms samples; 10 rough: random values held
          over 10 ms): measured ‖y_err,j‖_L2(0,T) / ‖f‖_L2(0,T) per probe,
          exactly (Van Loan), against ``force_error_bound``.
cost      Offline cost of the dense Lyapunov solves at N = 400 (and larger N
          with --large), and pyMOR's low-rank ADI when pyMOR is installed.

Timings depend on the machine's load; OPENBLAS_NUM_THREADS=1 helps on a
shared 2-core machine.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..progress import progress_bar
from . import program_parser

# The measuring modules (numba through the model code, scipy, matplotlib, pymor) are imported inside the functions:
# `sphrom bench balanced_measure --help` answers before they load (tests/test_bench_programs.py).

SECTIONS = ("headline", "orders", "forces", "cost")
FORCE_STEP = 1e-3        # the scene's force: samples every 1 ms, linear between them [s]
RANDOM_STEP = 1e-2       # random forces: samples every 10 ms [s]
DEFAULT_FORCE_SCENES = ("damped_forced:12,damped_forced@shaped:12,damped@shaped:12,mild_damped_forced@shaped:12,"
                        "tenmode@shaped:24")


def pod_model(scene, problem, lti, k):
    """The exact POD model with k velocity and k specific-volume modes, as a ReducedLTI."""
    from ..pod.pipeline import basis_for_scene
    from ..rom.balanced import reduced_from_exact
    from ..rom.exact_linear import build_linear_operators
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    ops = build_linear_operators(problem, basis.U_ve[:, :k], basis.U_e[:, :k], input_direction="needed")
    return reduced_from_exact(lti, ops)


def scene_outputs(scene, lti, A, B, C, x0, h=FORCE_STEP):
    """Samples t, y (M, rows) of ẋ = A x + B f, y = C x from x0 under the scene's force (exact in time)."""
    from ..rom.lti import sample_outputs
    t = np.arange(int(round(scene.T / h)) + 1) * h
    f = scene.force(t)
    if not np.any(f):
        return t, sample_outputs(A, None, C, x0, h, np.zeros_like(t))
    return t, sample_outputs(A, B, C, x0, h, f)


def model_errors(scene, lti, red, full):
    """(v error, e error) of eq. 3.4 (square root) over the probes, against the full samples ``full``."""
    from ..norms import relative_l2
    t, y_full = full
    _, y = scene_outputs(scene, lti, red.Ar, red.Br[:, 0], red.Cr, red.x0)
    p = lti.n_probes
    return relative_l2(y[:, :p], y_full[:, :p], t), relative_l2(y[:, p:], y_full[:, p:], t)


def energy_drift(red, T=1000.0, samples=2001):
    """max |E(t) - E(0)| / E(0) of the free response over [0, T] (d = f = 0)."""
    import scipy.linalg as sla
    x = red.free_response(np.linspace(0.0, T, samples)) if red.skew else \
        np.array([sla.expm(red.Ar * t) @ red.x0 for t in np.linspace(0.0, T, samples)])
    E = 0.5 * np.sum(x * x, axis=1)
    return float(np.max(np.abs(E - E[0])) / E[0])


def _row(cells, widths):
    return "| " + " | ".join(str(c).ljust(w) for c, w in zip(cells, widths)) + " |"


def print_table(header, rows):
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(header)]
    print(_row(header, widths))
    print("| " + " | ".join("-" * w for w in widths) + " |")
    for r in rows:
        print(_row(r, widths))
    print()


# ---------------------------------------------------------------------------
def headline():
    from ..rom.balanced import balancing, truncate
    from .lib.linear_scenes import setup
    rows = []
    cases = [("damped_forced", 12, ["bt"]), ("tenmode", 24, ["galerkin", "bt_shifted"])]
    for name, r, methods in cases:
        scene, problem, lti = setup(name)
        full = scene_outputs(scene, lti, lti.dense(), lti.B[:, 0], lti.C, lti.x0)
        models = []
        for method in methods:
            t0 = time.perf_counter()
            bal = balancing(lti, method=method)
            models.append((f"balanced ({method})", truncate(lti, bal, r), time.perf_counter() - t0))
        t0 = time.perf_counter()
        pod = pod_model(scene, problem, lti, r // 2)
        models.append((f"exact POD k = {r // 2}", pod, time.perf_counter() - t0))
        for label, red, offline in models:
            ev, ee = model_errors(scene, lti, red, full)
            alpha = float(np.max(np.linalg.eigvals(red.Ar).real))
            skew = float(np.max(np.abs(red.Ar + red.Ar.T)))
            drift = energy_drift(red) if not lti.damped else float("nan")
            rows.append([name, label, red.order, f"{ev:.3e}", f"{ee:.3e}", f"{alpha:.2e}", f"{skew:.1e}",
                         "-" if np.isnan(drift) else f"{drift:.1e}", f"{offline:.2f}"])
    print("## Headline: probe errors against the full linear model (scene's own force and initial state)\n")
    print_table(["scene", "model", "r", "v error (eq. 3.4)", "e error", "max Re λ(Ar)", "max abs(Ar + Arᵀ)",
                 "energy drift T=1000", "offline [s]"], rows)


def orders(out):
    from ..norms import relative_l2
    from ..rom.balanced import balancing, truncate
    from .lib.linear_scenes import setup
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    table = []
    cases = [("damped_forced", "bt", list(range(2, 31, 2))), ("tenmode", "galerkin", list(range(4, 49, 4)))]
    for col, (name, method, rs) in enumerate(cases):
        scene, problem, lti = setup(name)
        h = 1e-2
        full = scene_outputs(scene, lti, lti.dense(), lti.B[:, 0], lti.C, lti.x0, h=h)
        bal = balancing(lti, method=method)
        ax = axes[0, col]
        ax.semilogy(np.arange(1, 61), bal.hsv[:60], "o-", ms=3)
        ax.set_title(f"{name}: Hankel singular values ({method}, σ = {bal.sigma:g})")
        ax.set_xlabel("i")
        from ..pod.pipeline import basis_for_scene
        basis, _ = basis_for_scene(scene, progress=False, problem=problem)
        available = min(basis.U_ve.shape[1], basis.U_e.shape[1])          # the POD modes of the scene's snapshots
        errs_b, errs_p, bounds = [], [], []
        with progress_bar(len(rs), f"orders {name}") as bar:
            for r in rs:
                red = truncate(lti, bal, r)
                t, y_full = full
                _, y = scene_outputs(scene, lti, red.Ar, red.Br[:, 0], red.Cr, red.x0, h=h)
                p = lti.n_probes
                errs_b.append(relative_l2(y[:, :p], y_full[:, :p], t))
                bounds.append(red.bt_bound / bal.hsv.sum() / 2)
                if r % 2 == 0 and r // 2 <= available:
                    pod = pod_model(scene, problem, lti, r // 2)
                    _, yp = scene_outputs(scene, lti, pod.Ar, pod.Br[:, 0], pod.Cr, pod.x0, h=h)
                    errs_p.append(relative_l2(yp[:, :p], y_full[:, :p], t))
                else:
                    errs_p.append(np.nan)
                table.append([name, r, f"{errs_b[-1]:.3e}", "-" if np.isnan(errs_p[-1]) else f"{errs_p[-1]:.3e}",
                              f"{red.bt_bound:.3e}"])
                bar.update(1)
        ax = axes[1, col]
        ax.semilogy(rs, errs_b, "o-", label=f"balanced ({method})")
        ax.semilogy(rs, errs_p, "s-", label="exact POD (k_v = k_e = r/2)")
        ax.set_xlabel("order r")
        ax.set_ylabel("probe-velocity error (eq. 3.4)")
        ax.set_title(f"{name}: error against the full linear model")
        ax.legend()
    fig.tight_layout()
    path = Path(out) / "balanced_orders.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print("## Error against the order (samples every 10 ms)\n")
    print_table(["scene", "r", "balanced v error", "exact POD v error", "2 Σ_{i>r} σ_i (weighted)"], table)
    print(f"figure: {path}\n")


def random_forces(rng, T, h, count=10):
    """(smooth, rough) force samples on t = 0, h, ..., T, each (K+1, count)."""
    t = np.arange(int(round(T / h)) + 1) * h
    smooth = np.zeros((t.size, count))
    for m in range(count):
        for _ in range(4):
            smooth[:, m] += rng.normal() * np.sin(2 * np.pi * rng.uniform(0, 3) * t + rng.uniform(0, 2 * np.pi))
    rough = rng.normal(size=(t.size, count))
    return smooth, rough


def measured_gains(lti, red, h, U, hold):
    """‖y_err,j‖_L2(0,T) / ‖f‖_L2(0,T) from rest, exactly, shape (P, count)."""
    import scipy.linalg as sla
    from ..rom.lti import input_norm, output_energy
    Ae = sla.block_diag(lti.dense(), red.Ar)
    be = np.concatenate([lti.B[:, 0], red.Br[:, 0]])
    Ce = np.hstack([lti.C[:lti.n_probes], -red.Cr[:lti.n_probes]])
    E = output_energy(Ae, be, Ce, np.zeros((Ae.shape[0], U.shape[1])), h, U, hold=hold)
    return np.sqrt(np.maximum(E, 0.0)) / input_norm(h, U, hold)


def forces(scenes):
    from ..rom.balanced import balancing, error_bounds, truncate
    from .lib.linear_scenes import setup
    rows = []
    rng = np.random.default_rng(2026)
    for name, r in scenes:
        scene, problem, lti = setup(name)
        smooth, rough = random_forces(rng, scene.T, RANDOM_STEP)
        bal = balancing(lti)
        for label, red in ((f"balanced ({bal.method})", truncate(lti, bal, r)),
                           (f"exact POD k = {r // 2}", pod_model(scene, problem, lti, r // 2))):
            t0 = time.perf_counter()
            b = error_bounds(lti, red)
            tb = time.perf_counter() - t0
            g = np.hstack([measured_gains(lti, red, RANDOM_STEP, smooth, "linear"),
                           measured_gains(lti, red, RANDOM_STEP, rough, "zero")])
            ratio = g / b["force_error_bound"][:, None]
            for j in range(lti.n_probes):
                rows.append([name, label, f"{lti.probes[j]:g}", f"{b['force_error_bound'][j]:.3e}",
                             f"{np.max(g[j]):.3e}", f"{np.min(ratio[j]):.3f}", f"{np.median(ratio[j]):.3f}",
                             f"{np.max(ratio[j]):.3f}", "yes" if np.all(ratio[j] <= 1) else "NO",
                             f"{b['sigma']:.3g}", f"{b['initial_state_error_bound'][j]:.3e}", f"{tb:.1f}"])
    print("## Random forces from rest: measured gain against force_error_bound (20 forces per row)\n")
    print_table(["scene", "model", "probe x/L", "bound [s]", "max measured [s]", "ratio min", "ratio median",
                 "ratio max", "holds", "σ [1/s]", "initial-state bound", "bounds time [s]"], rows)


def cost(large):
    import scipy.sparse as sp
    from ..rom.balanced import balancing
    from .lib.linear_scenes import setup
    rows = []
    sizes = [400] + ([1600] if large else [])
    for n in sizes:
        scene, problem, lti = setup("tenmode", n)
        t0 = time.perf_counter()
        bal = balancing(lti, method="galerkin")
        rows.append([n, 2 * n, "dense (scipy Bartels-Stewart), P and Q", f"{bal.timings['lyapunov']:.1f}",
                     f"{bal.timings['svd']:.1f}", f"{time.perf_counter() - t0:.1f}"])
    print("## Offline cost: Lyapunov solves of tenmode (shifted by 1/T)\n")
    print_table(["N", "2N", "method", "Lyapunov [s]", "factors + SVD [s]", "total [s]"], rows)
    try:
        import pymor  # noqa: F401
    except ImportError:
        print("pyMOR not installed: low-rank ADI skipped (pip install pymor)\n")
        return
    from pymor.operators.numpy import NumpyMatrixOperator
    from pymor.solvers.matrix_equations.adi import ADILyapunovSolver
    from pymor.solvers.matrix_equations.equations import LyapunovEquation
    rows = []
    for n in (400, 1600, 3200):
        scene, problem, lti = setup("tenmode", n)
        As = (lti.A - sp.identity(lti.order) / scene.T).tocsc()
        op = NumpyMatrixOperator(As)
        for gram, M, trans in (("P (inputs)", lti.B, False), ("Q (outputs)", lti.C.T, True)):
            rhs = op.source.from_numpy(M) if not trans else op.range.from_numpy(M)
            t0 = time.perf_counter()
            Z = LyapunovEquation(op, None, rhs, trans=trans).solve_lr(ADILyapunovSolver(adi_tol=1e-8,
                                                                                      adi_maxiter=500))
            Zn = Z.to_numpy()
            Zn = Zn if Zn.shape[0] == lti.order else Zn.T
            el = time.perf_counter() - t0
            BB = M @ M.T
            R = (As.T if trans else As) @ Zn
            res = np.linalg.norm(R @ Zn.T + Zn @ R.T + BB) / np.linalg.norm(BB)
            rows.append([n, gram, f"{el:.1f}", Zn.shape[1], f"{res:.1e}"])
    print("## pyMOR low-rank ADI (projection shifts, tol 1e-8, at most 500 steps), tenmode shifted by 1/T\n")
    print_table(["N", "Gramian", "time [s]", "rank of factor", "relative residual"], rows)


def _sections(text):
    """``headline,cost`` -> ["headline", "cost"], each one of SECTIONS (argparse names the option on failure)."""
    sections = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in sections if s not in SECTIONS]
    if bad:
        raise argparse.ArgumentTypeError(f"{bad[0]!r} is not a section (allowed: {', '.join(SECTIONS)})")
    return sections


def main(argv=None):
    ap = program_parser("balanced_measure", description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=".", help="folder for balanced_orders.png (default .)")
    ap.add_argument("--sections", type=_sections, default=list(SECTIONS),
                    help=f"comma-separated subset of {','.join(SECTIONS)} (default all)")
    ap.add_argument("--scenes", default=DEFAULT_FORCE_SCENES,
                    help=f"forces section: NAME[@shaped]:ORDER,... (default {DEFAULT_FORCE_SCENES})")
    ap.add_argument("--large", action="store_true", help="cost section: also the dense solve at N = 1600")
    args = ap.parse_args(argv)
    sections = args.sections
    Path(args.out).mkdir(parents=True, exist_ok=True)
    if "headline" in sections:
        headline()
    if "orders" in sections:
        orders(args.out)
    if "forces" in sections:
        scenes = []
        for item in args.scenes.split(","):
            name, _, r = item.partition(":")
            scenes.append((name.strip(), int(r or 12)))
        forces(scenes)
    if "cost" in sections:
        cost(args.large)


if __name__ == "__main__":
    main()
