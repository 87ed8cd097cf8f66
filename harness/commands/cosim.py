"""``sphrom cosim``: co-simulate an sphrom FMU on sphrom's FMU driver (harness/fmu/run/driver.py)."""

from ..options import add_n_freeze, number, positive_float


def add_parser(sub):
    p = sub.add_parser("cosim", help="co-simulate an FMU from 'sphrom fmu' (through fmpy's FMI bindings)",
                       description="Run FILE.fmu on sphrom's FMU driver (fmpy's FMI 2 / 3 bindings): the input f "
                                   "[m s^-2] is an expression in t (and T, the end time) sampled at the "
                                   "communication points, or a CSV file with columns time,f (interpolated linearly "
                                   "between its rows). One rule: an FMU that declares canInterpolateInputs (FMI 2: "
                                   "every sphrom FMU) also gets df/dt, the slope to the next point, so f goes "
                                   "linearly over each step; FMI 3.0 co-simulation has no input derivatives, so an "
                                   "FMI 3 FMU holds f over each step, and --hold-inputs holds it for every FMU "
                                   "(docs/fmu/cosim.md). Writes time and all outputs as CSV and prints the wall "
                                   "time.")
    p.add_argument("fmu", metavar="FILE.fmu")
    p.add_argument("--force", metavar="EXPR|CSV", help="f(t) as an expression in t, T or a CSV file (default 0)")
    p.add_argument("--t-end", type=positive_float, metavar="T",
                   help="end time [s] (default: the FMU's DefaultExperiment stopTime)")
    p.add_argument("--step", type=positive_float, metavar="H", help="communication step [s] (default: its stepSize)")
    add_n_freeze(p, help="the n_freeze parameter of a frozen-model FMU (default: the packaged value; an FMU without "
                         "it, a linear model's, is an error)")
    p.add_argument("--initial-state-scale", type=number, metavar="S",
                   help="the initial_state_scale parameter: the initial state is S x the scene's deviation from "
                        "rest (1: the scene's initial velocity v0, 0: at rest; default: the FMU's start value, 0)")
    p.add_argument("--hold-inputs", action="store_true",
                   help="hold f over each communication step even when the FMU can take input derivatives "
                        "(default: pass df/dt with fmi2SetRealInputDerivatives when the FMU declares "
                        "canInterpolateInputs, FMI 2)")
    p.add_argument("--out", required=True, metavar="RESULT.csv")
    p.set_defaults(handler=run)


def run(args):
    from ..fmu.run.cosim import run_cosim, write_csv
    from ..runio import check_output_path

    out = check_output_path(args.out)
    result = run_cosim(args.fmu, force=args.force, t_end=args.t_end, step=args.step, n_freeze=args.n_freeze,
                        hold_inputs=args.hold_inputs, initial_state_scale=args.initial_state_scale)
    write_csv(out, result)
    t_end = result.values[-1, 0]
    print(f"cosim {args.fmu}: {result.steps} communication steps to t = {t_end:g} s, "
          f"{len(result.names) - 1} outputs; wall time {result.wall_time:.3f} s (sphrom's FMU driver on fmpy's FMI "
          f"bindings)")
    print("input: f linear over each step (df/dt by fmi2SetRealInputDerivatives)" if result.input_derivatives
          else "input: f held over each communication step")
    for text in result.warnings:             # e.g. the FMU left its training envelope
        print(f"FMU warning: {' '.join(text.split())}")
    print(f"wrote {out}")
    return 0
