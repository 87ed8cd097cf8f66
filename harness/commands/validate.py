"""``sphrom validate``: the validation report of one scene or of every paper scene."""

from ..options import MAX_REPEATS, add_quiet, int_in


def add_parser(sub):
    p = sub.add_parser("validate", help="validation report: SPH and reduced models against independent references",
                       description="One Markdown page per scene (PNG plots beside it) and an index: the full SPH "
                                   "against the exact solution and each continuum reference (scikit-fem, py-pde, "
                                   "the paper's FD), the references against each other, the paper's reported "
                                   "figures beside ours with the ratio and, beyond 25 %, the evidence; the POD "
                                   "figures (singular values, modes, error against k, the snapshot studies, time "
                                   "against error of the accelerated models); convergence studies of the references "
                                   "(multimode, damped_forced) and scikit-fem against py-pde (heterogeneous).")
    p.add_argument("scene", metavar="SCENE", nargs="?", help="a built-in scene name or a scene TOML path")
    p.add_argument("--all", action="store_true", help="every built-in (paper) scene, and the index")
    p.add_argument("--out", metavar="DIR", default="validation/reports", help="report folder (default "
                   "validation/reports)")
    p.add_argument("--repeats", type=int_in(1, MAX_REPEATS), default=3,
                   help="timed runs per point of the time-against-error study (median; default 3)")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    import time

    from ..errors import UserError
    from ..progress import progress_bar
    from ..report.pages import index_page, scene_page
    from ..pod.pipeline import modes_line
    from ..runio import check_output_dir, output_dir
    from ..scene import announce, builtin_names, load_scene

    if args.all == (args.scene is not None):
        raise UserError("give a SCENE or --all")
    scenes = [load_scene(n) for n in builtin_names()] if args.all else [load_scene(args.scene)]
    out = check_output_dir(args.out)
    for scene in scenes:
        announce(scene, "validate")
    started = time.perf_counter()
    summaries = []
    with output_dir(out), progress_bar(total=len(scenes), desc="validate", enabled=not args.quiet) as bar:
        for scene in scenes:
            bar.set_postfix_str(scene.name)
            summaries.append(scene_page(scene, out, repeats=args.repeats, progress=not args.quiet))
            line = modes_line(scene, progress=False)        # the POD's basis is in the cache by now
            if line:
                print(line)
            bar.update(1)
            print(f"wrote {out / (scene.name + '.md')} ({summaries[-1]['wall']:.0f} s)")
    if args.all:
        index_page(summaries, out, f"sphrom validate --all --repeats {args.repeats}", time.perf_counter() - started)
        print(f"wrote {out / 'README.md'}")
    return 0
