"""Model kind 1 of ``resources/model.bin``: the frozen-coefficient model (eqs. 2.19-2.24), advanced by internal steps.

The kind's data (:class:`ModelData`), its part of the file (its own header: integrator, n_pairs, the default
n_freeze, dt; its arrays, :data:`sphrom.fmu.layout.KINDS`), its build options (``n_freeze``, ``dt``,
``integrator``: only this kind has them), its packaging step, its words, and its co-simulation in Python that the
C core (fmu_src/rom_frozen.c) must equal bit for bit.

:func:`cosim_reference` drives the compiled loop of the frozen model
(:func:`sphrom.rom.frozen.frozen_advance`, the same loop as
``get_model("frozen").run``) communication step by communication step,
with the FMU's rules (fmu_src/rom.c ``rom_do_step``):

* the input f is held over each communication step, or, with an input
  derivative (``rate``, fmi2SetRealInputDerivatives), taken as
  f + rate τ at each refresh of the force term, τ = j Δt the time of internal
  step j after the communication point (the shortened step: τ = n_full Δt),
  in the C order of operations: f + rate (τ0 + j h);
* the port forces F_port_j [N] likewise: held, or with their derivatives
  (``port_rates``) F_j + rate_j (τ0 + j h) at each refresh, ports in order,
  divided by the area after (fmu_src/rom_frozen.c ``refresh``); after a step
  a force with a rate reads F_j + rate_j h (the FMU's rule for f);
* a step of length h is ``n_full`` whole internal steps of dt and, when the
  remainder exceeds 1e-12 dt, one shortened step (:func:`split_step`);
* the internal step counter n runs over all internal steps, shortened ones
  included, and the frozen coefficients are refreshed when n % n_freeze == 0.

Probe outputs are summed in the C order (q ascending from 0.0), so equality
with the FMU can be checked bit for bit.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from html import escape
from typing import ClassVar

import numpy as np

from ... import defaults
from ...errors import SimulationError
from ...rom import parametric as par
from ...rom.frozen import frozen_advance, loop_operators
from ...rom.operators import probe_rows, wants_tensor
from ...rom.port_channel import (ChannelState, attach, density_shift, from_sections, model_ports,
                                 probe_outputs)
from ...rom.registry import get_model
from ...rom.stepping import initial_scale, runaway_bound
from ...sph.solver import step_count
from ..resources import FLAG_DAMPING, FLAG_INPUT, INTEGRATORS, port_sections
from ..training.steps import model_basis, packaging_truth, shadow_step, training_basis, training_envelope
from . import ModelWords, pack, step_error

NUMBER = 1
BUILD_OPTIONS = ("n_freeze", "dt", "integrator")
INTERNAL_STEP = True
INITIAL_STATE = "a_v0"           # what initial_state_scale multiplies (rom.h rom_set_initial_state_scale)
OUTPUT_DERIVATIVE_ORDER = 0      # a discrete map of internal steps: no output derivatives (rom.h)
PORT_INTEGRATOR = "symplectic"
FROZEN_INTEGRATORS = ("euler", "symplectic")      # the time-stepped model's own (the full SPH also has rk4)


def default_integrator(scene, ports=()):
    """The time integrator of a time-stepped FMU given none: the scene's, but :data:`PORT_INTEGRATOR` (ρ then v)
    for any FMU with ports.  A port couples the bar to components outside, for as long as the master runs, and the
    coupled system is stable when the FMU adds no energy (passivity, docs/fmu/ports.md); explicit Euler multiplies
    each mode's energy by 1 + (ω dt)² a step, symplectic Euler keeps a modified energy of the undamped bar.
    Measured (``sphrom bench inputs``, tenmode with a constant port force for 10 s): the full SPH with explicit
    Euler is 0.1 off the linear SPH integrated exactly in time, with symplectic Euler 9e-6.  With the port channel
    (:mod:`sphrom.rom.port_channel`) the port forces never reach the model's own state, but that state runs for
    the whole co-simulation: heterogeneous's frozen part (k = 21, 20) with explicit Euler at dt = 2e-4 s amplifies
    its fastest mode (ω = 33.2 rad/s) 3.6e9-fold over 200 s, and from the scene's initial state in the ports bench's
    damped loop its density turns negative at a particle, and at probe 1 at t = 194.56 s; with symplectic Euler its
    energy stays within 2.3 % of the start over the 200 s (``sphrom bench port_integrator heterogeneous --sph``;
    docs/fmu/ports.md, "The integrator of a port FMU").  A scene whose full SPH steps with RK4 (which the frozen
    model does not have): symplectic Euler too (the scene's step is within its limit on the reduced model's lower
    frequencies)."""
    if len(ports):
        return PORT_INTEGRATOR
    return scene.sph.integrator if scene.sph.integrator in FROZEN_INTEGRATORS else PORT_INTEGRATOR


EULER_GROWTH = 1e-12     # explicit Euler is an FMU's default only where no reduced mode grows by more than this a step


def open_ended_integrator(ops, dt, integrator):
    """The integrator of a frozen FMU given none, once its operators are built: ``integrator`` (the scene's,
    :func:`default_integrator`), but :data:`PORT_INTEGRATOR` where that is explicit Euler and it amplifies a reduced
    mode at all: the spectral radius of its step on the model linearised about rest
    (:func:`sphrom.rom.stepping.reduced_amplification` over one step dt) above 1 + EULER_GROWTH.

    An FMU runs as long as its master does, not the scene's T: explicit Euler multiplies an undamped mode's energy
    by 1 + (ω dt)² every step, so on an undamped bar (and where a damping d < ω² dt is too weak for the fastest
    mode) its rounding errors and its state grow without end.  Heterogeneous's frozen FMU (k = 21, 20, dt = 2e-4
    s): the fastest mode (ω = 33.2 rad/s) 3.6e9-fold over 200 s; from the scene's initial state its own state's
    energy reaches 8e11 x its start and a density turns negative (``sphrom bench port_integrator heterogeneous``:
    the same own state in its port FMU, which no port force reaches).  Symplectic
    Euler keeps a modified energy of the undamped bar.  A damped scene whose explicit Euler contracts every mode
    keeps it: the paper's model as the paper ran it."""
    from ...rom.stepping import reduced_amplification
    if integrator != "euler":
        return integrator
    growth, _ = reduced_amplification(ops, dt, integrator, dt)
    return PORT_INTEGRATOR if growth > 1.0 + EULER_GROWTH else integrator


MODELS = {
    "frozen": ModelWords(
        ports=("Each port's directions are in the basis as the exact model's (rigid motion, static deflection, "
               "in-band moments, the ringing modes), and the model is projected in the energy inner products, "
               "which keeps its port map passive on every scene; on top, the density linearisation (eq. 2.17) errs "
               "in proportion to the strain. A port FMU steps with symplectic Euler unless packaged with "
               "--integrator (this one's: the model section): explicit Euler grows an undamped bar's ringing "
               "modes."),
        what=("POD-Galerkin with the density linearised (eq. 2.17) and the ρ² coefficient frozen between "
              "refreshes (eqs. 2.19-2.24): the paper's model (with ports: projected in the energy inner products, "
              "so its ports are passive)"),
        limits=("explicit internal steps dt; the linearisation fails beyond a probe strain of about 0.04 "
                "(the FMU warns); its certified error bound includes the linearisation's"),
        when="you want the paper's model, or its `n_freeze` / `dt` knobs"),
}


@dataclass
class ModelData:
    """The contents of a model.bin (all arrays float64, shapes as in the file).

    Attributes
    ----------
    integrator : str
        ``euler`` or ``symplectic``.
    n_freeze : int
        Default refresh period of the frozen coefficients.
    dt : float
        Internal step [s].
    bound : float
        Runaway bound on |a| (:func:`sphrom.rom.stepping.runaway_bound`).
    L : float
        Period [m].
    a_v0, a_rho0, K, b, D, p, T, Pv, Prho, probe_x : ndarray
        D and p may be None.
    token : str
        The instantiation token (set by :func:`sphrom.fmu.kinds.pack`).
    sections : dict of str to ndarray
        Tagged sections (tag -> 2-D float64 array), in file order.
    """

    integrator: str
    n_freeze: int
    dt: float
    bound: float
    L: float
    a_v0: np.ndarray
    a_rho0: np.ndarray
    K: np.ndarray
    b: np.ndarray
    D: np.ndarray | None
    p: np.ndarray | None
    T: np.ndarray | None      # None: no tensor, the particle sections PART* carry the refresh
    Pv: np.ndarray
    Prho: np.ndarray
    probe_x: np.ndarray
    token: str = ""
    sections: dict = field(default_factory=dict)
    n_freeze_errors: dict = field(default_factory=dict)   # packaging only: choose_n_freeze's measurements
    bounds = None                # the frozen model has no certified error bounds (ExactData.bounds)
    KIND: ClassVar[int] = 1      # resources/model.bin's model_kind (sphrom.fmu.layout.KINDS)
    INTERNAL_STEP: ClassVar[bool] = INTERNAL_STEP     # the kind's (sphrom.fmu.variables.facts reads it)

    @property
    def k_v(self):
        return self.a_v0.size

    @property
    def k_rho(self):
        return self.a_rho0.size

    @property
    def n_probes(self):
        return self.probe_x.size


def model_data(ops, problem, *, dt, integrator, n_freeze, probes, bound):
    """Collect the FMU's numbers from reduced operators.

    Parameters
    ----------
    ops : ReducedOperators
        With the refresh tensor, or without it (``T`` None: the particle refresh's sections must then be added
        to the data's sections before :func:`sphrom.fmu.kinds.pack`,
        :func:`particle_sections`); built
        with ``input_direction="needed"`` for an input row.
    problem : SPHProblem
        The full problem (particle positions, L).
    dt : float
        Internal step [s].
    integrator : {"euler", "symplectic"}
    n_freeze : int
        Default refresh period (>= 1).
    probes : sequence of float
        Probe positions in units of L, in [0, 1].
    bound : float
        Runaway bound on |a|.
    """
    probes = np.asarray(probes, dtype=float)
    L = problem.scene.L
    return ModelData(integrator=integrator, n_freeze=int(n_freeze), dt=float(dt), bound=float(bound), L=float(L),
                     a_v0=np.asarray(ops.a_v0, float), a_rho0=np.asarray(ops.a_rho0, float),
                     K=np.asarray(ops.K, float), b=np.asarray(ops.b, float),
                     D=None if ops.D is None else np.asarray(ops.D, float),
                     p=None if ops.p is None else np.asarray(ops.p, float),
                     T=None if ops.T is None else np.asarray(ops.T, float),
                     Pv=probe_rows(ops.U_v, problem.x, L, probes), Prho=probe_rows(ops.U_rho, problem.x, L, probes),
                     probe_x=probes, sections=port_sections(ops))


Data = ModelData


def from_operators(ops, problem, *, probes, dt, n_freeze, integrator="euler", bound=None):
    """:func:`model_data` of operators built elsewhere (a benchmark's own), the runaway bound that of their initial
    state unless given (:func:`sphrom.rom.stepping.runaway_bound`)."""
    return model_data(ops, problem, dt=dt, integrator=integrator, n_freeze=n_freeze, probes=probes,
                      bound=runaway_bound(ops) if bound is None else bound)


def parametric(affine, c, d, problem, *, probes, dt, n_freeze, integrator="euler"):
    """(data, operators, the affine pieces' sections KC, BC and DD with damping) of a parametric frozen model at
    (c, d) (:func:`sphrom.fmu.make.parametric.parametric_resource`; the C core assembles K = c K_c, b = c b_c,
    D = d D_d)."""
    ops = par.frozen_at(affine, c, d)
    data = from_operators(ops, problem, probes=probes, dt=dt, n_freeze=n_freeze, integrator=integrator)
    sections = {"KC": affine.unit.K, "BC": affine.unit.b[None, :]}
    if affine.damping:
        sections["DD"] = affine.unit.D
    return data, ops, sections

def example(rng):
    """A small frozen model with random numbers in the layout's shapes (k_v = 3, k_rho = 2, two probes, damping,
    no input, the tensor), for tests of the file and the core: its numbers are not a physical model's."""
    kv, kr, npr = 3, 2, 2
    return ModelData(integrator="symplectic", n_freeze=7, dt=2.5e-4, bound=1e6, L=0.5, a_v0=rng.normal(size=kv),
                     a_rho0=1.0 + 0.01 * rng.normal(size=kr), K=0.1 * rng.normal(size=(kv, kr)),
                     b=0.1 * rng.normal(size=kv), D=0.01 * rng.normal(size=(kv, kv)), p=None,
                     T=0.01 * rng.normal(size=(kr * (kr + 1) // 2, kr, kv)), Pv=rng.normal(size=(npr, kv)),
                     Prho=np.abs(rng.normal(size=(npr, kr))) + 1.0, probe_x=np.array([0.25, 0.5]))

# ---------------------------------------------------------------------------------------------------------------
# its part of model.bin (sphrom.fmu.kinds pack, unpack; the shared pieces sphrom.fmu.resources write, read)
# ---------------------------------------------------------------------------------------------------------------

def min_k_rho(flags):
    """The smallest k_rho of a frozen model's header."""
    return 1


def file_fields(data):
    """(shared header fields, its own header, {array name: array}) of ``data`` for :func:`sphrom.fmu.kinds.pack`;
    ``data.T`` None: no refresh tensor (n_pairs = 0), which the particle refresh's sections (PARTUR, PARTGUV, PARTIR0)
    then replace."""
    if data.T is None and "PARTUR" not in data.sections:
        raise ValueError("T: a frozen model without its refresh tensor needs the particle sections PARTUR, PARTGUV, "
                         "PARTIR0")
    kr = data.k_rho
    flags = (FLAG_DAMPING if data.D is not None else 0) | (FLAG_INPUT if data.p is not None else 0)
    header = {"k_v": data.k_v, "k_rho": kr, "n_probes": data.n_probes, "flags": flags, "runaway_bound": data.bound,
              "L": data.L}
    head = {"integrator": INTEGRATORS[data.integrator], "n_pairs": 0 if data.T is None else kr * (kr + 1) // 2,
            "n_freeze_default": int(data.n_freeze), "reserved": 0, "dt": data.dt}
    arrays = {name: getattr(data, name) for name in ("a_v0", "a_rho0", "K", "b", "D", "p", "T", "Pv", "Prho",
                                                     "probe_x")}
    return header, head, arrays


def from_file(header, head, arrays, token, sections):
    """The :class:`ModelData` of a frozen model.bin's fields (:func:`sphrom.fmu.kinds.unpack`)."""
    kr = header["k_rho"]
    if head["n_pairs"] not in (0, kr * (kr + 1) // 2):         # 0: no tensor (the particle sections replace it)
        raise ValueError("n_pairs")
    name = {v: k for k, v in INTEGRATORS.items()}[head["integrator"]]
    return ModelData(integrator=name, n_freeze=head["n_freeze_default"], dt=head["dt"], bound=header["runaway_bound"],
                     L=header["L"], a_v0=arrays["a_v0"], a_rho0=arrays["a_rho0"], K=arrays["K"], b=arrays["b"],
                     D=arrays.get("D"), p=arrays.get("p"), T=arrays["T"] if head["n_pairs"] else None,
                     Pv=arrays["Pv"], Prho=arrays["Prho"], probe_x=arrays["probe_x"], token=token, sections=sections)


# ---------------------------------------------------------------------------------------------------------------
# packaging
# ---------------------------------------------------------------------------------------------------------------

def resource(scene, model, k, n_freeze, probes, integrator, progress, problem, order_tolerance=None,
             bounds=True, ports=(), build_options=None, extra_steps=(), error_bounds=True, integrator_given=True):
    """The packaging step of kind 1 (``sphrom.fmu.make.package.model_step``): the frozen model with its training
    envelope and error bounds, (data, operators, model.bin bytes); ``n_freeze`` None: chosen per scene
    (:func:`choose_n_freeze`, the errors it measured in ``data.n_freeze_errors``); ``integrator_given`` False
    (the user named none): :func:`open_ended_integrator` decides (``data.integrator``)."""
    basis, run, problem = training_basis(scene, progress, problem, extra_steps)
    truth = packaging_truth(problem, ports, build_options, error_bounds)   # the port channel's and the shadow's
    data, ops, problem, _ = reduced_model(scene, k, n_freeze or defaults.N_FREEZE, probes, integrator,
                                          progress=progress, problem=problem, model=model, ports=ports,
                                          build_options=build_options, made=(basis, run), truth=truth)
    if not integrator_given:
        integrator = data.integrator = open_ended_integrator(ops, data.dt, integrator)
    data.sections.update(particle_sections(ops, problem))
    if "PARTUR" in data.sections:
        data.T = None                     # the particles replace the tensor: its bytes stay out of the FMU
    if n_freeze is None:
        data.n_freeze, data.n_freeze_errors = choose_n_freeze(scene, ops, problem, run, model, integrator,
                                                              refresh="direct" if "PARTUR" in data.sections
                                                              else "tensor")
    data.sections.update(training_envelope(scene, ops, problem, probes, False, progress, run=run).sections())
    if error_bounds:
        shadow_step(data, ops, problem, probes, truth=truth)
    return data, ops, pack(data)


def parameter_starts(data):
    """The start values of the kind's own FMU parameters (the variable table's From cells n_freeze and dt)."""
    return {"n_freeze": int(data.n_freeze), "dt": float(data.dt)}


def reduced_model(scene, k, n_freeze, probes, integrator, progress=True, problem=None, model="frozen", ports=(),
                  build_options=None, made=None, tensor=None, truth=None):
    """The FMU's numbers for a model of resource kind 1 (frozen coefficients): (ModelData, ops, problem, basis).

    Runs (or reuses) the full SPH and the POD (sphrom.pod.pipeline), builds the model's operators
    (``get_model(model).build``: the frozen model's own, b about the projected rest density so that the FMU
    started at rest stays at rest, :func:`sphrom.rom.operators.rest_b`) with ``input_direction="needed"`` (an
    input row always; the force profile appended to U_v only when the POD modes miss more than 1 % of it) and
    the refresh tensor where the FMU keeps it or it is small (``tensor`` None: where it costs less than the
    particle refresh, :func:`particle_sections`, or has at most ``TENSOR_MAX_ENTRIES`` entries; a port model's
    larger basis, whose tensor grows as k⁴, is not built; ``"always"``: built anyway).  ``build_options`` go to
    the model's build (``{"b": "paper"}``: eq. 2.22's b, the paper's variant, :mod:`sphrom.bench.rest` compares
    them).  ``truth``: the packaging's truth's matrix for the port channel
    (:func:`sphrom.fmu.training.steps.packaging_truth`; None: built there).
    """

    spec = get_model(model)
    basis, problem = model_basis(scene, spec, k, progress=progress, problem=problem, made=made)
    own_ports, options, channel = model_ports(problem, ports, build_options)
    ops = spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction,
                     tensor="always" if tensor == "always" else "never",
                     **({"ports": own_ports} if own_ports else {}), **options)
    if channel:                     # the portless model and the port channel, which takes every port force
        ops = attach(ops, problem, ports, probes, truth=truth)
    if ops.T is None and (not particle_sections(ops, problem) or wants_tensor("auto", ops.k_v, ops.k_rho)):
        from ...rom.operators import refresh_tensor                     # the FMU's, or small enough to keep
        t0 = time.perf_counter()
        ops.T = refresh_tensor(ops.U_rho, ops.GU_v, ops.inv_rho0)
        ops.timings["tensor"] = time.perf_counter() - t0
        ops.tensor_rule = "always"
    data = model_data(ops, problem, dt=scene.sph.dt, integrator=integrator, n_freeze=n_freeze, probes=probes,
                      bound=runaway_bound(ops))
    if ops.T is None:                                                   # the particle refresh replaces it
        data.sections.update(particle_sections(ops, problem))
    return data, ops, problem, basis


N_FREEZE_CANDIDATES = (1, 2, 5, 10, 20, 50, 100)   # refresh periods tried when the user gives none
N_FREEZE_SLACK = 0.05       # ... the largest whose training error is within this of n_freeze = 1's (relative)
N_FREEZE_BUDGET = 4e9       # multiply-adds of one trial run at n_freeze = 1 (about 2 s here); beyond, a shorter run
N_FREEZE_MIN_SAMPLES = 10   # ... of at least this many of the training run's samples


def particle_sections(ops, problem):
    """The sections of the frozen model's particle refresh (PARTUR, PARTGUV, PARTIR0: U^rho, G U^v, 1/rho0 at the
    N particles), or {} where the tensor costs less.  The refresh of M (eq. 2.23 projected) from the tensor takes
    n_pairs (1 + nm) multiply-adds and streams its n_pairs k_rho k_v values from memory; from the particles it
    takes N (k_rho + kr_pad + k_v kr_pad) + nm on arrays that stay in cache (the core's counts,
    :func:`refresh_matrix_work`).  A port model's larger basis (k_v, k_rho = 48, 47 on damped_forced, whose
    tensor is 20 MB) is where the particles win; k = 12 on N = 400 keeps the tensor.  The particle path sums in
    another order than the tensor: the FMU then equals the Python model run with ``refresh="direct"``."""
    if refresh_matrix_work(ops.k_v, ops.k_rho, problem.n) >= refresh_matrix_work(ops.k_v, ops.k_rho):
        return {}
    return {"PARTUR": np.asarray(ops.U_rho, float), "PARTGUV": np.asarray(ops.GU_v, float),
            "PARTIR0": np.asarray(ops.inv_rho0, float)[None, :]}


def choose_n_freeze(scene, ops, problem, run, model="frozen", integrator=None, candidates=N_FREEZE_CANDIDATES,
                    slack=N_FREEZE_SLACK, refresh=None):
    """The refresh period n_freeze of a frozen FMU whose user gave none: the largest of ``candidates`` whose
    training error (the frozen model of ``ops`` over the scene's T, relative L² of eq. 3.4 of the velocity field
    against the full SPH training run ``run`` at its samples) is within ``slack`` of n_freeze = 1's.  A larger
    n_freeze refreshes the frozen coefficients (eq. 2.23) less often: cheaper per step; the force and the port
    forces are frozen with them, which is where it costs accuracy (damped_forced's time-varying force).

    Returns (n_freeze, {n_freeze: error} of the candidates run): n_freeze = 1 first, then from the largest down,
    stopping at the first within the slack (a run that blows up counts as not within).  The trial runs stop
    early when the scene's T would cost more than :data:`N_FREEZE_BUDGET` multiply-adds at n_freeze = 1 (a port
    model's large basis: each refresh then costs O(N k²)); the errors are then those of the training run's
    first part (at least its first :data:`N_FREEZE_MIN_SAMPLES` samples).  ``refresh``: the frozen model's
    refresh path (default the tensor where ``ops`` has it, else the particles, ``"direct"``).
    """
    spec = get_model(model)
    refresh = refresh or ("tensor" if ops.T is not None else "direct")
    n_steps = step_count(scene.T, scene.sph.dt)
    per_step = step_work(ops.k_v, ops.k_rho, 1, particles=problem.n if refresh == "direct" else 0)
    steps = np.asarray(run.steps)
    if per_step * n_steps > N_FREEZE_BUDGET:              # the first part of the training run only
        keep = max(N_FREEZE_MIN_SAMPLES, int(np.count_nonzero(steps <= N_FREEZE_BUDGET / per_step)))
        steps = steps[:min(keep, steps.size)]
        n_steps = int(steps[-1])
    v_ref = np.asarray(run.v)[:steps.size]
    ref = np.linalg.norm(v_ref)

    def error(nf):
        try:
            res = spec.run(ops, problem, dt=scene.sph.dt, n_steps=n_steps, sample_steps=steps,
                           options=spec.options(n_freeze=nf, integrator=integrator, refresh=refresh))
        except SimulationError:
            return float("inf")
        return float(np.linalg.norm(ops.velocity(res.z[:, :ops.k_v]) - v_ref) / ref)

    errors = {1: error(1)}
    for nf in sorted(candidates, reverse=True):
        if nf == 1:
            break
        errors[nf] = error(nf)
        if errors[nf] <= (1.0 + slack) * errors[1]:
            return nf, errors
    return 1, errors

def model_name(data):
    """The registered reduced model a frozen model.bin holds."""
    return "frozen"


def integrator(data):
    """The time integrator of the frozen model (its own: euler or symplectic)."""
    return data.integrator


# ---------------------------------------------------------------------------------------------------------------
# its words (modelDescription, documentation/index.html)
# ---------------------------------------------------------------------------------------------------------------

def stepping(data):
    """modelDescription's words on the time stepping."""
    return f"{data.integrator} integrator, internal dt = {data.dt:g} s, n_freeze = {data.n_freeze} by default"


def model_rows(data):
    """The documentation page's rows (quantity, HTML value) on the time stepping."""
    return [("integrator", escape(data.integrator)), ("default n_freeze", str(data.n_freeze)),
            ("default internal dt [s]", format(float(data.dt), "g"))]


def usage(data):
    """The documentation page's sentence on how the FMU steps (HTML)."""
    return ("It takes internal steps of <code>dt</code> and refreshes its frozen coefficients every "
            "<code>n_freeze</code> of them; any h &gt; 0 is accepted, the last internal step shortened to end "
            "exactly at the communication point.")


# ---------------------------------------------------------------------------------------------------------------
# the co-simulation in Python the C core must equal (module docstring)
# ---------------------------------------------------------------------------------------------------------------

STEP_ROUNDING = 1e-9       # fmu_src/rom.h ROM_STEP_ROUNDING
SHORT_STEP_MIN = 1e-12     # ROM_SHORT_STEP_MIN
# The work of one doStep is bounded (fmu_src/rom.h): dt >= dt_floor, at most max_steps_per_call internal steps
DT_MIN = 1e-9              # ROM_DT_MIN [s]: the smallest internal step of a frozen model's resources
DT_FLOOR_RATIO = 1e-3      # ROM_DT_FLOOR_RATIO: the parameter dt is at least this x the model's dt
MAX_WORK_PER_CALL = 2e9    # ROM_MAX_WORK_PER_CALL: multiply-adds of the internal steps of one doStep
STEP_OVERHEAD = 32.0       # ROM_STEP_OVERHEAD: multiply-adds one internal step costs beyond its arithmetic


def dt_floor(model_dt):
    """The smallest internal step [s] a frozen FMU with internal step ``model_dt`` [s] accepts (rom_dt_floor)."""
    return max(DT_MIN, model_dt * DT_FLOOR_RATIO)


def refresh_matrix_work(k_v, k_rho, particles=0):
    """Multiply-adds of M's refresh (fmu_src/rom_frozen.c frozen_step_work): from the tensor, n_pairs (1 + nm), or
    from ``particles`` particles (the particle refresh), N (k_rho + kr_pad + k_v kr_pad) + nm."""
    krp = -(-k_rho // 4) * 4
    nm = -(-(k_v * krp) // 32) * 32
    if particles:
        return particles * (k_rho + krp + k_v * krp) + nm
    return k_rho * (k_rho + 1) // 2 * (1.0 + nm)


def step_work(k_v, k_rho, n_freeze, n_ports=0, damping=True, particles=0):
    """Multiply-adds of one internal step of the frozen model (rom_step_work, fmu_src/rom_frozen.c): the density
    and velocity rates over the padded blocks, the two updates, the runaway check, and 1/n_freeze of a refresh
    (from the tensor, or from ``particles`` particles where the model has the particle refresh)."""
    pad = lambda k: -(-k // 4) * 4                                      # noqa: E731
    kvp, krp = pad(k_v), pad(k_rho)
    step = krp * k_v + kvp * (k_rho + (k_v if damping else 0)) + kvp + krp + k_v + k_rho
    refresh = refresh_matrix_work(k_v, k_rho, particles) + kvp + n_ports * k_v
    return step + refresh / max(int(n_freeze), 1) + STEP_OVERHEAD


def max_steps_per_call(k_v, k_rho, n_freeze, n_ports=0, damping=True, particles=0):
    """The most internal steps one doStep of the frozen FMU takes (rom_max_steps_per_call)."""
    return math.floor(MAX_WORK_PER_CALL / step_work(k_v, k_rho, n_freeze, n_ports, damping, particles))


def split_step(h, dt):
    """(n_full, rest): whole internal steps of ``dt`` in ``h`` and the shortened remainder [s].

    h/dt is taken as a whole number when within 1e-9 max(1, h/dt) of one;
    ``rest`` is 0 when no shortened step is taken.  A ``dt`` above ``h`` gives
    (0, h): one internal step of length h (the FMU warns once), never a no-op.
    """
    ratio = h / dt
    nearest = math.floor(ratio + 0.5)
    if nearest < 1 or (ratio < 1.0 and not abs(ratio - 1.0) <= STEP_ROUNDING):
        return 0, h
    if abs(ratio - nearest) <= STEP_ROUNDING * max(1.0, ratio):
        return int(nearest), 0.0
    n_full = int(math.floor(ratio))
    rest = h - n_full * dt
    return n_full, (rest if rest > SHORT_STEP_MIN * dt else 0.0)


def probe_values(rows, a):
    """rows @ a summed in the C order: 0.0 + rows[:, 0] a_0 + rows[:, 1] a_1 + ..."""
    acc = np.zeros(rows.shape[0])
    for q in range(rows.shape[1]):
        acc = acc + rows[:, q] * a[q]
    return acc


class FrozenCosim:
    """The frozen model stepped like the FMU (see module docstring).

    Parameters
    ----------
    data : sphrom.fmu.resources.ModelData
        The FMU's model (what model.bin holds).
    n_freeze : int, optional
        Refresh period (default the packaged one).
    dt : float, optional
        Internal step [s] (default the packaged one).
    initial_state_scale : float
        a^v(0) = this x a_v0, a^rho(0) = a_rho0 (the FMU parameter; default 1, the scene's initial state,
        where the FMU's own start value is 0, at rest).
    start : float
        The start time [s] (the FMU's startTime): doStep's rules are checked against the time reached.
    """

    def __init__(self, data, n_freeze=None, dt=None, initial_state_scale=1.0, start=0.0):
        self.data = data
        self.n_freeze = int(data.n_freeze if n_freeze is None else n_freeze)
        self.dt = float(data.dt if dt is None else dt)
        self.method = {"euler": 0, "symplectic": 1}[data.integrator]
        self.av = initial_scale(initial_state_scale) * np.array(data.a_v0, dtype=float)    # rom.c apply_initial_state
        self.ar = np.array(data.a_rho0, dtype=float)
        self.M = np.zeros((data.k_rho, data.k_v))
        self.F = np.zeros(data.k_v)
        self.n = 0
        self.t = float(start)
        self.elapsed = 0.0           # the time since the start [s] (the C state's elapsed)
        part = data.sections.get("PARTUR")
        if part is None:
            self._ops = loop_operators(data.K, data.b, data.D, data.p, self.n_freeze, T=data.T, refresh="tensor")
        else:                   # the particle refresh (sections PART*), as the FMU's core takes it
            self._ops = loop_operators(data.K, data.b, data.D, data.p, self.n_freeze, T=data.T, U_rho=part,
                                       GU_v=data.sections["PARTGUV"], inv_rho0=data.sections["PARTIR0"][0],
                                       refresh="direct")
        self._no_samples = np.zeros(0, dtype=np.int64)
        self._out = np.zeros((0, 1))
        # mechanical ports (resources sections PORTB, PORTC): F_port [N] held over a step, or going as
        # F_port + port_rates τ [N s^-1] (input derivatives), divided by area; with the port channel (sections PC*,
        # no PORTB) the channel takes them (fmu_src/rom_port.c), its part added to the outputs
        self.port_B = data.sections.get("PORTB")
        self.port_C = data.sections.get("PORTC")
        self.n_ports = 0 if self.port_C is None else self.port_C.shape[0]
        self.port_forces = np.zeros(self.n_ports)
        self.port_rates = np.zeros(self.n_ports)
        self.area = 1.0
        channel = from_sections(data.sections)
        self.channel = None if channel is None else ChannelState(channel)
        self.impedance = 0.0                               # the wave form (port_impedance; 0: the force form)
        self.waves = np.zeros(self.n_ports)
        self.wave_rates = np.zeros(self.n_ports)           # da_port/dt [N s^-1] (input derivatives; 0: held)

    def _advance(self, count, h, f, rate=0.0, tau0=0.0):
        if count <= 0:
            return
        # f at each step's time tau0 + j h after the communication point (fmu_src/rom_frozen.c run_steps_kernel)
        tau = tau0 + np.arange(count) * h
        g = np.full(count, float(f)) if rate == 0.0 else float(f) + float(rate) * tau
        status, _, bad = frozen_advance(self.method, self.av, self.ar, self.M, self.F, self.n, self.n + count, h, g,
                                        self._ops, self._no_samples, 0, self._out, self._out, self.data.bound,
                                        *self._port_arguments(tau))
        if status != 0:
            raise SimulationError(f"reference: reduced state failed (status {status}) by internal step {bad}",
                                  step=bad)
        self.n += count

    def do_step(self, h, f, rate=0.0, t_comm=None):
        """One communication step of length ``h`` [s] with input ``f`` [m s^-2] held, or going as
        f + ``rate`` τ over the step (``rate`` df/dt [m s^-3], an input derivative), from ``t_comm`` [s] (default
        the time reached): a step doStep refuses is a ValueError in the core's words
        (:func:`sphrom.fmu.kinds.step_error`)."""
        problem = step_error(self.t, self.t if t_comm is None else t_comm, h, self.elapsed)
        if problem:
            raise ValueError(problem)
        v_own = self.own_port_velocities() if self.channel is not None else None
        n_full, rest = split_step(h, self.dt)
        self._advance(n_full, self.dt, f, rate, 0.0)
        if rest > 0.0:
            self._advance(1, rest, f, rate, n_full * self.dt)
        if self.channel is not None:                       # the port forces' response (fmu_src/rom.c's order)
            self.channel.fmu_step(h, self.port_forces, self.port_rates, self.area, self.impedance, self.waves,
                                  0.5 * (v_own + self.own_port_velocities()), self.wave_rates)
            if self.impedance > 0:                         # an incident wave with a rate goes on linearly
                self.waves = np.where(self.wave_rates != 0.0, self.waves + self.wave_rates * h, self.waves)
        self.t = (self.t if t_comm is None else t_comm) + h
        self.elapsed = self.elapsed + h
        if self.n_ports:                                   # a port force with a rate goes on linearly (rom_do_step)
            rates = np.asarray(self.port_rates, float)
            self.port_forces = np.where(rates != 0.0, self.port_forces + rates * h, self.port_forces)

    def outputs(self):
        """(v at the probes [m s^-1], rho at the probes [kg m^-3]), with the port channel's part."""
        v, rho = probe_values(self.data.Pv, self.av), probe_values(self.data.Prho, self.ar)
        if self.channel is None:
            return v, rho
        vc, ec, _ = probe_outputs(self.channel.ch, self._channel_rows())
        return v + vc, rho + density_shift(self.channel.ch, ec)

    def _channel_rows(self):
        return self.channel.rows(self.channel.inputs_now(self.port_forces, self.area, self.impedance))

    def own_port_velocities(self):
        """The model's own part of v_port_j [m s^-1] (PORTC over a^v), without the port channel's."""
        return probe_values(self.port_C, self.av) if self.n_ports else np.zeros(0)

    def _port_arguments(self, tau):
        """(Bp, the port inputs F(τ)/area per step, (len(τ), P)) for frozen_advance, τ [s] the steps' times after
        the communication point; () without ports.  F(τ) = F + rate τ where the rate is nonzero, else F (held), as
        fmu_src/rom_frozen.c refresh computes it."""
        if self.port_B is None:                            # no ports, or the port channel takes them
            return ()
        forces = np.asarray(self.port_forces, float)[None, :]
        rates = np.asarray(self.port_rates, float)[None, :]
        tau = np.asarray(tau, float)[:, None]
        value = np.where(rates != 0.0, forces + rates * tau, forces)
        return self.port_B, np.ascontiguousarray(value / self.area)

    def port_velocities(self):
        """v_port_j [m s^-1] (as rom_v_port: 0.0 + C[j][0] a_0 + ..., plus the port channel's part); empty without
        ports."""
        v = self.own_port_velocities()
        if self.channel is None:
            return v
        return v + probe_outputs(self.channel.ch, self._channel_rows())[2]


def cosim_reference(data, steps, inputs, n_freeze=None, dt=None, rates=None, initial_state_scale=1.0):
    """Outputs of the FMU's co-simulation computed in Python.

    Parameters
    ----------
    data : ModelData
    steps : sequence of float
        Communication step sizes [s].
    inputs : sequence of float
        f held over each step [m s^-2] (same length as ``steps``), its value at the step's start.
    rates : sequence of float, optional
        df/dt over each step [m s^-3] (input derivatives; default none: f held).
    n_freeze, dt, initial_state_scale
        The FMU's parameters (:class:`FrozenCosim`).

    Returns
    -------
    t : ndarray (M+1,)
        Communication points [s], starting at 0.
    v, rho : ndarray (M+1, P)
        Probe outputs at the communication points.
    """
    sim = FrozenCosim(data, n_freeze=n_freeze, dt=dt, initial_state_scale=initial_state_scale)
    t, v, rho = [0.0], [], []
    v0, r0 = sim.outputs()
    v.append(v0)
    rho.append(r0)
    rates = np.zeros(len(steps)) if rates is None else rates
    for h, f, rate in zip(steps, inputs, rates):
        sim.do_step(h, f, rate)
        t.append(sim.t)
        vi, ri = sim.outputs()
        v.append(vi)
        rho.append(ri)
    return np.array(t), np.array(v), np.array(rho)
