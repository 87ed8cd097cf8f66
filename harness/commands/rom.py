"""``sphrom rom``: run a reduced model from a basis file."""

from .options import add_n_freeze, add_quiet, add_scene, modes_pair, positive_float


def add_parser(sub):
    p = sub.add_parser("rom", help="run a reduced model (original, linearized, frozen)",
                       description="Run the original POD-MOR (eq. 2.16), the density-linearised model (eq. 2.17) or "
                                   "the frozen-coefficient model (eqs. 2.19-2.24) of SCENE on a basis from "
                                   "'sphrom pod', write the reconstructed fields in the run layout of 'sphrom sph', "
                                   "and print the errors against the full SPH and the exact solution.")
    add_scene(p)
    p.add_argument("--basis", required=True, metavar="BASIS.h5")
    from ..rom.registry import MODELS
    p.add_argument("--model", required=True, choices=tuple(MODELS),
                   help="; ".join(f"{m.name}: {m.description}" for m in MODELS.values()))
    add_n_freeze(p, default=10)
    p.add_argument("--modes", type=modes_pair, metavar="K|KV,KRHO", help="mode counts (default: the basis file's)")
    p.add_argument("--integrator", choices=("euler", "symplectic", "rk4"),
                   help="time integrator (default: the scene's; rk4 is not defined for frozen coefficients)")
    p.add_argument("--refresh", choices=("tensor", "direct"), default="tensor",
                   help="frozen refresh: the exact O(k^4)-type tensor (default) or the O(N k^2) product")
    p.add_argument("--step", type=positive_float, metavar="H",
                   help="exact model: communication step [s] (default the sample spacing)")
    p.add_argument("--hold", choices=("linear", "held"), default="linear",
                   help="exact model: input linear or held over a step (default linear)")
    p.add_argument("--augment-input", action="store_true",
                   help="append the force direction to the velocity basis (default: project it, as the paper does)")
    p.add_argument("--out", required=True, metavar="RUN.h5")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    from ..cache import cached_sph
    from ..compare import error_table, exact_errors, format_errors
    from ..errors import UserError
    from ..pod.io import read_basis
    from ..pod.pipeline import error_steps, on_steps
    from ..rom.registry import get_model
    from ..runio import check_output_path, scene_attrs, write_run
    from ..scene import load_scene
    from ..sph.solver import build_problem, step_count

    model = get_model(args.model)
    out = check_output_path(args.out)
    scene = load_scene(args.scene)
    basis = read_basis(args.basis)              # FieldError "basis": the CLI names --basis
    if basis.U_v.shape[0] != scene.sph.n_particles:
        raise UserError(f"--basis: '{args.basis}' has {basis.U_v.shape[0]} particles, the scene "
                        f"{scene.sph.n_particles}")
    if abs(basis.dt - scene.sph.dt) > 1e-15 * scene.sph.dt:
        raise UserError(f"--basis: '{args.basis}' was made with dt = {basis.dt:g} s, the scene has {scene.sph.dt:g} s")
    integrator = args.integrator or (model.integrators[0] if model.linear else scene.sph.integrator)
    if integrator not in model.integrators:
        raise UserError(f"--integrator: {integrator} is not defined for the {model.name} model "
                        f"(allowed: {', '.join(model.integrators)})")
    k_v, k_r = args.modes or (int(basis.attrs.get("default_modes_v", 1)),
                              int(basis.attrs.get("default_modes_rho", 1)))
    rv, rr = basis.max_modes
    if k_v > rv or k_r > rr:
        raise UserError(f"--modes: {k_v},{k_r} is out of range (allowed: at most {rv},{rr}, the basis' modes)")
    problem = build_problem(scene)
    steps = error_steps(scene)
    n = step_count(scene.T, scene.sph.dt)
    try:
        ops = model.build(problem, basis, k_v, k_r, input_direction="augment" if args.augment_input else "auto")
    except UserError as exc:
        raise UserError(f"--basis: '{args.basis}': {exc}") from None
    result = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, integrator=integrator,
                       n_freeze=args.n_freeze, refresh=args.refresh, step=args.step, hold=args.hold, force=scene.force,
                       progress=not args.quiet)
    if model.linear:
        integrator = f"matrix exponential, H = {result.settings['step']:g} s, input {args.hold}"
    sph_scene = scene if model.linear else scene.with_sph(integrator=integrator)
    sph = cached_sph(sph_scene, steps, progress=not args.quiet, problem=problem)
    v_sph, rho_sph = on_steps(sph, steps)
    v, rho = result.v, result.rho
    vs_sph = error_table(v, rho, v_sph, rho_sph, result.t, problem.rho0)
    vs_exact = exact_errors(scene, result.t, problem.x, v, rho, problem.rho0)
    offline = {"svd": basis.timings.get("svd", 0.0), "tensor": 0.0, **ops.timings}
    label = f"{args.model}" + (f", n_freeze = {args.n_freeze}, {args.refresh} refresh" if model.uses_n_freeze else "")
    k_second = ops.k_rho
    print(f"rom {scene.name}: {label}, k_v = {ops.k_v}, k_{model.second_symbol} = {k_second}, "
          f"{integrator}, to t = {n * scene.sph.dt:g} s")
    print(format_errors(vs_sph, "  relative L2 error vs full SPH"))
    if vs_exact is not None:
        print(format_errors(vs_exact, "  relative L2 error vs exact   "))
    print(f"  online {result.wall_time:.4f} s; offline: SVD {offline['svd'] * 1e3:.2f} ms, operators "
          f"{offline['operators'] * 1e3:.2f} ms, tensor {offline['tensor'] * 1e3:.2f} ms; full SPH "
          f"{sph.wall_time:.4f} s ({'cached run, timed earlier' if sph.reused else 'timed now'})")
    attrs = {**scene_attrs(scene), "solver": f"rom-{args.model}", "solver.model": args.model,
             "solver.integrator": integrator, "solver.k_v": ops.k_v, "solver.k_rho": k_second,
             "solver.basis": str(args.basis), "solver.augmented_input": int(ops.augmented),
             "solver.input_error": ops.input_error, "wall_time_s": result.wall_time,
             **{f"offline_time.{k}": v for k, v in offline.items()},
             **{f"error.sph.{k}": v for k, v in vs_sph.items()}}
    if model.uses_n_freeze:
        attrs.update({"solver.n_freeze": args.n_freeze, "solver.refresh": args.refresh})
    if vs_exact is not None:
        attrs.update({f"error.exact.{k}": v for k, v in vs_exact.items()})
    write_run(out, result.t, problem.x, v, rho, attrs, steps=result.steps,
              extra={"a_v": result.a_v, "a_rho": result.a_rho})
    print(f"wrote {out}")
    return 0
