"""``sphrom sph``: run the full SPH model of a scene and write an HDF5 run."""

import sys

from ..options import add_quiet, add_scene, int_at_least, positive_float


def add_parser(sub):
    p = sub.add_parser("sph", help="run the full SPH model (eqs. 2.10-2.11)",
                       description="Run the full SPH model of SCENE with the paper's settings (or the ones given), "
                                   "write the samples to an HDF5 run file, and print the relative L2 errors "
                                   "(eq. 3.4, square-root form) against the exact solution when the scene has one.")
    add_scene(p)
    p.add_argument("--n-particles", type=int_at_least(1), metavar="N", help="number of particles (scene default)")
    p.add_argument("--alpha", type=positive_float, metavar="A", help="h / dx (scene default)")
    p.add_argument("--dt", type=positive_float, metavar="DT", help="time step [s] (scene default)")
    p.add_argument("--t-end", type=positive_float, metavar="T", help="final time [s] (scene default)")
    p.add_argument("--integrator", choices=("euler", "symplectic", "rk4"), help="time integrator (default: the scene's; a scene that names none: symplectic)")
    p.add_argument("--every", type=int_at_least(1), metavar="K", help="store a sample every K steps (scene default)")
    p.add_argument("--out", required=True, metavar="FILE.h5", help="output HDF5 run file")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    from ..compare import exact_errors, format_errors
    from ..runio import check_output_path, check_run_memory, scene_attrs, write_run
    from ..scene import announce, load_scene
    from ..sph.solver import build_problem, run_sph, stability, step_count

    out = check_output_path(args.out)
    base = load_scene(args.scene)
    scene = base.with_T(args.t_end).with_sph(n_particles=args.n_particles, alpha=args.alpha, dt=args.dt,
                           integrator=args.integrator, every=args.every)
    announce(scene, "sph")
    check_run_memory(scene, "sph")                 # a run beyond this machine's memory: refused before the work
    sph = scene.sph
    problem = build_problem(scene)
    stab = stability(problem, sph.dt, sph.integrator, scene.T)
    n_steps = step_count(scene.T, sph.dt)
    if args.every is not None and args.every > max(n_steps, 1):
        from ..errors import FieldError
        raise FieldError("every", f"{args.every} is out of range (allowed: 1 to {max(n_steps, 1)}, the run's steps)")
    result = run_sph(scene, problem=problem, progress=not args.quiet)
    us = 1e6 * result.wall_time / max(n_steps, 1)
    print(f"sph {scene.name}: N = {sph.n_particles}, alpha = {sph.alpha:g}, dt = {sph.dt:g} s, {sph.integrator}, "
          f"{n_steps} steps to t = {n_steps * sph.dt:g} s in {result.wall_time:.3f} s ({us:.2f} us/step)")
    attrs = {**scene_attrs(scene), "solver": "sph", "solver.integrator": sph.integrator,
             "solver.n_particles": sph.n_particles, "solver.alpha": sph.alpha, "solver.dt": sph.dt,
             "solver.every": sph.every, "solver.h": problem.neighbours.h,
             "solver.neighbours_per_particle": problem.neighbours.index.shape[1],
             "solver.terms": ",".join(k for k, v in problem.terms.items() if v),
             "wall_time_s": result.wall_time, "stability.dt_limit": stab["dt_limit"], "stability.cfl": stab["cfl"]}
    errors = exact_errors(scene, result.t, result.x, result.v, result.rho, problem.rho0)
    if errors is not None:
        attrs.update({f"error.exact.{k}": v for k, v in errors.items()})
    write_run(out, result.t, result.x, result.v, result.rho, attrs, steps=result.steps)
    print(f"wrote {out} ({result.t.size} samples x {result.x.size} particles)")
    if errors is None:
        print("no exact reference for this scene (c, rho0 or d is not uniform); "
              "compare with a continuum reference instead (sphrom reference)")
    else:
        print(format_errors(errors, "relative L2 error vs exact (sqrt form of eq. 3.4)"))
        paper = scene.paper
        if scene.sph == base.sph and scene.T == base.T and "sph_error_v" in paper:
            rho_txt = f"rho {paper['sph_error_rho']:.4e}" if "sph_error_rho" in paper else "rho not reported"
            print(f"paper ({paper['reference']} reference): v {paper['sph_error_v']:.4e}   {rho_txt}")
    return 0
