"""``sphrom reference``: a continuum reference of eqs. 2.2-2.4, written as an HDF5 run."""

import argparse

from ..options import add_quiet, add_scene, integer, number

SOLVERS = ("skfem", "pypde", "fd", "exact")
LAYOUTS = ("staggered", "collocated")

DESCRIPTION = """\
Solve the continuum model of SCENE (eqs. 2.2-2.4) with an independent reference
solver and write v and rho at the SPH particles x_i = (i + 1/2) L/N and the SPH
sample times (every K*dt of the scene), in the run-file layout of 'sphrom sph'.
The relative L2 errors against the exact solution are printed and stored when
the scene has one (uniform c, rho0 and d).

solvers and their defaults (accuracy: relative L2 error at T = 10 s):
  skfem  scikit-fem Galerkin on the displacement form (eqs. A.1-A.3), periodic mesh,
         Newmark average acceleration with a factorised matrix.
         --order 1: 4096 P1 elements, dt = 2.5e-4 s (~1e-5 on multimode);
         --order 2: 256 P2 elements, dt = 1.25e-4 s (~3e-6 on multimode).
  pypde  py-pde on the density-velocity form (eqs. 2.2-2.3), staggered 4th-order
         differences, classical RK4: 256 cells, dt = 0.5 dx/c_s (~4e-6 on multimode).
  fd     the paper's reference: forward/backward differences + Heun RK2, at the
         paper's dx and dt when the scene gives them (tenmode 1.25e-3 m / 2.5e-5 s;
         damped, damped_forced, heterogeneous 5e-3 m / 1e-4 s), else 2048 cells
         and dt = 1/4 of Heun's stability limit (~1e-4 on multimode).
  exact  the exact solution (d'Alembert / Fourier), uniform c, rho0, d only.

On scenes whose initial velocity has a kink (eq. 3.8: tenmode, damped,
damped_forced) every solver converges more slowly (about order 1.5 in L2).
"""


def add_parser(sub):
    p = sub.add_parser("reference", help="a continuum reference of eqs. 2.2-2.4 (skfem, pypde, fd, exact)",
                       description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_scene(p)
    p.add_argument("--solver", required=True, metavar="|".join(SOLVERS), help="reference solver (see above)")
    p.add_argument("--resolution", type=integer, metavar="N",
                   help="elements (skfem) or cells (pypde, fd), an integer >= 8 (default: see above)")
    p.add_argument("--dt", type=number, metavar="DT",
                   help="time step [s] (default: see above); reduced so that every sample time is a step")
    p.add_argument("--t-end", type=number, metavar="T", help="final time [s] (scene default)")
    p.add_argument("--every", type=integer, metavar="K",
                   help="a sample every K SPH steps of the scene, as 'sphrom sph --every K' (scene default)")
    p.add_argument("--n-particles", type=integer, metavar="N", help="output at N particles' positions (scene default)")
    p.add_argument("--order", type=integer, metavar="1|2", help="skfem: P1 or P2 elements (default 1)")
    p.add_argument("--layout", metavar="|".join(LAYOUTS),
                   help="fd: rho on the cell centres (staggered, 2nd order; default) or on the nodes "
                        "(collocated, 1st order in rho)")
    p.add_argument("--out", required=True, metavar="FILE.h5", help="output HDF5 run file")
    add_quiet(p)
    p.set_defaults(handler=run)


def _check_options(args, scene):
    from ..errors import UserError
    from ..references.exact import check_available, ExactUnavailable

    if args.solver not in SOLVERS:
        raise UserError(f"--solver: {args.solver!r} is out of range (allowed: {', '.join(SOLVERS)})")
    if args.order is not None and args.solver != "skfem":
        raise UserError(f"--order: only for --solver skfem (allowed: leave it out for {args.solver})")
    if args.order is not None and args.order not in (1, 2):
        raise UserError(f"--order: {args.order} is out of range (allowed: 1 or 2)")
    if args.layout is not None and args.solver != "fd":
        raise UserError(f"--layout: only for --solver fd (allowed: leave it out for {args.solver})")
    if args.layout is not None and args.layout not in LAYOUTS:
        raise UserError(f"--layout: {args.layout!r} is out of range (allowed: {', '.join(LAYOUTS)})")
    if args.solver == "exact":
        for name, value in (("--resolution", args.resolution), ("--dt", args.dt)):
            if value is not None:
                raise UserError(f"{name}: not used by --solver exact (allowed: leave it out)")
        try:
            check_available(scene)
        except ExactUnavailable as exc:
            raise UserError(f"--solver: exact is out of range for this scene ({exc}; allowed: skfem, pypde, fd)") \
                from None


def run(args):
    import time

    import numpy as np

    from ..compare import exact_errors, format_errors
    from ..references import fd, pypde_ref, skfem_ref
    from ..references.common import check_dt, check_resolution, output_times
    from ..references.exact import exact_solution
    from ..runio import check_output_path, scene_attrs, write_run
    from ..scene import load_scene
    from ..sph.operator import particle_positions

    out = check_output_path(args.out)
    scene = load_scene(args.scene).with_T(args.t_end).with_sph(every=args.every, n_particles=args.n_particles)
    _check_options(args, scene)
    if args.every is not None:
        from ..errors import FieldError
        from ..sph.solver import step_count
        steps = max(step_count(scene.T, scene.sph.dt), 1)
        if args.every > steps:
            raise FieldError("every", f"{args.every} is out of range (allowed: 1 to {steps}, the scene's SPH steps)")
    if args.resolution is not None:
        check_resolution(args.resolution)
    if args.dt is not None:
        check_dt(args.dt, scene.T)
    x = particle_positions(scene.L, scene.sph.n_particles)
    t = output_times(scene)
    progress = not args.quiet
    t0 = time.perf_counter()
    if args.solver == "skfem":
        v, rho, settings = skfem_ref.solve(scene, args.resolution, args.dt, x, t, order=args.order or 1,
                                           progress=progress)
    elif args.solver == "pypde":
        v, rho, settings = pypde_ref.solve(scene, args.resolution, args.dt, x, t, progress=progress)
    elif args.solver == "fd":
        v, rho, settings = fd.solve(scene, args.resolution, args.dt, x, t, layout=args.layout or "staggered",
                                    progress=progress)
    else:
        v, rho = exact_solution(scene, x, t)
        settings = {"method": "exact: d'Alembert (d = 0) or Fourier damped oscillators with a Duhamel force"}
    wall = time.perf_counter() - t0

    attrs = {**scene_attrs(scene), "solver": args.solver, "wall_time_s": wall}
    attrs.update({f"solver.{k}": val for k, val in settings.items()})
    steps = None
    if "dt" in settings:
        steps = np.round(t / settings["dt"]).astype(np.int64)
    errors = exact_errors(scene, t, x, v, rho) if args.solver != "exact" else None
    if errors is not None:
        attrs.update({f"error.exact.{k}": val for k, val in errors.items()})
    write_run(out, t, x, v, rho, attrs, steps=steps)

    desc = f"reference {scene.name}: {args.solver}"
    if "resolution" in settings:
        desc += (f", N = {settings['resolution']}, dt = {settings['dt']:.4g} s, {settings['steps']} steps"
                 + (f", CFL c_s dt/dx = {settings['cfl']:.3g}" if "cfl" in settings else ""))
    print(f"{desc}, {wall:.3f} s")
    print(f"wrote {out} ({t.size} samples x {x.size} particles)")
    if errors is not None:
        print(format_errors(errors, "relative L2 error vs exact (sqrt form of eq. 3.4)"))
    elif args.solver != "exact":
        print("no exact solution for this scene (c, rho0 or d is not uniform); compare two references instead")
    return 0
