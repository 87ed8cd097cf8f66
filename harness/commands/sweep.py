"""``sphrom sweep``: a parameter study of FMU co-simulations (and full SPH runs) on dask.distributed."""

from ..options import add_quiet, int_in


def add_parser(sub):
    p = sub.add_parser("sweep", help="a parameter study of FMU runs (and full SPH runs) on dask.distributed",
                       description="Expand SPEC.toml (a scene and grids over force shape, amplitude, frequency, "
                                   "c, d, profile, k, model, n_freeze) into entries, package one FMU per scene "
                                   "variant (cached), and run every entry as a task on dask.distributed: a "
                                   "LocalCluster on this machine, or the cluster at --scheduler. Each worker "
                                   "loads an FMU once and resets it between runs. Writes RESULTS.h5, "
                                   "RESULTS.csv and a summary RESULTS.png; a failed run is recorded with its "
                                   "error; a rerun on the same --out skips the finished entries (resume).")
    p.add_argument("spec", metavar="SPEC.toml")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="address of a running dask scheduler, e.g. tcp://host:8786 (default: a LocalCluster)")
    p.add_argument("--workers", type=int_in(1, 256), metavar="N",
                   help="workers of the LocalCluster, one process with one thread each (default: the number "
                        "of cores)")
    p.add_argument("--out", required=True, metavar="RESULTS.h5")
    add_quiet(p)
    p.set_defaults(handler=run)


def spare_spec_inputs(spec, out):
    """UserError (before any work) when one of the files the sweep writes (RESULTS.h5 and the .csv, .png beside it)
    is a file the spec reads: its scene TOML (the command line's own inputs are checked by
    sphrom.options.check_outputs_spare_inputs; the scene is named inside the spec)."""
    from pathlib import Path

    from ..errors import UserError
    from ..options import _same_file
    from ..paths import is_file
    from ..sweep.table import output_paths
    scene = Path(spec.scene.source) if spec.scene.source else None
    if scene is None or not is_file(scene):
        return                                  # a built-in scene: no file of the user's
    for path in output_paths(out):
        if _same_file(path, scene):
            shown = "" if Path(path) == Path(out) else f" (written beside '{out}')"
            raise UserError(f"--out: '{path}'{shown} is the scene '{scene}' the spec '{spec.source}' reads: writing "
                            "it would destroy that input (allowed: an output path that names no input)")


def run(args):
    import os
    import sys

    from ..errors import UserError
    from ..runio import check_output_path, output_target
    from ..sweep.spec import load_spec
    from ..sweep.table import output_paths

    out = check_output_path(args.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise UserError(f"--out: '{out}' must end in .h5 (RESULTS.csv and RESULTS.png are written beside it)")
    for path in output_paths(out):          # written together, renamed into place: regular files only
        how, kind = output_target(path)
        if how != "replace":
            raise UserError(f"--out: '{path}' is a {kind} (allowed: a new or regular file; a sweep's results "
                            "are files it resumes from, renamed into place together)")
    if args.scheduler is not None and args.workers is not None:
        raise UserError("--workers: applies to the LocalCluster only (the cluster at --scheduler has its own "
                        "workers)")
    if args.scheduler is not None and not args.scheduler.strip():
        raise UserError("--scheduler: empty address (allowed: a scheduler address such as tcp://host:8786)")
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    spec = load_spec(args.spec)
    from ..scene import announce
    announce(spec.scene, "sweep")
    spare_spec_inputs(spec, out)
    for note in spec.notes:         # what the spec decided (one parametric FMU, or why not): shown even --quiet
        print(f"sphrom sweep: {note}", file=sys.stderr)
    if out.exists():        # a file that is not ours is refused before any work
        from ..sweep.table import read_results
        read_results(out)

    from ..sweep.study import run_study

    def log(text):
        if not args.quiet:
            print(text, file=sys.stderr)

    r = run_study(spec, out, scheduler=args.scheduler, workers=None if args.scheduler else workers,
                  progress=not args.quiet, log=log)
    print(f"sweep {args.spec}: {r.entries} entries on scene {spec.scene.name}; {r.skipped} already done, "
          f"{r.ran} run now ({r.ok} ok, {r.failed} failed)" + (f"; {r.kept} rows of earlier specs kept"
                                                            if r.kept else ""))
    if r.ran:
        print(f"  {r.workers} workers ({r.scheduler}); compute {r.compute_wall:.2f} s, {r.throughput:.2f} runs/s; "
              f"packaging {r.package_wall:.2f} s, cluster start {r.cluster_start:.2f} s, total {r.total_wall:.2f} s")
    for path in r.paths:
        print(f"wrote {path}")
    if r.interrupted:
        import signal
        print(f"sphrom sweep: interrupted ({signal.Signals(r.interrupted).name}); {r.ran} finished runs kept in "
              f"{out} and {out.with_suffix('.csv')}; run the same command again to resume", file=sys.stderr)
        return 128 + r.interrupted
    if not r.ran and not r.paths:
        print("  nothing to run: every entry is done (remove the file to run afresh)")
    if r.lost:                      # tasks lost with their workers beyond the retries: the sweep failed
        for line in r.lost:
            print(f"sphrom sweep: failed: {line}; the other results are kept in {out}; run the same command "
                  f"again to retry it", file=sys.stderr)
        return 3
    return 0
