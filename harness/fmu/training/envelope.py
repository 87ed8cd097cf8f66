"""The training envelope of an FMU: what its basis was trained on, and the margins the C core checks.

Recorded at packaging (``sphrom fmu``) in three tagged sections of ``resources/model.bin``
(:data:`sphrom.fmu.resources.SECTION_TAGS`) and printed in the summary and the model description:

``ENVELOPE`` (1 x :data:`N_SCALARS`), in this order
    0 ``force_amplitude``    max |f(t)| over the training run, t = n dt in [0, T] [m s^-2]
    1 ``force_band``         the frequency below which 99 % of the training force's energy lies
                             (one-sided spectrum of f over [0, T], the mean included) [Hz]; 0 for a
                             constant force and for f = 0
    2 ``max_strain``         the largest strain |J - 1| = |ρ0/ρ - 1| over the particles and the stored
                             samples of the training run (the full SPH) [-]
    3 ``max_probe_strain``   the same at the probes (ρ and ρ0 interpolated linearly between particles) [-]
    4 ``failure_strain``     frozen model: the probe strain at which the density linearization (eq. 2.17)
                             is measured to fail (:data:`FAILURE_STRAIN`); 0 for a linear model [-]
    5 ``margin``             factor on the trained ranges before a warning (:data:`MARGIN`) [-]
    6 ``checks``             bit mask of the run-time checks (:data:`CHECK_COORDINATES`,
                             :data:`CHECK_FORCE`, :data:`CHECK_STRAIN`, :data:`CHECK_FAILURE`)
    7 ``force_mean``         mean of f over the training run [m s^-2]
``ENVRANGE`` (2 x k)
    row 0 the minimum, row 1 the maximum of each reduced coordinate over the training run's stored
    samples (the full SPH projected on the FMU's basis): a^v then a^ρ (frozen, Euclidean projection
    as eq. 2.16) or z = (a; b) (exact linear model, ρ0- and c-weighted projections of v and e = J - 1).
``ENVPROBE`` (2 x n_probes)
    row 0: ρ0 at each probe (linear between particles) [kg m^-3]: the C core's probe strain is
    |ρ0_j / ρ_j - 1|; row 1: max |v| at each probe over the training run [m s^-1] (the outputs'
    ``nominal`` in modelDescription.xml).
``ENVPORT`` (1 x 2, only with mechanical ports)
    the numbers of trailing coordinates of the first block (a^v, or a) and of the second (a^ρ, or b) that
    are the ports' directions (:func:`sphrom.rom.operators.port_directions`), not POD modes.

With ports the training run is the scene's own, without port forces: port forces are untrained inputs by
design (the basis carries their exact input directions instead, each port's profile and its Krylov
response, :func:`sphrom.rom.operators.port_directions`).  So (1) the port coordinates are never checked
against the training run's ranges, which leave them at ~0 (its POD residual), nor do they count in a
block's largest half-width; (2) once a step has been taken with a nonzero port force or rate (the C
state's ``port_driven``, kept in FMU states, cleared by reset) the state holds a response that run never
saw, and only |f| and the failure strain are checked: a port force moves the POD coordinates and the
probe strain beyond their trained ranges while the frozen model stays accurate (damped_forced, k = 12:
port error 0.28 % unforced, 0.32 % at the port-coupling forces, 0.48 % at 12x them, probe strain 8.5x
the trained, docs/fmu/envelope.md).  Until then a port FMU is checked as one without ports.

A parametric model's envelope (``--vary``) is the :func:`union` of the envelopes of the runs at all its
sample points (:func:`sphrom.fmu.make.parametric.parametric_envelope`).

At run time the frozen model is checked after every doStep (fmu_src/rom_envelope.c): a coordinate
a_i whose distance from the centre c_i of its trained range [lo_i, hi_i] exceeds its half-width h_i plus
(margin - 1) H, H the largest half-width of its block (a^v or a^ρ: the block's trained amplitude, so
that a coordinate the training hardly moved is not judged on the reduced model's own error in it);
|f| above ``margin`` times the trained max |f| (a forced scene only: f = 0 trains no amplitude, and a
force is then judged by the response it makes); a probe strain above ``margin`` x
``max_probe_strain``; a probe strain above ``failure_strain``.  The linear models are exact in the
state (scale invariant; the full SPH is itself linear in J up to its time stepping of ρ): no amplitude check applies, and the input
band is recorded, not checked (a frequency cannot be estimated from the samples of one step).  The
FMU logs the first breach once per instance as a warning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...sph.solver import step_count
from .. import layout
from ..resources import probe_pairs

SCALARS = layout.SECTIONS["ENVELOPE"].columns    # the named columns of ENVELOPE (sphrom.fmu.layout)
N_SCALARS = len(SCALARS)
CHECK_COORDINATES, CHECK_FORCE, CHECK_STRAIN, CHECK_FAILURE = (layout.ENVELOPE_CHECKS[name] for name in
                                                                ("coordinates", "force", "strain", "failure"))
ENERGY_FRACTION = 0.99       # the band that holds this fraction of the training force's energy
# Factor on the trained ranges (coordinates, |f|, probe strain) before a warning, from
# `python -m sphrom.bench.envelope` (validation/benchmarks/envelope.csv, BENCHMARKS.md "The training
# envelope"): with the initial state scaled by s the frozen model's probe error against the full SPH
# grows about linearly in s (tenmode 0.128 at s = 1, 0.185 at 1.5, 0.243 at 2); within 1.5x the
# trained amplitude it stays within 1.5x its trained value, and the reduced model's own run of its
# training scene stays inside this margin on every built-in scene (largest coordinate excess 0.18 H of
# the 0.5 H allowed, probe strain 1.11x of the 1.5x allowed).
MARGIN = 1.5
# Probe strain |ρ0/ρ - 1| at which the frozen model's probe error reaches 50 % (the density
# linearization of eq. 2.17 has failed, whatever the training): 0.045 on tenmode, 0.088 on multimode
# (same benchmark, interpolated), rounded down.
FAILURE_STRAIN = 0.04


@dataclass
class Envelope:
    """What a basis was trained on (module docstring for the fields and units)."""

    force_amplitude: float
    force_band: float
    max_strain: float
    max_probe_strain: float
    failure_strain: float
    margin: float
    checks: int
    force_mean: float
    lo: np.ndarray
    hi: np.ndarray
    probe_rho0: np.ndarray
    probe_v_max: np.ndarray
    k_v: int = 0                 # the first k_v coordinates are a^v (not stored: the header has it)
    port_v: int = 0              # trailing port coordinates of the first block (ENVPORT), not checked
    port_rho: int = 0            # and of the second block

    def sections(self):
        """The tagged sections (tag -> 2-D array) of :mod:`sphrom.fmu.resources`."""
        scalars = [float(getattr(self, name)) for name in SCALARS]       # the columns, by name
        out = {"ENVELOPE": np.array([scalars]), "ENVRANGE": np.vstack([self.lo, self.hi]),       # rows min, max
               "ENVPROBE": np.vstack([self.probe_rho0, self.probe_v_max])}                  # rows rho0, v_max
        if self.port_v or self.port_rho:
            out["ENVPORT"] = np.array([[float(getattr(self, name)) for name in layout.SECTIONS["ENVPORT"].columns]])
        return out

    def checked(self, k_v):
        """The checked coordinates of each block: (("a_v", slice), ("a_rho", slice)), the port directions
        (the last ``port_v`` and ``port_rho`` of the blocks) left out."""
        k = self.lo.size
        return (("a_v", slice(0, k_v - self.port_v)), ("a_rho", slice(k_v, k - self.port_rho)))

    @classmethod
    def from_sections(cls, sections, k_v):
        """The envelope of a model.bin's sections (None without them); k_v from its header."""
        if "ENVELOPE" not in sections:
            return None
        scalars = {name: layout.value(sections, "ENVELOPE", name) for name in SCALARS}
        scalars["checks"] = int(scalars["checks"])
        rng = np.asarray(sections["ENVRANGE"], float)
        probe = np.asarray(sections["ENVPROBE"], float)
        ports = {name: int(layout.value(sections, "ENVPORT", name)) if "ENVPORT" in sections else 0
                 for name in ("port_v", "port_rho")}
        return cls(**scalars, lo=rng[layout.row("ENVRANGE", "min")], hi=rng[layout.row("ENVRANGE", "max")],
                   probe_rho0=probe[layout.row("ENVPROBE", "rho0")], probe_v_max=probe[layout.row("ENVPROBE", "v_max")],
                   k_v=int(k_v), **ports)

    def lines(self, linear=False, bounded=False):
        """Human-readable lines (the ``sphrom fmu`` summary and the model description); ``bounded``: the FMU
        carries certified error bounds, whose warning (error_tolerance) replaces the envelope's."""
        if self.force_amplitude == 0.0:
            force = ("training force f = 0 (a free response: no force amplitude or band was trained; a force "
                     "is judged by the response it makes)")
        else:
            force = (f"training force max |f| = {self.force_amplitude:.3g} m s^-2 (mean {self.force_mean:.3g}), "
                     f"99 % of its energy below {self.force_band:.3g} Hz")
        half = 0.5 * (self.hi - self.lo)
        names = ("a", "b") if linear else ("a^v", "a^rho")
        out = [force,
               f"largest strain |rho0/rho - 1| in training {self.max_strain:.3g} (at the probes "
               f"{self.max_probe_strain:.3g}); ranges of the {self.lo.size} reduced coordinates stored, largest "
               f"half-width {names[0]} {half[:self.k_v].max():.3g}, {names[1]} {half[self.k_v:].max():.3g}"]
        if bounded:
            out.append("run-time signal: the certified error bound of every output at every step (one warning "
                       "when a velocity output's bound first exceeds error_tolerance); this envelope is "
                       "information, not checked")
        elif linear:
            out.append("run-time checks: none (the linear model is exact in its state: amplitude does not "
                       "change its accuracy)")
        elif self.port_v or self.port_rho:
            out.append(f"run-time warning (once) beyond {self.margin:g}x the trained ranges of the POD "
                       f"coordinates, force amplitude and probe strain, or at a probe strain above "
                       f"{self.failure_strain:g} (where the density linearization, eq. 2.17, fails); the "
                       f"{self.port_v} + {self.port_rho} port coordinates are exact input directions, not trained: "
                       "not checked; once a port force has acted (untrained by design) only the force amplitude "
                       "and the failure strain are checked")
        else:
            out.append(f"run-time warning (once) beyond {self.margin:g}x the trained coordinate ranges, force "
                       f"amplitude and probe strain, or at a probe strain above {self.failure_strain:g} (where "
                       "the density linearization, eq. 2.17, fails)")
        return out


def force_band(f, dt, fraction=ENERGY_FRACTION):
    """The frequency [Hz] below which ``fraction`` of the energy of the samples ``f`` (step dt [s]) lies.

    One-sided power spectrum |F_k|² of the samples (the mean, k = 0, included); 0 for a constant or zero
    signal.
    """
    f = np.asarray(f, float)
    power = np.abs(np.fft.rfft(f)) ** 2
    total = power.sum()
    if not total > 0 or np.allclose(f, f[0]):
        return 0.0
    freqs = np.fft.rfftfreq(f.size, dt)
    k = int(np.searchsorted(np.cumsum(power), fraction * total))
    return float(freqs[min(k, freqs.size - 1)])


def training_force(scene):
    """(amplitude max|f| [m s^-2], band [Hz], mean [m s^-2]) of the scene's force at its SPH steps over [0, T]."""
    n = step_count(scene.T, scene.sph.dt)
    t = np.arange(n + 1) * scene.sph.dt
    f = scene.force(t)
    if not np.any(f != 0.0):
        return 0.0, 0.0, 0.0
    mean = float(np.mean(f))
    return float(np.max(np.abs(f))), force_band(f, scene.sph.dt), mean


def _probe_values(field, x, L, probes):
    """field (M, N) or (N,) interpolated linearly between particles at the probes (as probe_rows)."""
    i0, i1, w = probe_pairs(x, L, probes)
    field = np.asarray(field, float)
    return (1.0 - w) * field[..., i0] + w * field[..., i1]


def measure(scene, ops, problem, run, probes, linear):
    """The :class:`Envelope` of a packaged model.

    Parameters
    ----------
    scene : Scene
    ops : ReducedOperators or LinearOperators
        The FMU's operators (their bases, the force direction appended where it was); the training run's
        reduced coordinates are their projection of its fields (``ops.project``: frozen a^v = U_vᵀ v,
        a^ρ = U_ρᵀ ρ, eq. 2.16; exact a = U_vᵀ diag(ρ0) v, b = U_eᵀ diag(c) e, its energy inner products).
    problem : SPHProblem
    run : Run
        The cached full SPH training run (:func:`sphrom.pod.pipeline.basis_for_scene`).
    probes : sequence of float
        Probe positions in units of L.
    linear : bool
        The model is linear (exact in its state): no run-time checks.
    """
    z = ops.project(run.v, run.rho, problem)
    rho0 = np.asarray(problem.rho0, float)
    strain = np.abs(rho0[None, :] / run.rho - 1.0)
    L = scene.L
    probe_rho0 = _probe_values(rho0, problem.x, L, probes)
    probe_strain = np.abs(probe_rho0[None, :] / _probe_values(run.rho, problem.x, L, probes) - 1.0)
    amplitude, band, mean = training_force(scene)
    checks = 0 if linear else (CHECK_COORDINATES | CHECK_STRAIN | CHECK_FAILURE
                               | (CHECK_FORCE if amplitude > 0 else 0))
    return Envelope(force_amplitude=amplitude, force_band=band, max_strain=float(strain.max()),
                    max_probe_strain=float(probe_strain.max()), failure_strain=0.0 if linear else FAILURE_STRAIN,
                    margin=MARGIN, checks=checks, force_mean=mean, lo=z.min(axis=0), hi=z.max(axis=0),
                    probe_rho0=probe_rho0, probe_v_max=np.abs(_probe_values(run.v, problem.x, L, probes)).max(axis=0),
                    k_v=int(ops.k_v), port_v=int(ops.port_added), port_rho=int(ops.port_added_2))


def union(envelopes):
    """One :class:`Envelope` of several training runs of the same basis (a parametric model's sample points): the
    ranges, strains, probe velocities and force amplitude and band the largest of any run's; the checks and
    margins those of the first (all alike), the force mean that of the first (the same f at every point)."""
    first = envelopes[0]
    return Envelope(force_amplitude=max(e.force_amplitude for e in envelopes),
                    force_band=max(e.force_band for e in envelopes),
                    max_strain=max(e.max_strain for e in envelopes),
                    max_probe_strain=max(e.max_probe_strain for e in envelopes),
                    failure_strain=first.failure_strain, margin=first.margin, checks=first.checks,
                    force_mean=first.force_mean, lo=np.min([e.lo for e in envelopes], axis=0),
                    hi=np.max([e.hi for e in envelopes], axis=0), probe_rho0=first.probe_rho0,
                    probe_v_max=np.max([e.probe_v_max for e in envelopes], axis=0), k_v=first.k_v,
                    port_v=first.port_v, port_rho=first.port_rho)


def check(env: Envelope, z, f, probe_rho, k_v, port_driven=False):
    """The first breach of the envelope, as the C core finds it (fmu_src/rom_envelope.c, same order):
    (quantity, value, lo, hi) or None.

    ``z`` the reduced state (a^v then the second block), ``f`` the input [m s^-2], ``probe_rho`` the probe
    densities [kg m^-3].  The port coordinates (``port_v``, ``port_rho``) are not checked; ``port_driven``
    (a port force has acted since the start) leaves out the coordinates and the trained probe strain.
    """
    z = np.asarray(z, float)
    checks = env.checks & ~(CHECK_COORDINATES | CHECK_STRAIN) if port_driven else env.checks
    strain = np.abs(env.probe_rho0 / np.asarray(probe_rho, float) - 1.0)
    if checks & CHECK_FAILURE:
        for j, s in enumerate(strain):
            if s > env.failure_strain:
                return f"strain at probe {j + 1}", s, 0.0, env.failure_strain
    if checks & CHECK_COORDINATES:
        for name, block in env.checked(k_v):                 # the port directions left out
            lo, hi = env.lo[block], env.hi[block]
            centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            widen = (env.margin - 1.0) * half.max()
            for i, value in enumerate(z[block]):
                if abs(value - centre[i]) > half[i] + widen:
                    return f"{name}_{i + 1}", value, lo[i] - widen, hi[i] + widen
    if checks & CHECK_FORCE and abs(f) > env.margin * env.force_amplitude:
        return "|f|", abs(f), 0.0, env.force_amplitude
    if checks & CHECK_STRAIN:
        for j, s in enumerate(strain):
            if s > env.margin * env.max_probe_strain:
                return f"strain at probe {j + 1}", s, 0.0, env.max_probe_strain
    return None
