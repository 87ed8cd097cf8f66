"""``sphrom cosim``: co-simulate an sphrom FMU through fmpy.simulate_fmu."""


def add_parser(sub):
    p = sub.add_parser("cosim", help="co-simulate an FMU from 'sphrom fmu' through fmpy",
                       description="Run FILE.fmu with fmpy.simulate_fmu: the input f [m s^-2] is an expression in t "
                                   "(and T, the end time) sampled at the communication points, or a CSV file with "
                                   "columns time,f; the FMU holds it over each step. Writes time and all outputs as "
                                   "CSV and prints the wall time.")
    p.add_argument("fmu", metavar="FILE.fmu")
    p.add_argument("--force", metavar="EXPR|CSV", help="f(t) as an expression in t, T or a CSV file (default 0)")
    p.add_argument("--t-end", metavar="T", help="end time [s] (default: the FMU's DefaultExperiment stopTime)")
    p.add_argument("--step", metavar="H", help="communication step [s] (default: its stepSize)")
    p.add_argument("--n-freeze", metavar="NF", help="the n_freeze parameter (default: the packaged value)")
    p.add_argument("--out", required=True, metavar="RESULT.csv")
    p.set_defaults(handler=run)


def _number(text, option):
    from ..errors import UserError
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise UserError(f"{option}: {text!r} is not a number (allowed: a finite number > 0)") from None


def run(args):
    from ..errors import UserError
    from ..fmu.cosim import run_cosim, write_csv
    from ..runio import check_output_path

    out = check_output_path(args.out)
    n_freeze = None
    if args.n_freeze is not None:
        try:
            n_freeze = int(args.n_freeze)
        except ValueError:
            raise UserError(f"--n-freeze: {args.n_freeze!r} is not an integer (allowed: an integer >= 1)") from None
    result = run_cosim(args.fmu, force=args.force, t_end=_number(args.t_end, "--t-end"),
                       step=_number(args.step, "--step"), n_freeze=n_freeze)
    write_csv(out, result)
    t_end = result.values[-1, 0]
    print(f"cosim {args.fmu}: {result.steps} communication steps to t = {t_end:g} s, "
          f"{len(result.names) - 1} outputs; wall time {result.wall_time:.3f} s (fmpy.simulate_fmu)")
    print(f"wrote {out}")
    return 0
