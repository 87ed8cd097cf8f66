"""``sphrom rom``: run a reduced model from a basis file."""

import sys

from .. import defaults
from ..options import (LazyChoices, LazyHelp, add_n_freeze, add_order_tolerance, add_quiet, add_scene, modes_pair,
                      positive_float)

# deferred imports below (inside the handlers): start-up time, the parsers of every command import nothing heavy

B_CHOICES = ("paper", "rest")    # the frozen model's b (sphrom.rom.operators.B_FORMS)
# At most this many communication steps H in one run of a linear model (a Python loop of one k x k product
# each, and the input sampled at every step): 1e6 steps take seconds, 1e12 would take days and terabytes.
MAX_ROM_STEPS = 1_000_000


def add_parser(sub):
    p = sub.add_parser("rom", help="run a reduced model (original, linearized, frozen, exact, balanced)",
                       description="Run the original POD-MOR (eq. 2.16), the density-linearised model (eq. 2.17) or "
                                   "the frozen-coefficient model (eqs. 2.19-2.24) of SCENE on a basis from "
                                   "'sphrom pod', the exact linear model on its energy-weighted modes, or the balanced "
                                   "model (no basis: --modes R is its order), write the reconstructed fields in the "
                                   "run layout of 'sphrom sph', and print the errors against the full SPH and the "
                                   "exact solution (balanced: also at the probes, with its certified error bounds).")
    add_scene(p)
    p.add_argument("--basis", metavar="BASIS.h5",
                   help="POD basis from 'sphrom pod' (required by every model but balanced, which uses none)")
    # the registry (which imports numba and scipy) is read only when a value is checked or the help is shown
    p.add_argument("--model", required=True, metavar="MODEL", action=LazyHelp,
                   choices=LazyChoices(lambda: _models()), help=lambda: "; ".join(
                       f"{m.name}: {m.description}" for m in _models().values()))
    add_n_freeze(p, default=defaults.N_FREEZE)
    p.add_argument("--modes", type=modes_pair, metavar="K|KV,KRHO",
                   help="mode counts (default: the basis file's); balanced: its order r, one number")
    add_order_tolerance(p, "--tolerance", note="; --tolerance is its earlier name (in 'sphrom rom' only: "
                                               "'sphrom fmu --tolerance' is the measured error accepted)")
    p.add_argument("--integrator", choices=("euler", "symplectic", "rk4"),
                   help="time integrator (default: the scene's; rk4 is not defined for frozen coefficients)")
    p.add_argument("--refresh", choices=("tensor", "direct"), default=defaults.REFRESH,
                   help=f"frozen refresh: the exact O(k^4)-type tensor or the O(N k^2) product (default "
                        f"{defaults.REFRESH})")
    p.add_argument("--b", choices=B_CHOICES, dest="b",
                   help="frozen model: b of eq. 2.19, eq. 2.22's (paper; the default here, as the paper's model) or "
                        "K a^rho_rest, which makes the projected rest state an equilibrium (rest; the frozen FMU's "
                        "model, as 'sphrom fmu' packages it)")
    p.add_argument("--step", type=positive_float, metavar="H",
                   help="linear models (exact, balanced): communication step [s] (default the sample spacing)")
    p.add_argument("--hold", choices=("linear", "held"), default=defaults.HOLD,
                   help=f"linear models: input linear or held over a step (default {defaults.HOLD})")
    p.add_argument("--augment-input", action="store_true",
                   help="append the force direction to the velocity basis (default: project it, as the paper does)")
    p.add_argument("--out", required=True, metavar="RUN.h5")
    add_quiet(p)
    p.set_defaults(handler=run)


def _models():
    from ..rom.registry import MODELS
    return MODELS


def run(args):
    from ..cache import cached_sph
    from ..compare import error_table, exact_errors, format_errors
    from ..errors import UserError, exact
    from ..pod.io import read_basis
    from ..pod.pipeline import error_steps, on_steps
    from ..rom.registry import get_model
    from ..rom.stepping import reduced_stability_warnings
    from ..runio import check_output_path, scene_attrs, write_run
    from ..scene import announce, load_scene
    from ..sph.solver import build_problem, step_count

    model = get_model(args.model)
    build = build_options(args, model)
    if not model.needs_basis:
        return run_without_basis(args, model)
    if args.basis is None:
        raise UserError(f"--basis: required for the {model.name} model (a POD basis from 'sphrom pod')")
    if args.order_tolerance is not None:
        raise UserError(f"--order-tolerance: applies to models without a POD basis; the {model.name} model takes "
                        "--modes")
    out = check_output_path(args.out)
    scene = load_scene(args.scene)
    basis = read_basis(args.basis)              # FieldError "basis": the CLI names --basis
    announce(scene, "rom")
    if basis.U_v.shape[0] != scene.sph.n_particles:
        raise UserError(f"--basis: '{args.basis}' has {basis.U_v.shape[0]} particles, the scene "
                        f"{scene.sph.n_particles}")
    if abs(basis.dt - scene.sph.dt) > 1e-15 * scene.sph.dt:
        raise UserError(f"--basis: '{args.basis}' was made with dt = {exact(basis.dt)} s, the scene has "
                        f"{exact(scene.sph.dt)} s")
    integrator = args.integrator or (model.integrators[0] if model.linear else scene.sph.integrator)
    if integrator not in model.integrators:
        raise UserError(f"--integrator: {integrator} is not defined for the {model.name} model "
                        f"(allowed: {', '.join(model.integrators)})")
    k_v, k_r = args.modes or (int(basis.attrs.get("default_modes_v", 1)),
                              int(basis.attrs.get("default_modes_rho", 1)))
    rv, rr = basis.max_modes
    if k_v > rv or k_r > rr:
        raise UserError(f"--modes: {k_v},{k_r} is out of range (allowed: at most {rv},{rr}, the basis' modes)")
    check_step(args.step, scene.T, model)
    problem = build_problem(scene)
    steps = error_steps(scene)
    n = step_count(scene.T, scene.sph.dt)
    try:
        ops = model.build(problem, basis, k_v, k_r, input_direction="augment" if args.augment_input else "auto",
                          **build)
    except UserError as exc:
        raise UserError(f"--basis: '{args.basis}': {exc}") from None
    for line in reduced_stability_warnings(model, ops, scene.sph.dt, integrator, scene.T):
        print(f"sphrom rom: warning: {line}", file=sys.stderr)
    # the command's settings that are options of this model (integrator; n_freeze, refresh; step, hold)
    options = model.select_options(integrator=integrator, n_freeze=args.n_freeze, refresh=args.refresh,
                                   step=args.step, hold=args.hold)
    result = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, options=options,
                       force=scene.force, progress=not args.quiet)
    if model.linear:
        integrator = f"matrix exponential, H = {result.settings['step']:g} s, input {args.hold}"
    sph_scene = scene if model.linear else scene.with_sph(integrator=integrator)
    sph = cached_sph(sph_scene, steps, progress=not args.quiet, problem=problem)
    v_sph, rho_sph = on_steps(sph, steps)
    v, rho = result.v, result.rho
    vs_sph = error_table(v, rho, v_sph, rho_sph, result.t, problem.rho0)
    vs_exact = exact_errors(scene, result.t, problem.x, v, rho, problem.rho0)
    offline = {"svd": basis.timings.get("svd", 0.0), "tensor": 0.0, **ops.timings}
    label = (f"{args.model}" + (f", n_freeze = {args.n_freeze}, {args.refresh} refresh" if model.uses_n_freeze else "")
             + (", b = K a_rho_rest" if build.get("b") == "rest" else ""))
    k_first, k_second = ops.sizes.values()
    print(f"rom {scene.name}: {label}, k_v = {k_first}, k_{model.second_symbol} = {k_second}, "
          f"{integrator}, to t = {n * scene.sph.dt:g} s")
    print(format_errors(vs_sph, "  relative L2 error vs full SPH"))
    if vs_exact is not None:
        print(format_errors(vs_exact, "  relative L2 error vs exact   "))
    print(f"  online {result.wall_time:.4f} s; offline: SVD {offline['svd'] * 1e3:.2f} ms, operators "
          f"{offline['operators'] * 1e3:.2f} ms, tensor {offline['tensor'] * 1e3:.2f} ms; full SPH "
          f"{sph.wall_time:.4f} s ({'cached run, timed earlier' if sph.reused else 'timed now'})")
    attrs = {**scene_attrs(scene), "solver": f"rom-{args.model}", "solver.model": args.model,
             "solver.integrator": integrator, "solver.k_v": k_first, "solver.k_rho": k_second,
             "solver.basis": str(args.basis), "solver.augmented_input": int(ops.augmented),
             "solver.input_error": ops.input_error, "wall_time_s": result.wall_time,
             **{f"offline_time.{k}": v for k, v in offline.items()},
             **{f"error.sph.{k}": v for k, v in vs_sph.items()}}
    if model.uses_n_freeze:
        attrs.update({"solver.n_freeze": args.n_freeze, "solver.refresh": args.refresh})
    if "b" in build:
        attrs["solver.b"] = build["b"]
    if vs_exact is not None:
        attrs.update({f"error.exact.{k}": v for k, v in vs_exact.items()})
    write_run(out, result.t, problem.x, v, rho, attrs, steps=result.steps,
              extra={"a_v": result.a_v, "a_rho": result.a_rho})
    print(f"wrote {out}")
    return 0


def build_options(args, model):
    """The model's build options the command sets: the frozen model's ``b`` (``--b``, default ``paper``: 'sphrom
    rom' runs the paper's model; the registry's and the FMU's default is ``rest``).  UserError for ``--b`` with a
    model without that option."""
    from ..errors import UserError
    if "b" not in model.build_options:
        if args.b is not None:
            raise UserError(f"--b: applies to the frozen model only (not {model.name})")
        return {}
    return {"b": args.b or model.paper_build.get("b", "paper")}


def check_step(step, T, model):
    """FieldError ``step`` unless ``step`` (None: the default) is a communication step of a linear model with
    at most MAX_ROM_STEPS steps to T [s] and no longer than T."""
    from ..errors import FieldError, exact
    if step is None:
        return
    if not model.linear:
        raise FieldError("step", f"applies to the linear models, whose communication step it is (the {model.name} "
                                 "model steps with the scene's dt)")
    if not (step <= T and T / step <= MAX_ROM_STEPS):
        raise FieldError("step", f"{exact(step)} is out of range (allowed: T / {MAX_ROM_STEPS:.0e} = "
                                 f"{T / MAX_ROM_STEPS:g} s <= step <= T = {T:g} s)")


def run_without_basis(args, model):
    """``sphrom rom --model M`` for a model without a POD basis (balanced): its order from --modes R or
    --order-tolerance, errors at the probes and of the reconstructed fields, and its certified error bounds."""
    import time

    import numpy as np

    from ..cache import cached_sph
    from ..compare import error_table, exact_errors, format_errors
    from ..errors import FieldError, UserError
    from ..norms import relative_l2
    from ..pod.pipeline import error_steps, on_steps
    from ..progress import progress_bar
    from ..references.exact import exact_solution, is_available
    from ..rom.balanced_model import METHOD_TITLES, measured_errors
    from ..rom.result import probe_values
    from ..runio import check_output_path, scene_attrs, write_run
    from ..scene import load_scene
    from ..sph.solver import build_problem, step_count

    if args.basis is not None:
        raise UserError(f"--basis: the {model.name} model uses no POD basis (leave --basis out)")
    if args.modes is not None and args.modes[0] != args.modes[1]:
        raise UserError(f"--modes: the {model.name} model takes one order R (allowed: one integer >= 1, "
                        f"not KV,KRHO)")
    if args.modes is not None and args.order_tolerance is not None:
        raise UserError("--order-tolerance: give --modes R or --order-tolerance TOL, not both")
    if args.integrator is not None and args.integrator not in model.integrators:
        raise UserError(f"--integrator: {args.integrator} is not defined for the {model.name} model "
                        f"(allowed: {', '.join(model.integrators)})")
    out = check_output_path(args.out)
    scene = load_scene(args.scene)
    check_step(args.step, scene.T, model)
    problem = build_problem(scene)
    steps = error_steps(scene)
    n = step_count(scene.T, scene.sph.dt)
    order = None if args.modes is None else args.modes[0]
    try:
        ops = model.build(problem, None, order, order, order_tolerance=args.order_tolerance)
    except ValueError as exc:
        field, _, detail = str(exc).partition(": ")
        raise FieldError("modes" if field == "order" else field, detail) from None
    result = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, force=scene.force,
                       options=model.options(step=args.step, hold=args.hold))
    integrator = f"matrix exponential, H = {result.settings['step']:g} s, input {args.hold}"
    sph = cached_sph(scene, steps, progress=not args.quiet, problem=problem)
    v_sph, rho_sph = on_steps(sph, steps)
    v, rho, t, x, L, rho0 = result.v, result.rho, result.t, problem.x, scene.L, problem.rho0
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(rho)) and np.all(rho > 0)):
        raise UserError(f"--modes: the fields reconstructed at order {ops.order} are not finite and positive; "
                        "raise the order")
    probes = ops.output_probes
    P = probes.size
    y = result.y
    y_sph = probe_values(v_sph, rho_sph, rho0, x, L, probes)
    probe_err = {"v": relative_l2(y[:, :P], y_sph[:, :P], t), "e": relative_l2(y[:, P:], y_sph[:, P:], t)}
    vs_sph = error_table(v, rho, v_sph, rho_sph, t, rho0)
    vs_exact = exact_errors(scene, t, x, v, rho, rho0)
    probe_exact = None
    if is_available(scene):
        y_ex = probe_values(*exact_solution(scene, x, t), rho0, x, L, probes)
        probe_exact = {"v": relative_l2(y[:, :P], y_ex[:, :P], t), "e": relative_l2(y[:, P:], y_ex[:, P:], t)}
    # certified bounds, and what they bound measured apart (both models exact in time)
    t0 = time.perf_counter()
    with progress_bar(P, "bounds", unit="probe", enabled=not args.quiet) as bar:
        bounds = ops.error_bounds(problem, probes, progress=bar)
    t_bounds = time.perf_counter() - t0
    h, measured, gain = measured_errors(ops, scene.T, scene.force)
    fb, ib = bounds["force_error_bound"], bounds["initial_state_error_bound"]
    offline = dict(ops.timings)
    probe_list = ", ".join(f"{p:g}" for p in probes)
    print(f"rom {scene.name}: {model.name}, order r = {ops.order} ({ops.method}: {METHOD_TITLES[ops.method]}), "
          f"{integrator}, to t = {n * scene.sph.dt:g} s")
    print(f"  relative L2 error at the probes x/L = {probe_list} vs full SPH: v {probe_err['v']:.4e}   "
          f"e {probe_err['e']:.4e}")
    if probe_exact is not None:
        print(f"  relative L2 error at the probes x/L = {probe_list} vs exact   : v {probe_exact['v']:.4e}   "
              f"e {probe_exact['e']:.4e}")
    print(format_errors(vs_sph, "  fields reconstructed through V, vs full SPH"))
    if vs_exact is not None:
        print(format_errors(vs_exact, "  fields reconstructed through V, vs exact   "))
    print(f"  online {result.wall_time:.4f} s; offline {offline['operators']:.3f} s (Lyapunov "
          f"{offline.get('lyapunov', 0.0):.3f} s, factors + SVD {offline.get('svd', 0.0):.3f} s, projection "
          f"{offline.get('projection', 0.0) * 1e3:.2f} ms); bounds {t_bounds:.2f} s; full SPH {sph.wall_time:.4f} s "
          f"({'cached run, timed earlier' if sph.reused else 'timed now'})")
    shift = (f"shift sigma = {bounds['sigma']:.4g} 1/s, factor e^(sigma T) = {bounds['factor']:.4g}"
             if bounds["sigma"] else "shift sigma = 0: the error system is stable")
    print(f"  certified bounds on [0, T] = [0, {bounds['horizon']:g}] s against the full linear SPH ({shift}); "
          "measured: both models exact in time, Simpson's rule at h = " f"{h:.3g} s and 2h, extrapolated")
    print("  probe x/L | force_error_bound [s] | measured, scene's force from rest [s] | "
          "initial_state_error_bound [m s^-1 s^1/2] | measured initial-state error | measured/bound")
    for j in range(P):
        print(f"  {probes[j]:9.4g} | {fb[j]:21.4e} | {'-' if np.isnan(gain[j]) else f'{gain[j]:.4e}':>37} | "
              f"{ib[j]:40.4e} | {measured[j]:28.4e} | {measured[j] / ib[j] if ib[j] else float('nan'):.6f}")
    attrs = {**scene_attrs(scene), "solver": f"rom-{args.model}", "solver.model": args.model,
             "solver.integrator": integrator, "solver.order": ops.order, "solver.method": ops.method,
             "solver.k_v": ops.order, "solver.k_rho": 0, "solver.basis": "", "wall_time_s": result.wall_time,
             "probes": probes, **{f"offline_time.{k}": v for k, v in offline.items()},
             "offline_time.bounds": t_bounds,
             **{f"error.sph.{k}": v for k, v in vs_sph.items()},
             **{f"error.sph.probes.{k}": v for k, v in probe_err.items()},
             "bound.force_error_bound": fb, "bound.initial_state_error_bound": ib,
             "bound.initial_state_error_measured": measured, "bound.force_gain_measured": gain,
             "bound.sigma": bounds["sigma"]}
    if args.order_tolerance is not None:
        attrs["solver.tolerance"] = args.order_tolerance          # the attribute's name kept (file layout)
    if vs_exact is not None:
        attrs.update({f"error.exact.{k}": v for k, v in vs_exact.items()})
        attrs.update({f"error.exact.probes.{k}": v for k, v in probe_exact.items()})
    write_run(out, t, x, v, rho, attrs, steps=result.steps,
              extra={"x_r": result.z, "y": y, "hsv": ops.hsv})
    print(f"wrote {out}")
    return 0
