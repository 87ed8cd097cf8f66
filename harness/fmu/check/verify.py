"""A packaged FMU measured against the full SPH it was trained on (``sphrom fmu``'s verification).

Two cases, both over the scene's T at the FMU's default communication step
h (its DefaultExperiment stepSize):

- ``training``: the scene's own force f(t) and initial state (the FMU's
  ``initial_state_scale`` set to 1 where it has that parameter): the run the
  POD basis was made from;
- ``unseen``: f_u(t) = A sin(2 pi nu t) with nu = :data:`UNSEEN_FREQUENCY`
  (0.7 Hz: no tone of a built-in scene's force, which are 10 l / T rad/s,
  l = 1, 3, 10, i.e. 0.16, 0.48 and 1.6 Hz at T = 10 s, and inside their band)
  and A = the training force's peak |f| on [0, T] (forced scenes), else
  2 pi nu max|v0| (free scenes: the forced velocity swing of a uniform force
  is then of the initial velocity's size); from rest where the FMU has
  ``initial_state_scale`` (set to 0, the full SPH starts at v = 0, rho = rho0),
  else from the scene's initial state in both.

The FMU gets f at each communication point, held over the step, or with df/dt
(the slope to the next point) when it declares ``canInterpolateInputs`` (FMI 2,
linear models): what ``sphrom cosim`` does by default.  The full SPH is the
compiled loop of :func:`sphrom.sph.solver.run_sph` with f(t) at every internal
step.  Errors: the relative L2 error of eq. 3.4 (square-root form, trapezoidal
in time, summed over the probes) of the probe velocities, and of the probe
densities as rho - rho0.  Times: one run each, setup excluded on both sides:
the FMU's is its run through fmpy on an instantiated FMU (initialize, every
set input, doStep and output read: Python's per-step overhead included), the
full SPH's its compiled time loop (``SPHResult.wall_time``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

UNSEEN_FREQUENCY = 0.7                 # nu of the unseen force [Hz]
SCALE_NAME = "initial_state_scale"     # the FMU's parameter (harness/fmu/variables.py)


@dataclass
class CaseResult:
    """One force case: the FMU and the full SPH at the probes, at the communication points.

    Attributes
    ----------
    name : str
        ``training`` or ``unseen``.
    force : str
        f(t) as an expression in t [m s^-2].
    start : str
        ``the scene's initial state`` or ``rest``.
    t : ndarray (M,)
        Communication points [s].
    fmu_v, sph_v : ndarray (M, P)
        Probe velocities [m s^-1].
    fmu_rho, sph_rho : ndarray (M, P)
        Probe densities [kg m^-3].
    rho0 : ndarray (P,)
        Rest density at the probes [kg m^-3].
    err_v, err_rho : float
        Eq. 3.4 (square-root form) of v and of rho - rho0 over probes and time (inf when the FMU failed;
        err_rho nan when the full SPH's rho - rho0 is 0 at the probes, where a relative error has no meaning:
        a uniform force from rest moves the bar rigidly).
    max_drho : float
        The largest |rho_FMU - rho_SPH| at the probes [kg m^-3].
    fmu_s, sph_s : float
        Wall times [s] of one FMU run and one full SPH run over T.
    note : str
        The FMU's error message when it failed, else ''.
    fmu_v_bound : ndarray (M, P) or None
        The FMU's certified bounds of its probe velocities (``v_probe_j_error_bound``; None without them).
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

    @property
    def speedup(self):
        """Full SPH time / FMU time (> 1: the FMU is faster)."""
        return self.sph_s / self.fmu_s if self.fmu_s > 0 else float("inf")


@dataclass
class Verification:
    """The measurement of one FMU (see the module docstring)."""

    step: float                  # communication step h [s]
    T: float                     # horizon [s]
    input: str                   # "held" or "linear (df/dt)"
    probes: list                 # x/L
    cases: list = field(default_factory=list)
    refs: dict = field(default=None, repr=False)   # the full SPH runs (:func:`references`), to reuse
    channels: list = field(default_factory=list)   # every input channel (:mod:`.channels`), when measured

    def case(self, name):
        return next(c for c in self.cases if c.name == name)

    @property
    def training(self):
        return self.case("training")

    @property
    def unseen(self):
        return self.case("unseen")

    def sentence(self):
        """The short text stored in the modelDescription's description."""
        tr, un = self.training, self.unseen
        return (f"Measured against the full SPH at the probes (h = {self.step:g} s, T = {self.T:g} s, eq. 3.4): "
                f"v error {tr.err_v:.2g} on the training force, {un.err_v:.2g} on an unseen force "
                f"({un.force}, from {un.start}); run time {tr.fmu_s:.3g} s against {tr.sph_s:.3g} s for the "
                f"full SPH ({tr.speedup:.3g}x){self.channel_sentence()}; see documentation/index.html.")

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
                 "max_drho": c.max_drho, "fmu_s": c.fmu_s, "sph_s": c.sph_s, "speedup": c.speedup, "note": c.note} for c in self.cases]


def unseen_force(scene, step):
    """The unseen force's expression in t (module docstring): A sin(2 pi nu t)."""
    t = np.arange(int(round(scene.T / step)) + 1) * step
    peak = float(np.max(np.abs(scene.force(t))))
    if peak > 0:
        amplitude = peak
    else:
        from ...sph.operator import particle_positions
        v0 = scene.field("v0", particle_positions(scene.L, scene.sph.n_particles))
        amplitude = 2 * math.pi * UNSEEN_FREQUENCY * float(np.max(np.abs(v0)))
    return f"{amplitude:.4g}*sin(2*pi*{UNSEEN_FREQUENCY:g}*t)"


def communication_times(scene, step):
    """(times, SPH steps at them): t_j = j h for j = 0, 1, ... while t_j <= T (to 1e-9 relative), and the SPH
    step nearest to each (the same time when h is a whole number of the scene's dt, as in every built-in
    scene; else at most dt/2 away)."""
    from ...sph.solver import step_count
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
    from ..resources import probe_pairs
    i0, i1, w = probe_pairs(problem.x, L, np.asarray(probes, float))
    return [a[..., i0] * (1 - w) + a[..., i1] * w for a in fields]


def sph_reference(scene, force, scale, step, probes, problem=None):
    """The full SPH at the probes: (t, v (M, P), rho (M, P), rho0 at the probes (P,), wall time [s]).

    ``force`` is an expression in t (the scene's own when it equals its text); ``scale`` multiplies the
    initial velocity v0 (1: the scene's initial state, 0: rest; rho starts at rho0 either way).
    """
    from ...scene import derive_scene
    from ...sph.solver import build_problem, run_sph
    problem = problem or build_problem(scene)
    run_scene = scene if force == scene.f.text else derive_scene(scene, {"force": {"f": force}})
    t, steps = communication_times(scene, step)
    # the SPH's samples are its steps, each once: a communication step shorter than the scene's dt names some
    # step twice (dt = 0.02 s, h = 0.01 s: steps 0, 0, 1, 1, 2, ...), and the rows follow the points again below
    unique, index = np.unique(steps, return_inverse=True)
    if run_scene is scene and scale == 1.0:
        # the training run itself (the scene's force from its initial state): the cached run the model was
        # trained on, with the communication points stored (run once when they are not); its wall time is that
        # run's, as recorded when it was made
        from ...cache import cached_sph
        from ...pod.pipeline import on_steps
        run = cached_sph(scene, steps, progress=False, problem=problem)
        v_all, rho_all = on_steps(run, unique)
    else:
        run = run_sph(run_scene, sample_steps=unique, progress=False, problem=problem,
                      state=(scale * problem.v0, problem.rho0.copy()))
        v_all, rho_all = run.v, run.rho
    v_all, rho_all = v_all[index], rho_all[index]
    v, rho, rho0 = probe_values(problem, scene.L, probes, (v_all, rho_all, problem.rho0))
    return t, v, rho, rho0, run.wall_time


def fmu_run(path, force_values, t, scale=None, interpolate=False, bounds=False):
    """Run the FMU over the communication points ``t`` with f = ``force_values`` there (the FMU driver).

    Returns (v (M, P), rho (M, P), wall time [s]).  ``scale`` sets ``initial_state_scale`` (None: the FMU does
    not have it); ``interpolate`` passes df/dt to the next point (fmi2SetRealInputDerivatives).  The time is
    initialization and the loop (every set input, doStep and output read).  Raises RuntimeError with the FMU's
    logged reason when a call fails.  ``bounds``: a fourth element, the FMU's v_probe_j_error_bound (M, P), or None
    when it has none.
    """
    from fmpy.fmi1 import FMICallException

    from ..run.driver import FMU
    from ..variables import members
    with FMU(path) as fmu:
        try:
            t0 = time.perf_counter()
            fmu.initialize(parameters={SCALE_NAME: scale}, inputs={"f": float(force_values[0])})
            out = fmu.simulate(t, {"f": force_values}, rates=interpolate)
            wall = time.perf_counter() - t0
        except FMICallException as exc:            # the FMU logged why
            raise RuntimeError("; ".join(fmu.errors()) or str(exc)) from None
        names = fmu.outputs
    iv, ir, ib = members(names, "v_probe_j"), members(names, "rho_probe_j"), members(names, "v_probe_j_error_bound")
    if bounds:
        return out[:, iv], out[:, ir], wall, (out[:, ib] if ib else None)
    return out[:, iv], out[:, ir], wall


def case_errors(fmu_v, fmu_rho, sph_v, sph_rho, rho0, t):
    """(err_v, err_rho, max_drho): eq. 3.4, square-root form, of the probe velocities and of rho - rho0 (nan
    when the full SPH's rho - rho0 is 0 at every probe and time), and the largest |rho_FMU - rho_SPH|
    [kg m^-3]."""
    from ...norms import relative_l2
    flat = not np.any(sph_rho - rho0)
    err_rho = float("nan") if flat else relative_l2(fmu_rho, sph_rho, t, baseline=rho0)
    return relative_l2(fmu_v, sph_v, t), err_rho, float(np.max(np.abs(fmu_rho - sph_rho)))


def fmu_features(path):
    """(has initial_state_scale, declares canInterpolateInputs, step [s], probes x/L) of an FMU file."""
    from fmpy import read_model_description

    from ..run.driver import can_interpolate_inputs
    md = read_model_description(str(path))
    names = {v.name for v in md.modelVariables}
    return SCALE_NAME in names, can_interpolate_inputs(md), float(md.defaultExperiment.stepSize)


def references(scene, step, probes, has_scale, problem=None, progress=False):
    """The full SPH of both cases: {name: (force, scale, start, (t, v, rho, rho0, wall))} (shared by every model
    measured on the same scene, probes and step)."""
    from ...progress import progress_bar
    from ...sph.solver import build_problem
    problem = problem or build_problem(scene)
    unseen = unseen_force(scene, step)
    cases = {"training": (scene.f.text, 1.0, "the scene's initial state"),
             "unseen": (unseen, 0.0 if has_scale else 1.0, "rest" if has_scale else "the scene's initial state")}
    out = {}
    with progress_bar(len(cases), f"full SPH for the verification of {scene.name}", unit="run",
                      enabled=progress) as bar:
        for name, (force, scale, start) in cases.items():
            out[name] = (force, scale, start, sph_reference(scene, force, scale, step, probes, problem=problem))
            bar.update(1)
    return out


def verify_fmu(path, scene, probes, refs=None, problem=None, progress=False):
    """Measure the FMU at ``path`` against the full SPH of ``scene`` (module docstring).

    Parameters
    ----------
    path : path
        The packaged FMU (FMI 2 or 3) of ``scene``.
    scene : Scene
    probes : sequence of float
        The FMU's probes, x/L.
    refs : dict, optional
        :func:`references` already computed for this scene, step and probes.

    Returns
    -------
    Verification
    """
    from ...expr import compile_expr
    has_scale, interpolate, step = fmu_features(path)
    refs = refs or references(scene, step, probes, has_scale, problem=problem, progress=progress)
    result = Verification(step=step, T=scene.T, input="linear (df/dt)" if interpolate else "held",
                          probes=list(probes), refs=refs)
    for name, (force, scale, start, (t, sph_v, sph_rho, rho0, sph_s)) in refs.items():
        expr = compile_expr(force, ("t", "L", "T"), "force")
        f = np.broadcast_to(expr(t=t, L=scene.L, T=scene.T), t.shape).astype(float)
        note, v_bound = "", None
        try:
            v, rho, fmu_s, v_bound = fmu_run(path, f, t, scale=scale if has_scale else None, interpolate=interpolate,
                                             bounds=True)
            err_v, err_rho, max_drho = case_errors(v, rho, sph_v, sph_rho, rho0, t)
        except RuntimeError as exc:
            v = rho = np.full_like(sph_v, np.nan)
            err_v = err_rho = max_drho = float("inf")
            fmu_s, note = float("nan"), f"the FMU failed: {exc}"
        result.cases.append(CaseResult(name=name, force=_readable(force), start=start, t=t, fmu_v=v, fmu_rho=rho,
                                       sph_v=sph_v, sph_rho=sph_rho, rho0=rho0, err_v=err_v, err_rho=err_rho,
                                       fmu_s=fmu_s, sph_s=sph_s, note=note, max_drho=max_drho,
                                       fmu_v_bound=v_bound))
    return result


def _readable(force):
    return " ".join(str(force).split())


def probes_png(verification, title="") -> bytes:
    """documentation/probes.png: FMU (dashed) against the full SPH (solid) probe velocity, one panel per case; with
    the FMU's certified bounds, the band FMU ± bound (against the full linear SPH: docs/science/error-bounds.md)."""
    import io

    import matplotlib
    from matplotlib.figure import Figure          # not pyplot: its import is a second of the packaging's time

    cases = verification.cases
    fig = Figure(figsize=(8, 2.8 * len(cases)))
    axes = fig.subplots(len(cases), 1, squeeze=False, sharex=True)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, c in zip(axes[:, 0], cases):
        for j, x in enumerate(verification.probes):
            colour = colours[j % len(colours)]
            ax.plot(c.t, c.sph_v[:, j], color=colour, lw=1.2, label=f"full SPH, x/L = {x:g}")
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
