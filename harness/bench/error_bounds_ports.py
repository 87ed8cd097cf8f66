"""The certified error bounds of port FMUs, measured: open-loop port forces, a coupled mass-spring, f and ports.

``sphrom bench error_bounds_ports [SCENE ...] [--corpus N] [--si-corpus N [--si-seed S]] [--models frozen,exact,balanced] [--span S]
[--out FOLDER] [--report BENCHMARKS.md]`` packages each scene's FMU with ports at x/L = 0.3 and 0.7 (FMI 2, the
scene's defaults, without the a priori bounds) for each model and drives it over S x the scene's T (default 20; at
most T_MAX) at 10 ms communication steps (a user scene's: at most 0.02 / ω1, :func:`sizes`), inputs held, from rest and from the scene's
initial state, in five cases no basis saw (:func:`cases`).  The scenes: built-in scenes or scenes' TOML files, and
``--corpus`` N generated user scenes, the corpus of ``sphrom bench error_bounds --corpus N``
(:func:`sphrom.bench.lib.error_corpus.user_scenes`: unit bars of N 64-128), and ``--si-corpus`` N scenes of the SI
corpus of ``sphrom bench scenes`` (seed ``--si-seed``, default 0: unit, rubber and steel bars of any magnitudes) with
at least :data:`~sphrom.bench.lib.error_corpus.SI_MIN_PARTICLES` particles
(:func:`sphrom.bench.lib.error_corpus.si_scenes`; seed 0: user0_02 steel N 507, user0_03 the graded rubber bar of
tests/data/graded_rubber.toml, user0_04 rubber N 910, ...).

On a built-in scene the cases are those of the unit bar (:data:`UNIT_BAR`): slow port forces (2e-3 sin 1.3t N at port 1, 1e-3 cos 3.1t + 5e-4·[t > T/2] N at port 2), a
constant 1e-3 N at port 1, port 1 coupled to a mass-spring (0.05 kg, 5 N/m, stretched 1 mm at t = 0; the spring
force at the start of a step held over it, :mod:`sphrom.bench.lib.ports`), the same with a dashpot of DAMPER
beside the spring (the undamped loop runs away on an undamped bar whatever model is in it, the damped one does
not: the section prints each loop's spectral radius with the full SPH in the FMU's place), and f = 2e-3 m s^-2
with the slow port forces.  On any other scene (a user's, of any SI magnitudes: a steel bar's
impedance is 10^7 times the unit bar's, its periods a fraction of a millisecond) the same five cases are sized from
the scene's own properties (:func:`sizes`): its lowest elastic frequency ω1 (:func:`sphrom.rom.inputs.band`), its
mass per port area M = Σ ρ0 Δx [kg m^-2] (x the FMU's area, :data:`sphrom.defaults.FMU_AREA`), its impedance
Z = M ω1 / 2π (ρ0 x the wave speed on a uniform bar) and its velocity scale V (the largest |v0|, else a strain of
1e-3 of the wave speed).  The port force unit is F = Z V A (the force that moves a port at about V/2), the
slow forces' frequencies 0.65 ω1 and 1.55 ω1, f = 0.2 V ω1, the lumped mass 5 % of the bar's mass, its spring
tuned to 5 ω1 (inside the band [ω1, 10 ω1] of :func:`~sphrom.rom.inputs.band`), stretched 2 V / (5 ω1) at t = 0, the
dashpot a tenth of the lumped oscillator's critical damping, the communication step at most 0.02 / ω1 (the unit
bar's ω1 h at 10 ms: with coarser steps the sampled loop of a user's stiff bar runs away, even with the dashpot, and
with the full SPH in the FMU's place, :func:`~sphrom.bench.lib.ports.loop_radius`).  On the unit bar (ω1 = 2 s^-1, M = 1 kg m^-2, V = 5e-3
m s^-1) these rules give back the built-in cases within a factor 1.3.  The truth is the full SPH of eqs. 2.10-2.11 as the linear system in J with the port forces
(:func:`sphrom.rom.reference.linear_reference`), advanced exactly in time with the very inputs the FMU received
(the coupled case's port forces as the FMU read them), independent of the reduced models and of the bounds.

Per scene, model, start and case: the communication points where a bound of v_probe_j, rho_probe_j or v_port_j is
below the true error (must be 0); per output the effectivity, the largest bound over the run / the largest true
error over the run, where that error exceeds FLOOR of the output's signal (median and max over the outputs, and
v_port_j's own); false alarms (a velocity bound above error_tolerance while the true velocity errors stayed below a
tenth of it); the largest port error and bound.  Writes ``error_bounds_ports.csv`` into FOLDER and the section
"Certified error bounds: ports and coupled components" of the report (the user scenes' sizes listed below the
table).  Default scenes (without SCENE and --corpus): damped_forced (N = 100), tenmode (N = 400) and high_frequency
(N = 1000, above 500 particles); with --corpus N and no SCENE, the N user scenes alone.
"""

from __future__ import annotations

import sys
from typing import NamedTuple
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import defaults
from ..fmu.make.build import ensure_binaries
from ..fmu.run.driver import FMU
from ..fmu.variables import members
from ..options import int_at_least, positive_float
from ..parser import fmu_models, positive_int
from ..scene import builtin_names, load_scene
from . import machine_text, program_command, program_parser
from .lib.native_cost import COUNT_STEPS, NATIVE_BUDGET, NATIVE_ROUNDS, cost_lines, native_cost
from .lib.document import update_report
from .lib.error_corpus import SI_MIN_PARTICLES, si_scenes, user_scenes
from .lib.stopped import RunStopped, reason
from .lib.ports import MASS, S0, STIFFNESS, coupling_force, loop_radius, mass_spring_step
from .lib.tables import write_csv

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## Certified error bounds: ports and coupled components"
PORTS = (0.3, 0.7)
STEP = 0.01             # [s] the communication step ...
STEP_OMEGA = 0.02       # ... on a user scene at most this / its ω1 (the unit bar's ω1 h = 2 s^-1 x 10 ms)
SPAN = 20.0             # runs over this x the scene's T ...
T_MAX = 200.0           # [s] ... at most this
FLOOR = 1e-9            # effectivity counted where the run's largest error exceeds this x its output's signal
STARTS = (("rest", 0.0), ("initial state", 1.0))
DAMPER = 0.1            # [N s m^-1] the dashpot of the mass-spring-damper case: its loop holds on every built-in scene
DEFAULT_SCENES = ("damped_forced", "tenmode", "high_frequency")
COST_STEP = 1e-3        # [s] the native doStep cost's step (a spring to ground on each port: error_bounds.native_cost),
#                         at most a tenth of the scene's communication step (:func:`step`: a steel bar's T is < 1 ms)


class Coupled(NamedTuple):
    """Port 1 coupled to the lumped mass-spring, with a dashpot of ``damping`` [N s m^-1] beside the spring, of
    ``mass`` [kg] and ``stiffness`` [N m^-1], stretched ``stretch`` [m] at t = 0."""
    damping: float
    mass: float = MASS
    stiffness: float = STIFFNESS
    stretch: float = S0


class Sizes(NamedTuple):
    """The magnitudes of the five cases (:func:`cases`)."""
    force: float        # [N] the slow port force's amplitude at port 1 (port 2: half; the step: a quarter)
    rate: float         # [rad s^-1] the slow forces' frequencies are 0.65 and 1.55 x this
    accel: float        # [m s^-2] f of the last case
    mass: float         # [kg] the lumped mass
    stiffness: float    # [N m^-1] its spring
    stretch: float      # [m] the spring's stretch at t = 0
    damper: float       # [N s m^-1] the dashpot of the mass-spring-damper case
    step: float = STEP  # [s] the communication step


# the built-in scenes' cases (the unit bar: L = 1 m, ρ0 = 1, c = 0.1): the published figures were measured with these
UNIT_BAR = Sizes(force=2e-3, rate=2.0, accel=2e-3, mass=MASS, stiffness=STIFFNESS, stretch=S0, damper=DAMPER)


def sizes(problem, area=None):
    """The cases' :class:`Sizes` from the scene's own properties (module docstring): ω1, M, Z = M ω1 / 2π, V.

    Parameters
    ----------
    problem : SPHProblem
    area : float, optional
        The FMU's cross-section [m^2] (default :data:`sphrom.defaults.FMU_AREA`).
    """
    from ..rom.inputs import band
    area = defaults.FMU_AREA if area is None else float(area)
    w1 = band(problem)[0]                                            # [rad s^-1]
    M = float(np.sum(problem.rho0)) * problem.neighbours.dx          # [kg m^-2]
    Z = M * w1 / (2 * np.pi)                                         # [kg m^-2 s^-1]
    V = float(np.max(np.abs(problem.v0)))                            # [m s^-1]
    if not V > 0:
        V = 1e-3 * w1 * problem.scene.L / (2 * np.pi)                # a strain of 1e-3 of the wave speed
    mass = 0.05 * M * area
    w_s = 5.0 * w1
    stiffness = mass * w_s ** 2
    return Sizes(force=Z * V * area, rate=w1, accel=0.2 * V * w1, mass=mass, stiffness=stiffness,
                 stretch=2.0 * V / w_s, damper=0.1 * 2.0 * np.sqrt(stiffness * mass), step=min(STEP, STEP_OMEGA / w1))


def cases(t, T, size=UNIT_BAR):
    """{case: (f (M,) [m s^-2], port forces (M, 2) [N] or :class:`Coupled` for port 1 tied to the lumped mass)}
    of the magnitudes ``size`` (:class:`Sizes`; default the built-in scenes' :data:`UNIT_BAR`)."""
    a, w = size.force, size.rate
    slow = np.stack([a * np.sin(0.65 * w * t), a / 2 * np.cos(1.55 * w * t) + a / 4 * (t > T / 2)], axis=1)
    constant = np.stack([np.full_like(t, a / 2), np.zeros_like(t)], axis=1)
    zero = np.zeros_like(t)
    lumped = dict(mass=size.mass, stiffness=size.stiffness, stretch=size.stretch)
    return {"slow port forces": (zero, slow), f"constant {_e(a / 2)} N at port 1": (zero, constant),
            "port 1 coupled to a mass-spring": (zero, Coupled(0.0, **lumped)),
            "port 1 coupled to a mass-spring-damper": (zero, Coupled(size.damper, **lumped)),
            f"f = {_e(size.accel)} and slow port forces": (zero + size.accel, slow)}


def _e(x):
    """x in a case's name: 3 significant digits as 1e-3, 7.94e-4."""
    m, e = f"{x:.2e}".split("e")
    return f"{m.rstrip('0').rstrip('.')}e{int(e)}"


def sizes_line(name, size):
    """The report's line of one user scene's case sizes."""
    return (f"{name}: {size.step * 1e3:.4g} ms steps, port force {_e(size.force)} N at ω1 = {size.rate:.4g} rad/s, f {_e(size.accel)} m/s², lumped "
            f"mass {_e(size.mass)} kg on {_e(size.stiffness)} N/m (at {np.sqrt(size.stiffness / size.mass):.4g} "
            f"rad/s) stretched {_e(size.stretch)} m, dashpot {_e(size.damper)} N s/m")


def run_fmu(path, t, scale, f, F):
    """(outputs (M, n), names, the port forces applied (M, 2) [N], warnings, error_tolerance) of the FMU at ``path``
    driven over ``t``; ``F`` a :class:`Coupled`: port 1 coupled to the mass-spring(-damper), port 2 free.  Raises
    :class:`RunStopped`
    (with the FMU's logged reason) when the FMU returns an error status."""
    from fmpy.fmi1 import FMICallException
    applied = np.zeros((t.size, len(PORTS)))
    messages = []
    try:
        return _run_fmu(path, t, scale, f, F, applied, messages)
    except FMICallException as exc:               # the FMU stopped the run (an error status): say why
        raise RunStopped(reason(messages, exc)) from None


def _run_fmu(path, t, scale, f, F, applied, messages):
    with FMU(path, messages=messages) as fmu:
        names = fmu.outputs
        fmu.initialize(parameters={"initial_state_scale": scale}, inputs={"f": float(f[0])})
        if not isinstance(F, Coupled):
            applied[:] = F
            y = fmu.simulate(t, {"f": f, **{f"F_port_{j + 1}": F[:, j] for j in range(len(PORTS))}})
        else:
            lumped = [np.array([F.stretch, 0.0])]
            at = names.index("v_port_1")
            h = float(t[1] - t[0])

            def spring(j, tj, y):
                if j:
                    lumped[0] = mass_spring_step(lumped[0], feedback_v[0], h, F.damping, mass=F.mass,
                                                 stiffness=F.stiffness)
                feedback_v[0] = y[at]
                applied[j, 0] = coupling_force(lumped[0], feedback_v[0], F.damping, stiffness=F.stiffness)
                return {"F_port_1": applied[j, 0]}

            feedback_v = [0.0]
            y = fmu.simulate(t, {"f": f}, feedback=spring)
        warned, tol = fmu.warnings(), fmu.get_real([fmu.vr["error_tolerance"]])[0]
    return y, names, applied, warned, tol


def truth(problem, t, scale, f, applied):
    """(v at the probes (M, P), ρ at the probes (M, P), v_port (M, 2)) of the full linear SPH with the inputs held
    over each step from ``scale`` x the scene's initial state (scale 0 or 1)."""
    from ..rom.lti import probe_matrix
    from ..rom.reference import linear_reference
    h = float(t[1] - t[0])
    index = lambda tt: np.minimum(np.floor(np.asarray(tt, float) / h + 1e-9).astype(int), t.size - 1)
    _, v, v_port, e = linear_reference(problem, PORTS, t[-1], h, force=lambda tt: f[index(tt)],
                                       port_forces=lambda tt: applied[index(tt)], state=bool(scale),
                                       specific_volume=True)
    rows = probe_matrix(problem.x, problem.scene.L, defaults.PROBES, np.ones(problem.n))
    return v @ rows.T, (problem.rho0 / (1.0 + e)) @ rows.T, v_port


def compare(y, names, v, rho, v_port, warned, tol):
    """(violations, points, effectivities of every output (nan where not counted), v_port's, max port error, max
    port bound, false alarm) of one run (module docstring)."""
    col = lambda name: y[:, members(names, name)]
    errors = [np.abs(col("v_probe_j") - v), np.abs(col("rho_probe_j") - rho), np.abs(col("v_port_j") - v_port)]
    bounds = [col("v_probe_j_error_bound"), col("rho_probe_j_error_bound"), col("v_port_j_error_bound")]
    signals = [np.abs(v), np.abs(rho), np.abs(v_port)]
    bad = np.zeros(y.shape[0], bool)
    effs = []
    for e, b, s in zip(errors, bounds, signals):
        bad |= np.any(b < e, axis=1)
        em, bm, sm = e.max(axis=0), b.max(axis=0), s.max(axis=0)
        effs.append(np.where((em > FLOOR * sm) & (em > 0), bm / np.where(em > 0, em, 1.0), np.nan))
    v_err = max(float(errors[0].max()), float(errors[2].max()))
    alarm = bool(warned) and v_err < 0.1 * tol
    return (int(bad.sum()), y.shape[0], np.concatenate(effs), effs[2], float(errors[2].max()), float(bounds[2].max()),
            alarm)


def measure_scene(scene, models, folder, span=SPAN, progress=True, repeats=3):
    """Rows (one per model, start and case) of ``scene`` (a built-in scene's name, or a Scene: a built-in scene runs
    the :data:`UNIT_BAR` cases, any other the cases of its :func:`sizes`)."""
    from ..fmu.make.package import package_fmu
    from ..sph.solver import build_problem
    if isinstance(scene, str):
        scene = load_scene(scene)
    name = scene.name
    problem = build_problem(scene)
    size = UNIT_BAR if name in builtin_names() else sizes(problem)
    h = size.step
    T = min(span * scene.T, T_MAX)
    t = np.arange(int(round(T / h)) + 1) * h
    binaries = ensure_binaries(quiet=True)
    radius = {}                                        # the coupled cases' loops with the full SPH in them
    rows = []
    for model in models:
        path = Path(folder) / f"{name}-{model}-ports.fmu"
        try:
            s = package_fmu(scene, path, model=model, fmi=2, progress=progress, binaries=binaries, problem=problem,
                            bounds=False, ports=list(PORTS))
        except Exception as exc:                     # a model that does not build on this scene: say so
            rows.append({"scene": name, "model": model, "note": str(exc).splitlines()[0]})
            continue
        native = native_cost(path, repeats, h=min(COST_STEP, h / 10))
        cost = native.row() if native else {}
        for start, scale in STARTS:
            for case, (f, F) in cases(t, T, size).items():
                loop = None
                if isinstance(F, Coupled):
                    if F not in radius:
                        radius[F] = loop_radius(problem, PORTS[0], h, F.damping, mass=F.mass, stiffness=F.stiffness)
                    loop = radius[F]
                try:
                    y, names, applied, warned, tol = run_fmu(path, t, scale, f, F)
                except RunStopped as exc:            # e.g. an explicit loop that runs away with any model in it
                    note = f"the run stopped: {exc}"
                    if loop is not None and loop > 1.0 + 1e-12:
                        note += (f"; the loop itself runs away at {h * 1e3:g} ms steps: with the full SPH in the "
                                 f"FMU's place it grows by {loop:.6g} per step (bench/lib/ports.py loop_radius)")
                    rows.append({"scene": name, "model": model, "N": problem.n, "start": start, "case": case,
                                 "loop_radius": loop, "note": note})
                    continue
                bad, points, eff, eff_port, max_err, max_bound, alarm = compare(
                    y, names, *truth(problem, t, scale, f, applied), warned, tol)
                counted, port = eff[np.isfinite(eff)], eff_port[np.isfinite(eff_port)]
                rows.append({"scene": name, "model": model, "N": problem.n, "k_v": s.k_v, "k_rho": s.k_rho,
                             "shadow_order": s.shadow_order, "start": start, "case": case, "violations": bad,
                             "points": points, "counted": int(counted.size), "outputs": int(eff.size),
                             "effectivities": " ".join(f"{x:.4g}" for x in eff),
                             "eff_median": float(np.median(counted)) if counted.size else float("nan"),
                             "eff_max": float(counted.max()) if counted.size else float("nan"),
                             "port_eff_max": float(port.max()) if port.size else float("nan"),
                             "false_alarm": alarm, "max_port_err": max_err, "max_port_bound": max_bound,
                             "loop_radius": loop, **cost, "note": ""})
    return rows


def _g(x, spec=".3g"):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else format(x, spec)


def section(rows, *, command, wall, machine, sized=()):
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall; `validation/benchmarks/error_bounds_ports.csv`). "
             f"Each scene's FMU with ports at x/L = {', '.join(f'{x:g}' for x in PORTS)} (FMI 2, the scene's "
             f"defaults) over min(span x T, {T_MAX:g} s) at {STEP * 1e3:g} ms steps (a user scene's at most {STEP_OMEGA:g} / ω1), inputs held, from rest and from the "
             "scene's initial state, in five cases no basis saw (harness/bench/error_bounds_ports.py `cases`: slow "
             "port forces, a constant port force, port 1 coupled to a mass-spring, the same with a dashpot of "
             f"{DAMPER:g} N s/m beside the spring, f with slow port forces; on a user scene the same cases sized "
             "from the scene's lowest frequency, mass, impedance and velocity scale: `sizes`, listed below the "
             "table). Truth: "
             "the full SPH of eqs. 2.10-2.11, linear in J, with the port forces the FMU received, exact in time. "
             "Violations: points where a bound of v_probe_j, rho_probe_j or v_port_j is below its true error. "
             "Effectivity: per output (v_probe_j, rho_probe_j, v_port_j) the largest bound over the run / the largest "
             f"true error over the run, where that error exceeds {FLOOR:g} of the output's signal (median and max over "
             "the run's counted outputs, and v_port_j's largest). False alarms: runs that warned while their true "
             "velocity errors stayed below a tenth of error_tolerance. Native doStep ratio: each FMU in the native "
             "FMI 2 master (fmu_src/tests/step_cost.c: per step fmi2SetReal of f and of each F_port_j, a spring to "
             "ground on each port, fmi2DoStep, fmi2GetReal of the outputs) against the same FMU without the bounds' "
             f"sections, {COST_STEP * 1e3:g} ms steps (at most a tenth of the communication step), thread CPU time, "
             "the three back to back in each round, the median of the rounds' ratios "
             f"(at least --repeats, up to {NATIVE_ROUNDS} while they take less than {NATIVE_BUDGET:g} s); and its "
             "instructions per step (callgrind, the difference of runs of "
             f"{COUNT_STEPS[1]} and "
             f"{COUNT_STEPS[0]} steps), which the load of a shared machine does not move.", "",
             "| scene | model | N, k_v, k_ρ, shadow | start | case | violations | effectivity median | max | "
             "v_port max | false alarm | max v_port error [m/s] | max v_port bound [m/s] |",
             "| --- | --- | --- | --- | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: |"]
    for r in rows:
        if r.get("note") and r.get("case"):
            lines.append(f"| {r['scene']} | {r['model']} | {r['N']} | {r['start']} | {r['case']} | "
                         f"{r['note'].replace('|', '/')} | — | — | — | — | — | — |")
            continue
        if r.get("note"):
            lines.append(f"| {r['scene']} | {r['model']} | — | — | — | not built: {r['note'].replace('|', '/')} | — | — | — | — | — "
                         "| — |")
            continue
        lines.append(f"| {r['scene']} | {r['model']} | {r['N']}, {r['k_v']}, {r['k_rho']}, {r['shadow_order']} | "
                     f"{r['start']} | {r['case']} | {r['violations']} / {r['points']} | {_g(r['eff_median'])} | "
                     f"{_g(r['eff_max'])} | {_g(r['port_eff_max'])} | {'yes' if r['false_alarm'] else 'no'} | "
                     f"{_g(r['max_port_err'], '.2e')} | {_g(r['max_port_bound'], '.2e')} |")
    built = [r for r in rows if not r.get("note")]
    if built:
        every = np.array([float(x) for r in built for x in r["effectivities"].split()])
        every = every[np.isfinite(every)]
        lines += ["", f"In all: violations {sum(r['violations'] for r in built)} of "
                      f"{sum(r['points'] for r in built)} communication points; false alarms "
                      f"{sum(r['false_alarm'] for r in built)} of {len(built)} runs; effectivity median "
                      f"{_g(float(np.median(every)) if every.size else float('nan'))}, max "
                      f"{_g(float(every.max()) if every.size else float('nan'))} over {every.size} outputs."]
    lines += cost_lines(built)
    if sized:
        lines += ["", "The user scenes' cases, sized from each scene's own properties (`sizes`): "
                      + "; ".join(sized) + "."]
    stopped = [r for r in rows if r.get("note") and r.get("case")]
    if stopped:
        lines += ["", f"Runs the FMU stopped with an error (not counted above): {len(stopped)}."]
    radii = {}
    for r in rows:
        if r.get("loop_radius") is not None:
            radii.setdefault(r["scene"], {})[r["case"]] = r["loop_radius"]
    if radii:
        lines += ["", "The coupled cases' loops with the full SPH (linear in J, exact over each step) in the FMU's "
                      "place, their spectral radius per step (bench/lib/ports.py `loop_radius`; above 1 the loop "
                      "itself runs away at the communication step, whatever model stands in for the bar), "
                      "mass-spring / mass-spring-damper: "
                      + ", ".join(f"{k} " + " / ".join(f"{x:.6g}" for x in v.values()) for k, v in radii.items())
                      + "."]
    return lines + [""]


def scene_names(scenes, corpus):
    """The SCENE arguments to measure: those given; none given, :data:`DEFAULT_SCENES` without a corpus and none
    with one (the corpus alone; ``corpus``: --corpus or --si-corpus)."""
    return list(scenes) or ([] if corpus else list(DEFAULT_SCENES))


def main(argv=None):
    p = program_parser("error_bounds_ports", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help=f"a built-in scene or a scene's TOML file (default: {' '.join(DEFAULT_SCENES)}; none "
                        "where --corpus or --si-corpus is given)")
    p.add_argument("--corpus", type=int_at_least(0), default=0, metavar="N",
                   help="also N generated user scenes, those of `sphrom bench error_bounds --corpus N`, their cases "
                        "sized from their own properties (default 0)")
    p.add_argument("--si-corpus", type=int_at_least(0), default=0, metavar="N",
                   help="also the first N scenes of the SI corpus of `sphrom bench scenes` (unit, rubber and steel "
                        f"bars) with at least {SI_MIN_PARTICLES} particles, their cases sized from their own "
                        "properties (default 0)")
    p.add_argument("--si-seed", type=int_at_least(0), default=0, metavar="S",
                   help="the SI corpus's seed (default 0)")
    p.add_argument("--models", type=fmu_models, default="frozen,exact,balanced", metavar="M1,M2")
    p.add_argument("--span", type=positive_float, default=SPAN, metavar="S", help="runs over S x the scene's T (default 20, "
                   f"at most {T_MAX:g} s)")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--repeats", type=positive_int, default=3, metavar="R",
                   help="rounds of the native doStep cost per FMU at least (default 3; up to "
                        f"{NATIVE_ROUNDS} while they take less than {NATIVE_BUDGET:g} s)")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    names = scene_names(args.scenes, args.corpus or args.si_corpus)
    unknown = [s for s in names if s not in builtin_names() and not Path(s).is_file()]
    if unknown:
        p.error(f"SCENE: {unknown[0]!r} is neither a built-in scene nor a file (built-in: "
                f"{', '.join(builtin_names())})")
    scenes = [load_scene(s) for s in names] + user_scenes(args.corpus) + si_scenes(args.si_corpus, args.si_seed)
    models = args.models
    t0 = time.perf_counter()
    rows, sized = [], []
    with tempfile.TemporaryDirectory(prefix="sphrom-error-bounds-ports-") as folder:
        for scene in scenes:
            got = measure_scene(scene, models, folder, span=args.span, progress=not args.quiet, repeats=args.repeats)
            if scene.name not in builtin_names():
                from ..sph.solver import build_problem
                sized.append(sizes_line(scene.name, sizes(build_problem(scene))))
                print(sized[-1], flush=True)
            rows += got
            for r in got:
                if r.get("note"):
                    where = f"{r['start']:14s} {r['case']:32s} " if r.get("case") else "not built: "
                    print(f"{r['scene']:14s} {r['model']:9s} {where}{r['note']}", flush=True)
                    continue
                print(f"{r['scene']:14s} {r['model']:9s} {r['start']:14s} {r['case']:38s} violations "
                      f"{r['violations']}, effectivity median {_g(r['eff_median'])} max {_g(r['eff_max'])} (v_port "
                      f"{_g(r['port_eff_max'])}), false alarm {r['false_alarm']}", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "error_bounds_ports.csv", rows)
    update_report(args.report, {SECTION_HEADING: section(rows, command=program_command("error_bounds_ports", argv),
                                                         wall=wall, machine=machine_text(), sized=sized)})
    print(f"wrote {out / 'error_bounds_ports.csv'} and the section of {args.report}")
    return 0 if all(r.get("note") or r["violations"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
