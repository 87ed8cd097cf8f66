"""A packaged FMU measured against the truth it approximates (``sphrom fmu``'s verification and acceptance).

The truth is the full SPH linear in J, integrated exactly in time (:mod:`.truth`; the certified bounds' truth,
docs/science/error-bounds.md), driven by the very input the FMU gets.  Three cases over the scene's T at the FMU's
default communication step h (its DefaultExperiment stepSize, :func:`communication_step`: it resolves the scene's
own band, :func:`top_frequency`):

- ``training``: the scene's own force f(t) from its initial state (the FMU's ``initial_state_scale`` set to 1 where
  it has that parameter): the run the POD basis was made from;
- ``step``: a constant force A_s from rest (a force switched on at t = 0: every mode the force profile reaches rings);
- ``unseen``: f_u(t) = A sin(2 pi nu_u t) from rest, nu_u = :data:`UNSEEN_RATIO` x the bar's lowest elastic
  frequency nu_1 (between its second and third resonance on a uniform bar), at most half the top of the band h
  resolves;

with A = the training force's peak |f| on [0, T] (forced scenes), else, for the sine, 2 pi nu_u max|v0| and, for the
step, max|v0| / T (free scenes: the velocity swing of a uniform force is then of the initial velocity's size).  An FMU without ``initial_state_scale``
starts every case from the scene's initial state, in the truth too.

The FMU gets f at each communication point, held over the step, or with df/dt (the slope to the next point) when it
declares ``canInterpolateInputs`` (FMI 2, linear models): what ``sphrom cosim`` does by default; the truth gets the
same.  Errors: the relative L2 error of eq. 3.4 (square-root form, trapezoidal in time, summed over the probes) of
the probe velocities, and of the probe densities as rho - rho0.  With its certified bounds the FMU's
``v_probe_j_error_bound`` is recorded against the true error (does it hold, how tight), and the warnings it logged
(:attr:`CaseResult.warnings`).  Times: the FMU's inside its doStep calls and its whole run through fmpy (Python's
per-step overhead included), the full SPH's compiled time loop of the scene's own run, timed in the same process
(:func:`sph_cost`; its cost per simulated second is that of every case: the full SPH's work does not depend on the
force).

:func:`acceptance` is packaging's verdict: the FMU failed, ran away, or missed the accuracy (:data:`ACCURACY` by
default, ``--tolerance``) on a case, named in one line with the remedy.
"""

from __future__ import annotations

import dataclasses
import io
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ...cache import cached_sph
from ...expr import compile_expr
from ...norms import relative_l2
from ...pod.pipeline import error_steps
from ...progress import progress_bar
from ...rom.inputs import band as rayleigh
from ...scene import derive_scene
from ...sph.operator import particle_positions
from ...sph.solver import build_problem, run_sph, step_count
from ..resources import probe_pairs
from ..run.driver import FMU, can_interpolate_inputs
from ..training.envelope import training_force
from ..variables import members
from .truth import TRUTH_NAME, exact_probe_outputs

SCALE_NAME = "initial_state_scale"     # the FMU's parameter (harness/fmu/variables.py)
TOLERANCE_NAME = "error_tolerance"     # the FMU's parameter of its bounds' warning
ACCURACY = 0.1          # the largest probe v error (eq. 3.4) packaging accepts on any case by default
POINTS_PER_PERIOD = 25  # communication points per period of the top of the scene's band
UNSEEN_RATIO = 2.2      # nu_u / nu_1: the unseen sine between a uniform bar's 2nd and 3rd resonance
CASES = ("training", "step", "unseen")


ROUNDOFF_ERROR = 1e-9     # a case's largest v error below this x max |v_truth|: round-off


@dataclass
class CaseResult:
    """One force case: the FMU and the truth at the probes, at the communication points.

    Attributes
    ----------
    name : str
        ``training``, ``step`` or ``unseen``.
    force : str
        f(t) as an expression in t [m s^-2].
    start : str
        ``the scene's initial state`` or ``rest``.
    t : ndarray (M,)
        Communication points [s].
    fmu_v, sph_v : ndarray (M, P)
        Probe velocities [m s^-1] of the FMU and of the truth (:mod:`.truth`; the name ``sph_v`` is kept: the truth
        is the full SPH linear in J, integrated exactly in time).
    fmu_rho, sph_rho : ndarray (M, P)
        Probe densities [kg m^-3].
    rho0 : ndarray (P,)
        Rest density at the probes [kg m^-3].
    err_v, err_rho : float
        Eq. 3.4 (square-root form) of v and of rho - rho0 over probes and time (inf when the FMU failed;
        err_rho nan when the truth's rho - rho0 is 0 at the probes, where a relative error has no meaning:
        a uniform force from rest moves the bar rigidly).
    max_drho : float
        The largest |rho_FMU - rho_truth| at the probes [kg m^-3].
    fmu_s : float
        Wall time [s] of the FMU's run over T through fmpy (initialization, inputs, doStep, outputs).
    sph_s : float
        CPU time [s] of the full SPH's compiled time loop over T (the scene's training run; :func:`sph_cost`).
    note : str
        The FMU's error message when it failed, else ''.
    fmu_v_bound : ndarray (M, P) or None
        The FMU's certified bounds of its probe velocities (``v_probe_j_error_bound``; None without them).
    step_s : float
        CPU time [s] of the FMU's doStep calls (its own work per simulated T; :func:`time.thread_time`, as the full
        SPH's ``sph_s``: their ratio does not count the time other processes took the core).
    warnings : list of str
        The warnings the FMU logged during the run.
    """

    name: str
    force: str
    start: str
    t: np.ndarray
    fmu_v: np.ndarray
    fmu_rho: np.ndarray
    sph_v: np.ndarray
    sph_rho: np.ndarray
    rho0: np.ndarray
    err_v: float
    err_rho: float
    fmu_s: float
    sph_s: float
    note: str = ""
    max_drho: float = float("nan")
    fmu_v_bound: np.ndarray | None = None
    step_s: float = float("nan")
    warnings: list = field(default_factory=list)

    @property
    def speedup(self):
        """Full SPH time / FMU time through fmpy (> 1: the FMU is faster)."""
        return self.sph_s / self.fmu_s if self.fmu_s > 0 else float("inf")

    @property
    def cost_ratio(self):
        """The FMU's own work (its doStep calls) / the full SPH's compiled loop, per simulated second (< 1: the
        FMU is cheaper)."""
        return self.step_s / self.sph_s if self.sph_s > 0 else float("inf")

    @property
    def max_error(self):
        """The largest |v_FMU - v_truth| over the probes and points [m s^-1]."""
        return float(np.max(np.abs(self.fmu_v - self.sph_v)))

    @property
    def bound_holds(self):
        """Whether the FMU's v bound is at least its true error at every point and probe (None without bounds)."""
        if self.fmu_v_bound is None or not np.all(np.isfinite(self.fmu_v)):
            return None
        err = np.abs(self.fmu_v - self.sph_v)
        return bool(np.all(self.fmu_v_bound >= err - 1e-12 * np.max(np.abs(self.sph_v))))

    @property
    def error_is_roundoff(self):
        """Whether the largest true error is below :data:`ROUNDOFF_ERROR` of the largest |v_truth| (a ratio of the bound to
        it then says nothing; the benchmarks count no effectivity there either)."""
        return self.max_error <= ROUNDOFF_ERROR * float(np.max(np.abs(self.sph_v)))

    @property
    def bound_ratio(self):
        """The largest bound over the largest true error (nan without bounds; inf when the error is 0)."""
        if self.fmu_v_bound is None or not np.all(np.isfinite(self.fmu_v)):
            return float("nan")
        top = self.max_error
        return float(np.max(self.fmu_v_bound)) / top if top > 0 else float("inf")


@dataclass
class Verification:
    """The measurement of one FMU (see the module docstring)."""

    step: float                  # communication step h [s]
    T: float                     # horizon [s]
    input: str                   # "held" or "linear (df/dt)"
    probes: list                 # x/L
    cases: list = field(default_factory=list)
    refs: dict = field(default=None, repr=False)   # the truth of every case (:func:`references`), to reuse
    channels: list = field(default_factory=list)   # every input channel (:mod:`.channels`), when measured
    truth: str = ""              # what the FMU was measured against
    error_tolerance: float = float("nan")          # the FMU's error_tolerance start value (nan without bounds)
    stepped_error: tuple = (float("nan"), float("nan"), 0)   # the stepped SPH's (v, rho) error vs the truth, points
    channel_horizon: float = float("nan")          # the channels' horizon [s] (:func:`.channels.horizon`)
    cost: Cost | None = None     # the robust cost per simulated second (:func:`measure_cost`), when measured
    default_step: float = float("nan")   # the FMU's DefaultExperiment stepSize [s] (``step`` is the measurement's)

    @property
    def cost_ratio(self):
        """The FMU's cost per simulated second over the full SPH's: :attr:`cost`'s median ratio when measured, else
        the training case's single run."""
        return self.cost.ratio if self.cost is not None else self.training.cost_ratio

    @property
    def slower(self):
        """Whether the FMU costs more per simulated second than the full SPH it replaces (:attr:`cost_ratio`)."""
        return self.cost_ratio > 1

    def case(self, name):
        return next(c for c in self.cases if c.name == name)

    @property
    def training(self):
        return self.case("training")

    @property
    def unseen(self):
        return self.case("unseen")

    @property
    def worst(self):
        """The case with the largest v error."""
        return max(self.cases, key=lambda c: c.err_v if c.err_v == c.err_v else math.inf)

    def sentence(self):
        """The short text stored in the modelDescription's description."""
        tr, un = self.training, self.unseen
        others = "; ".join(f"{c.err_v:.2g} on {_force_words(c)}" for c in self.cases if c.name != "training")
        c = self.cost
        work = (f"{tr.step_s:.3g} s against {tr.sph_s:.3g} s for the full SPH per T ({_ratio(tr.cost_ratio)}"
                if c is None else f"{c.fmu_s:.3g} s against {c.sph_s:.3g} s for the full SPH per T in steady "
                f"stepping ({_ratio(c.ratio)}, the median of {c.repeats} pairs of runs; setup {c.setup_s:.2g} s")
        return (f"Measured against {self.truth or 'the full SPH'} at the probes (h = {self.step:g} s, T = "
                f"{self.T:g} s, eq. 3.4): v error {tr.err_v:.2g} on the training force, {others}; its own work "
                f"{work}; {un.fmu_s:.3g} s through fmpy){self.channel_sentence()}; see documentation/index.html.")

    def channel_sentence(self):
        """'; input channels ...: largest error X (which)' when the channels were measured, else ''."""
        if not self.channels:
            return ""
        worst = max(self.channels, key=lambda c: c.err)
        names = ", ".join(dict.fromkeys(c.channel for c in self.channels))
        return (f"; input channels {names} (a constant and a slow force each, from rest): largest error "
                f"{worst.err:.2g} ({worst.case} {worst.channel}, {worst.output})")

    def as_rows(self):
        """One dict per case (no arrays), for tables and CSV files."""
        return [{"case": c.name, "force": c.force, "start": c.start, "err_v": c.err_v, "err_rho": c.err_rho,
                 "max_drho": c.max_drho, "fmu_s": c.fmu_s, "sph_s": c.sph_s, "speedup": c.speedup,
                 "step_s": c.step_s, "cost_ratio": c.cost_ratio, "bound_holds": c.bound_holds,
                 "bound_ratio": c.bound_ratio, "warnings": len(c.warnings), "note": c.note} for c in self.cases]


def _force_words(case):
    return {"step": f"a step force ({case.force}, from {case.start})",
            "unseen": f"an unseen force ({case.force}, from {case.start})"}.get(case.name, case.name)


def _ratio(r):
    """A cost ratio in words: 'x0.05 of its cost', '3.2x its cost'."""
    return f"{r:.2g}x the full SPH's cost" if r == r else "cost not measured"


# --------------------------------------------------------------------------------------------------------------
# the scene's band, the communication step and the forces
# --------------------------------------------------------------------------------------------------------------
def lowest_frequency(problem):
    """nu_1 [Hz]: the bar's lowest elastic frequency, the Rayleigh quotient of sin 2 pi x/L
    (:func:`sphrom.rom.inputs.band`)."""
    return rayleigh(problem)[0] / (2 * math.pi)


def top_frequency(scene, problem, ops):
    """nu_top [Hz]: the top of the band that matters for the scene as the reduced model ``ops`` holds it, the largest
    of

    - :func:`energy_band` of its velocity modes (a POD model: its POD modes and any appended input direction): the
      frequency below which :data:`BAND_ENERGY` of the training run's kinetic energy lies, and that of the step
      case's elastic response (a force along the scene's profile switched on at t = 0);
    - the frequency below which 99 % of the training force's energy lies (:func:`force_top`).

    The unseen sine is in this band by construction (:func:`unseen_frequency`).  Not the highest of the k modes'
    own frequencies: a mode that carries a thousandth of the energy would set a step near the SPH's dt (a steel bar
    of 71 particles: 48 kHz against a band of a few kHz) and the FMU would do more steps than the SPH it replaces.
    A model without a POD basis (the balanced one): the largest |Im lambda| of its state matrix."""
    return max(model_band(scene, problem, ops), force_top(scene))


def model_band(scene, problem, ops):
    """The response's part of :func:`top_frequency` [Hz]: :func:`energy_band` of the model's velocity modes (the
    training run's and the step case's kinetic energy), or, without a POD basis, the largest |Im lambda| of its
    state matrix."""
    U = ops.velocity_modes
    if U is not None and U.shape[1]:
        run = cached_sph(scene, error_steps(scene), progress=False, problem=problem)   # the training run, cached
        return energy_band(problem, U, run.v, problem.profile if problem.terms["force_profile"] else None, scene.T)
    return float(np.max(np.abs(np.linalg.eigvals(np.asarray(ops.A, float)).imag), initial=0.0)) / (2 * math.pi)


BAND_ENERGY = 0.99      # the fraction of the kinetic energy below the top of the band (:func:`energy_band`)


def energy_band(problem, U, v_samples, profile=None, horizon=None, fraction=BAND_ENERGY):
    """The frequency [Hz] below which ``fraction`` of the kinetic energy lies, in the modes of the bar reduced to
    the velocity modes ``U`` (N, k): the Galerkin problem K_r psi = omega^2 M_r psi (M_r = U^T M U, K_r = U^T K U,
    the linearised eqs. 2.10-2.11's mass and stiffness, :func:`sphrom.rom.inputs.second_order`), the larger of

    - the training run's: sum over the samples ``v_samples`` (m, N) [m s^-1] of (psi_j^T M v)^2 per mode;
    - with a force ``profile`` (N,) and its ``horizon`` [s]: the step case's, a force along it switched on at t = 0
      from rest, mean square velocity over the horizon per mode: a_j^2 / (2 omega_j^2) for an elastic mode
      (v = a_j sin(omega_j t) / omega_j), a_j^2 horizon^2 / 3 for a rigid one (v = a_j t), a_j = psi_j^T M profile.

    Modes are sorted by omega (a rigid mode's is 0); the top is the omega of the mode at which the cumulative energy
    reaches ``fraction`` of the total (0 when there is no energy, or when the rigid modes hold the fraction)."""
    from scipy.linalg import eigh
    from ...rom.inputs import second_order

    M, _, K, _ = second_order(problem)
    U = np.asarray(U, float)
    MU = np.asarray(M @ U)
    Mr, Kr = U.T @ MU, U.T @ np.asarray(K @ U)
    w2, Q = eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    w = np.sqrt(np.clip(w2, 0.0, None))
    elastic = w > 1e-6 * max(float(w.max(initial=0.0)), 1e-300)
    PsiM = Q.T @ MU.T                                      # psi_j^T M, (k, N)
    w = np.where(elastic, w, 0.0)

    def top(energy):
        total = float(energy.sum())
        if not total > 0:
            return 0.0
        order = np.argsort(w)
        j = int(np.searchsorted(np.cumsum(energy[order]), fraction * total))
        return float(w[order][min(j, w.size - 1)])

    nu = top(np.sum((PsiM @ np.asarray(v_samples, float).T) ** 2, axis=1))
    if profile is not None and horizon is not None:
        amp = PsiM @ np.asarray(profile, float)
        nu = max(nu, top(np.where(elastic, 0.5 * (amp / np.where(elastic, w, 1.0)) ** 2, amp ** 2 * horizon ** 2 / 3)))
    return nu / (2 * math.pi)


def force_top(scene, fraction=0.99):
    """The frequency [Hz] below which ``fraction`` of the energy of the training force's variation lies: f at the
    SPH's steps over [0, T] less the line through its two ends (so that the window's ends leave no jump whose
    spectrum would fill the band), one-sided power spectrum; 0 for a constant or linear force."""
    n = step_count(scene.T, scene.sph.dt)
    t = np.arange(n + 1) * scene.sph.dt
    f = scene.force(t)
    f = f - (f[0] + (f[-1] - f[0]) * t / max(t[-1], 1e-300))
    power = np.abs(np.fft.rfft(f)) ** 2
    total = float(power.sum())
    if not total > 0 or not np.max(np.abs(f)) > 1e-12 * max(float(np.max(np.abs(scene.force(t)))), 1e-300):
        return 0.0
    k = int(np.searchsorted(np.cumsum(power), fraction * total))
    return float(np.fft.rfftfreq(f.size, scene.sph.dt)[min(k, power.size - 1)])


def nice_ceil(x):
    """The smallest of 1, 2, 5 x 10^n at least x (x > 0)."""
    e = math.floor(math.log10(x))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0 ** e >= x * (1 - 1e-12):
            return int(round(m * 10.0 ** e)) if e >= 0 else m * 10.0 ** e
    return 10.0 ** (e + 1)


def ceil_digits(x, digits=2):
    """The smallest whole number at least x (x > 0) with at most ``digits`` significant digits (126.3 -> 130)."""
    unit = 10 ** max(0, math.floor(math.log10(x * (1 - 1e-12))) + 1 - digits)
    return int(math.ceil(x * (1 - 1e-12) / unit) * unit)


def communication_step(scene, nu_top, dt=None, nu_input=None):
    """The FMU's DefaultExperiment stepSize and its verification's step h [s]: T / n with n the smallest of 1, 2,
    5 x 10^m that gives at least :data:`POINTS_PER_PERIOD` points per period of the top of the scene's band
    ``nu_top`` [Hz] and at least 10 steps over T (a whole number of steps, and the same fraction of T for a bar
    and the same bar in other units), and at least ``dt`` (a model's own internal step: a communication step
    shorter than it takes one shortened internal step).

    ``nu_input`` [Hz] given (a model exact in time, :func:`exact_time_step`): ``nu_top`` is then the response's band
    alone, sampled at :data:`OUTPUT_POINTS_PER_PERIOD` points per period, and the input's band ``nu_input`` at
    :data:`POINTS_PER_PERIOD` (the input is what the step approximates: held, or linear between the points); n is
    then that count rounded up to two significant digits (:func:`ceil_digits`), not to 1, 2, 5 x 10^m: such a model
    costs the same per step whatever h, so a count up to 2.5 times the need would cost up to 2.5 times more."""
    steps = 10.0
    if nu_input is not None:
        steps = max(steps, POINTS_PER_PERIOD * nu_input * scene.T, OUTPUT_POINTS_PER_PERIOD * nu_top * scene.T)
        return scene.T / max(1, ceil_digits(steps))      # every step costs the same: no more than 10 % above
    if nu_top > 0:
        steps = max(steps, POINTS_PER_PERIOD * nu_top * scene.T)
    h = scene.T / max(1, int(nice_ceil(steps)))
    return float(max(h, dt) if dt is not None else h)


# Points per period of the top of the response's band for a model exact in time (:func:`exact_time_step`): 2.5 times
# the Nyquist rate.  Its outputs are exact at every point whatever the step, so the points need only sample the band:
# the sum of eq. 3.4 over points above the Nyquist rate is the L2 norm of a band-limited signal (Parseval), and
# a plot of the outputs shows every oscillation of the band.  A finer step is the user's choice at no loss.
OUTPUT_POINTS_PER_PERIOD = 5


def measure_step(scene, problem, ops):
    """The communication step [s] at which packaging measures the accuracy of a model exact in time: the one a
    time-stepped model of the same band takes (:func:`communication_step` of :func:`top_frequency`, 25 points per
    period of the top of the band).  The error of a reduced model lives in the modes it leaves out, above its band;
    sampled at its default step (:func:`exact_time_step`, 5 points per period) a harmonic bar's error modes can
    alias onto the points' zeros, and the unseen sine (at most half the band the step resolves) would be slower:
    measured here, the error and the bounds are seen as every other model's."""
    return communication_step(scene, top_frequency(scene, problem, ops))


def exact_time_step(scene, problem, ops):
    """The default communication step [s] of a model exact in time for a held or linear input (the linear models:
    the matrix exponential over each step): :func:`communication_step` with the input's band (:func:`force_top`,
    :data:`POINTS_PER_PERIOD` points per period) and the response's (:func:`model_band`,
    :data:`OUTPUT_POINTS_PER_PERIOD`), not the :data:`POINTS_PER_PERIOD` points of the response's band that a
    time-stepped model's own error needs: the model's fastest mode sets no step of its own."""
    return communication_step(scene, model_band(scene, problem, ops), nu_input=force_top(scene))


def force_amplitude(scene, nu):
    """A [m s^-2] of the step and the unseen sine (module docstring): the training force's peak |f| at the SPH's
    steps, or 2 pi nu max|v0| for a free scene."""
    peak, _, _ = training_force(scene)
    if peak > 0:
        return peak
    v0 = scene.field("v0", particle_positions(scene.L, scene.sph.n_particles))
    return 2 * math.pi * nu * float(np.max(np.abs(v0)))


def unseen_frequency(scene, step, problem=None):
    """nu_u [Hz] of the unseen sine: :data:`UNSEEN_RATIO` nu_1, and in the band the communication step ``step`` [s]
    resolves (at most 1/(2 POINTS_PER_PERIOD h), half the top of the band it was chosen for); 3 digits."""
    nu_1 = lowest_frequency(problem or build_problem(scene))
    return float(f"{min(UNSEEN_RATIO * nu_1, 1.0 / (2 * POINTS_PER_PERIOD * step)):.3g}")


def unseen_force(scene, step, problem=None):
    """The unseen force's expression in t (module docstring): A sin(2 pi nu_u t) at the communication step ``step``."""
    freq = unseen_frequency(scene, step, problem)
    return f"{force_amplitude(scene, freq):.4g}*sin(2*pi*{freq:g}*t)"


def step_force(scene):
    """The step force's expression, a constant A_s (module docstring): the training force's peak |f| (forced scenes),
    else max|v0| / T (a free scene: a uniform step then moves the bar rigidly to the initial velocity's size by T)."""
    peak, _, _ = training_force(scene)
    if peak > 0:
        return f"{peak:.4g}"
    v0 = scene.field("v0", particle_positions(scene.L, scene.sph.n_particles))
    return f"{float(np.max(np.abs(v0))) / scene.T:.4g}"


def communication_times(scene, step):
    """(times, SPH steps at them): t_j = j h for j = 0, 1, ... while t_j <= T (to 1e-9 relative), and the SPH
    step nearest to each (the same time when h is a whole number of the scene's dt; else at most dt/2 away)."""
    n = int(math.floor(scene.T / step * (1 + 1e-9)))
    t = np.arange(n + 1) * step
    return t, np.minimum(np.round(t / scene.sph.dt).astype(np.int64), step_count(scene.T, scene.sph.dt))


def rows_at(t, sample_dt, rows):
    """The index of the sample nearest each communication point ``t`` [s] among ``rows`` samples taken every
    ``sample_dt`` [s] from 0: a step h shorter than the sampling (a scene's dt longer than the FMU's step)
    names a sample more than once, one longer skips some; never more rows than there are points."""
    return np.minimum(np.round(np.asarray(t, float) / sample_dt).astype(np.int64), rows - 1)


def probe_values(problem, L, probes, fields):
    """The fields (M, N) interpolated linearly at the probes x/L (as the FMU's probe rows)."""
    i0, i1, w = probe_pairs(problem.x, L, np.asarray(probes, float))
    return [a[..., i0] * (1 - w) + a[..., i1] * w for a in fields]


def sph_reference(scene, force, scale, step, probes, problem=None):
    """The full SPH (the compiled loop, the scene's integrator and dt) at the probes: (t, v (M, P), rho (M, P), rho0
    at the probes (P,), wall time [s]).  The benchmarks time it; the verification's truth is :mod:`.truth`.

    ``force`` is an expression in t (the scene's own when it equals its text); ``scale`` multiplies the
    initial velocity v0 (1: the scene's initial state, 0: rest; rho starts at rho0 either way).
    """
    problem = problem or build_problem(scene)
    run_scene = scene if force == scene.f.text else derive_scene(scene, {"force": {"f": force}})
    t, steps = communication_times(scene, step)
    unique, index = np.unique(steps, return_inverse=True)
    run = run_sph(run_scene, sample_steps=unique, progress=False, problem=problem,
                  state=(scale * problem.v0, problem.rho0.copy()))
    v_all, rho_all = run.v[index], run.rho[index]
    v, rho, rho0 = probe_values(problem, scene.L, probes, (v_all, rho_all, problem.rho0))
    return t, v, rho, rho0, run.wall_time


# --------------------------------------------------------------------------------------------------------------
# the FMU's runs
# --------------------------------------------------------------------------------------------------------------
@dataclass
class FMURun:
    """One run of an FMU: probe outputs (M, P), their v bounds (or None), wall times [s], warnings."""

    v: np.ndarray
    rho: np.ndarray
    v_bound: np.ndarray | None
    wall: float
    step_s: float
    warnings: list
    first_s: float = float("nan")     # CPU time [s] of the first doStep alone (part of step_s)


def fmu_case(path, force_values, t, scale=None, interpolate=False):
    """Run the FMU over the communication points ``t`` with f = ``force_values`` there (the FMU driver): an
    :class:`FMURun`.  ``scale`` sets ``initial_state_scale`` (None: the FMU does not have it); ``interpolate`` passes
    df/dt to the next point (fmi2SetRealInputDerivatives).  Raises RuntimeError with the FMU's logged reason when a
    call fails (the instantiation included)."""
    from fmpy.fmi1 import FMICallException

    messages = []
    instance = FMU(path, messages=messages)        # a model.bin the C core refuses: driver.InstantiateError
    with instance as fmu:
        try:
            t0 = time.perf_counter()
            fmu.initialize(parameters={SCALE_NAME: scale}, inputs={"f": float(force_values[0])})
            out = fmu.simulate(t, {"f": force_values}, rates=interpolate)
            wall = time.perf_counter() - t0
        except FMICallException as exc:            # the FMU logged why
            raise RuntimeError("; ".join(fmu.errors()) or str(exc)) from None
        names = fmu.outputs
        warnings = list(fmu.warnings())
        step_s = float(getattr(fmu, "step_seconds", float("nan")))
        first_s = float(getattr(fmu, "first_step_seconds", float("nan")))
    iv, ir, ib = members(names, "v_probe_j"), members(names, "rho_probe_j"), members(names, "v_probe_j_error_bound")
    return FMURun(v=out[:, iv], rho=out[:, ir], v_bound=out[:, ib] if ib else None, wall=wall, step_s=step_s,
                  warnings=warnings, first_s=first_s)


def fmu_run(path, force_values, t, scale=None, interpolate=False, bounds=False):
    """(v (M, P), rho (M, P), wall time [s]) of :func:`fmu_case`; ``bounds``: a fourth element, the FMU's
    v_probe_j_error_bound (M, P), or None when it has none."""
    r = fmu_case(path, force_values, t, scale=scale, interpolate=interpolate)
    return (r.v, r.rho, r.wall, r.v_bound) if bounds else (r.v, r.rho, r.wall)


def case_errors(fmu_v, fmu_rho, sph_v, sph_rho, rho0, t):
    """(err_v, err_rho, max_drho): eq. 3.4, square-root form, of the probe velocities and of rho - rho0 (nan
    when the reference's rho - rho0 is 0 at every probe and time, to 1e-12 of rho0), and the largest
    |rho_FMU - rho_ref| [kg m^-3]."""
    flat = not np.any(np.abs(sph_rho - rho0) > 1e-12 * np.abs(rho0))
    err_rho = float("nan") if flat else relative_l2(fmu_rho, sph_rho, t, baseline=rho0)
    return relative_l2(fmu_v, sph_v, t), err_rho, float(np.max(np.abs(fmu_rho - sph_rho)))


def fmu_features(path):
    """(has initial_state_scale, declares canInterpolateInputs, step [s]) of an FMU file."""
    return fmu_facts(path)[:3]


def fmu_facts(path):
    """(has initial_state_scale, declares canInterpolateInputs, step [s], error_tolerance's start value or nan)."""
    from fmpy import read_model_description

    md = read_model_description(str(path))
    names = {v.name: v for v in md.modelVariables}
    tol = names.get(TOLERANCE_NAME)
    tolerance = float(tol.start) if tol is not None and tol.start is not None else float("nan")
    return SCALE_NAME in names, can_interpolate_inputs(md), float(md.defaultExperiment.stepSize), tolerance


# --------------------------------------------------------------------------------------------------------------
# the truth and the verification
# --------------------------------------------------------------------------------------------------------------
def case_forces(scene, step, problem=None):
    """{case: (force expression, initial state scale, start)} of the three cases (module docstring) at the
    communication step ``step`` [s], when the FMU starts from rest; :func:`references` puts the scene's initial
    state where it cannot."""
    return {"training": (scene.f.text, 1.0, "the scene's initial state"),
            "step": (step_force(scene), 0.0, "rest"),
            "unseen": (unseen_force(scene, step, problem), 0.0, "rest")}


def references(scene, step, probes, has_scale, problem=None, progress=False, interpolate=False):
    """The truth of every case: {name: (force, scale, start, (t, v, rho, rho0, sph wall time))} (shared by every
    model measured on the same scene, probes, step and input mode; ``interpolate``: f linear between the points).
    The wall time is the full SPH's compiled loop over T of the scene's own run, timed now (:func:`sph_cost`)."""
    problem = problem or build_problem(scene)
    cases = case_forces(scene, step, problem)
    if not has_scale:
        cases = {name: (force, 1.0, "the scene's initial state") for name, (force, _, _) in cases.items()}
    t, _ = communication_times(scene, step)
    forces = np.column_stack([np.broadcast_to(compile_expr(f, ("t", "L", "T"), "force")(t=t, L=scene.L, T=scene.T),
                                              t.shape).astype(float) for f, _, _ in cases.values()])
    with progress_bar(1, f"the exact linear SPH for the verification of {scene.name}", unit="run",
                      enabled=progress) as bar:
        v, rho = exact_probe_outputs(problem, probes, t, forces, [s for _, s, _ in cases.values()],
                                     interpolate=interpolate)
        bar.update(1)
    run = cached_sph(scene, error_steps(scene), progress=progress, problem=problem)   # the training run, cached
    sph_s = sph_cost(scene, problem, run.wall_time)
    rho0 = probe_values(problem, scene.L, probes, (problem.rho0,))[0]
    i = list(cases).index("training")
    stepped = stepped_error(scene, problem, probes, run, t, v[:, :, i], rho[:, :, i], rho0)
    return {name: (force, scale, start, (t, v[:, :, i], rho[:, :, i], rho0, sph_s))
            for i, (name, (force, scale, start)) in enumerate(cases.items())} | {"_interpolate": interpolate,
                                                                                 "_stepped_error": stepped,
                                                                                 "_step": step}


def stepped_error(scene, problem, probes, run, t, v_true, rho_true, rho0):
    """The full SPH stepped in time (the scene's own run: its integrator and dt, f at every internal step) against
    the truth of the training case: (err_v, err_rho, points) of eq. 3.4 over the communication points ``t`` where
    the cached run holds a sample at that very time (``points`` of them; nan when fewer than two do: no new run).
    What the FMU's error against the truth leaves out: the stepped SPH's own time-step error, and its f at every
    step against the truth's f held or linear between the points (dominant where f is fast against the points)."""
    steps = np.round(t / scene.sph.dt).astype(np.int64)
    exact = np.abs(steps * scene.sph.dt - t) <= 1e-9 * np.maximum(t, scene.sph.dt)
    where = {int(s): j for j, s in enumerate(np.asarray(run.steps, np.int64))}
    keep = np.flatnonzero(exact & np.isin(steps, list(where)))
    if keep.size < 2:
        return float("nan"), float("nan"), int(keep.size)
    rows = [where[int(s)] for s in steps[keep]]
    v, rho = probe_values(problem, scene.L, probes, (run.v[rows], run.rho[rows]))
    err_v, err_rho, _ = case_errors(v, rho, v_true[keep], rho_true[keep], rho0, t[keep])
    return err_v, err_rho, int(keep.size)


SPH_TIMING = 0.3     # [s] the least wall time of the full SPH's timed run (shorter than T when T takes longer)


def sph_cost(scene, problem, recorded, repeats=1):
    """The CPU time [s] of the full SPH's compiled time loop over the scene's T (:func:`time.thread_time`: what the
    loop cost, not the time other processes took the core), timed now: the scene's own run (its force, integrator
    and dt) over T, or over the first steps that take about :data:`SPH_TIMING` s (``recorded``: the training run's
    recorded wall time over T, which sets how many), scaled to T (the loop's cost per step does not change along
    the run); the median of ``repeats`` runs."""
    n = step_count(scene.T, scene.sph.dt)
    m = n if not recorded > SPH_TIMING else max(1, int(n * SPH_TIMING / recorded))
    short = scene if m == n else dataclasses.replace(scene, T=m * scene.sph.dt)
    times = [run_sph(short, sample_steps=[m], progress=False, problem=problem).cpu_time for _ in range(repeats)]
    return float(np.median(times)) * n / m


COST_REPEATS = 5     # pairs of runs (the FMU, the full SPH) whose median CPU-time ratio is the cost ratio


@dataclass
class Cost:
    """The FMU's cost per simulated second against the full SPH's (:func:`measure_cost`).

    Attributes
    ----------
    fmu_s : float
        CPU time [s] per simulated T of the FMU's doStep calls in steady stepping at its communication step (the
        first call left out and scaled back to every step: :func:`steady_seconds`); the median of the runs.
    sph_s : float
        CPU time [s] of the full SPH's compiled loop per simulated T (:func:`sph_cost`); the median of the runs.
    ratio : float
        The median over the pairs of the ratio FMU / full SPH (< 1: the FMU is cheaper per simulated second).
    setup_s : float
        CPU time [s] of the FMU's first doStep (the median): the work done once per step length (a linear model's
        maps e^{A h}, the bounds' plane maps), then cached for every later step of that length; a setup, as the
        instantiation, not a cost per simulated second.
    steps, sph_steps : int
        Communication steps of the FMU, and time steps of the full SPH, over T.
    repeats : int
        Pairs timed.
    """

    fmu_s: float
    sph_s: float
    ratio: float
    setup_s: float
    steps: int
    sph_steps: int
    repeats: int

    def why(self):
        """What sets the ratio, in words: each one's CPU time per step and steps per T."""
        per = self.fmu_s / max(self.steps, 1)
        sph = self.sph_s / max(self.sph_steps, 1)
        return (f"the FMU's doStep {per * 1e6:.3g} us per step x {self.steps} communication steps per T against "
                f"the full SPH's {sph * 1e6:.3g} us per step x {self.sph_steps} time steps; its one-time setup "
                f"(the first doStep) {self.setup_s * 1e3:.3g} ms")


def steady_seconds(run, steps):
    """The CPU time [s] of an :class:`FMURun`'s ``steps`` doStep calls in steady stepping: those after the first,
    scaled to ``steps`` (the first computes what a step length needs once: :attr:`Cost.setup_s`); the whole
    time for a single step."""
    if steps <= 1 or not run.first_s == run.first_s:
        return run.step_s
    return (run.step_s - run.first_s) * steps / (steps - 1)


def cost_medians(path, scene, verification, problem=None, repeats=COST_REPEATS):
    """(FMU, full SPH, ratio) of :func:`measure_cost`."""
    c = measure_cost(path, scene, verification, problem=problem, repeats=repeats)
    return c.fmu_s, c.sph_s, c.ratio


def measure_cost(path, scene, verification, problem=None, repeats=COST_REPEATS):
    """The :class:`Cost` of the FMU at ``path`` per simulated second, the figure behind packaging's choice, its
    verdict and ``sphrom bench scenes``: the CPU time per simulated T of its doStep calls in steady stepping on the
    training case of ``verification`` (its force and start) at the FMU's default communication step (what a user
    runs it at; :func:`steady_seconds`) and of
    the full SPH's compiled loop (:func:`sph_cost`), each the median of ``repeats`` runs timed in pairs (FMU, SPH,
    FMU, SPH, ...), and the median of the pairs' ratios FMU / SPH: a pair is timed under one load (another process
    on the core's sibling thread slows both; CPU time does not see that), so the ratio varies less than either
    time.  nan for the FMU when it failed."""
    problem = problem or build_problem(scene)
    has_scale, interpolate, default, _ = fmu_facts(path)
    t, _ = communication_times(scene, default)
    expr = compile_expr(verification.refs["training"][0], ("t", "L", "T"), "force")
    f = np.broadcast_to(expr(t=t, L=scene.L, T=scene.T), t.shape).astype(float)
    recorded = cached_sph(scene, error_steps(scene), progress=False, problem=problem).wall_time
    steps = t.size - 1
    fmu, first, sph = [], [], []
    for _ in range(repeats):
        try:
            run = fmu_case(path, f, t, scale=1.0 if has_scale else None, interpolate=interpolate)
            fmu.append(steady_seconds(run, steps))
            first.append(run.first_s)
        except RuntimeError:
            fmu.append(float("nan"))
            first.append(float("nan"))
        sph.append(sph_cost(scene, problem, recorded))
    fmu, sph = np.asarray(fmu), np.asarray(sph)
    return Cost(fmu_s=float(np.median(fmu)), sph_s=float(np.median(sph)),
                ratio=float(np.median(fmu / np.where(sph > 0, sph, np.nan))), setup_s=float(np.median(first)),
                steps=steps, sph_steps=step_count(scene.T, scene.sph.dt), repeats=repeats)


def verify_fmu(path, scene, probes, refs=None, problem=None, progress=False, step=None):
    """Measure the FMU at ``path`` against the truth of ``scene`` (module docstring).

    Parameters
    ----------
    path : path
        The packaged FMU (FMI 2 or 3) of ``scene``.
    scene : Scene
    probes : sequence of float
        The FMU's probes, x/L.
    refs : dict, optional
        :func:`references` already computed for this scene, step and probes (recomputed when its input mode or its
        communication step is not this FMU's: two models of one scene can hold different bands).
    step : float, optional
        The communication step [s] of the measurement (default: the FMU's DefaultExperiment stepSize).  A model
        exact in time is measured at the step a time-stepped model of its band takes (:func:`measure_step`), finer
        than its default: its error and its bounds are then seen at the points that resolve its band, as any other
        model's, while its cost is that of its default step (:func:`measure_cost`).

    Returns
    -------
    Verification
    """
    has_scale, interpolate, default, tolerance = fmu_facts(path)
    step = default if step is None else float(step)
    if refs is None or refs.get("_interpolate") != interpolate or refs.get("_step", step) != step:
        refs = references(scene, step, probes, has_scale, problem=problem, progress=progress, interpolate=interpolate)
    result = Verification(step=step, T=scene.T, input="linear (df/dt)" if interpolate else "held",
                          probes=list(probes), refs=refs, truth=TRUTH_NAME, error_tolerance=tolerance,
                          stepped_error=refs.get("_stepped_error", (float("nan"), float("nan"), 0)),
                          default_step=default)
    for name in CASES:
        force, scale, start, (t, sph_v, sph_rho, rho0, sph_s) = refs[name]
        expr = compile_expr(force, ("t", "L", "T"), "force")
        f = np.broadcast_to(expr(t=t, L=scene.L, T=scene.T), t.shape).astype(float)
        note, run = "", None
        try:
            run = fmu_case(path, f, t, scale=scale if has_scale else None, interpolate=interpolate)
            v, rho = run.v, run.rho
            err_v, err_rho, max_drho = case_errors(v, rho, sph_v, sph_rho, rho0, t)
        except RuntimeError as exc:
            v = rho = np.full_like(sph_v, np.nan)
            err_v = err_rho = max_drho = float("inf")
            note = f"the FMU failed: {exc}"
        result.cases.append(CaseResult(name=name, force=_readable(force), start=start, t=t, fmu_v=v, fmu_rho=rho,
                                       sph_v=sph_v, sph_rho=sph_rho, rho0=rho0, err_v=err_v, err_rho=err_rho,
                                       fmu_s=run.wall if run else float("nan"), sph_s=sph_s, note=note,
                                       max_drho=max_drho, fmu_v_bound=run.v_bound if run else None,
                                       step_s=run.step_s if run else float("nan"),
                                       warnings=run.warnings if run else []))
    return result


def acceptance(verification, accuracy=None, model="frozen"):
    """Packaging's verdict on a verified FMU: None when it passes, else one line (no prefix) naming the case that
    failed, how, and the remedy: the FMU failed or ran away on a case, or its probe v error is above ``accuracy``
    (default :data:`ACCURACY`) on a case."""
    accuracy = ACCURACY if accuracy is None else accuracy
    remedy = ("more modes (--modes), another model (--model exact, or --model auto --tolerance TOL), or a shorter "
              "SPH step (sph.dt)")
    for c in verification.cases:
        if c.note:
            return (f"the {model} FMU failed on the {c.name} case ({c.force} from {c.start}): {c.note}; remedy: "
                    f"{remedy}")
        if not np.all(np.isfinite(c.fmu_v)):
            return f"the {model} FMU ran away on the {c.name} case ({c.force} from {c.start}); remedy: {remedy}"
    for c in verification.cases:
        if not c.err_v <= accuracy:
            return (f"the {model} FMU's probe v error on the {c.name} case ({c.force} from {c.start}), {c.err_v:.3g}, "
                    f"is above the accuracy {accuracy:g} (against {verification.truth or 'the full SPH'}); remedy: "
                    f"{remedy}")
    return None


def _readable(force):
    return " ".join(str(force).split())


def probes_png(verification, title="") -> bytes:
    """documentation/probes.png: FMU (dashed) against the truth (solid) probe velocity, one panel per case; with
    the FMU's certified bounds, the band FMU ± bound (against the full linear SPH: docs/science/error-bounds.md)."""
    import matplotlib
    from matplotlib.figure import Figure          # not pyplot: its import is a second of the packaging's time

    cases = verification.cases
    fig = Figure(figsize=(8, 2.8 * len(cases)))
    axes = fig.subplots(len(cases), 1, squeeze=False, sharex=True)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, c in zip(axes[:, 0], cases):
        for j, x in enumerate(verification.probes):
            colour = colours[j % len(colours)]
            ax.plot(c.t, c.sph_v[:, j], color=colour, lw=1.2, label=f"truth, x/L = {x:g}")
            ax.plot(c.t, c.fmu_v[:, j], color=colour, lw=1.2, ls="--", label=f"FMU, x/L = {x:g}")
            if c.fmu_v_bound is not None:
                ax.fill_between(c.t, c.fmu_v[:, j] - c.fmu_v_bound[:, j], c.fmu_v[:, j] + c.fmu_v_bound[:, j],
                                color=colour, alpha=0.2, lw=0, label="FMU ± certified bound" if j == 0 else None)
        ax.set_ylabel("v [m/s]")
        ax.set_title(f"{c.name} force: f = {c.force} from {c.start}; v error {c.err_v:.2g}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=2, loc="upper right")
    axes[-1, 0].set_xlabel("t [s]")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, metadata={"Software": None})
    return buf.getvalue()
