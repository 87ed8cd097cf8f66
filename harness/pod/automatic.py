"""The automatic choices of a scene that leaves them out: the stored samples (``sph.every``), the POD snapshots
(``[snapshots]``) and the POD mode count (``rom.modes``), each by a stated rule.

Plain functions of numbers (and, for the modes, of a :class:`~sphrom.pod.basis.Basis`); :mod:`sphrom.scene`
applies the first two when it loads a scene, :mod:`sphrom.pod.pipeline` the third when it builds the POD, and
the rules' texts go to the schema page (``docs/user/scenes.md``) and the commands' messages.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..scene_schema import MAX_SAMPLE_BYTES, least_every
from ..sph.timestep import AUTO_DT_RULE, DEFAULT_INTEGRATOR_RULE
from .basis import modes_for_energy
from .snapshots import MAX_SNAPSHOT_BYTES

# Snapshots: uniform over the training run [0, T], at the paper's spacing T'/200 (section 3.1.1: 100 snapshots
# over T'/2 = 1.58 s, spacing 0.016 s), where T' is the time a wave takes once around the periodic bar
# (sphrom.scene.Scene.period); at least MIN_AUTO_SNAPSHOTS for short runs, at most MAX_AUTO_SNAPSHOTS for long.
SNAPSHOTS_PER_PERIOD = 200
MIN_AUTO_SNAPSHOTS = 20
MAX_AUTO_SNAPSHOTS = 1000
AUTO_SNAPSHOTS_RULE = (
    f"count snapshots uniform over the training run [0, T] (the paper's strategy of section 3.1 at its spacing: "
    f"100 snapshots over T'/2), count = ceil({SNAPSHOTS_PER_PERIOD} T / T'), where T' = sum over the particles of "
    "dx sqrt(rho0/c) is the time a wave takes once around the periodic bar (L sqrt(rho0/c), the paper's T', for "
    f"uniform fields); at least {MIN_AUTO_SNAPSHOTS} (short runs), at most {MAX_AUTO_SNAPSHOTS} (long ones), at "
    f"most the run's steps, and at most {MAX_SNAPSHOT_BYTES // 2**30} GiB of snapshot matrices (v and rho)")
AUTO_EVERY_RULE = ("a sample at the spacing of the automatic snapshots (below; T'/200 for runs from T'/10 to 5 T'), "
                   "every = floor(T / (count dt)) steps, at least 1, and large enough that the samples fit "
                   f"{MAX_SAMPLE_BYTES // 2**30} GiB (v and rho)")

# Modes (the truncation of eq. 2.15): the fewest modes that leave out at most ENERGY_LEFT_OUT of the snapshots'
# energy in the energy-weighted bases of the exact model (kinetic: velocity weighted by rho0; strain: specific
# volume e = rho0/rho - 1 weighted by c), plus one density mode for the rest density; at most MAX_AUTO_MODES for a
# time-stepped model (the frozen model's refresh costs O(k^4)).  A linear model (advanced exactly in time, O(k^2) per
# step) takes the kinetic energy's count k_v uncapped (up to the snapshots' rank): a cap there leaves out velocity the
# criterion asked for, and the FMU's outputs and acceptance are velocities (a two-material bar whose stiff and soft
# parts differ 19x in c needs k_v = 45 of 103 modes: capped at 20 the exact FMU's training error was 0.22); its
# strain count k_e + 1 stays capped (a uniform force on a two-material bar of 926 particles spreads its strain energy
# over k_e = 264 modes while k_v = 1: uncapped the exact FMU cost 25x the full SPH, capped at 20 its error is 2e-13).
ENERGY_LEFT_OUT = 1e-3
MAX_AUTO_MODES = 20
AUTO_MODES_RULE = (
    f"k = max(k_v, k_e + 1): k_v and k_e the fewest modes leaving out at most {ENERGY_LEFT_OUT:g} of the snapshots' "
    "kinetic energy (velocity modes weighted by rho0) and strain energy (specific-volume modes e = rho0/rho - 1 "
    f"weighted by c), so a projection error of the snapshots of at most sqrt({ENERGY_LEFT_OUT:g}) = 3 %, of the "
    "order of the full SPH's own error on the paper's scenes of section 3 (their paper.sph_error_v: 6.7e-3 to "
    "8.5e-2); + 1 for the rest density, the first mode of the uncentred density basis (the paper's minimum data, "
    f"section 3.1.2: 3 velocity and 4 density snapshots for 3 sine modes); at most {MAX_AUTO_MODES} for a "
    "time-stepped model (the paper's scenes need at most 12; the frozen model's refresh costs O(k^4)); a linear "
    f"model (the exact one: O(k^2) per step) takes k = max(k_v, min(k_e + 1, {MAX_AUTO_MODES})), its velocity count "
    "uncapped (its outputs are velocities); at most the rank of the snapshots.  "
    "Chosen when the POD is built (`sphrom pod`, `fmu`, `validate`), and printed")


def automatic_count(T, period, n_steps, n_particles):
    """The snapshot count of :data:`AUTO_SNAPSHOTS_RULE` for a run of ``n_steps`` steps to ``T`` [s], the
    wave's period ``period`` T' [s] and N = ``n_particles``."""
    count = int(np.ceil(SNAPSHOTS_PER_PERIOD * T / period - 1e-9))
    count = min(max(count, MIN_AUTO_SNAPSHOTS), MAX_AUTO_SNAPSHOTS)
    return max(1, min(count, n_steps, MAX_SNAPSHOT_BYTES // (n_particles * 16)))


def automatic_snapshots(T, period, dt, n_steps, n_particles):
    """``[snapshots]`` of :data:`AUTO_SNAPSHOTS_RULE`: {count, window} over the run's ``n_steps`` steps of ``dt``."""
    return {"count": automatic_count(T, period, n_steps, n_particles), "window": [0.0, float(min(T, n_steps * dt))]}


def automatic_every(T, period, dt, n_steps, n_particles):
    """``sph.every`` of :data:`AUTO_EVERY_RULE`."""
    count = automatic_count(T, period, n_steps, n_particles)
    return int(max(1, np.floor(T / (count * dt) + 1e-9), least_every(n_steps, n_particles)))


def automatic_modes(basis, linear=False):
    """(k, text): the mode count of :data:`AUTO_MODES_RULE` for ``basis`` (with its energy-weighted bases) and
    a one-line account of the choice; ``linear``: for a linear model (no :data:`MAX_AUTO_MODES` cap).

    Raises UserError naming ``rom.modes`` when the snapshots carry no motion (v0 = 0 and no force).
    """
    def count(sigma):
        return 0 if float(np.sum(np.asarray(sigma) ** 2)) == 0.0 else modes_for_energy(sigma, ENERGY_LEFT_OUT)

    k_v = count(basis.sigma_ve if basis.sigma_ve is not None else basis.sigma_v)
    k_e = count(basis.sigma_e) if basis.sigma_e is not None else max(0, count(basis.sigma_rho) - 1)
    if k_v == 0 and k_e == 0:
        raise UserError("rom.modes: the snapshots carry no motion (v0 = 0 and no force), so there are no modes to "
                        "choose (allowed: a scene with v0 or a force, or rom.modes given)")
    k = max(k_v, k_e + 1)
    rank = min(basis.max_modes)
    cap = min(MAX_AUTO_MODES, rank)
    k_linear = min(max(k_v, min(k_e + 1, cap)), rank)       # the velocity count uncapped
    chosen = k_linear if linear else min(k, cap)
    text = (f"k = {chosen} (automatic: k_v = {k_v}, k_e = {k_e} modes leave out at most {ENERGY_LEFT_OUT:g} of "
            f"the snapshots' kinetic and strain energy; k = max(k_v, k_e + 1) = {k}"
            + (f", capped at {cap}" if k > cap and not linear else "")
            + (f"; a linear model: max(k_v, min(k_e + 1, {cap})) = {k_linear}" if linear or k_linear != chosen
               else "") + ")")
    return chosen, text


def automatic_rules():
    """(what, rule) of every automatic choice, for the schema page."""
    return [("name", "the file name without `.toml` (it must then be a valid name)"),
            ("title", "the name"),
            ("sph.integrator", DEFAULT_INTEGRATOR_RULE),
            ("sph.dt", AUTO_DT_RULE),
            ("sph.every", AUTO_EVERY_RULE),
            ("snapshots", AUTO_SNAPSHOTS_RULE),
            ("rom.modes", AUTO_MODES_RULE),
            ("rom.accel_modes", "[modes]: the FMU's default k is then the automatic mode count")]

