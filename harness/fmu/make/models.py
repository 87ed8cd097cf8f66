"""Step "model" of ``package_fmu``: the builders of the reduced models' numbers and operators that the model kinds'
packaging steps use (:mod:`sphrom.fmu.kinds`: kind 1 the frozen model, kind 2 the exact model on its POD basis and
the balanced model without one), the training envelope (:mod:`.envelope`) and the certified error bounds.

:func:`resources` maps a model's ``fmu_kind`` to its kind's packaging step; :func:`operator_resource` packs
operators built elsewhere (a benchmark's own).
"""

from __future__ import annotations

import time

import numpy as np

from ... import defaults
from ...errors import FieldError
from ..kinds import by_number, kinds
from ..kinds.frozen import model_data
from ..kinds.linear import balanced_data, exact_data
from ..resources import pack


def model_basis(scene, spec, k, progress=True, problem=None, made=None):
    """(basis, problem) of ``scene`` for the model ``spec``: its POD basis, with k checked against the modes of the
    model's basis kind (FieldError naming the field ``k`` or ``model``).  ``made``: the (basis, run) of
    :func:`sphrom.pod.pipeline.basis_for_scene` already made for this scene (not made again)."""
    from ...pod.pipeline import basis_for_scene
    from ...rom.model import BASIS_KINDS
    from ...sph.solver import build_problem

    problem = problem or build_problem(scene)
    basis, _ = made or basis_for_scene(scene, progress=progress, problem=problem)
    available = spec.available_modes(basis)
    if available is None:
        raise FieldError("model", f"{spec.name}: the basis of scene '{scene.name}' has no "
                                  f"{' and '.join(BASIS_KINDS[spec.basis_kind][:2])} modes")
    if k > min(available):
        raise FieldError("k", f"{k} is out of range (allowed: 1 to {min(available)}, the POD modes of scene "
                              f"'{scene.name}')")
    return basis, problem


def reduced_model(scene, k, n_freeze, probes, integrator, progress=True, problem=None, model="frozen", ports=(),
                  build_options=None, made=None, tensor=None):
    """The FMU's numbers for a model of resource kind 1 (frozen coefficients): (ModelData, ops, problem, basis).

    Runs (or reuses) the full SPH and the POD (sphrom.pod.pipeline), builds the model's operators
    (``get_model(model).build``: the frozen model's own, b about the projected rest density so that the FMU
    started at rest stays at rest, :func:`sphrom.rom.operators.rest_b`) with ``input_direction="needed"`` (an
    input row always; the force profile appended to U_v only when the POD modes miss more than 1 % of it) and
    the refresh tensor where the FMU keeps it or it is small (``tensor`` None: where it costs less than the
    particle refresh, :func:`particle_sections`, or has at most ``TENSOR_MAX_ENTRIES`` entries; a port model's
    larger basis, whose tensor grows as k⁴, is not built; ``"always"``: built anyway).  ``build_options`` go to
    the model's build (``{"b": "paper"}``: eq. 2.22's b, the paper's variant, :mod:`sphrom.bench.rest` compares
    them).
    """
    from ...rom.registry import get_model
    from ...rom.stepping import runaway_bound

    spec = get_model(model)
    basis, problem = model_basis(scene, spec, k, progress=progress, problem=problem, made=made)
    ops = spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction,
                     tensor="always" if tensor == "always" else "never",
                     **({"ports": tuple(ports)} if ports else {}), **(build_options or {}))
    from ...rom.operators import wants_tensor
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


def exact_model(scene, k, probes, progress=True, problem=None, model="exact", ports=(),
                build_options=None, made=None):
    """The FMU's numbers for a model of resource kind 2 on a POD basis (the exact model):
    (ExactData, lin, problem, basis).

    The model's bases (the exact model: the energy-weighted ``Basis.U_ve``, ``U_e``), the operators with the
    model's ``fmu_input_direction`` (the exact model: ``"always"``, the force profile is always in its
    velocity basis, so the input f is represented exactly) and ``build_options``.
    """
    from ...rom.registry import get_model

    spec = get_model(model)
    basis, problem = model_basis(scene, spec, k, progress=progress, problem=problem, made=made)
    lin = spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction,
                     **({"ports": tuple(ports)} if ports else {}), **(build_options or {}))
    data = exact_data(lin, problem, probes=probes, bound=linear_bound(lin, scene))
    return data, lin, problem, basis


def training_envelope(scene, ops, problem, probes, linear, progress=False, run=None):
    """The :class:`~sphrom.fmu.make.envelope.Envelope` of the model ``ops``: its ranges over the scene's cached
    full SPH training run (:mod:`sphrom.fmu.make.envelope`)."""
    from ...pod.pipeline import basis_for_scene
    from .envelope import measure
    if run is None:
        _, run = basis_for_scene(scene, progress=progress, problem=problem)
    return measure(scene, ops, problem, run, probes, linear)


def training_basis(scene, progress, problem, extra_steps=()):
    """(basis, run, problem): the scene's POD basis and its cached training run, made once for the model and its
    training envelope (one SPH load and one POD).  ``extra_steps``: more samples the same run stores (the
    communication points a verification reads: the training run is then not run again for it)."""
    import dataclasses

    from ...pod.pipeline import basis_for_scene, error_steps
    from ...sph.solver import build_problem
    problem = problem or build_problem(scene)
    basis, run = basis_for_scene(scene, progress=progress, problem=problem, extra_steps=extra_steps)
    # the envelope is measured on the samples the model asks for (error and snapshot steps), not on whatever
    # else the cache holds from other commands: the same resources whatever the cache's history
    keep = np.isin(run.steps, np.union1d(error_steps(scene), np.union1d(basis.steps_v, basis.steps_rho)))
    if not keep.all():
        run = dataclasses.replace(run, t=run.t[keep], v=run.v[keep], rho=run.rho[keep], steps=run.steps[keep])
    return basis, run, problem


def balanced_model(scene, k, probes, order_tolerance=None, problem=None, model="balanced",
                   build_options=None, ports=()):
    """The FMU's numbers for a linear model without a POD basis (balanced): (ExactData, ops, problem).

    The full linear SPH of the scene with the FMU's probes as outputs, balanced
    and truncated at order ``k`` (or the order ``order_tolerance`` gives; the default
    tolerance when both are None); :func:`sphrom.fmu.resources.balanced_data`.
    """
    from ...rom.registry import get_model
    from ...sph.solver import build_problem

    problem = problem or build_problem(scene)
    try:
        ops = get_model(model).build(problem, None, k, k, order_tolerance=None if k is not None else order_tolerance,
                                     probes=probes, **({"ports": tuple(ports)} if ports else {}),
                                     **(build_options or {}))
    except ValueError as exc:
        field_name, _, detail = str(exc).partition(": ")
        raise FieldError("k" if field_name == "order" else field_name, detail) from None
    return balanced_data(ops, problem), ops, problem


def linear_bounds(ops, problem, probes, progress=True):
    """The certified error bounds of a linear reduced model at the velocity probes (the operators'
    ``error_bounds``, :func:`sphrom.rom.balanced.error_bounds`), with a progress bar over the probes."""
    from ...progress import progress_bar

    with progress_bar(len(probes), "error bounds", unit="probe", enabled=progress) as bar:
        return ops.error_bounds(problem, probes, progress=bar)


def linear_bound(lin, scene, samples=4097):
    """The linear FMU's runaway bound on |z|: 10⁶ (|z0| + |B| ∫_0^T |f| dt) with the scene's force over its T
    (:func:`sphrom.rom.exact_linear.linear_runaway_bound`; trapezoidal rule on ``samples`` points).

    10⁶ |z0| alone is 0 for a scene at rest, and such an FMU stopped as a runaway at its first forced step.
    """
    import numpy as np

    from ...rom.exact_linear import linear_runaway_bound
    t = np.linspace(0.0, float(scene.T), samples)
    f = np.abs(np.asarray(scene.force(t), float)) if lin.B is not None else np.zeros(samples)
    return linear_runaway_bound(lin, float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t))))


N_FREEZE_CANDIDATES = (1, 2, 5, 10, 20, 50, 100)   # refresh periods tried when the user gives none
N_FREEZE_SLACK = 0.05       # ... the largest whose training error is within this of n_freeze = 1's (relative)
N_FREEZE_BUDGET = 4e9       # multiply-adds of one trial run at n_freeze = 1 (about 2 s here); beyond, a shorter run
N_FREEZE_MIN_SAMPLES = 10   # ... of at least this many of the training run's samples


def particle_sections(ops, problem):
    """The sections of the frozen model's particle refresh (PARTUR, PARTGUV, PARTIR0: U^rho, G U^v, 1/rho0 at the
    N particles), or {} where the tensor costs less.  The refresh of M (eq. 2.23 projected) from the tensor takes
    n_pairs (1 + nm) multiply-adds and streams its n_pairs k_rho k_v values from memory; from the particles it
    takes N (k_rho + kr_pad + k_v kr_pad) + nm on arrays that stay in cache (the core's counts,
    :func:`sphrom.fmu.kinds.frozen.refresh_matrix_work`).  A port model's larger basis (k_v, k_rho = 48, 47 on damped_forced, whose
    tensor is 20 MB) is where the particles win; k = 12 on N = 400 keeps the tensor.  The particle path sums in
    another order than the tensor: the FMU then equals the Python model run with ``refresh="direct"``."""
    from ..kinds.frozen import refresh_matrix_work
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
    from ...errors import SimulationError
    from ...rom.registry import get_model
    from ...sph.solver import step_count
    from ..kinds.frozen import step_work
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


def shadow_step(data, problem, probes, ports=(), parametric=False):
    """The certified error bounds' shadow of every output into ``data.sections`` (SH*, :mod:`sphrom.rom.bounds`;
    the FMU's outputs ``*_error_bound`` and parameter ``error_tolerance``), its default tolerance from the training
    run's largest |v_probe| (section ENVPROBE; without it the initial state's); nothing where the C core cannot
    certify (more than FMU_MAX_PARTICLES particles, a parametric model whose d is not uniform).  A damping d that
    is not uniform gives one dense block (sections SHDENSE, SHEGRAM).  ``parametric``: the shadow of a parametric
    FMU (its planes in pieces of c and d, sections SHPIECE and SHPARAM; the C core assembles them at the FMU's c
    and d)."""
    from ...rom.bounds import fmu_shadow, sections
    envelope = data.sections.get("ENVPROBE")
    scale_v = float(np.max(envelope[1])) if envelope is not None else None
    shadow = fmu_shadow(problem, probes, tuple(ports or ()), parametric=parametric, scale_v=scale_v)
    if shadow is not None:
        data.sections.update(sections(shadow))


def resources():
    """{model_kind (ReducedModel.fmu_kind): the kind's packaging step} (:mod:`sphrom.fmu.kinds`: each kind's
    ``resource``, which makes the FMU's numbers and their bytes)."""
    return {number: kind.resource for number, kind in kinds().items()}


def __getattr__(name):
    if name == "RESOURCES":           # the table's former name: resources()
        return resources()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def operator_resource(kind, ops, problem, *, dt, n_freeze=defaults.N_FREEZE, probes=defaults.PROBES,
                      integrator="euler"):
    """(data, bytes) of resources/model.bin of kind ``kind`` (ReducedModel.fmu_kind) from operators built
    elsewhere (a benchmark's own), the runaway bound that of their initial state, as :func:`reduced_model` and
    :func:`exact_model` have it; the initial state is scaled at run time by the FMU's initial_state_scale.  The
    operators are packaged as they are: the frozen model's own (``get_model("frozen").build``, b about the
    projected rest density) give the FMU's frozen model, ``b="paper"`` ones eq. 2.22's variant.  ``dt``,
    ``n_freeze``, ``integrator`` go to a kind that takes them (its ``BUILD_OPTIONS``: the frozen kind)."""
    module = by_number(kind)
    given = {"dt": dt, "n_freeze": n_freeze, "integrator": integrator}
    data = module.from_operators(ops, problem, probes=probes,
                                 **{name: given[name] for name in module.BUILD_OPTIONS})
    return data, pack(data)
