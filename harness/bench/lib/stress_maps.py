"""The stress maps of several scenes (``sphrom stress``, the last section of BENCHMARKS.md).

For each scene: every method (and the FMUs, when they can be built here) over
Δt factors against amplitudes, long horizons, mode counts and random forces
(:mod:`sphrom.bench.lib.stress`, :mod:`sphrom.bench.lib.stress_fmu`); a heat map per
scene and four CSV files into the output folder.  The Markdown is
:func:`sphrom.measure.markdown.stress_section`.
"""

from __future__ import annotations

import dataclasses
import time

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
        from ...fmu.make.build import ensure_binaries
        from .stress_fmu import FMUStress
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
    from ...progress import progress_bar
    from . import stress as st

    extra = None
    if fmu is not None:
        from .stress_fmu import stress_runners
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
    from .document import stress_section
    maps = stress_maps(scenes, amps, horizons, ks, factors, out, fmu=not no_fmu, progress=progress)
    command = command or (f"sphrom stress {' '.join(s.name for s in scenes)}" + (" --quick" if quick else ""))
    return "\n".join(stress_section(maps, command, image_dir, level=1)) + "\n", maps.wall
