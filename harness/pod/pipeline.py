"""From a scene to a POD basis: the full SPH run (cached) and the SVD."""

from __future__ import annotations

import numpy as np

from ..cache import cached_sph
from ..sph.solver import build_problem, default_sample_steps, step_count
from .automatic import automatic_modes
from .basis import build_basis
from .snapshots import describe, snapshot_steps


def error_steps(scene):
    """The steps at which errors are measured: every ``sph.every`` and the last."""
    return default_sample_steps(step_count(scene.T, scene.sph.dt), scene.sph.every)


def training_steps(scene, spec=None):
    """The steps :func:`basis_for_scene` asks the cached full SPH run for: the error steps and, unless the
    strategy takes every stored sample, the snapshot steps of ``spec`` (default the scene's)."""
    spec = dict(scene.snapshots if spec is None else spec)
    steps = error_steps(scene)
    if spec.get("all"):
        return steps
    n = step_count(scene.T, scene.sph.dt)
    sv, sr = snapshot_steps(spec, scene.sph.dt, n, n_particles=scene.sph.n_particles)
    return np.union1d(steps, np.union1d(sv, sr))


def basis_for_scene(scene, spec=None, progress=True, problem=None, extra_steps=()):
    """POD basis of ``scene`` for the snapshot strategy ``spec`` (default the scene's).

    Returns (basis, run): the run is the cached full SPH solution, with samples
    at the error steps and at the snapshot steps (and at ``extra_steps``, e.g. the
    communication points a verification reads: stored by the same run).
    """
    spec = dict(scene.snapshots if spec is None else spec)
    problem = problem or build_problem(scene)
    n = step_count(scene.T, scene.sph.dt)
    steps = error_steps(scene)
    if not spec.get("all"):
        sv, sr = snapshot_steps(spec, scene.sph.dt, n, n_particles=scene.sph.n_particles)
        run = cached_sph(scene, np.union1d(training_steps(scene, spec), np.asarray(extra_steps, np.int64)),
                         progress=progress, problem=problem)
    else:
        run = cached_sph(scene, np.union1d(steps, np.asarray(extra_steps, np.int64)), progress=progress,
                         problem=problem)
        sv, sr = snapshot_steps(spec, scene.sph.dt, n, stored_steps=run.steps)
    basis = build_basis(run.v, run.rho, run.steps, sv, sr, run.x, scene.sph.dt, scene.text, describe(spec),
                        weights=(problem.rho0, problem.c))
    basis.timings["sph"] = 0.0 if run.reused else run.wall_time
    return basis, run


def on_steps(run, steps):
    """(v, rho) of a cached run at ``steps`` (all must be stored)."""
    index = np.searchsorted(run.steps, steps)
    if np.any(run.steps[np.minimum(index, run.steps.size - 1)] != steps):
        raise ValueError("requested steps are not all stored")
    return run.v[index], run.rho[index]


def scene_modes(scene, basis=None, progress=True, problem=None, linear=False):
    """The POD mode count k of ``scene``: its rom.modes, else :func:`automatic_modes` of its POD basis (the full
    SPH run from the cache or run now; ``linear``: the count for a linear model, uncapped)."""
    if "modes" in scene.rom:
        return int(scene.rom["modes"])
    if basis is None:
        basis, _ = basis_for_scene(scene, progress=progress, problem=problem)
    return automatic_modes(basis, linear=linear)[0]


def accel_modes(scene, basis=None, progress=True, problem=None, linear=False):
    """The mode counts of the scene's acceleration study: rom.accel_modes, else [:func:`scene_modes`] (``linear``:
    of a linear model)."""
    given = scene.rom.get("accel_modes")
    return [int(k) for k in given] if given else [scene_modes(scene, basis, progress=progress, problem=problem,
                                                              linear=linear)]


def modes_line(scene, basis=None, progress=True, problem=None):
    """The line a command prints about the scene's automatic mode count; None when the scene gives rom.modes."""
    if "modes" in scene.rom:
        return None
    if basis is None:
        basis, _ = basis_for_scene(scene, progress=progress, problem=problem)
    return f"scene {scene.name}: rom.modes: {automatic_modes(basis)[1]}"
