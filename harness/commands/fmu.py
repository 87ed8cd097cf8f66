"""``sphrom fmu``: package a scene's reduced model (frozen-coefficient or exact linear) as an FMU."""

import argparse
import sys
import textwrap

from ..options import (add_n_freeze, add_order_tolerance, add_quiet, add_scene, float_list, int_at_least, max_probes,
                      one_of, positive_float)

DESCRIPTION = ("Build a reduced model of SCENE (--model: the frozen-coefficient model of eqs. 2.19-2.24 by "
               "default, the exact linear or the balanced one; full SPH and POD reused from the cache or run now, "
               "the force profile as input direction), "
               "write its numbers to resources/model.bin, build or reuse the binary with CMake, "
               "zip the FMU, validate it with fmpy, measure it against the full SPH (the training force and "
               "an unseen one, A sin(2 pi 0.7 t), from rest where the FMU can start at rest: probe errors of "
               "eq. 3.4 and run times, stored in its description and in documentation/index.html with a plot) "
               "and print a summary. Input f [m s^-2]; outputs v_probe_j [m s^-1] and rho_probe_j [kg m^-3]; "
               "parameters n_freeze, dt (frozen), initial_state_scale; linear models (exact, balanced) also "
               "carry certified error bounds. Exit status 4: the measured error is above --tolerance (nothing "
               "written).")


def add_parser(sub):
    from ..fmu.variables import help_text, vr
    p = sub.add_parser("fmu", help="package a scene's reduced model as an FMI 2.0/3.0 co-simulation FMU",
                       description="\n".join(textwrap.wrap(DESCRIPTION, 100)), epilog=help_text(),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_scene(p)
    p.add_argument("--modes", type=int_at_least(1), metavar="K",
                   help="POD modes k (default: the largest of the scene's rom.accel_modes); balanced: its order r "
                        "(1 to 2N - 1)")
    p.add_argument("--tolerance", type=positive_float, metavar="TOL",
                   help="the largest relative probe v error (eq. 3.4) accepted on every case of the measurement "
                        "(the training force, a step and an unseen sine, against the full SPH linear in J "
                        "integrated exactly in time) and on every input channel (0 < TOL < 1; default 0.1 on the "
                        "cases), for every model: above it, or when the FMU fails or runs away, the exit status is "
                        "4, one line names the case and the remedy, and nothing is written (its one meaning; the "
                        "balanced model's order criterion is --order-tolerance, and --tolerance with --model "
                        "balanced but neither --modes nor --order-tolerance, where it set the order before, is "
                        "refused)")
    add_order_tolerance(p, note=" (not with --model auto)")
    add_n_freeze(p, help="default refresh period n_freeze of the frozen coefficients (the FMU's parameter's start "
                         "value; default: chosen per scene, the largest of 1, 2, 5, 10, 20, 50, 100 whose training "
                         "error is within 5 %% of n_freeze = 1's)")
    p.add_argument("--probes", type=float_list(1, max_probes, lo=0.0, hi=1.0, hi_open=True, distinct=True),
                   metavar="X1,X2,...", default="0.25,0.5,0.66",
                   help="distinct probe positions in units of L, in [0, 1) (the bar is periodic: 1 is 0; default "
                        "0.25,0.5,0.66)")
    p.add_argument("--fmi", type=one_of("2", "3"), metavar="2|3", default="2", help="FMI version (default 2)")
    p.add_argument("--integrator", type=one_of("euler", "symplectic"), metavar="euler|symplectic",
                   help="time integrator of the frozen model (default: the scene's where its explicit Euler "
                        "amplifies no reduced mode; symplectic, which adds no energy to the bar, with --ports and "
                        "where explicit Euler would grow a mode step after step: an FMU runs as long as its master)")
    p.add_argument("--model", metavar="frozen|exact|balanced|auto", default=None,
                   help="reduced model: frozen (eqs. 2.19-2.24, internal dt; the default, but where the measured "
                        "frozen FMU misses the accuracy or costs more per simulated second than the exact one, the "
                        "exact model, said on the terminal; --model frozen keeps the frozen one; where the FMU "
                        "written would be slower than the full SPH, a cheaper configuration that meets the accuracy "
                        "(fewer modes, no certified bounds), else a warning), exact (the exact "
                        "linear "
                        "model in the specific volume, advanced by the matrix exponential over each "
                        "communication step) or balanced (balanced reduction of the full linear SPH, no POD basis, "
                        "the same C code as exact); every model reports a certified error bound per output at each "
                        "communication step (docs/science/error-bounds.md); auto (needs "
                        "--tolerance) packages and measures every model and keeps the fastest whose "
                        "training-force error meets the tolerance")
    p.add_argument("--a-priori-bounds", dest="bounds", action="store_true", default=False,
                   help="linear models: also compute the a priori bounds (calculated parameters "
                        "force_error_bound[_j], initial_state_error_bound[_j]: an H-infinity gain of the force "
                        "channel from rest and the L2 error of the free response; dense solves of the full 2N "
                        "linear system, growing about as N^3; sphrom fmu prints the time).  Off by default: every "
                        "FMU already reports a certified bound of each output at every step")
    p.add_argument("--no-bounds", dest="bounds", action="store_false",
                   help="without the a priori bounds (the default; kept for scripts that pass it)")
    p.add_argument("--no-verify", dest="verify", action="store_false",
                   help="skip the measurement against the full SPH (the documentation then says 'not measured')")
    p.add_argument("--vary", action="append", default=[], metavar="c=LO:HI|d=LO:HI",
                   help="a parametric FMU: train one basis over this range of the uniform stiffness c "
                        "[kg m^-1 s^-2] or damping d [s^-1] (full SPH at the corners and the centre of the range, "
                        f"one POD of all snapshots) and expose c (value reference {vr('c')}) or d ({vr('d')}) as "
                        "fixed parameters, min/max the range; give both to vary both")
    p.add_argument("--ports", metavar="X1,X2,...",
                   help="mechanical ports at these positions in units of L, each in [0, 1), at most 4: per port j an "
                        "input F_port_j [N] (a point force spread by the SPH kernel) and an output v_port_j "
                        "[m s^-1] (its power-conjugate velocity), and the parameter area [m^2] (default: no ports)")
    p.add_argument("--out", required=True, metavar="FILE.fmu")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    from ..errors import ToleranceError
    try:
        return _run(args)
    except ToleranceError as exc:       # the library's one line, with what to try next
        if "remedy:" in str(exc):
            raise
        hint = "more --modes" if args.model == "auto" else "--model auto tries every model, --modes sets k"
        raise ToleranceError(f"{exc}; {hint}") from None


def _run(args):
    from ..errors import UserError
    from ..fmu.make.request import is_default_request, package_request, pod_modes_line
    from ..runio import check_output_path, check_run_memory
    from ..scene import announce, load_scene

    out = check_output_path(args.out)
    if out.suffix.lower() != ".fmu":
        raise UserError(f"--out: '{out}' must end in .fmu")
    by_default = is_default_request(args.model, verify=args.verify, n_freeze=args.n_freeze,
                                    integrator=args.integrator)
    args.model = check_arguments(args)
    scene = load_scene(args.scene)
    announce(scene, "fmu")
    check_run_memory(scene, "fmu", args.model, args.modes)   # beyond this machine's memory: refused before the work
    line = pod_modes_line(scene, args.model, args.modes, progress=not args.quiet)  # the full SPH and POD (cached)
    if line:
        print(line)
    s, candidates, note = package_request(
        scene, out, args.model, by_default=by_default, k=args.modes, n_freeze=args.n_freeze, probes=args.probes,
        fmi=int(args.fmi), integrator=args.integrator, progress=not args.quiet, verify=args.verify,
        tolerance=args.tolerance, vary=args.vary, ports=args.ports, bounds=args.bounds,
        order_tolerance=args.order_tolerance)
    if candidates is not None:
        print_candidates(s, candidates, args.tolerance)
    if note:
        print(f"sphrom fmu: note: {note}", file=sys.stderr)
    print_summary(s, modes=args.modes, order_tolerance=args.order_tolerance)
    print_verification(s.verification, args.tolerance)
    return 0


def check_arguments(args):
    """The model to package (``--model``, the default one when not given), once the options that go together
    are checked (UserError naming the option): ``--tolerance`` ambiguous where it set a balanced model's order,
    or without the measurement; ``--model auto`` with ``--tolerance`` and without ``--vary``, ``--ports``,
    ``--order-tolerance``; ``--ports`` not with ``--vary``."""
    from ..errors import UserError
    from ..fmu.make.auto import DEFAULT_MODEL
    from ..fmu.make.request import AUTO
    from ..rom.registry import MODELS, fmu_model_names
    model = DEFAULT_MODEL if args.model is None else args.model
    if model not in fmu_model_names() + (AUTO,):
        raise UserError(f"--model: {model!r} is out of range (allowed: {', '.join(fmu_model_names())}, {AUTO})")
    if (args.tolerance is not None and model != AUTO and MODELS[model].sized_by_tolerance
            and args.modes is None and args.order_tolerance is None):
        raise UserError(f"--tolerance: ambiguous with --model {model} and no --modes: it set the order before "
                        "and now means the measured training error accepted; give the order with --order-tolerance "
                        "TOL or --modes R (and --tolerance for the accepted error)")
    if args.tolerance is not None and not args.verify:
        raise UserError("--tolerance: needs the measurement (drop --no-verify)")
    if model == AUTO:
        if args.vary or args.ports:
            raise UserError(f"--{'vary' if args.vary else 'ports'}: not with --model auto (choose a model)")
        if args.tolerance is None:
            raise UserError("--model: auto needs --tolerance TOL (the error the chosen model must meet)")
        if args.order_tolerance is not None:
            raise UserError("--order-tolerance: not with --model auto (choose --model balanced)")
    if args.vary and args.ports:
        raise UserError("--ports: not with --vary (a parametric FMU has no ports)")
    return model


def print_candidates(s, candidates, tolerance):
    """``--model auto``: every candidate's measured error and own work, and the verdict on it."""
    from ..fmu.make.auto import verdicts
    print(f"fmu {s.scene}: --model auto, tolerance {tolerance:g} on the v error of every case; "
          "candidates (each packaged and measured):")
    for c, verdict in verdicts(s, candidates, tolerance):
        tr, worst = c.verification.training, c.verification.worst
        print(f"  {c.model:8s} v error {tr.err_v:.3e} (largest {worst.err_v:.3e}, {worst.name}), its own work "
              f"{tr.step_s:.4f} s: {verdict}")


def print_summary(s, modes=None, order_tolerance=None):
    """What was written: the model, its modes or order, its input, integrator, probes, envelope, bounds,
    parameters, ports and the times of each stage (``modes``, ``order_tolerance``: the options that set the
    order, named in its line)."""
    from ..errors import exact
    from ..rom.registry import MODELS
    added = " (+ the force profile direction, not in the POD span)" if s.augmented else ""
    print(f"fmu {s.scene}: FMI {s.fmi}.0 co-simulation, {s.model} model, wrote {s.path} ({s.size / 1024:.1f} KiB)")
    print(f"  binaries for {s.platforms}")
    for line in s.missing_platforms:         # a platform left out, in one line (sphrom.fmu.make.build.fmu_binaries)
        print(f"sphrom fmu: note: {line}; the FMU carries the others", file=sys.stderr)
    model = MODELS[s.model]
    if not model.needs_basis:
        from ..defaults import ORDER_TOLERANCE
        from ..rom.balanced_model import METHOD_TITLES
        print(f"  order r = {s.k_v} ({s.method}: {METHOD_TITLES.get(s.method, s.method)}"
              + (f", from --order-tolerance {order_tolerance:g}" if order_tolerance is not None else
                 "" if modes is not None else f", from the default order tolerance {ORDER_TOLERANCE:g}")
              + "); the state does not split into velocity and specific-volume coordinates: outputs are rows "
              "over the whole state")
    elif model.basis_kind == "energy":
        print(f"  modes: k = {s.k} energy-weighted POD modes -> k_v = {s.k_v}{added}, k_e = {s.k_rho} "
              f"(specific volume)")
    else:
        print(f"  modes: k = {s.k} POD modes -> k_v = {s.k_v}{added}, k_rho = {s.k_rho}")
    decision = input_decision(model, augmented=s.augmented, parametric=bool(s.parameters))
    if model.needs_basis:
        print(f"  input projection error of the force profile on the {s.k} POD velocity modes: {s.input_error:.3g} "
              f"({decision})")
    if model.linear:
        print("  advanced by the matrix exponential over each communication step (input held, or linear over the "
              "step with df/dt: FMI 2 input derivatives; cached per step length): no internal step, so no parameters "
              "dt and n_freeze")
    else:
        print(f"  integrator {s.integrator}, dt = {s.dt:g} s, n_freeze = {s.n_freeze} (parameters dt, n_freeze)")
        if s.n_freeze_errors:
            tried = ", ".join(f"{nf}: {err:.3g}" for nf, err in sorted(s.n_freeze_errors.items()))
            print(f"  n_freeze = {s.n_freeze} chosen: the largest whose training error is within 5 % of n_freeze "
                  f"= 1's (velocity, eq. 3.4; tried {tried})")
    print(f"  probes at x/L = {', '.join(exact(x) for x in s.probes)}: outputs v_probe_1..{len(s.probes)}, "
          f"rho_probe_1..{len(s.probes)}; input f")
    if s.envelope is not None:
        for line in s.envelope.lines(linear=model.linear, bounded=s.shadow_order > 0):
            print(f"  envelope: {line}")
    if s.shadow_order:
        print(f"  certified bounds: every output's error at every step (outputs *_error_bound, a shadow of "
              f"{s.shadow_order} coordinates); error_tolerance = {s.error_tolerance:.3g} m s^-1 by default (5 % of "
              "the training run's largest |v_probe|): one warning when a velocity output's bound first exceeds it")
    else:
        print("  certified bounds: none in this FMU (docs/science/error-bounds.md, 'Not covered', says "
              "which FMUs have none); its run-time signal is the training envelope")
    if s.bounds is not None:
        print_bounds(s)
    for row in s.parameters:
        print(f"  parameter {row['name']} (value reference {row['vr']}): start {row['start']}, trained range "
              f"[{row['min']}, {row['max']}]")
    if s.ports:
        print_ports(s)
    t = s.timings
    print(f"  token {s.token}; fmpy validation: no problems; times: model {t['model']:.2f} s, "
          f"binaries {t['binaries']:.2f} s, package {t['package']:.2f} s"
          + (f", verification {t['verify']:.2f} s" if "verify" in t else ""))


def print_ports(s):
    """The ports' inputs and outputs, their profiles' projection errors and the port map's passivity (a warning on
    stderr when it is not passive)."""
    from ..errors import exact
    print(f"  ports at x/L = {', '.join(exact(x) for x in s.ports)}: inputs F_port_1..{len(s.ports)} [N], outputs "
          f"v_port_1..{len(s.ports)} [m s^-1], parameter area [m^2] (start 1); each port's profile, its "
          f"short-time, static and in-band directions and the modes a step rings appended to the basis "
          f"(docs/fmu/ports.md; profile projection errors on the modes: "
          f"{', '.join(f'{e:.3g}' for e in s.port_errors)})")
    if s.port_passivity is not None:
        print(f"  port map (F_port to v_port): {s.port_passivity.line()}")
        if s.port_passivity.verdict == "not passive":
            print(f"sphrom fmu: warning: the {s.model} model's port map is not passive (min λ(H + Hᴴ)/‖H‖ = "
                  f"{s.port_passivity.margin:.2e} at {s.port_passivity.at:.3g} rad/s): coupled through its ports "
                  "to a passive component it can gain energy; --model exact is passive by structure",
                  file=sys.stderr)


def print_verification(v, tolerance=None):
    """The measurement's lines (stdout) and its warnings (stderr); nothing when not measured."""
    if v is None:
        print("  not measured (--no-verify)")
        return
    finer = v.default_step == v.default_step and abs(v.default_step - v.step) > 1e-12 * v.step
    print(f"  measured against {v.truth or 'the full SPH'} at the probes (h = {v.step:g} s"
          + (f", finer than the default step {v.default_step:g} s, which sets the cost" if finer else "")
          + f", T = {v.T:g} s, input "
          f"{v.input}; relative L2 of eq. 3.4; stored in the description and documentation/index.html):")
    for c in v.cases:
        rho = ("rho-rho0 of the truth is 0" if c.err_rho != c.err_rho else f"rho-rho0 error {c.err_rho:.3e}")
        bound = ""
        if c.bound_holds is not None:
            bound = (f"; certified bound {'holds' if c.bound_holds else 'FAILS'}, largest bound "
                     f"{c.bound_ratio:.3g}x the largest error")
            if c.error_is_roundoff:                      # a ratio to round-off says nothing about the bound
                from ..fmu.check.verify import ROUNDOFF_ERROR
                bound += f" (that error is round-off, below {ROUNDOFF_ERROR:g} of max |v|)"
        print(f"    {c.name:8s} f = {c.force} from {c.start}: v error {c.err_v:.3e}, {rho}, max |rho - rho_true| "
              f"{c.max_drho:.2e} kg/m^3{bound}; {len(c.warnings)} warning(s)" + (f"; {c.note}" if c.note else ""))
    sv, sr, points = v.stepped_error
    if sv == sv:
        print(f"  the full SPH stepped in time (the scene's integrator and dt, f at every step) against the same "
              f"truth, training case, at the {points} points where its run has a sample: v error {sv:.3e}"
              + ("" if sr != sr else f", rho-rho0 error {sr:.3e}")
              + " (its time-step error, and f at every step against f "
              + ("linear" if v.input.startswith("linear") else "held") + " between the points in the truth)")
    tr = v.training
    # one run of the training case; where packaging measured its verdict (the median of pairs, below), that ratio is
    # the one printed, so that the terminal gives one FMU / SPH figure
    print(f"  cost per simulated T, one run of the training case: the FMU's own work (doStep, CPU time) "
          f"{tr.step_s:.4g} s, through fmpy (wall) {tr.fmu_s:.4g} s; the full SPH's compiled loop (CPU time) "
          f"{tr.sph_s:.4g} s" + ("" if v.cost is not None else f" (FMU / full SPH = {tr.cost_ratio:.3g})"))
    if v.cost is not None:
        c = v.cost
        print(f"  cost per simulated second (packaging's verdict): FMU / full SPH = {c.ratio:.3g}, the median of "
              f"{c.repeats} pairs of runs in steady stepping ({c.why()}, not counted per second)")
    if v.channels:
        print(f"  every input channel from rest against the full SPH stepped in time (the integrator the FMU "
              f"reduces; over {v.channel_horizon:.4g} s; relative L2 of eq. 3.4):")
        for c in v.channels:
            print(f"    {c.channel:10s} {c.case:9s} {c.force}: {c.output} error {c.err:.3e}"
                  + (f"; {c.note}" if c.note else ""))
    from ..fmu.check.verify import ACCURACY
    accepted = ACCURACY if tolerance is None else tolerance
    print(f"  accuracy {accepted:g} on the v error of every case: met (largest {v.worst.err_v:.3e}, {v.worst.name})"
          + (f"; on every input channel: met (at most {max(c.err for c in v.channels):.3e})"
             if v.channels and tolerance is not None else ""))
    if v.slower:
        why = v.cost.why() if v.cost is not None else f"{tr.step_s:.3g} s against {tr.sph_s:.3g} s over T"
        print(f"sphrom fmu: warning: the FMU is SLOWER than the full SPH it replaces: its own work per simulated "
              f"second is {v.cost_ratio:.3g}x the full SPH's ({why}); no cheaper configuration packaging tried "
              "(fewer modes, no certified error bounds) met the accuracy at a lower cost; the full SPH may serve "
              "better here (or another --model)", file=sys.stderr)


def print_bounds(s):
    """The certified error bounds stored in the FMU, and exactly what they bound."""
    from ..fmu.make.describe import bound_text
    b = s.bounds
    print(f"  error bounds (calculated parameters force_error_bound[_j], initial_state_error_bound[_j]): "
          f"{bound_text(b)}")
    print("    probe x/L | force_error_bound_j [s] | initial_state_error_bound_j [m s^-1 s^1/2]")
    for j, x in enumerate(s.probes):
        print(f"    {x:9.4g} | {b['force_error_bound'][j]:23.4e} | {b['initial_state_error_bound'][j]:.4e}")
    t = b["timings"]
    print(f"    computed in {sum(t.values()):.2f} s (H-infinity bisection {t['hinf']:.2f} s)")


def input_decision(model, augmented, parametric=False):
    """What packaging did with the force profile, in words: projected on the modes (eq. 2.19) or its residual
    appended to the basis, and why (the model's ``fmu_input_direction``: the frozen model's 1 % rule, the exact
    model's always, a parametric frozen model's never)."""
    from ..rom.operators import INPUT_TOLERANCE
    if parametric and not augmented and not model.linear:
        return "f projected on the modes (eq. 2.19), as in every parametric frozen model"
    if model.fmu_input_direction == "always":
        return (f"the {model.name} model appends the residual to the basis whatever its size, so a force along the "
                "profile is represented exactly" if augmented else
                "the profile lies in the modes' span: a force along it is represented exactly")
    return (f"above {INPUT_TOLERANCE:g}: its residual appended to the basis" if augmented else
            f"at most {INPUT_TOLERANCE:g}: f projected on the modes (eq. 2.19)")
