"""Every benchmark of ``sphrom bench`` in one run: what BENCHMARKS.md reports.

:func:`run_benchmarks` measures (run time against error per scene, cost
against N and k, skipped terms, the force direction, the full SPH step, the
FMU, optionally the stress maps), writes the CSV and PNG files into one
folder and returns a :class:`BenchResults`; :func:`sphrom.measure.markdown.report`
turns that into the Markdown.  Times are medians of ``repeats`` runs, ratios
are taken within the run.
"""

from __future__ import annotations

import csv
import dataclasses
import platform
import time
from pathlib import Path

from .lib.tables import write_csv

DEFAULT_SCENES = ("tenmode", "damped", "damped_forced", "heterogeneous", "mild_damped_forced")
SIZES = (100, 400, 1600, 6400, 10000)          # N of the cost-against-N table
KS_SCALING = (4, 8, 12, 20, 40)                # the k sweep of the cost table (N = 400)
SPH_SIZES = (100, 400, 10000, 100000)          # N of the full-SPH step table (as sphrom bench-sph)
SPH_INTEGRATORS = ("euler", "symplectic", "rk4")
SKIP_SCENES = 2                                # the skipped-terms table uses the first scenes only
BENCH_FIELDS = ["scene", "method", "k", "n_freeze", "online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph",
                "err_v_ref", "err_rho_ref", "note"]
COST_FIELDS = ["method", "n", "k", "us_per_step"]


@dataclasses.dataclass
class BenchResults:
    """What :func:`run_benchmarks` measured (rows are lists of dicts, as in the CSV files)."""

    command: str                  # the command line quoted in the report
    version: str
    python: str
    machine: str
    repeats: int
    scene_names: list
    rows: list                    # run time against error, every scene (bench.csv)
    savings: list                 # (scene, {k: saving of the frozen model}, the paper's saving or None)
    sizes: list
    scaling: list                 # cost against N (scaling.csv)
    ks_scaling: list
    scaling_k: list               # cost against k (scaling_k.csv)
    skips: list                   # skip.csv
    directions: list              # input_direction.csv
    input_tolerance: float
    sph_sizes: list
    sph_steps: list               # sph_scaling.csv
    fmu: dict | None = None       # sphrom.bench.lib.fmu.fmu_measurements, None without the FMU
    stress: object = None         # sphrom.bench.lib.stress_maps.StressMaps, None without the maps
    stress_command: str = ""
    wall: float = 0.0             # [s]
    packaged: list | None = None  # rows of sphrom.bench.fmu_verify (python -m sphrom.bench.fmu_verify), or None
    packaged_meta: dict | None = None   # its command, repeats, wall, machine


def run_benchmarks(scenes, out, *, ks=None, repeats=5, sizes=SIZES, ks_scaling=KS_SCALING, sph_sizes=SPH_SIZES,
                   fmu=True, fmu_scene="tenmode", stress=False, progress=True):
    """Run every benchmark on ``scenes``; CSV and PNG files into ``out`` (created).

    Parameters
    ----------
    scenes : list of Scene
    out : Path
        Folder for bench.csv, scaling.csv, scaling_k.csv, skip.csv, input_direction.csv, sph_scaling.csv,
        fmu_core.csv, fmu_e2e.csv, the plots and (``stress``) ``stress/``.
    ks : list of int, optional
        Mode counts (default each scene's acceleration-study k).
    repeats : int
        Timed runs per point (median).
    sizes, ks_scaling, sph_sizes : list of int
        N of the cost table, k of the cost table at N = 400, N of the full-SPH step table.
    fmu : bool
        The FMU rows and tables (needs a compiler and CMake).
    fmu_scene : str
        Scene of the FMU's end-to-end table.
    stress : bool
        Also the stress maps of :data:`sphrom.bench.lib.stress_settings.DEFAULT_SCENES`.
    progress : bool
        Progress bars.

    Returns
    -------
    BenchResults
    """
    from .. import __version__
    from ..progress import progress_bar
    from ..rom.operators import INPUT_TOLERANCE
    from ..scene import load_scene
    from .lib.input_direction import input_direction_rows
    from .lib.methods import bench_python, plot_time_error, savings_by_k
    from .lib.scaling import per_step_costs, plot_costs
    from .lib.skip import skip_savings
    from .lib.sph_scaling import scaling_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    extra = None
    if fmu:
        from .lib.fmu import bench_rows as extra
    all_rows, savings = [], []
    total = sum(1 + len(ks or s.rom.get("accel_modes", [1])) * 9 for s in scenes)
    with progress_bar(total=total, desc="bench", enabled=progress) as bar:
        for scene in scenes:
            rows = bench_python(scene, ks=ks, repeats=repeats, progress=bar, extra=extra)
            all_rows += rows
            plot_time_error(rows, out / f"{scene.name}_time_error.png", scene.name)
            savings.append((scene.name, savings_by_k(rows, scene), scene.paper.get("cpu_saving")))
    with progress_bar(total=len(sizes), desc="scaling", enabled=progress) as bar:
        scaling = per_step_costs(sizes=sizes, repeats=repeats, progress=bar)
    plot_costs(scaling, out / "scaling_n.png")
    with progress_bar(total=1, desc="scaling in k", enabled=progress) as bar:
        scaling_k = per_step_costs(sizes=[400], ks=ks_scaling, repeats=repeats, progress=bar)
    plot_costs(scaling_k, out / "scaling_k.png", key="k")
    skips = []
    for scene in scenes[:SKIP_SCENES]:
        skips += skip_savings(scene, repeats=repeats, fmu=fmu)
    directions = []
    for scene in scenes:
        directions += input_direction_rows(scene)
    with progress_bar(total=len(sph_sizes) * len(SPH_INTEGRATORS), desc="full SPH step", enabled=progress) as bar:
        sph_steps = scaling_table("tenmode", sph_sizes, SPH_INTEGRATORS, repeats, bar)
    write_csv(out / "sph_scaling.csv", sph_steps)
    fmu_results = None
    if fmu:
        from .lib.fmu import fmu_measurements, write_fmu_csv
        fmu_results = fmu_measurements(fmu_scene, repeats=max(5, repeats), progress=progress)
        write_fmu_csv(out, fmu_results["core"], fmu_results["e2e"], prefix="fmu_")
    maps, stress_command = None, ""
    if stress:
        from .lib.document import stress_section
        from .lib.stress_maps import stress_maps
        from .lib.stress_settings import AMPLITUDES, DT_FACTORS, HORIZONS, MODE_COUNTS
        from .lib.stress_settings import DEFAULT_SCENES as STRESS_SCENES
        from ..markdown import write_text
        stress_command = "sphrom bench --report (the stress maps of sphrom stress)"
        maps = stress_maps([load_scene(s) for s in STRESS_SCENES], list(AMPLITUDES), list(HORIZONS),
                           list(MODE_COUNTS), DT_FACTORS, out / "stress", fmu=fmu, progress=progress)
        write_text(out / "stress" / "stress.md", "\n".join(stress_section(maps, stress_command, "", level=1)) + "\n")
    wall = time.perf_counter() - started
    write_csv(out / "bench.csv", all_rows, BENCH_FIELDS)
    write_csv(out / "scaling.csv", scaling, COST_FIELDS)
    write_csv(out / "scaling_k.csv", scaling_k, COST_FIELDS)
    write_csv(out / "skip.csv", skips)
    if directions:
        write_csv(out / "input_direction.csv", directions)
    return BenchResults(
        command="sphrom bench " + " ".join(s.name for s in scenes) + f" --repeats {repeats} --report",
        version=__version__, python=platform.python_version(), machine=platform.machine(), repeats=repeats,
        scene_names=[s.name for s in scenes], rows=all_rows, savings=savings, sizes=list(sizes), scaling=scaling,
        ks_scaling=list(ks_scaling), scaling_k=scaling_k, skips=skips, directions=directions,
        input_tolerance=INPUT_TOLERANCE, sph_sizes=list(sph_sizes), sph_steps=sph_steps, fmu=fmu_results,
        stress=maps, stress_command=stress_command, wall=wall)


def read_bench_csv(path):
    """The rows of a bench.csv written by :func:`run_benchmarks` (numbers parsed, NaN for empty)."""
    rows = []
    with open(path) as fh:
        for r in csv.DictReader(fh):
            for key in ("online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph", "err_v_ref", "err_rho_ref"):
                r[key] = float(r[key]) if r[key] not in ("", "nan") else float("nan")
            r["k"] = int(r["k"]) if r["k"] else None
            r["n_freeze"] = int(r["n_freeze"]) if r["n_freeze"] else None
            rows.append(r)
    return rows


def replot(out):
    """Redraw ``out``/<scene>_time_error.png from ``out``/bench.csv (the measured rows, unchanged).

    Returns the scene names redrawn.
    """
    from .lib.methods import plot_time_error
    out = Path(out)
    rows = read_bench_csv(out / "bench.csv")
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    for scene in scenes:
        plot_time_error([r for r in rows if r["scene"] == scene], out / f"{scene}_time_error.png", scene)
    return scenes
