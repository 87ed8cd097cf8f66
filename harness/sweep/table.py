"""The result table of a study: HDF5 (one column per dataset) and CSV beside it.

Layout of RESULTS.h5::

    /results/<column>   (R,)   one dataset per column, in the order of the
                               group's ``columns`` attribute; each has
                               ``units`` and ``description`` attributes
    root attributes            format = "sphrom-sweep", format_version,
                               spec.text, spec.source, versions (sphrom,
                               dask, distributed, fmpy, numpy), scheduler,
                               workers, wall times [s], throughput [runs/s],
                               counts, complete (0 while partial), and
                               ``sessions`` (JSON: one record per session)

RESULTS.csv has the same columns and rows (full double precision).  Both (and
the summary plot RESULTS.png, when drawn) are written to temporary names and
renamed together (:func:`sphrom.runio.atomic_paths`), so an interrupted write
leaves the previous versions of all of them.  A row per entry: inputs, status (``ok`` | ``failed``) and
error, attempts, probe statistics, errors against the full SPH (nan when not
run), timings, worker.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..errors import FieldError
from ..runio import atomic_paths, h5_create

FORMAT = "sphrom-sweep"
FORMAT_VERSION = 1

# name: (kind, units, description); per-probe columns are added by columns()
BASE_COLUMNS = {
    "id": ("str", "", "entry id: hash of its inputs"),
    "index": ("int", "1", "position in the expanded grid"),
    "scene": ("str", "", "scene name"),
    "c": ("float", "kg m^-1 s^-2", "Young's modulus (nan: the scene's, non-uniform)"),
    "d": ("float", "s^-1", "damping (nan: the scene's, non-uniform)"),
    "profile": ("str", "", "force profile expression over x"),
    "k": ("int", "1", "POD modes"),
    "model": ("str", "", "reduced model: frozen or exact"),
    "fmi": ("int", "1", "FMI version"),
    "shape": ("str", "", "force shape (built-in name or expression in t, T, A, F)"),
    "amplitude": ("float", "m s^-2", "force amplitude A"),
    "frequency": ("float", "Hz", "force frequency F"),
    "n_freeze": ("int", "1", "refresh period of the frozen coefficients"),
    "t_end": ("float", "s", "horizon"),
    "step": ("float", "s", "communication step"),
    "compare_sph": ("int", "1", "1 when the full SPH was run for comparison"),
    "status": ("str", "", "ok or failed"),
    "error": ("str", "", "why the run failed (empty when ok)"),
    "attempts": ("int", "1", "times the entry was run (failed entries are retried on resume)"),
}
PROBE_COLUMNS = {
    "v_max": ("float", "m s^-1", "max |v| at probe {j} over the statistics window"),
    "v_rms": ("float", "m s^-1", "RMS of v at probe {j} over the statistics window"),
    "v_final": ("float", "m s^-1", "v at probe {j} at t_end"),
}
TAIL_COLUMNS = {
    "sph_err_v": ("float", "1", "relative L2 error (eq. 3.4) of the probe velocities against the full SPH"),
    "sph_err_rho": ("float", "1", "relative L2 error of rho - rho0 at the probes against the full SPH"),
    "fmu_wall_s": ("float", "s", "FMU reset, initialization and co-simulation loop"),
    "load_s": ("float", "s", "FMU extraction and instantiation in this task (0: cached on the worker)"),
    "sph_wall_s": ("float", "s", "full SPH run (problem reused), when compared"),
    "task_wall_s": ("float", "s", "whole task on the worker"),
    "worker": ("str", "", "dask worker name"),
    "fmu_loads": ("int", "1", "instantiations of this FMU by this worker (thread) so far"),
    "fmu": ("str", "", "key of the entry's FMU (scene variant)"),
    "started_utc": ("str", "", "when the task started"),
    "session": ("int", "1", "the session (see the sessions attribute) that produced the row"),
}


def columns(n_probes):
    """{name: (kind, units, description)} in table order for ``n_probes`` probes."""
    cols = dict(BASE_COLUMNS)
    for name, (kind, units, desc) in PROBE_COLUMNS.items():
        for j in range(1, n_probes + 1):
            cols[f"{name}_{j}"] = (kind, units, desc.format(j=j))
    cols.update(TAIL_COLUMNS)
    return cols


def _default(kind):
    return {"str": "", "int": -1, "float": float("nan")}[kind]


def _column_array(rows, name, kind):
    values = [row.get(name, _default(kind)) for row in rows]
    if kind == "str":
        return np.array(["" if v is None else str(v) for v in values], dtype=object)
    if kind == "int":
        return np.array([int(v) for v in values], dtype=np.int64)
    return np.array([float("nan") if v is None else float(v) for v in values], dtype=np.float64)


def _all_columns(rows, n_probes):
    cols = columns(n_probes)
    for row in rows:                 # rows of an earlier spec with other probes: keep their columns
        for name in row:
            if name not in cols:
                kind = "float" if isinstance(row[name], float) else ("int" if isinstance(row[name], int) else "str")
                cols[name] = (kind, "", "")
    return cols


def output_paths(path, plot=True):
    """RESULTS.h5 and the files beside it: RESULTS.csv (and RESULTS.png with ``plot``)."""
    path = Path(path)
    return [path, path.with_suffix(".csv")] + ([path.with_suffix(".png")] if plot else [])


def write_results(path, rows, attrs, n_probes, plot=None):
    """Write ``rows`` (dicts) to ``path`` (.h5) and the CSV beside it, together: both renamed, or neither.

    Parameters
    ----------
    path : Path
        RESULTS.h5; the CSV is ``path.with_suffix(".csv")``.
    rows : list of dict
    attrs : dict
        Root attributes (numbers or strings).
    n_probes : int
    plot : callable, optional
        ``plot(tmp)`` draws the summary PNG into the temporary ``tmp`` (or nothing, leaving RESULTS.png as it
        was); committed with the table.
    """
    path = Path(path)
    table = _table(rows, n_probes)
    with atomic_paths(output_paths(path, plot is not None)) as tmps:
        _write_h5(tmps[0], table, attrs)
        _write_csv(tmps[1], table)
        if plot is not None:
            plot(tmps[2])


def _table(rows, n_probes):
    """(rows sorted by index, columns, {column: array})."""
    rows = sorted(rows, key=lambda r: (r.get("index", 0), r.get("id", "")))
    cols = _all_columns(rows, n_probes)
    return rows, cols, {name: _column_array(rows, name, kind) for name, (kind, _, _) in cols.items()}


def _write_h5(tmp, table, attrs):
    rows, cols, arrays = table
    with h5_create(tmp) as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        h5.attrs["sphrom_version"] = __version__
        for key, value in attrs.items():
            h5.attrs[key] = "none" if value is None else value
        group = h5.create_group("results")
        group.attrs["columns"] = np.array(list(cols), dtype=h5py.string_dtype())
        for name, (kind, units, desc) in cols.items():
            data = arrays[name]
            if kind == "str":
                ds = group.create_dataset(name, data=data, dtype=h5py.string_dtype())
            else:
                ds = group.create_dataset(name, data=data)
            ds.attrs["units"] = units
            ds.attrs["description"] = desc


def _write_csv(tmp, table):
    rows, cols, arrays = table
    with open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(cols))
        for i in range(len(rows)):
            writer.writerow([_csv(arrays[name][i], cols[name][0]) for name in cols])


def _csv(value, kind):
    if kind == "float":
        return repr(float(value))
    if kind == "int":
        return str(int(value))
    return str(value)


def read_results(path):
    """(rows, attrs) of a RESULTS.h5 written by :func:`write_results`.

    Raises FieldError ``out`` when the file is not one.
    """
    path = Path(path)
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != FORMAT or "results" not in h5:
                raise FieldError("out", f"'{path}' exists and is not a sphrom sweep result file (allowed: a new "
                                        f"path, or the results of an earlier sweep to resume)")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            group = h5["results"]
            names = [n.decode() if isinstance(n, bytes) else str(n) for n in group.attrs["columns"]]
            data = {}
            for name in names:
                arr = group[name]
                if h5py.check_string_dtype(arr.dtype) is not None:
                    data[name] = [s.decode() if isinstance(s, bytes) else str(s) for s in arr[()]]
                else:
                    data[name] = arr[()].tolist()
    except OSError as exc:
        raise FieldError("out", f"'{path}' exists and cannot be read as HDF5 ({exc}); move it away to start "
                                f"afresh") from None
    n = len(data[names[0]]) if names else 0
    rows = [{name: data[name][i] for name in names} for i in range(n)]
    return rows, attrs


def merge(previous, new):
    """Rows of ``previous`` updated by ``new`` (by id); rows only in ``previous`` are kept."""
    out = {row["id"]: row for row in previous}
    for row in new:
        out[row["id"]] = row
    return list(out.values())


def finite(value):
    return isinstance(value, (int, float)) and math.isfinite(value)
