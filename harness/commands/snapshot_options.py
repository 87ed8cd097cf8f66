"""CLI options that choose a snapshot strategy (shared by pod, modes, fmu)."""

from ..errors import UserError
from ..options import float_list, int_at_least


def add_snapshot_options(p):
    g = p.add_argument_group("snapshots (default: the scene's [snapshots] table, the paper's setting)")
    g.add_argument("--snapshots", metavar="COUNT|all",
                   help="COUNT snapshots uniform in the window (t0 + i (t1-t0)/COUNT), or 'all' stored samples")
    g.add_argument("--window", type=float_list(2, 2, lo=0.0, increasing=True), metavar="T0,T1",
                   help="time window [s] of the snapshots (default the scene's)")
    g.add_argument("--times", type=float_list(lo=0.0), metavar="T,...",
                   help="explicit snapshot times [s] for both fields")
    g.add_argument("--times-v", type=float_list(lo=0.0), metavar="T,...", help="velocity snapshot times [s]")
    g.add_argument("--times-rho", type=float_list(lo=0.0), metavar="T,...", help="density snapshot times [s]")
    g.add_argument("--random", type=int_at_least(0), metavar="SEED", help="random times in the window, with this seed")


def strategy_from_args(args, scene):
    """The snapshot strategy dict from CLI options over the scene's default."""
    if (args.times_v is None) != (args.times_rho is None):
        raise UserError("--times-v and --times-rho go together")
    given = [k for k in ("snapshots", "times", "times_v") if getattr(args, k) is not None]
    if len(given) > 1:
        raise UserError("give one of --snapshots, --times, --times-v/--times-rho")
    base = dict(scene.snapshots)
    window = args.window or base.get("window")
    if window is not None and (len(window) != 2 or not window[0] < window[1]):
        raise UserError(f"--window: {window} is out of range (allowed: T0,T1 with 0 <= T0 < T1)")
    if args.times is not None:
        return {"times": args.times}
    if args.times_v is not None:
        return {"times_v": args.times_v, "times_rho": args.times_rho}
    if args.snapshots is not None:
        if args.snapshots == "all":
            spec = {"all": True}
            if args.window:
                spec["window"] = args.window
            return spec
        try:
            count = int(args.snapshots)
        except ValueError:
            raise UserError(f"--snapshots: {args.snapshots!r} is out of range (allowed: an integer >= 1 or 'all')") from None
        if count < 1:
            raise UserError(f"--snapshots: {count} is out of range (allowed: an integer >= 1 or 'all')")
        if window is None:
            raise UserError("--window: required with --snapshots (the scene has no window)")
        spec = {"count": count, "window": list(window)}
    elif "count" in base:
        spec = {"count": base["count"], "window": list(window)}
        if "random" in base:
            spec["random"] = base["random"]
    else:
        spec = base
    if args.random is not None:
        if "count" not in spec:
            raise UserError("--random: needs a count and a window (--snapshots COUNT --window T0,T1)")
        spec["random"] = args.random
    return spec

