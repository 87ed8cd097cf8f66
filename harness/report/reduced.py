"""The POD figures of a scene's report: singular values, modes, error against k,
the paper's snapshot studies and the time against error of the accelerated models."""

from __future__ import annotations

from ..bench.lib.methods import bench_python, paper_saving, plot_time_error, savings_by_k
from ..pod.pipeline import accel_modes, basis_for_scene
from ..markdown import image, num, table
from ..rom.study import PAPER_MODEL, mode_sweep, plot_sweep, snapshot_study, threshold


def plot_modes(basis, path, title, n_modes=4):
    """The first POD modes of v and ρ against x, as PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9.5, 3.2), sharex=True)
    for ax, U, label in ((axes[0], basis.U_v, "velocity"), (axes[1], basis.U_rho, "density")):
        for j in range(min(n_modes, U.shape[1])):
            ax.plot(basis.x, U[:, j], lw=1.2, label=f"mode {j + 1}")
        ax.set_xlabel("x [m]")
        ax.set_title(f"{title}: {label} modes", fontsize=9)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def pod_section(scene, reference, out_dir, stem, repeats=3, progress=True):
    """Markdown lines and a summary dict of the POD part of a scene's report.

    Parameters
    ----------
    reference : (v, rho, label)
        The reference at the SPH particles and error steps (for the SPH error line).
    repeats : int
        Timed runs per point of the time-against-error study (median).
    """
    lines = ["## POD and the reduced models", ""]
    summary = {}
    sweep = mode_sweep(scene, kmax=None, models=(PAPER_MODEL,), progress=progress, reference=reference)
    paper_k = scene.paper.get("mode_threshold")
    plot_sweep(sweep, out_dir / f"{stem}_modes_sweep.png", paper_k)
    k = threshold(sweep["rows"], sweep["sph_error"], PAPER_MODEL)
    summary["threshold"], summary["paper_threshold"] = k, paper_k
    lines += [f"Snapshots: {sweep['strategy']}. Mode threshold (smallest k from which the original POD-MOR error "
              f"against the full SPH stays below the SPH error against {sweep['reference']}, in v and in ρ − ρ0): "
              f"**{k if k else 'none within k ≤ ' + str(sweep['kmax'])}**"
              + (f"; paper: {paper_k} (ratio {k / paper_k:.2f})." if k and paper_k else "."), ""]
    lines += image(f"{out_dir.name}/{stem}_modes_sweep.png", "singular values and error against k")
    basis, _ = basis_for_scene(scene, progress=False)
    plot_modes(basis, out_dir / f"{stem}_modes.png", scene.name)
    lines += image(f"{out_dir.name}/{stem}_modes.png", "POD modes")
    rows = [r for r in sweep["rows"] if r["model"] == PAPER_MODEL]
    pick = sorted({1, 2, 4} | {r["k"] for r in rows if r["k"] % 4 == 0} | ({k} if k else set()))
    lines += table(["k", "v", "ρ − ρ0", "online [s]"],
                   [[r["k"], num(r["v"]), num(r["rho_var"]), num(r["online"], ".3f")] for r in rows if r["k"] in pick])

    studies = scene.paper.get("snapshot_studies", [])
    if studies:
        lines += ["### The paper's snapshot studies", ""]
        srows, agree = [], 0
        for i, study in enumerate(studies):
            def sweep_fn(spec, suffix, i=i):
                s = mode_sweep(scene, spec, models=(PAPER_MODEL,), progress=progress, reference=reference)
                plot_sweep(s, out_dir / f"{stem}_study{i + 1}{suffix}.png")
                return s, {PAPER_MODEL: threshold(s["rows"], s["sph_error"], PAPER_MODEL)}
            r = snapshot_study(scene, study, sweep, sweep_fn)
            agree += bool(r["agrees"])
            srows.append([r["figure"], r["snapshots"], r["paper"], r["ours"], "yes" if r["agrees"] else "**no**",
                          r["detail"]])
        lines += table(["paper figure", "snapshots", "paper", "ours", "agrees", "detail"], srows)
        summary["studies"] = (agree, len(studies))

    accel = accel_modes(scene, basis)            # a scene without rom: its automatic mode count
    if accel:
        lines += ["### Time against error of the accelerated models", ""]
        rows = bench_python(scene, ks=accel, repeats=repeats)
        plot_time_error(rows, out_dir / f"{stem}_time_error.png", scene.name)
        lines += image(f"{out_dir.name}/{stem}_time_error.png", "time against error")
        lines += table(["method", "k", "n_freeze", "online [s]", "speed-up", "v vs SPH", "ρ−ρ0 vs SPH",
                        "v vs ref", "ρ−ρ0 vs ref"],
                       [[r["method"], r["k"] or "", r["n_freeze"] or "", num(r["online_s"], ".4f"),
                         num(r["speedup"], ".1f"), num(r["err_v_sph"]), num(r["err_rho_sph"]), num(r["err_v_ref"]),
                         num(r["err_rho_ref"])] for r in rows])
        saving = paper_saving(rows, scene)
        by_k = savings_by_k(rows, scene)
        paper = scene.paper.get("cpu_saving")
        summary["saving"], summary["paper_saving"], summary["saving_by_k"] = saving, paper, by_k
        lines += [f"Online times: medians of {repeats} runs, speed-ups against the full SPH timed in the same run. "
                  "CPU saving of the frozen model (n_freeze = 10) against the full SPH: "
                  + ", ".join(f"**{100 * v:.0f} %** at k = {k}" for k, v in by_k.items())
                  + (f"; the paper: up to {100 * paper:.0f} %." if paper else ".")
                  + " Our full SPH is a compiled (numba) O(N) loop, so at N = 100 a reduced step with k ≳ 10 costs "
                    "about as much as a full step; the paper's full SPH was slower relative to its reduced models. "
                    "BENCHMARKS.md has the per-step costs against N and k.", ""]
    return lines, summary

