"""One FMU per scene variant of a study, packaged on the client and cached on disk.

A variant is (scene text, c, d, profile, k, model, fmi, probes): a new
material or force profile is a new scene, so it gets its own full SPH
training run and POD basis (both cached by :mod:`sphrom.cache` and the
pipeline) and its own FMU.  The FMU is kept as
``$SPHROM_CACHE/sweep/fmu-<key>.fmu``; the key hashes the variant, the sphrom
version and the binaries' build key (a change of the C sources makes new
FMUs).  Forces and n_freeze change per run on the same FMU.  Entries with
parametric ranges (by default the grid's [min, max] of c and d when they
vary, or a ``[parametric]`` table; :mod:`sphrom.sweep.spec`) share ONE
parametric FMU (:mod:`sphrom.fmu.make.parametric`: trained at the corners and
centre of the ranges), and each run sets c and d as FMU parameters.

Packaging happens on the client, before any task: it needs CMake once (the
binaries) and the full SPH runs, which are heavier than a task and cached
here; the workers receive the FMU's bytes (scattered once per FMU), so a
remote cluster needs no shared file system.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from ..cache import cache_dir
from ..fmu.make.build import build_key, ensure_binaries
from ..fmu.make.package import package_fmu


@dataclass
class Variant:
    """A packaged FMU of the study.

    Attributes
    ----------
    key : str
        16 hex digits (file name and worker-cache key).
    path : Path
        The cached .fmu.
    scene_text : str
        TOML of the variant scene (for the full SPH comparison on the workers).
    probes : tuple of float
    reused : bool
        Found in the cache.
    wall_time : float
        Packaging wall time [s] (0 when reused).
    """

    key: str
    path: Path
    scene_text: str
    probes: tuple
    reused: bool
    wall_time: float


def sweep_dir() -> Path:
    path = cache_dir() / "sweep"
    path.mkdir(parents=True, exist_ok=True)
    return path


def variant_key(entry, binaries_key):
    """Hash of what makes the FMU of ``entry`` (16 hex digits)."""
    inputs = {"variant": list(entry.variant_inputs()), "sphrom": __version__, "binaries": binaries_key}
    return hashlib.sha256(json.dumps(inputs, sort_keys=True, default=str).encode()).hexdigest()[:16]


def ensure_fmus(spec, entries, progress=True, log=None):
    """The FMU of every variant ``entries`` use: {variant_inputs: Variant}.

    Packages (with :func:`sphrom.fmu.make.package.package_fmu`) the ones not in
    the cache.  ``log(text)`` is told about each packaging.

    Raises
    ------
    UserError
        A variant that cannot be packaged (e.g. k above the POD modes).
    """
    binaries = None
    key_b = build_key()
    out = {}
    for entry in entries:
        vin = entry.variant_inputs()
        if vin in out:
            continue
        vary = []
        if entry.parametric:             # one FMU over the ranges: c, d set per run
            from ..rom.parametric import Range
            from .spec import variant_scene
            names = {p[0] for p in entry.parametric}
            scene = variant_scene(spec.scene, None if "c" in names else entry.c, None if "d" in names else entry.d,
                                  entry.profile)
            vary = [Range(*p) for p in entry.parametric]
        else:
            scene = spec.variants[(entry.c, entry.d, entry.profile)]
        key = variant_key(entry, key_b)
        path = sweep_dir() / f"fmu-{key}.fmu"
        reused = path.is_file()
        t0 = time.perf_counter()
        if not reused:
            if log:
                if vary:
                    log(f"packaging the parametric FMU of {scene.name} ("
                        + ", ".join(f"{r.name} in [{r.lo:g}, {r.hi:g}]" for r in vary)
                        + f", k = {entry.k}, {entry.model}) ...")
                else:
                    log(f"packaging the FMU of {scene.name} (c = {entry.c if entry.c is not None else 'scene'}, "
                        f"d = {entry.d if entry.d is not None else 'scene'}, k = {entry.k}, {entry.model}) ...")
            binaries = binaries or ensure_binaries(quiet=not progress)
            package_fmu(scene, path, k=entry.k, probes=entry.probes, fmi=entry.fmi, model=entry.model,
                        progress=progress, binaries=binaries, vary=vary)
        out[vin] = Variant(key=key, path=path, scene_text=scene.text, probes=entry.probes, reused=reused,
                           wall_time=0.0 if reused else time.perf_counter() - t0)
    return out


def bundle(variant):
    """What a worker needs of a variant (scattered once): key, FMU bytes, scene text."""
    return {"key": variant.key, "fmu": variant.path.read_bytes(), "scene_text": variant.scene_text}
