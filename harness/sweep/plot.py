"""The summary PNG of a study.

When both the force frequency and the damping d vary, a response surface: the
probe amplitude max |v| (over the statistics window) against F and d, one
panel per force shape, at the largest amplitude and the first value of every
other varying input (the title says which).  Otherwise a scatter of the
probe amplitude against the input with the most values.  With full SPH
comparisons, a panel of their relative L2 errors beside it.  Failed entries
are marked with a red x.
"""

from __future__ import annotations

import numpy as np

from ..runio import atomic_path
from .table import finite

NUMERIC = ("frequency", "d", "amplitude", "c", "n_freeze", "k")
OTHERS = ("amplitude", "c", "profile", "k", "model", "n_freeze")


def _distinct(rows, name):
    return sorted({r[name] for r in rows if r.get(name) is not None and not (isinstance(r[name], float)
                                                                              and np.isnan(r[name]))})


def _log_axis(values):
    v = np.asarray([x for x in values if x > 0])
    return v.size == len(values) and v.size > 2 and v.max() / v.min() > 20


def summary_plot(rows, path, probe=1, title="", atomic=True):
    """Write the summary PNG of ``rows`` (table dicts) to ``path`` (atomically unless ``atomic`` is False:
    ``path`` is then a temporary of :func:`sphrom.runio.atomic_paths`); returns its kind.

    Returns ``"surface"``, ``"scatter"`` or ``None`` (no row to plot, nothing written).
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not rows:
        return None
    col = f"v_max_{probe}"
    freqs, ds = _distinct(rows, "frequency"), _distinct(rows, "d")
    sph = [r for r in rows if finite(r.get("sph_err_v", float("nan")))]
    surface = len(freqs) >= 2 and len(ds) >= 2
    shapes = _distinct(rows, "shape")[:4] if surface else [None]
    panels = len(shapes) + (1 if sph else 0)
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.4), squeeze=False)
    axes = axes[0]
    if surface:
        amps = _distinct(rows, "amplitude")
        fixed = {"amplitude": max(amps, key=abs)} if amps else {}
        for name in OTHERS:
            if name != "amplitude":
                values = _distinct(rows, name)
                if len(values) > 1:
                    fixed[name] = values[0]
        where = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in fixed.items())
        for ax, shape in zip(axes, shapes):
            sel = [r for r in rows if r["shape"] == shape and all(r.get(k) == v for k, v in fixed.items())]
            z = np.full((len(ds), len(freqs)), np.nan)
            failed = []
            for r in sel:
                i, j = ds.index(r["d"]), freqs.index(r["frequency"])
                if r["status"] == "ok":
                    z[i, j] = r.get(col, np.nan)
                else:
                    failed.append((r["frequency"], r["d"]))
            mesh = ax.pcolormesh(freqs, ds, np.ma.masked_invalid(z), shading="nearest", cmap="viridis")
            fig.colorbar(mesh, ax=ax, label=f"max |v| at probe {probe} [m/s]")
            if failed:
                fx, fy = zip(*failed)
                ax.plot(fx, fy, "x", color="red", ms=8, label="failed")
                ax.legend(loc="upper right", fontsize=8)
            if _log_axis(freqs):
                ax.set_xscale("log")
            if _log_axis(ds):
                ax.set_yscale("log")
            ax.set_xlabel("force frequency F [Hz]")
            ax.set_ylabel("damping d [1/s]")
            ax.set_title(f"shape {shape}" + (f"\n({where})" if where else ""), fontsize=9)
        kind = "surface"
    else:
        ax = axes[0]
        candidates = [(len(_distinct(rows, n)), n) for n in NUMERIC]
        n_values, xname = max(candidates)
        for status, style in (("ok", dict(marker="o", color="C0", ls="none", ms=4)),
                              ("failed", dict(marker="x", color="red", ls="none", ms=7))):
            sel = [r for r in rows if r["status"] == status]
            if sel:
                y = [r.get(col, np.nan) if status == "ok" else 0.0 for r in sel]
                ax.plot([r[xname] for r in sel], y, label=f"{status} ({len(sel)})", **style)
        if _log_axis(_distinct(rows, xname)):
            ax.set_xscale("log")
        ax.set_xlabel(xname)
        ax.set_ylabel(f"max |v| at probe {probe} [m/s]")
        ax.legend(fontsize=8)
        kind = "scatter"
    if sph:
        ax = axes[-1]
        x = "frequency" if len(freqs) >= 2 else max((len(_distinct(sph, n)), n) for n in NUMERIC)[1]
        for i, d in enumerate(_distinct(sph, "d") or [None]):
            sel = [r for r in sph if d is None or r["d"] == d]
            ax.plot([r[x] for r in sel], [r["sph_err_v"] for r in sel], "o", ms=4, color=f"C{i % 10}",
                    label=f"d = {d:g}" if d is not None else None)
        ax.set_yscale("log")
        if _log_axis(_distinct(sph, x)):
            ax.set_xscale("log")
        ax.set_xlabel(x)
        ax.set_ylabel("relative L2 error of v at the probes")
        ax.set_title(f"FMU against the full SPH ({len(sph)} runs)", fontsize=9)
        if len(_distinct(sph, "d")) > 1:
            ax.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    if atomic:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    else:
        fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
    return kind
