"""Package a scene's reduced model as an FMI 2.0 or 3.0 FMU.

Three models (``model=``): ``frozen``, the frozen-coefficient model of eqs.
2.19-2.24 (the default), stepped with the internal dt; ``exact``, the
exact linear model in the specific volume (:mod:`sphrom.rom.exact_linear`),
advanced over each communication step by the matrix exponential (cached per
step length in the C core), whatever dt; and ``balanced``, the balanced
reduction of the full linear SPH (:mod:`sphrom.rom.balanced_model`), which
runs through the same C code as ``exact`` (resource kind 2; only its matrices
differ).  The linear models carry certified error bounds against the full
linear SPH at their probes (section BOUNDS; calculated parameters
``force_error_bound``, ``initial_state_error_bound`` and per probe).

Steps of :func:`package_fmu` (``sphrom fmu``), each a function of its own, each in the module that does its job:

1. options        every option checked before any work              (:mod:`.options`)
2. model          the model's numbers and operators, per resource kind or parametric, with the training
                  envelope and (linear models) the certified bounds   (:mod:`.models`, :mod:`.parametric`)
3. envelope       what the basis was trained on, read back            (:mod:`sphrom.fmu.training.envelope`)
4. binaries       built once and cached                              (:mod:`.build`)
5. description    modelDescription.xml                               (:mod:`.describe`)
6. documentation  documentation/index.html (and probes.png)          (:mod:`.documentation`)
7. archive        the zip and fmpy's validation, at a temporary name  (:mod:`.archive`)
8. verification   measured against the full SPH, the tolerance checked, the texts rewritten
                                                                      (:mod:`sphrom.fmu.check.verify`)

and the rename into place.  ``--model auto`` is a step of its own around these (:mod:`.auto`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from ... import defaults
from ...errors import FieldError, SimulationError, ToleranceError
from ...rom.passivity import port_passivity
from ...rom.registry import get_model
from ...runio import atomic_path
from ...sph.solver import build_problem
from .. import layout
from ..check.channels import horizon, measure_channels
from ..check.verify import (acceptance, communication_step, exact_time_step, measure_cost, measure_step,
                            top_frequency, verify_fmu)
from ..kinds import for_model, kind_of
from ..training.envelope import Envelope
from .archive import validate, write_fmu
from .build import fmu_binaries
from .describe import model_description
from .documentation import DOC_INDEX, DOC_PLOT, index_html
from .options import check_options, check_ports
from .parametric import parameter_variables, parametric_resource


@dataclass
class FMUSummary:
    """What ``sphrom fmu`` built.

    Attributes
    ----------
    path : Path
    fmi : int
    scene : str
    k : int
        POD modes requested.
    k_v, k_rho : int
        Reduced velocity / density coordinates (k_v = k + 1 when the force
        profile direction was appended).
    input_error : float
        Relative projection error of the force profile on the first k POD
        velocity modes (nan without an input).
    probes : list of float
        Probe positions, units of L.
    n_freeze : int
        The parameter n_freeze's start value (a linear model, which has none: the option given).
    integrator : str
    dt : float
        Internal step [s] (a linear model, which has none: the scene's).
    token : str
    size : int
        Bytes of the .fmu.
    timings : dict
        Wall times [s] of the stages.
    model : str
        The registered reduced model packaged (one with an FMU resource kind).
    bounds : dict or None
        Linear models: the certified error bounds stored in the FMU
        (:func:`sphrom.rom.balanced.error_bounds`: ``force_error_bound``,
        ``initial_state_error_bound`` per probe, ``sigma``, ``factor``,
        ``horizon``, ...); None for the frozen model.
    method : str
        The balanced model's method (``bt``, ``galerkin``), else "".
    """

    path: Path
    fmi: int
    scene: str
    k: int
    k_v: int
    k_rho: int
    input_error: float
    augmented: bool
    probes: list
    n_freeze: int
    integrator: str
    dt: float
    token: str
    size: int
    timings: dict = field(default_factory=dict)
    model: str = "frozen"
    envelope: object = None        # sphrom.fmu.training.envelope.Envelope: what the basis was trained on
    verification: object = None      # sphrom.fmu.check.verify.Verification when measured, else None
    bounds: dict | None = None
    method: str = ""
    parameters: list = field(default_factory=list)     # a parametric FMU's c, d rows (sphrom.fmu.make.parametric)
    ports: list = field(default_factory=list)
    port_errors: list = field(default_factory=list)
    port_passivity: object = None      # sphrom.rom.passivity.PortPassivity of a port FMU, else None
    n_freeze_errors: dict = field(default_factory=dict)   # n_freeze chosen per scene: {candidate: training error}
    shadow_order: int = 0              # the certified error bounds' shadow: its coordinates (0: no bound outputs)
    error_tolerance: float = float("nan")   # error_tolerance's default [m s^-1] (nan: no bound outputs)
    platforms: str = ""                # the platforms whose binaries it carries, in words (build.FMUBinaries.words)
    missing_platforms: list = field(default_factory=list)   # one line per platform left out, with why


def package_fmu(scene, out, *, k=None, n_freeze=defaults.N_FREEZE, probes=defaults.PROBES, fmi=2, integrator=None,
                step_size=None, progress=True, binaries=None, problem=None, model="frozen", verify=False,
                tolerance=None, references=None, bounds=True, vary=(), ports=None, order_tolerance=None,
                build_options=None, error_bounds=True, accept=True, choice="") -> FMUSummary:
    """Build the FMU of ``scene`` at ``out`` (atomically) and validate it.

    Parameters
    ----------
    scene : Scene
    out : path
        The .fmu to write.
    k : int, optional
        POD modes (default :func:`default_modes`); for the balanced model its
        order r (default: from ``order_tolerance``).
    n_freeze : int or None
        Default refresh period (the ``n_freeze`` parameter's start value); None: chosen per scene from the measured
        training error (:func:`sphrom.fmu.make.models.choose_n_freeze`; the frozen model only, else the default).
    probes : sequence of float
        Probe positions in units of L.
    fmi : {2, 3}
    integrator : {"euler", "symplectic"}, optional
        Default: the scene's.
    step_size : float, optional
        DefaultExperiment stepSize [s] (default :func:`default_step`: it resolves the scene's own band).
    binaries : Binaries, optional
        Prebuilt binaries (default: :func:`sphrom.fmu.make.build.ensure_binaries`).
    model : str
        The reduced model to ship: a registered one with an FMU resource kind
        (``frozen``, ``exact``, ``balanced``; module docstring).
    verify : bool
        Measure the FMU against the full SPH before it is moved into place (:mod:`sphrom.fmu.check.verify`: the training
        force and an unseen one, errors and run times), and store the figures in its description and in
        ``documentation/`` (with the plot ``probes.png``).  Without it the documentation says "not measured".
    tolerance : float, optional
        With ``verify``: the largest probe v error accepted on every case of the verification (the training force
        from the scene's initial state, a step and an unseen sine from rest; default
        :data:`sphrom.fmu.check.verify.ACCURACY`) and on every input channel; above it, or when the FMU fails or
        runs away on a case, :class:`sphrom.errors.ToleranceError` is raised naming the case and the remedy, and
        nothing is written (an existing ``out`` is left as it was).
    accept : bool
        With ``verify``: apply that verdict (default); False measures only (``--model auto`` judges the
        candidates itself).
    order_tolerance : float, optional
        Balanced model without ``k``: its order is the smallest r with 2 Σ_{i>r} σ_i <= order_tolerance · 2 Σ σ_i
        (default :data:`sphrom.defaults.ORDER_TOLERANCE`).
    build_options : dict, optional
        More options of the model's build (:meth:`sphrom.rom.model.ReducedModel.build`; the frozen model's
        ``b="paper"``: eq. 2.22's b instead of the rest-consistent one).
    references : dict, optional
        :func:`sphrom.fmu.check.verify.references` computed before (several models of one scene).
    choice : str
        Why packaging chose this configuration (:func:`sphrom.fmu.make.auto.cheaper_if_slower`), said on the FMU's
        page; '' (default): nothing to say.
    error_bounds : bool
        Every model: the certified error bound of each output at every step (default; sections SH*,
        :mod:`sphrom.rom.bounds`, docs/science/error-bounds.md).  False leaves them out: the FMU then warns on
        leaving its training envelope instead (tests of that envelope, cost comparisons).
    bounds : bool
        Linear models: compute and declare the a priori error bounds (default;
        seconds to minutes at N = 400).  False leaves them out (benchmarks that
        time the stepping only).
    vary : sequence of sphrom.rom.parametric.Range
        Parameter ranges of c and/or d: a parametric FMU (:mod:`.parametric`) trained over them, with
        parameters ``c``, ``d``; empty (default): the scene's fixed c and d.
    ports : sequence of float or str, optional
        Mechanical port positions x/L (:mod:`sphrom.sph.ports`): inputs F_port_j [N], outputs v_port_j
        [m s^-1], parameter area [m^2]; the model must take ports (``ports`` in the registry).

    Raises
    ------
    FieldError
        A bad setting (naming its field and the allowed range); nothing is written.
    SimulationError
        The packaged FMU fails fmpy's validation (nothing is written).
    ToleranceError
        ``verify`` (and ``accept``): the FMU failed, ran away or missed the accuracy on a case (nothing is written).
    """
    integrator_given = integrator is not None
    k, n_freeze, probes, fmi, integrator = check_options(scene, k=k, n_freeze=n_freeze, probes=probes, fmi=fmi,
                                                         integrator=integrator, model=model,
                                                         tolerance=tolerance, order_tolerance=order_tolerance,
                                                         ports=ports or ())
    ports = check_ports(ports, model)
    timings = {}
    t0 = time.perf_counter()
    data, ops, blob, parameters = model_step(scene, model, k, n_freeze, probes, integrator, progress, problem,
                                             vary=vary, ports=ports, bounds=bounds, order_tolerance=order_tolerance,
                                             error_bounds=error_bounds,
                                             build_options=build_options, integrator_given=integrator_given)
    integrator = kind_of(data).integrator(data) or integrator       # a frozen kind's own choice (open-ended runs)
    problem = problem or build_problem(scene)
    step = step_size if step_size is not None else default_step(scene, data, ops, problem)
    timings["model"] = time.perf_counter() - t0
    stage_done(scene, "model", timings, progress)
    envelope = envelope_step(data)
    t1 = time.perf_counter()
    carried = binaries_step(binaries, fmi, progress)
    binary = carried.for_fmi(fmi)
    timings["binaries"] = time.perf_counter() - t1
    stage_done(scene, "binaries", timings, progress)
    k = data.k_v if k is None else k                 # the balanced model's order from its order tolerance
    passivity = passivity_step(ops, model, ports)
    texts = dict(scene=scene, model=model, data=data, ops=ops, k=k, fmi=fmi, step=step, envelope=envelope,
                 tolerance=tolerance, passivity=passivity, platforms=carried, choice=choice)
    t2 = time.perf_counter()
    out = Path(out)
    verification = None
    with atomic_path(out) as tmp:
        archive_step(tmp, blob, binary, check=not verify, **texts)   # verified: validated once, when rewritten
        timings["package"] = time.perf_counter() - t2
        stage_done(scene, "package", timings, progress)
        if verify:
            t3 = time.perf_counter()
            exact_in_time = kind_of(data).integrator(data) is None and step_size is None
            at = measure_step(scene, problem, ops) if exact_in_time else None
            verification = verification_step(tmp, scene, probes, references, problem, progress, tolerance, out, model,
                                             ports=ports, accept=accept, step=at)
            archive_step(tmp, blob, binary, verification=verification, **texts)   # only the texts change
            timings["verify"] = time.perf_counter() - t3
            stage_done(scene, "verify", timings, progress)
        size = tmp.stat().st_size
    # the kind's own parameters (the frozen kind's n_freeze and dt); a kind without them reports the options given
    starts = kind_of(data).parameter_starts(data)
    return FMUSummary(path=out, fmi=fmi, scene=scene.name, k=k, k_v=data.k_v, k_rho=data.k_rho,
                      input_error=ops.input_error, augmented=ops.augmented, probes=list(probes),
                      n_freeze=starts.get("n_freeze", n_freeze or defaults.N_FREEZE),
                      n_freeze_errors=dict(getattr(data, "n_freeze_errors", {}) or {}),
                      integrator=integrator, dt=starts.get("dt", scene.sph.dt), token=data.token, size=size, timings=timings, model=model,
                      envelope=envelope, verification=verification, bounds=data.bounds,
                      method=ops.method, parameters=parameters, ports=list(ports), port_errors=list(ops.port_errors),
                      port_passivity=passivity, platforms=carried.words(), missing_platforms=carried.missing_lines(),
                      **_shadow_facts(data.sections))


def _shadow_facts(sections):
    """The summary's shadow_order and error_tolerance from section SHSCAL (:func:`sphrom.rom.bounds.sections`)."""
    scal = sections.get("SHSCAL")
    if scal is None:
        return {}
    return {"shadow_order": int(layout.value(sections, "SHSCAL", "order")),
            "error_tolerance": layout.value(sections, "SHSCAL", "tolerance")}


def model_step(scene, model, k, n_freeze, probes, integrator, progress, problem, *, vary, ports, bounds,
               order_tolerance, build_options, extra_steps=(), error_bounds=True, integrator_given=True):
    """Step 2: (data, operators, resources/model.bin bytes, the parametric FMU's parameter rows) of ``model``:
    the model kind's packaging step (:mod:`sphrom.fmu.kinds`, ``resource``), or the parametric model over
    ``vary``.  ``integrator_given`` False: a time-stepped kind chooses its integrator for open-ended runs
    (:func:`sphrom.fmu.kinds.frozen.open_ended_integrator`)."""
    if not vary:
        kind = for_model(model)
        own = {"integrator_given": integrator_given} if "integrator" in kind.BUILD_OPTIONS else {}
        data, ops, blob = kind.resource(scene, model, k, n_freeze, probes, integrator, progress, problem,
                                        order_tolerance=order_tolerance, bounds=bounds, ports=ports,
                                        error_bounds=error_bounds, build_options=build_options,
                                        extra_steps=extra_steps, **own)
        return data, ops, blob, []
    if build_options:
        raise FieldError("build_options", "not with vary (a parametric model has its own build)")
    data, ops, blob, space = parametric_resource(scene, model, k, n_freeze or defaults.N_FREEZE, probes, integrator,
                                                 progress, vary, error_bounds=error_bounds,
                                                 integrator_given=integrator_given)
    return data, ops, blob, parameter_variables(space)


def envelope_step(data):
    """Step 3: the training envelope stored in the resources' sections (:class:`sphrom.fmu.training.envelope.Envelope`)."""
    return Envelope.from_sections(data.sections, data.k_v)


def binaries_step(binaries, fmi, progress):
    """Step 4: the binaries the FMU carries (:class:`.build.FMUBinaries`): this platform's (``binaries`` given, or
    built once and cached: :func:`.build.ensure_binaries`) and the cross-compiled ones (:func:`.build.fmu_binaries`:
    win64 where MinGW-w64 is installed)."""
    return fmu_binaries(binaries, quiet=not progress)


def description_step(*, scene, model, data, ops, k, fmi, step, envelope, verification=None, **_):
    """Step 5: modelDescription.xml, with the measured sentence when verified (:mod:`.describe`)."""
    return model_description(fmi, token=data.token, scene=scene, data=data, k_requested=k, step_size=step,
                             stop_time=scene.T, input_error=ops.input_error, model=model, envelope=envelope,
                             bounds=data.bounds, measured=None if verification is None else verification.sentence())


def archive_step(path, blob, binary, check=True, **texts):
    """Steps 5 to 7: description, documentation, the archive at ``path`` and fmpy's validation of it
    (``check``; SimulationError listing the problems)."""
    description = description_step(**texts)
    docs = documentation_files(scene=texts["scene"], spec=get_model(texts["model"]), data=texts["data"],
                               k=texts["k"], input_error=texts["ops"].input_error,
                               augmented=texts["ops"].augmented, description_xml=description,
                               verification=texts.get("verification"), tolerance=texts["tolerance"],
                               envelope=texts["envelope"], passivity=texts.get("passivity"),
                               platforms=texts.get("platforms"), choice=texts.get("choice", ""))
    write_fmu(path, fmi=texts["fmi"], blob=blob, description=description, binary=binary, documentation=docs)
    problems = validate(path) if check else []
    if problems:
        raise SimulationError("the packaged FMU fails fmpy's validation: " + "; ".join(problems))


def passivity_step(ops, model, ports):
    """The port map's passivity check of a port FMU's model (:func:`sphrom.rom.passivity.port_passivity`: the
    storage certificate, else the positive-real margin on a frequency grid; a second or less at k = 233), or
    None without ports."""
    if not len(ports):
        return None
    return port_passivity(ops, get_model(model).linear)


def verification_step(path, scene, probes, references, problem, progress, tolerance, out, model, ports=(),
                      accept=True, step=None):
    """Step 8: the FMU at ``path`` measured against the full SPH linear in J, integrated exactly in time
    (:func:`sphrom.fmu.check.verify.verify_fmu`: the training force, a step and an unseen sine), and each input
    channel (f, each port force, against the full SPH with the FMU's integrator:
    :func:`sphrom.fmu.check.channels.measure_channels`), and its cost per simulated second against the full SPH's
    (:func:`sphrom.fmu.check.verify.measure_cost`, the median of pairs of runs; when no case failed); ToleranceError
    (``accept``) when the FMU failed, ran away or
    missed the accuracy on a case (:func:`sphrom.fmu.check.verify.acceptance`), or a channel's error is above
    ``tolerance``.  ``step``: the measurement's communication step (:func:`sphrom.fmu.check.verify.measure_step`
    for a model exact in time; None: the FMU's default), the cost always at the FMU's default step."""
    verification = verify_fmu(path, scene, probes, refs=references, problem=problem, progress=progress, step=step)
    if all(not c.note for c in verification.cases):     # it ran every case: its cost per simulated second
        verification.cost = measure_cost(path, scene, verification, problem=problem)
    verification.channels = measure_channels(path, scene, ports=ports, problem=problem, progress=progress)
    verification.channel_horizon = horizon(scene)
    if accept:
        check_tolerance(verification, tolerance, out, model)
    return verification


def default_step(scene, data, ops, problem=None):
    """The FMU's DefaultExperiment stepSize [s]: :func:`sphrom.fmu.check.verify.communication_step` of the top of
    the scene's band as the model holds it (:func:`sphrom.fmu.check.verify.top_frequency` over its velocity modes),
    at least the model's internal dt; a model exact in time (no integrator of its own: the linear models) the step
    its input and its outputs need (:func:`sphrom.fmu.check.verify.exact_time_step`)."""
    problem = problem or build_problem(scene)
    if kind_of(data).integrator(data) is None:        # exact in time: the step the input and the outputs need
        return exact_time_step(scene, problem, ops)
    nu_top = top_frequency(scene, problem, ops)
    return communication_step(scene, nu_top, kind_of(data).parameter_starts(data).get("dt"))


def stage_done(scene, stage, timings, progress):
    """The progress line of a finished packaging stage and its time (stderr; nothing without ``progress``)."""
    if progress:
        import sys
        print(f"fmu {scene.name}: {stage} {timings[stage]:.2f} s", file=sys.stderr, flush=True)


def check_tolerance(verification, tolerance, out, model):
    """ToleranceError (one line: what failed, the remedy, that ``out`` was not written) when the FMU failed, ran away
    or missed the accuracy (``tolerance``, None: :data:`sphrom.fmu.check.verify.ACCURACY`) on a case of
    ``verification`` (:func:`sphrom.fmu.check.verify.acceptance`), or, with a ``tolerance``, an input channel's error
    is above it."""
    verdict = acceptance(verification, tolerance, model)
    if verdict is not None:
        raise ToleranceError(f"{verdict}; '{out}' was not written (an existing file is unchanged)")
    if tolerance is None:
        return
    for c in verification.channels:            # every input channel (sphrom.fmu.check.channels)
        if not c.err <= tolerance:
            raise ToleranceError(f"the {model} FMU's {c.output} error under a {c.case} {c.channel} from rest, "
                                 f"{c.err:.3g}, is above the tolerance {tolerance:g}; '{out}' was not written (an "
                                 "existing file is unchanged)")


def documentation_files(*, scene, spec, data, k, input_error, augmented, description_xml, verification=None,
                        tolerance=None, envelope=None, passivity=None, platforms=None, choice=""):
    """{archive name: content} of the FMU's documentation/ folder: index.html, and probes.png when measured."""
    files = {DOC_INDEX: index_html(scene=scene, spec=spec, data=data, k=k, input_error=input_error,
                                   augmented=augmented, description_xml=description_xml,
                                   verification=verification, tolerance=tolerance, envelope=envelope,
                                   passivity=passivity, platforms=platforms, choice=choice)}
    if verification is not None:
        from ..check.verify import probes_png
        files[DOC_PLOT] = probes_png(verification, title=f"{scene.name}, {spec.name} FMU against the full SPH")
    return files


