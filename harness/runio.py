"""Runs as self-describing HDF5 files, written atomically.

Layout (every solver: full SPH, reduced models, continuum references)::

    /t     (M,)    sample times                         [s]
    /x     (N,)    Lagrangian (reference) positions     [m]
    /v     (M, N)  velocity                             [m s^-1]
    /rho   (M, N)  density                              [kg m^-3]
    /steps (M,)    step index of each sample (when the solver has steps)

Each dataset has a ``units`` and a ``description`` attribute.  The root
attributes hold every scene parameter (``scene.*``: name, L, T and the field
expressions; the full TOML text in ``scene.toml``), the solver and its
settings (``solver``, ``solver.*``), the package version, the command line,
the creation time and the wall time [s].  Errors against references, when
computed, are stored as ``error.*`` attributes.

A file is written to a temporary name in the target folder and renamed at the
end, so an interrupted run leaves no half-written file.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import glob
import os
import signal
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .errors import FieldError

FORMAT = "sphrom-run"
FORMAT_VERSION = 1

UNITS = {"t": "s", "x": "m", "v": "m s^-1", "rho": "kg m^-3", "steps": "1"}
DESCRIPTIONS = {
    "t": "sample times",
    "x": "Lagrangian (reference) positions of the samples",
    "v": "velocity v(x, t)",
    "rho": "density rho(x, t)",
    "steps": "time-step index of each sample",
}


@dataclass
class Run:
    """A run read back from (or to be written to) HDF5.  Shapes as above."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    attrs: dict = field(default_factory=dict)
    steps: np.ndarray | None = None


def check_output_path(path):
    """Fail early (before any work) when ``path`` cannot be written.

    Raises FieldError ``out`` when the folder does not exist or is not
    writable, or the path is a folder.
    """
    path = Path(path)
    if path.is_dir():
        raise FieldError("out", f"'{path}' is a directory (allowed: a file path)")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise FieldError("out", f"folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK):
        raise FieldError("out", f"folder '{parent}' is not writable")
    return path


TMP_MARK = ".tmp-"


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True              # someone else's live process
    return True


def sweep_stale_temporaries(path):
    """Remove temporaries of ``path`` left by processes that no longer run.

    A run killed by SIGKILL cannot remove its temporary ``.NAME.tmp-PID``;
    the next write of the same output removes it when PID is dead (a live
    writer's temporary is left alone).  Returns the removed paths.
    """
    path = Path(path)
    prefix = f".{path.name}{TMP_MARK}"
    removed = []
    try:
        siblings = list(path.parent.glob(f"{glob.escape(prefix)}*"))
    except OSError:
        return removed
    for tmp in siblings:
        pid_text = tmp.name[len(prefix):].split("-")[0]
        if not pid_text.isdigit():
            continue
        pid = int(pid_text)
        if pid != os.getpid() and _pid_alive(pid):
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
            removed.append(tmp)
    return removed


@contextlib.contextmanager
def _deferred_signals(signums=(signal.SIGINT, signal.SIGTERM)):
    """Hold SIGINT/SIGTERM while the block runs, then deliver them to the previous handlers.

    A signal raised as an exception inside h5py or zipfile can land in a
    finaliser, where Python prints "Exception ignored" and carries on, so the
    run went on to rename its output and exit 0.  Held here, the signal is
    re-raised after the block and before the rename.  Only the main thread
    can set handlers; elsewhere nothing is held.
    """
    if threading.current_thread() is not threading.main_thread():
        yield []
        return
    caught = []
    previous = {}
    for sig in signums:
        previous[sig] = signal.getsignal(sig)
        if previous[sig] is not signal.SIG_IGN and previous[sig] is not None:
            signal.signal(sig, lambda signum, frame: caught.append(signum))
    try:
        yield caught
    finally:
        for sig, handler in previous.items():
            if handler is not signal.SIG_IGN and handler is not None:
                signal.signal(sig, handler)
    for sig in dict.fromkeys(caught):
        signal.raise_signal(sig)         # the restored handler raises (or ends the process)


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` on success.

    On any exception (including KeyboardInterrupt) the temporary file is
    removed and ``path`` is left as it was.  SIGINT and SIGTERM arriving while
    the block writes are held until it ends and then delivered before the
    rename (never swallowed).  Temporaries of ``path`` left by killed
    processes are removed first (:func:`sweep_stale_temporaries`).
    """
    path = Path(path)
    sweep_stale_temporaries(path)
    tmp = path.with_name(f".{path.name}{TMP_MARK}{os.getpid()}")
    try:
        with _deferred_signals():
            yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def scene_attrs(scene):
    """Root attributes describing a scene (``scene.*``)."""
    attrs = {
        "scene.name": scene.name,
        "scene.section": scene.section,
        "scene.source": str(scene.source),
        "scene.toml": scene.text,
        "scene.L": scene.L,
        "scene.T": scene.T,
    }
    for name, expr in scene.fields.items():
        attrs[f"scene.{name}"] = expr.text
    attrs["scene.f"] = scene.f.text
    for key, value in vars(scene.sph).items():
        attrs[f"scene.sph.{key}"] = value
    return attrs


def _clean(value):
    if value is None:
        return "none"
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (list, tuple)):
        return np.asarray(value)
    return value


def write_run(path, t, x, v, rho, attrs, steps=None, extra=None):
    """Write a run to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
    t, x, v, rho : ndarray
        See the module docstring for shapes and units.
    attrs : dict
        Root attributes (scene, solver, timings, errors); values must be
        numbers, strings or arrays of numbers.
    steps : ndarray of int, optional
    extra : dict of name -> ndarray, optional
        Additional datasets (e.g. reduced coordinates).
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    v, rho = np.asarray(v, float), np.asarray(rho, float)
    if v.shape != (t.size, x.size) or rho.shape != v.shape:
        raise ValueError(f"shapes: t {t.shape}, x {x.shape}, v {v.shape}, rho {rho.shape}")
    base = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "sphrom_version": __version__,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(sys.argv),
    }
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as h5:
            for key, value in {**base, **attrs}.items():
                h5.attrs[key] = _clean(value)
            data = {"t": t, "x": x, "v": v, "rho": rho}
            if steps is not None:
                data["steps"] = np.asarray(steps, dtype=np.int64)
            for name, arr in data.items():
                ds = h5.create_dataset(name, data=arr, compression="gzip" if arr.size > 4096 else None)
                ds.attrs["units"] = UNITS[name]
                ds.attrs["description"] = DESCRIPTIONS[name]
            for name, arr in (extra or {}).items():
                h5.create_dataset(name, data=np.asarray(arr))


def read_run(path) -> Run:
    """Read a run written by :func:`write_run`.

    Raises FieldError ``run`` when the file is missing or not a sphrom run.
    """
    path = Path(path)
    if not path.is_file():
        raise FieldError("run", f"'{path}': not found")
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != FORMAT:
                raise FieldError("run", f"'{path}': not a sphrom run file (format attribute missing)")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            steps = h5["steps"][()] if "steps" in h5 else None
            return Run(t=h5["t"][()], x=h5["x"][()], v=h5["v"][()], rho=h5["rho"][()], attrs=attrs, steps=steps)
    except OSError as exc:
        raise FieldError("run", f"'{path}': cannot be read as HDF5 ({exc})") from None
