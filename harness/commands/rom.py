"""``sphrom rom``: run a reduced model from a basis file."""

import sys

from .. import defaults
from ..options import (LazyChoices, LazyHelp, add_n_freeze, add_order_tolerance, add_quiet, add_scene, modes_pair,
                      positive_float)

# deferred imports below (inside the handlers): start-up time, the parsers of every command import nothing heavy

B_CHOICES = ("paper", "rest")    # the frozen model's b (sphrom.rom.operators.B_FORMS)


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
    from ..compare import format_errors
    from ..errors import UserError
    from ..pod.io import read_basis
    from ..rom.registry import get_model
    from ..rom.scene_run import build_on_basis, check_basis, check_step, run_on_basis
    from ..rom.stepping import reduced_stability_warnings
    from ..runio import check_output_path, write_run
    from ..scene import announce, load_scene
    from ..sph.solver import build_problem

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
    check_basis(scene, basis, args.basis)
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
    ops = build_on_basis(problem, model, basis, k_v, k_r, build=build, augment_input=args.augment_input,
                         name=args.basis)
    for line in reduced_stability_warnings(model, ops, scene.sph.dt, integrator, scene.T):
        print(f"sphrom rom: warning: {line}", file=sys.stderr)
    r = run_on_basis(scene, model, ops, problem, integrator=integrator, n_freeze=args.n_freeze, refresh=args.refresh,
                     step=args.step, hold=args.hold, build=build, basis=basis, basis_name=args.basis,
                     progress=not args.quiet)
    label = (f"{args.model}" + (f", n_freeze = {args.n_freeze}, {args.refresh} refresh" if model.uses_n_freeze else "")
             + (", b = K a_rho_rest" if build.get("b") == "rest" else ""))
    k_first, k_second = ops.sizes.values()
    print(f"rom {scene.name}: {label}, k_v = {k_first}, k_{model.second_symbol} = {k_second}, "
          f"{r.integrator}, to t = {r.n_steps * scene.sph.dt:g} s")
    print(format_errors(r.vs_sph, "  relative L2 error vs full SPH"))
    if r.vs_exact is not None:
        print(format_errors(r.vs_exact, "  relative L2 error vs exact   "))
    print(f"  online {r.result.wall_time:.4f} s; offline: SVD {r.offline['svd'] * 1e3:.2f} ms, operators "
          f"{r.offline['operators'] * 1e3:.2f} ms, tensor {r.offline['tensor'] * 1e3:.2f} ms; full SPH "
          f"{r.sph.wall_time:.4f} s ({'cached run, timed earlier' if r.sph.reused else 'timed now'})")
    write_run(out, r.result.t, problem.x, r.result.v, r.result.rho, r.attrs, steps=r.result.steps, extra=r.extra)
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


def run_without_basis(args, model):
    """``sphrom rom --model M`` for a model without a POD basis (balanced): its order from --modes R or
    --order-tolerance, errors at the probes and of the reconstructed fields, and its certified error bounds."""
    from ..errors import UserError
    from ..rom.scene_run import run_order
    from ..runio import check_output_path, write_run
    from ..scene import load_scene

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
    r = run_order(scene, model, order=None if args.modes is None else args.modes[0],
                  order_tolerance=args.order_tolerance, step=args.step, hold=args.hold, progress=not args.quiet)
    print_order_run(r, model)
    write_run(out, r.result.t, r.problem.x, r.result.v, r.result.rho, r.attrs, steps=r.result.steps, extra=r.extra)
    print(f"wrote {out}")
    return 0


def print_order_run(r, model):
    """The lines of a run without a basis (:func:`sphrom.rom.scene_run.run_order`): its order, the errors at the
    probes and of the reconstructed fields, its times, and a table of its certified bounds beside what they bound,
    measured."""
    import math

    from ..compare import format_errors
    from ..rom.balanced_model import METHOD_TITLES
    ops, bounds, probes = r.ops, r.bounds, r.ops.output_probes
    fb, ib, gain, measured = bounds["force_error_bound"], bounds["initial_state_error_bound"], r.gain, r.measured
    probe_list = ", ".join(f"{p:g}" for p in probes)
    print(f"rom {r.scene.name}: {model.name}, order r = {ops.order} ({ops.method}: {METHOD_TITLES[ops.method]}), "
          f"{r.integrator}, to t = {r.n_steps * r.scene.sph.dt:g} s")
    print(f"  relative L2 error at the probes x/L = {probe_list} vs full SPH: v {r.probe_err['v']:.4e}   "
          f"e {r.probe_err['e']:.4e}")
    if r.probe_exact is not None:
        print(f"  relative L2 error at the probes x/L = {probe_list} vs exact   : v {r.probe_exact['v']:.4e}   "
              f"e {r.probe_exact['e']:.4e}")
    print(format_errors(r.vs_sph, "  fields reconstructed through V, vs full SPH"))
    if r.vs_exact is not None:
        print(format_errors(r.vs_exact, "  fields reconstructed through V, vs exact   "))
    offline = r.offline
    print(f"  online {r.result.wall_time:.4f} s; offline {offline['operators']:.3f} s (Lyapunov "
          f"{offline.get('lyapunov', 0.0):.3f} s, factors + SVD {offline.get('svd', 0.0):.3f} s, projection "
          f"{offline.get('projection', 0.0) * 1e3:.2f} ms); bounds {r.t_bounds:.2f} s; full SPH "
          f"{r.sph.wall_time:.4f} s ({'cached run, timed earlier' if r.sph.reused else 'timed now'})")
    shift = (f"shift sigma = {bounds['sigma']:.4g} 1/s, factor e^(sigma T) = {bounds['factor']:.4g}"
             if bounds["sigma"] else "shift sigma = 0: the error system is stable")
    print(f"  certified bounds on [0, T] = [0, {bounds['horizon']:g}] s against the full linear SPH ({shift}); "
          "measured: both models exact in time, Simpson's rule at h = " f"{r.h:.3g} s and 2h, extrapolated")
    print("  probe x/L | force_error_bound [s] | measured, scene's force from rest [s] | "
          "initial_state_error_bound [m s^-1 s^1/2] | measured initial-state error | measured/bound")
    for j in range(probes.size):
        print(f"  {probes[j]:9.4g} | {fb[j]:21.4e} | {'-' if math.isnan(gain[j]) else f'{gain[j]:.4e}':>37} | "
              f"{ib[j]:40.4e} | {measured[j]:28.4e} | {measured[j] / ib[j] if ib[j] else float('nan'):.6f}")
