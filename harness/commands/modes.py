"""``sphrom modes``: the mode sweeps of the paper (singular values, error against k)."""

from ..options import add_n_freeze, add_quiet, choice_list, int_at_least
from .snapshot_options import add_snapshot_options

# deferred imports below (inside the handlers): start-up time, the parsers of every command import nothing heavy


def add_parser(sub):
    p = sub.add_parser("modes", help="singular values and reduced-model error against the number of modes",
                       description="The mode sweep of the paper's figures: singular-value decay and the relative L2 "
                                   "error of a reduced model against the full SPH for k = 1..KMAX, with the SPH error "
                                   "line (SPH vs the exact or continuum reference), as PNG and CSV. The mode threshold "
                                   "is the smallest k from which the error stays below the SPH error in v and in "
                                   "rho - rho0. With --all: every paper scene and every snapshot study of the paper, "
                                   "beside the paper's findings, in summary.md.")
    p.add_argument("scene", metavar="SCENE", nargs="?")
    p.add_argument("--all", action="store_true", help="every paper scene and snapshot study")
    add_snapshot_options(p)
    p.add_argument("--max-modes", "--kmax", dest="max_modes", type=int_at_least(1), metavar="K",
                   help="largest k (default min(rank, 20 or more))")
    p.add_argument("--model", "--models", dest="model", type=choice_list("original", "linearized", "frozen"),
                   default="original", metavar="NAME,...",
                   help="comma-separated reduced models out of original, linearized, frozen (default original)")
    add_n_freeze(p, default=10, help="refresh period n_freeze of the frozen model")
    p.add_argument("--out", metavar="DIR", default="modes", help="output folder (default ./modes)")
    add_quiet(p)
    p.set_defaults(handler=run)


def _write_csv(path, sweep):
    import csv
    import io

    from ..markdown import write_text
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    w.writerow(["k", "model", "err_v", "err_rho", "err_rho_var", "online_s"])
    for r in sweep["rows"]:
        w.writerow([r["k"], r["model"], f"{r['v']:.6e}", f"{r['rho']:.6e}", f"{r['rho_var']:.6e}",
                    f"{r['online']:.6e}"])
    w.writerow([])
    w.writerow(["mode", "sigma_v", "sigma_rho"])
    sv, sr = sweep["sigma_v"], sweep["sigma_rho"]
    for i in range(max(sv.size, sr.size)):
        w.writerow([i + 1, f"{sv[i]:.6e}" if i < sv.size else "", f"{sr[i]:.6e}" if i < sr.size else ""])
    write_text(path, fh.getvalue())


def _one(scene, spec, args, out, tag, models):
    from ..rom.study import mode_sweep, plot_sweep, threshold
    sweep = mode_sweep(scene, spec, kmax=args.max_modes, models=models, n_freeze=args.n_freeze,
                       progress=not args.quiet)
    _write_csv(out / f"{tag}.csv", sweep)
    plot_sweep(sweep, out / f"{tag}.png", scene.paper.get("mode_threshold") if spec is None else None)
    ths = {m: threshold(sweep["rows"], sweep["sph_error"], m) for m in models}
    return sweep, ths


def run(args):
    from ..errors import UserError
    from ..rom.registry import model_names
    from ..runio import check_output_dir, output_dir
    from ..scene import announce, builtin_names, load_scene
    from .snapshot_options import strategy_from_args

    models = tuple(args.model)
    allowed = model_names(linear=False)          # the models integrated with the full SPH's own time scheme
    bad = [m for m in models if m not in allowed]
    if bad:
        raise UserError(f"--model: {bad[0]!r} is not one of {', '.join(allowed)}")
    if args.all == (args.scene is not None):
        raise UserError("give a SCENE or --all")
    out = check_output_dir(args.out)
    if not args.all:
        scene = load_scene(args.scene)
        spec = strategy_from_args(args, scene)
        announce(scene, "modes")
        custom = spec != dict(scene.snapshots)
        with output_dir(out):
            sweep, ths = _one(scene, spec if custom else None, args, out, scene.name, models)
        _print_sweep(scene, sweep, ths, None if custom else scene.paper.get("mode_threshold"))
        print(f"wrote {out / (scene.name + '.csv')} and {out / (scene.name + '.png')}")
        return 0
    scenes = [load_scene(n) for n in builtin_names()]
    with output_dir(out):
        return _run_all(args, out, models, scenes)


def _print_sweep(scene, sweep, ths, paper):
    from ..rom.study import PAPER_MODEL
    e = sweep["sph_error"]
    sph = "no reference" if e is None else f"SPH error vs {sweep['reference']}: v {e['v']:.3e}, rho-rho0 {e['rho_var']:.3e}"
    print(f"modes {scene.name}: {sweep['strategy']}; {sph}")
    for model, k in ths.items():
        paper_txt = f" (paper: {paper})" if paper and model == PAPER_MODEL else ""
        print(f"  {model}: POD error below the SPH error from k = {k if k else '-- (not within k <= ' + str(sweep['kmax']) + ')'}{paper_txt}")


def _run_all(args, out, models, scenes):
    from ..rom.study import PAPER_MODEL, snapshot_study

    lines = ["# Mode thresholds and snapshot studies", "",
             "Produced by `sphrom modes --all`. Threshold: the smallest k from which the original POD-MOR error "
             "against the full SPH stays below the SPH error against the reference, in v and in ρ−ρ0 "
             "(relative L², square-root form of eq. 3.4).", "",
             "| scene | snapshots | reference | SPH error v | SPH error ρ−ρ0 | threshold k (ours) | paper |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    studies = []
    for scene in scenes:
        sweep, ths = _one(scene, None, args, out, scene.name, models)
        _print_sweep(scene, sweep, ths, scene.paper.get("mode_threshold"))
        e = sweep["sph_error"]
        lines.append(f"| {scene.name} | {sweep['strategy']} | {sweep['reference'] or 'none'} | "
                     f"{e['v']:.3e} | {e['rho_var']:.3e} | {ths[PAPER_MODEL] or '—'} | "
                     f"{scene.paper.get('mode_threshold', '—')} |" if e else
                     f"| {scene.name} | {sweep['strategy']} | none | — | — | — | {scene.paper.get('mode_threshold', '—')} |")
        for i, study in enumerate(scene.paper.get("snapshot_studies", [])):
            studies.append((scene, i, study, sweep))
    lines += ["", "## Snapshot studies", "",
              "| scene | paper figure | snapshots | paper | ours | detail |", "| --- | --- | --- | --- | --- | --- |"]
    for scene, i, study, base in studies:
        tag = f"{scene.name}-study{i + 1}"

        def sweep_fn(spec, suffix, scene=scene, tag=tag):
            return _one(scene, spec, args, out, tag + suffix, models)
        r = snapshot_study(scene, study, base, sweep_fn)
        lines.append(f"| {scene.name} | {r['figure']} | {r['snapshots']} | {r['paper']} | {r['ours']} | {r['detail']} |")
        print(f"  study {scene.name} {r['snapshots']}: paper {r['paper']}, ours {r['ours']} ({r['detail']})")
    from ..markdown import write_text
    write_text(out / "summary.md", "\n".join(lines) + "\n")
    print(f"wrote {out / 'summary.md'}")
    return 0
