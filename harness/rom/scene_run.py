"""A reduced model run over a scene and measured against the full SPH and the exact solution (``sphrom rom``).

:func:`build_on_basis` and :func:`run_on_basis` run a model on a POD basis (original, linearized, frozen, exact);
:func:`run_order` runs a model without a basis (balanced) at an order, with its certified error bounds and what they
bound measured apart.  Each returns the fields, the errors (relative L² of eq. 3.4) and the attributes of the run
file (:func:`sphrom.runio.write_run`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..cache import cached_sph
from ..compare import error_table, exact_errors
from ..errors import FieldError, UserError, exact
from ..norms import relative_l2
from ..pod.pipeline import error_steps, on_steps
from ..progress import progress_bar
from ..references.exact import exact_solution, is_available
from ..runio import scene_attrs
from ..sph.solver import build_problem, step_count
from .balanced_model import measured_errors
from .result import probe_values

# At most this many communication steps H in one run of a linear model (a Python loop of one k x k product
# each, and the input sampled at every step): 1e6 steps take seconds, 1e12 would take days and terabytes.
MAX_ROM_STEPS = 1_000_000


def check_step(step, T, model):
    """FieldError ``step`` unless ``step`` (None: the default) is a communication step of a linear model with
    at most MAX_ROM_STEPS steps to T [s] and no longer than T."""
    if step is None:
        return
    if not model.linear:
        raise FieldError("step", f"applies to the linear models, whose communication step it is (the {model.name} "
                                 "model steps with the scene's dt)")
    if not (step <= T and T / step <= MAX_ROM_STEPS):
        raise FieldError("step", f"{exact(step)} is out of range (allowed: T / {MAX_ROM_STEPS:.0e} = "
                                 f"{T / MAX_ROM_STEPS:g} s <= step <= T = {T:g} s)")


def check_basis(scene, basis, name):
    """FieldError ``basis`` unless ``basis`` (a PODBasis read from the file ``name``) was made for ``scene``: its
    particle count and its dt."""
    if basis.U_v.shape[0] != scene.sph.n_particles:
        raise FieldError("basis", f"'{name}' has {basis.U_v.shape[0]} particles, the scene {scene.sph.n_particles}")
    if abs(basis.dt - scene.sph.dt) > 1e-15 * scene.sph.dt:
        raise FieldError("basis", f"'{name}' was made with dt = {exact(basis.dt)} s, the scene has "
                                  f"{exact(scene.sph.dt)} s")


@dataclass
class SceneRun:
    """A reduced run of a scene beside the full SPH: the fields, their errors and the run file's attributes.

    ``vs_sph`` / ``vs_exact``: :func:`sphrom.compare.error_table` of the reconstructed fields against the full SPH
    and the exact solution (None where the scene has none); ``integrator``: the integrator's words (a linear
    model's communication step and input hold); ``attrs``: the run file's attributes; ``extra``: its extra
    datasets.  A model without a basis also has ``probe_err`` / ``probe_exact`` (the errors at its probes),
    ``bounds`` (its certified error bounds, computed in ``t_bounds`` [s]) and, measured apart, ``h`` [s],
    ``measured`` and ``gain`` (:func:`sphrom.rom.balanced_model.measured_errors`).
    """

    scene: object
    problem: object
    ops: object
    result: object
    sph: object
    integrator: str
    n_steps: int
    vs_sph: dict
    vs_exact: dict | None
    attrs: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    offline: dict = field(default_factory=dict)
    probe_err: dict | None = None
    probe_exact: dict | None = None
    bounds: dict | None = None
    t_bounds: float = 0.0
    h: float = 0.0
    measured: np.ndarray | None = None
    gain: np.ndarray | None = None


def build_on_basis(problem, model, basis, k_v, k_rho, *, build=None, augment_input=False, name=""):
    """The operators of ``model`` (a ReducedModel with a POD basis) on ``basis`` (read from the file ``name``)
    with k_v, k_rho modes.

    ``build``: the model's build options (the frozen model's ``b``); ``augment_input``: the force direction
    appended to the velocity basis (else the model's rule).  A UserError of the build is re-raised as a FieldError
    naming the field ``basis`` and the file."""
    try:
        return model.build(problem, basis, k_v, k_rho, input_direction="augment" if augment_input else "auto",
                           **(build or {}))
    except UserError as exc:
        raise FieldError("basis", f"'{name}': {exc}") from None


def run_on_basis(scene, model, ops, problem, *, integrator, n_freeze, refresh, step=None, hold=None, build=None,
                 basis=None, basis_name="", progress=True):
    """Run ``model``'s operators ``ops`` (:func:`build_on_basis`) over ``scene`` and measure the fields.

    Parameters
    ----------
    scene : Scene
    model : ReducedModel
    ops : Operators
    problem : Problem
        The scene's (:func:`sphrom.sph.solver.build_problem`), as ``ops`` was built on.
    integrator : str
        The time integrator (a time-stepped model), or the linear model's first (its words then name the step).
    n_freeze, refresh : int, str
        The frozen model's refresh period and refresh (ignored by the others).
    step, hold : float or None, str
        A linear model's communication step [s] (None: the sample spacing) and input hold.
    build : dict, optional
        The build options ``ops`` was made with (the frozen model's ``b``: stored in the run file).
    basis, basis_name :
        The PODBasis (its SVD time) and its file name (stored).

    Returns
    -------
    SceneRun
    """
    build = build or {}
    steps = error_steps(scene)
    n = step_count(scene.T, scene.sph.dt)
    # the command's settings that are options of this model (integrator; n_freeze, refresh; step, hold)
    options = model.select_options(integrator=integrator, n_freeze=n_freeze, refresh=refresh, step=step, hold=hold)
    result = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, options=options,
                       force=scene.force, progress=progress)
    if model.linear:
        integrator = f"matrix exponential, H = {result.settings['step']:g} s, input {hold}"
    sph_scene = scene if model.linear else scene.with_sph(integrator=integrator)
    sph = cached_sph(sph_scene, steps, progress=progress, problem=problem)
    v_sph, rho_sph = on_steps(sph, steps)
    v, rho = result.v, result.rho
    vs_sph = error_table(v, rho, v_sph, rho_sph, result.t, problem.rho0)
    vs_exact = exact_errors(scene, result.t, problem.x, v, rho, problem.rho0)
    offline = {"svd": basis.timings.get("svd", 0.0) if basis is not None else 0.0, "tensor": 0.0, **ops.timings}
    k_first, k_second = ops.sizes.values()
    attrs = {**scene_attrs(scene), "solver": f"rom-{model.name}", "solver.model": model.name,
             "solver.integrator": integrator, "solver.k_v": k_first, "solver.k_rho": k_second,
             "solver.basis": str(basis_name), "solver.augmented_input": int(ops.augmented),
             "solver.input_error": ops.input_error, "wall_time_s": result.wall_time,
             **{f"offline_time.{k}": v for k, v in offline.items()},
             **{f"error.sph.{k}": v for k, v in vs_sph.items()}}
    if model.uses_n_freeze:
        attrs.update({"solver.n_freeze": n_freeze, "solver.refresh": refresh})
    if "b" in build:
        attrs["solver.b"] = build["b"]
    if vs_exact is not None:
        attrs.update({f"error.exact.{k}": v for k, v in vs_exact.items()})
    return SceneRun(scene=scene, problem=problem, ops=ops, result=result, sph=sph, integrator=integrator,
                    n_steps=n, vs_sph=vs_sph, vs_exact=vs_exact, attrs=attrs, offline=offline,
                    extra={"a_v": result.a_v, "a_rho": result.a_rho})


def probe_errors(y, y_ref, t, P):
    """{"v", "e"}: relative L² errors (eq. 3.4) of the probe outputs ``y`` (M, 2P: P velocities, then P specific
    volumes) against ``y_ref`` at the times ``t`` [s]."""
    return {"v": relative_l2(y[:, :P], y_ref[:, :P], t), "e": relative_l2(y[:, P:], y_ref[:, P:], t)}


def run_order(scene, model, *, order=None, order_tolerance=None, step=None, hold=None, progress=True):
    """Run ``model`` (a ReducedModel without a POD basis: balanced) over ``scene`` at an order, with its
    certified error bounds.

    Parameters
    ----------
    scene : Scene
    model : ReducedModel
    order : int, optional
        The order r (None: from ``order_tolerance``, or the model's default tolerance).
    order_tolerance : float, optional
        The tolerance that sets the order.
    step, hold : float or None, str
        The communication step [s] (None: the sample spacing) and the input hold.

    Returns
    -------
    SceneRun
        With the probe errors against the full SPH (and the exact solution where the scene has one), the fields
        reconstructed through V, the certified bounds and what they bound measured apart (both models exact in
        time).

    Raises
    ------
    FieldError
        ``step`` out of range; ``modes`` (the order) or another build field out of range, or an order whose
        reconstructed fields are not finite and positive.
    """
    check_step(step, scene.T, model)
    problem = build_problem(scene)
    steps = error_steps(scene)
    n = step_count(scene.T, scene.sph.dt)
    try:
        ops = model.build(problem, None, order, order, order_tolerance=order_tolerance)
    except ValueError as exc:
        name, _, detail = str(exc).partition(": ")
        raise FieldError("modes" if name == "order" else name, detail) from None
    result = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, force=scene.force,
                       options=model.options(step=step, hold=hold))
    integrator = f"matrix exponential, H = {result.settings['step']:g} s, input {hold}"
    sph = cached_sph(scene, steps, progress=progress, problem=problem)
    v_sph, rho_sph = on_steps(sph, steps)
    v, rho, t, x, L, rho0 = result.v, result.rho, result.t, problem.x, scene.L, problem.rho0
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(rho)) and np.all(rho > 0)):
        raise FieldError("modes", f"the fields reconstructed at order {ops.order} are not finite and positive; "
                                  "raise the order")
    probes = ops.output_probes
    P = probes.size
    y = result.y
    probe_err = probe_errors(y, probe_values(v_sph, rho_sph, rho0, x, L, probes), t, P)
    vs_sph = error_table(v, rho, v_sph, rho_sph, t, rho0)
    vs_exact = exact_errors(scene, t, x, v, rho, rho0)
    probe_exact = None
    if is_available(scene):
        probe_exact = probe_errors(y, probe_values(*exact_solution(scene, x, t), rho0, x, L, probes), t, P)
    # certified bounds, and what they bound measured apart (both models exact in time)
    t0 = time.perf_counter()
    with progress_bar(P, "bounds", unit="probe", enabled=progress) as bar:
        bounds = ops.error_bounds(problem, probes, progress=bar)
    t_bounds = time.perf_counter() - t0
    h, measured, gain = measured_errors(ops, scene.T, scene.force)
    offline = dict(ops.timings)
    attrs = {**scene_attrs(scene), "solver": f"rom-{model.name}", "solver.model": model.name,
             "solver.integrator": integrator, "solver.order": ops.order, "solver.method": ops.method,
             "solver.k_v": ops.order, "solver.k_rho": 0, "solver.basis": "", "wall_time_s": result.wall_time,
             "probes": probes, **{f"offline_time.{k}": v for k, v in offline.items()},
             "offline_time.bounds": t_bounds,
             **{f"error.sph.{k}": v for k, v in vs_sph.items()},
             **{f"error.sph.probes.{k}": v for k, v in probe_err.items()},
             "bound.force_error_bound": bounds["force_error_bound"],
             "bound.initial_state_error_bound": bounds["initial_state_error_bound"],
             "bound.initial_state_error_measured": measured, "bound.force_gain_measured": gain,
             "bound.sigma": bounds["sigma"]}
    if order_tolerance is not None:
        attrs["solver.tolerance"] = order_tolerance          # the attribute's name kept (file layout)
    if vs_exact is not None:
        attrs.update({f"error.exact.{k}": v for k, v in vs_exact.items()})
        attrs.update({f"error.exact.probes.{k}": v for k, v in probe_exact.items()})
    return SceneRun(scene=scene, problem=problem, ops=ops, result=result, sph=sph, integrator=integrator, n_steps=n,
                    vs_sph=vs_sph, vs_exact=vs_exact, attrs=attrs, offline=offline,
                    extra={"x_r": result.z, "y": y, "hsv": ops.hsv}, probe_err=probe_err, probe_exact=probe_exact,
                    bounds=bounds, t_bounds=t_bounds, h=h, measured=measured, gain=gain)
