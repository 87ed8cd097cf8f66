"""A cache of full SPH runs, so that POD, reduced-model and FMU commands reuse them.

Runs are keyed by the scene's physics and SPH settings (the TOML text, the
settings and T); a run is stored with the samples it was asked for, and a
later request for more samples reruns once with the union.  The folder is
``$SPHROM_CACHE`` or ``~/.cache/sphrom``; deleting it is always safe.
"""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .runio import atomic_path, h5_create


def cache_dir() -> Path:
    path = Path(os.environ.get("SPHROM_CACHE", Path.home() / ".cache" / "sphrom"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def run_key(scene):
    text = f"{__version__}\n{scene.text}\n{scene.sph}\n{scene.T!r}"
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def run_file_name(scene):
    """``sph-<name>-<key>.h5``: the key (:func:`run_key`) decides which run it is; the name, for people reading
    the folder, keeps only the characters a scene name may have (A-Z a-z 0-9 _ . -, sphrom.scene_schema), each
    other character replaced by ``_`` and a leading ``.`` too, so that no name reaches outside the folder."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", str(scene.name))[:64]
    if name.startswith("."):
        name = "_" + name[1:]
    return f"sph-{name}-{run_key(scene)}.h5"


@dataclass
class CachedRun:
    """A full SPH run: samples at ``steps`` (t = steps * dt)."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    steps: np.ndarray
    wall_time: float     # of the SPH time loop when it ran [s]
    reused: bool
    problem: object


def cached_sph(scene, sample_steps, progress=True, problem=None):
    """The full SPH run of ``scene`` with at least ``sample_steps`` stored.

    Returns a CachedRun whose samples include every requested step (and maybe
    more from earlier requests).
    """
    from .sph.solver import build_problem, run_sph
    problem = problem or build_problem(scene)
    want = np.unique(np.asarray(sample_steps, dtype=np.int64))
    path = cache_dir() / run_file_name(scene)
    have = None
    if path.exists():
        try:
            with h5py.File(path, "r") as h5:
                have = h5["steps"][()]
                if np.all(np.isin(want, have)):
                    return CachedRun(t=h5["t"][()], x=h5["x"][()], v=h5["v"][()], rho=h5["rho"][()], steps=have,
                                     wall_time=float(h5.attrs["wall_time_s"]), reused=True, problem=problem)
        except (OSError, KeyError):
            have = None          # a damaged cache file is simply rebuilt
    steps = want if have is None else np.union1d(want, have)
    result = run_sph(scene, sample_steps=steps, progress=progress, problem=problem)
    with atomic_path(path) as tmp:
        with h5_create(tmp) as h5:
            for name in ("t", "x", "v", "rho", "steps"):
                h5.create_dataset(name, data=getattr(result, name))
            h5.attrs["wall_time_s"] = result.wall_time
            h5.attrs["scene.toml"] = scene.text
    return CachedRun(t=result.t, x=result.x, v=result.v, rho=result.rho, steps=result.steps,
                     wall_time=result.wall_time, reused=False, problem=problem)
