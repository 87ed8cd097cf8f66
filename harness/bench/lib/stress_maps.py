"""The stress maps of several scenes (``sphrom stress``, the last section of BENCHMARKS.md).

For each scene: every method (and the FMUs, when they can be built here) over
Δt factors against amplitudes, long horizons, mode counts and random forces
(:mod:`sphrom.bench.lib.stress`, :mod:`sphrom.bench.lib.stress_fmu`); a heat map per
scene and four CSV files into the output folder; their Markdown (:func:`stress_section`): the page stress.md and
the last section of BENCHMARKS.md.
"""

from __future__ import annotations

import dataclasses
import time

from ...fmu.make.build import ensure_binaries
from ...progress import progress_bar
from . import stress as st
from .stress_fmu import FMUStress, stress_runners
from .stress_settings import HORIZON_METHODS, SHORT_HORIZON, SHORT_HORIZON_METHODS
from .tables import write_csv


@dataclasses.dataclass
class StressMaps:
    """What :func:`stress_maps` measured.

    scenes : list of dict
        Per scene: name, T [s], dt (the paper's Δt) [s], dt_limit (Δt*) [s], k, fmu (bool: FMU columns),
        and the rows ``map``, ``horizons``, ``modes``, ``forces``.
    amplitudes : list
        The amplitude factors (the first is the one of the "stable up to" table).
    wall : float
        Wall time [s] of the whole study.
    """

    scenes: list
    amplitudes: list
    wall: float


def fmu_stress(fmu=True, log=print):
    """An FMUStress (the FMU columns), or None without ``fmu`` or when the FMU cannot be built here."""
    if not fmu:
        return None
    try:
        ensure_binaries(quiet=True)
    except Exception as exc:               # no compiler or cmake: say so, keep the Python columns
        log(f"stress: the FMU columns are skipped ({exc})")
        return None
    return FMUStress()


def stress_maps(scenes, amplitudes, horizons, ks, dt_factors, out, fmu=True, progress=True):
    """Run the stress maps of ``scenes``; heat maps (PNG) and CSV files into ``out`` (created).

    Parameters
    ----------
    scenes : list of Scene
    amplitudes : list of float
        Initial-amplitude factors.
    horizons : list of float
        Horizons T [s] at the paper's Δt.
    ks : list of int
        Mode counts of the k sweep.
    dt_factors : list of float
        Δt in units of the explicit limit Δt*.
    fmu : bool
        Add the FMU columns when the FMU can be built here.
    progress : bool
        Progress bars.

    Returns
    -------
    StressMaps
    """
    out.mkdir(parents=True, exist_ok=True)
    runner = fmu_stress(fmu)
    try:
        return _measure(scenes, amplitudes, horizons, ks, dt_factors, out, runner, progress)
    finally:
        if runner is not None:
            runner.close()


def _measure(scenes, amps, horizons, ks, factors, out, fmu, progress):
    extra = None
    if fmu is not None:
        extra = stress_runners(fmu)
    started = time.perf_counter()
    results = []
    for scene in scenes:
        ctx = st.context(scene)
        methods = list(st.METHODS) + list(extra or {})
        total = len(methods) * (len(factors) + 1) * len(amps) + len(methods) * len(horizons)
        with progress_bar(total=total, desc=f"stress {scene.name}", enabled=progress) as bar:
            rows = st.dt_amplitude_map(ctx, dt_factors=factors, amplitudes=amps, progress=bar, extra=extra)
            hor = st.horizon_rows(ctx, methods=HORIZON_METHODS, horizons=horizons, progress=bar, extra=extra)
            hor += st.horizon_rows(ctx, methods=SHORT_HORIZON_METHODS,
                                   horizons=[h for h in horizons if h <= SHORT_HORIZON], progress=bar)
        krows = st.modes_rows(ctx, ks=ks)
        frows = st.force_rows(ctx, extra={k: v for k, v in (extra or {}).items()})
        st.plot_map(rows, out / f"{scene.name}_stress.png", scene.name, ctx.dt_limit)
        results.append({"name": scene.name, "T": scene.T, "dt": scene.sph.dt, "dt_limit": ctx.dt_limit, "k": ctx.k,
                        "fmu": bool(extra), "map": rows, "horizons": hor, "modes": krows, "forces": frows})
    for name in ("map", "horizons", "modes", "forces"):
        write_csv(out / f"stress_{name}.csv", [r for s in results for r in s[name]])
    return StressMaps(results, list(amps), time.perf_counter() - started)


def stress_report(scenes, amps, horizons, ks, factors, out, no_fmu=False, quick=False, command=None, progress=True,
                  image_dir=""):
    """Run the stress maps of ``scenes`` (CSV and PNG into ``out``); return (Markdown page, wall time [s]).

    ``command`` is the command line quoted in the text (default the ``sphrom stress`` one); ``image_dir``
    the heat maps' folder as seen from the page ('' when the page sits in ``out``).
    """
    maps = stress_maps(scenes, amps, horizons, ks, factors, out, fmu=not no_fmu, progress=progress)
    command = command or (f"sphrom stress {' '.join(s.name for s in scenes)}" + (" --quick" if quick else ""))
    return "\n".join(stress_section(maps, command, image_dir, level=1)) + "\n", maps.wall


def stress_section(maps, command, image_dir="", level=1):
    """The stability stress maps (:class:`sphrom.bench.lib.stress_maps.StressMaps`) as Markdown lines.

    ``level`` 1 gives a page of its own (``stress.md``), 2 the section of BENCHMARKS.md; ``image_dir`` is
    the heat maps' folder as seen from the page ('' when they sit beside it).
    """
    h = "#" * level
    prefix = f"{image_dir.rstrip('/')}/" if image_dir else ""
    lines = [f"{h} Stability stress maps", "",
             f"Produced by `{command}`. Outcomes: stable (energy never above 1.1× its start), growing, "
             "unphysical (ρ ≤ 0 / J ≤ 0 reached: compression beyond the physical limit), blow-up (the method's "
             "own check fired: non-finite, non-positive density, runaway; the FMU returns an error status). "
             "Δt* = 2/ω_max is the explicit limit of the full SPH operator (ω_max Δt < 2 for the Euler schemes, 2√2 for RK4). "
             "Reduced models use the basis of the paper-setting run and start from the amplified state. "
             f"Wall time {maps.wall:.0f} s.", ""]
    for s in maps.scenes:
        lines += _stress_scene(s, maps.amplitudes[0], h + "#", prefix)
    return lines


def _stress_scene(s, amplitude, h, prefix):
    rows, hor, krows, frows = s["map"], s["horizons"], s["modes"], s["forces"]
    lines = [f"{h} {s['name']}", "",
             f"Explicit limit Δt* = {s['dt_limit']:.4g} s; the paper's Δt = {s['dt']:g} s "
             f"= {s['dt'] / s['dt_limit']:.3g} Δt*; k = {s['k']}.", "",
             f"![stress map]({prefix}{s['name']}_stress.png)", "",
             f"Largest Δt (in Δt*) at which each method stays finite and physical at amplitude ×1 over T = "
             f"{s['T']:g} s:", "", "| method | stable up to | first failure |", "| --- | --- | --- |"]
    for method in dict.fromkeys(r["method"] for r in rows):
        ok = [r for r in rows if r["method"] == method and r["amplitude"] == amplitude and r["dt_factor"] != "paper"]
        good = [r["dt_factor"] for r in ok if r["outcome"] in ("stable", "growing")]
        bad = [r for r in ok if r["outcome"] in ("blow-up", "unphysical")]
        first = (f"{bad[0]['outcome']} at Δt = {bad[0]['dt_factor']} Δt*, t = {bad[0]['blowup_time']:.3g} s"
                 if bad and bad[0]["blowup_time"] is not None else (bad[0]["outcome"] if bad else "none"))
        lines.append(f"| {method} | {max(good) if good else '—'} | {first} |")
    if s["fmu"]:
        fmu_rows = [r for r in rows + hor + frows if str(r["method"]).startswith("FMU")]
        errors = [r for r in fmu_rows if r.get("fmu_error")]
        silent = sum(int(r.get("silent_nan", 0)) for r in fmu_rows)
        lines += ["", f"The FMU (FMI 2 through fmpy, the same operators and internal grid): {len(fmu_rows)} runs, "
                      f"{len(errors)} ended with an error status whose message names the time"
                      + (f" (e.g. “{errors[0]['fmu_error'][:160]}”)" if errors else "")
                      + f"; non-finite outputs without an error status: **{silent}**."]
    lines += ["", "Long horizons at the paper's Δt (amplitude ×1):", "",
              "| method | T | outcome | blow-up time | max E/E0 |", "| --- | --- | --- | --- | --- |"]
    for r in hor:
        bt = "" if r["blowup_time"] is None else f"{r['blowup_time']:.4g} s"
        lines.append(f"| {r['method']} | {r['T']:g} | {r['outcome']} | {bt} | {r['energy_growth']:.4g} |")
    lines += ["", "Mode count (paper's Δt, amplitude ×1):", "", "| method | k | outcome | max E/E0 |",
              "| --- | --- | --- | --- |"]
    for r in krows:
        lines.append(f"| {r['method']} | {r['k']} | {r['outcome']} | {r['energy_growth']:.4g} |")
    lines += ["", "Random piecewise-constant forces (held 0.05 s): final energy against the exact-in-time reduced "
              "model:", "", "| force amplitude [m/s²] | method | outcome | E_end / E_end(exact) − 1 |",
              "| --- | --- | --- | --- |"]
    for r in frows:
        lines.append(f"| {r['force_amplitude']:g} | {r['method']} | {r['outcome']} | {r['energy_vs_exact']:.3g} |")
    return lines + [""]
