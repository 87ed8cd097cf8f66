"""From a scene to a POD basis: the full SPH run (cached) and the SVD."""

from __future__ import annotations

import numpy as np

from ..cache import cached_sph
from ..errors import UserError
from ..sph.solver import build_problem, default_sample_steps, step_count
from .basis import build_basis, modes_for_energy
from .snapshots import describe, snapshot_steps


def error_steps(scene):
    """The steps at which errors are measured: every ``sph.every`` and the last."""
    return default_sample_steps(step_count(scene.T, scene.sph.dt), scene.sph.every)


def basis_for_scene(scene, spec=None, progress=True, problem=None):
    """POD basis of ``scene`` for the snapshot strategy ``spec`` (default the scene's).

    Returns (basis, run): the run is the cached full SPH solution, with samples
    at the error steps and at the snapshot steps.
    """
    spec = dict(scene.snapshots if spec is None else spec)
    problem = problem or build_problem(scene)
    n = step_count(scene.T, scene.sph.dt)
    steps = error_steps(scene)
    if not spec.get("all"):
        sv, sr = snapshot_steps(spec, scene.sph.dt, n, n_particles=scene.sph.n_particles)
        run = cached_sph(scene, np.union1d(steps, np.union1d(sv, sr)), progress=progress, problem=problem)
    else:
        run = cached_sph(scene, steps, progress=progress, problem=problem)
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


# The automatic mode count of a scene without rom.modes (the truncation of eq. 2.15): the fewest modes that
# leave out at most ENERGY_LEFT_OUT of the snapshots' energy in the energy-weighted bases of the exact model
# (kinetic: velocity weighted by rho0; strain: specific volume e = rho0/rho - 1 weighted by c), plus one density
# mode for the rest density; AUTO_MODES_RULE says it in full, for the schema page and the messages.
ENERGY_LEFT_OUT = 1e-3
MAX_AUTO_MODES = 20
AUTO_MODES_RULE = (
    f"k = max(k_v, k_e + 1): k_v and k_e the fewest modes leaving out at most {ENERGY_LEFT_OUT:g} of the snapshots' "
    "kinetic energy (velocity modes weighted by rho0) and strain energy (specific-volume modes e = rho0/rho - 1 "
    f"weighted by c), so a projection error of the snapshots of at most sqrt({ENERGY_LEFT_OUT:g}) = 3 %, of the "
    "order of the full SPH's own error on the paper's scenes (their paper.sph_error_v: 6.7e-3 to 8.5e-2); + 1 for "
    f"the rest density, the first mode of the uncentred density basis; at most {MAX_AUTO_MODES} (the paper's scenes "
    "need at most 12; the frozen model's refresh costs O(k^4)) and at most the rank of the snapshots.  Chosen when "
    "the POD is built (`sphrom pod`, `fmu`, `validate`), and printed")


def automatic_modes(basis):
    """(k, text): the mode count of :data:`AUTO_MODES_RULE` for ``basis`` (with its energy-weighted bases) and
    a one-line account of the choice.

    Raises UserError naming ``rom.modes`` when the snapshots carry no motion (v0 = 0 and no force).
    """
    def count(sigma):
        return 0 if float(np.sum(np.asarray(sigma) ** 2)) == 0.0 else modes_for_energy(sigma, ENERGY_LEFT_OUT)

    sigma_v = basis.sigma_ve if basis.sigma_ve is not None else basis.sigma_v
    k_v = count(sigma_v)
    k_e = count(basis.sigma_e) if basis.sigma_e is not None else max(0, count(basis.sigma_rho) - 1)
    if k_v == 0 and k_e == 0:
        raise UserError("rom.modes: the snapshots carry no motion (v0 = 0 and no force), so there are no modes to "
                        "choose (allowed: a scene with v0 or a force, or rom.modes given)")
    rank = min(basis.max_modes)
    k = max(k_v, k_e + 1)
    capped = min(k, MAX_AUTO_MODES, rank)
    text = (f"k = {capped} (automatic: k_v = {k_v}, k_e = {k_e} modes leave out at most {ENERGY_LEFT_OUT:g} of the "
            f"snapshots' kinetic and strain energy; k = max(k_v, k_e + 1) = {k}"
            + (f", capped at {min(MAX_AUTO_MODES, rank)}" if capped < k else "") + ")")
    return capped, text


def scene_modes(scene, basis=None, progress=True, problem=None):
    """The POD mode count k of ``scene``: its rom.modes, else :func:`automatic_modes` of its POD basis (the full
    SPH run from the cache or run now)."""
    if "modes" in scene.rom:
        return int(scene.rom["modes"])
    if basis is None:
        basis, _ = basis_for_scene(scene, progress=progress, problem=problem)
    return automatic_modes(basis)[0]


def accel_modes(scene, basis=None, progress=True, problem=None):
    """The mode counts of the scene's acceleration study: rom.accel_modes, else [:func:`scene_modes`]."""
    given = scene.rom.get("accel_modes")
    return [int(k) for k in given] if given else [scene_modes(scene, basis, progress=progress, problem=problem)]


def modes_line(scene, basis=None, progress=True, problem=None):
    """The line a command prints about the scene's automatic mode count; None when the scene gives rom.modes."""
    if "modes" in scene.rom:
        return None
    if basis is None:
        basis, _ = basis_for_scene(scene, progress=progress, problem=problem)
    return f"scene {scene.name}: rom.modes: {automatic_modes(basis)[1]}"
