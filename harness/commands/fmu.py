"""``sphrom fmu``: package a scene's reduced model (frozen-coefficient or exact linear) as an FMU."""

from .options import add_n_freeze, add_quiet, add_scene, float_list, int_at_least, max_probes, one_of


def add_parser(sub):
    p = sub.add_parser("fmu", help="package a scene's reduced model as an FMI 2.0/3.0 co-simulation FMU",
                       description="Build the frozen-coefficient reduced model of SCENE (eqs. 2.19-2.24: full SPH "
                                   "and POD reused from the cache or run now, the force profile as input direction), "
                                   "write its numbers to resources/model.bin, build or reuse the binary with CMake, "
                                   "zip the FMU, validate it with fmpy and print a summary. Input f [m s^-2]; "
                                   "outputs v_probe_j [m s^-1] and rho_probe_j [kg m^-3]; parameters n_freeze, dt.")
    add_scene(p)
    p.add_argument("--modes", type=int_at_least(1), metavar="K",
                   help="POD modes k (default: the largest of the scene's rom.accel_modes)")
    add_n_freeze(p, default=10, help="default refresh period n_freeze of the frozen coefficients")
    p.add_argument("--probes", type=float_list(1, max_probes, lo=0.0, hi=1.0), metavar="X1,X2,...",
                   default="0.25,0.5,0.66", help="probe positions in units of L, in [0, 1] (default 0.25,0.5,0.66)")
    p.add_argument("--fmi", type=one_of("2", "3"), metavar="2|3", default="2", help="FMI version (default 2)")
    p.add_argument("--integrator", type=one_of("euler", "symplectic"), metavar="euler|symplectic",
                   help="time integrator of the frozen model (default: the scene's)")
    p.add_argument("--model", metavar="frozen|exact", default="frozen",
                   help="reduced model: frozen (eqs. 2.19-2.24, internal dt; default) or exact (the exact linear "
                        "model in the specific volume, advanced by the matrix exponential over each "
                        "communication step)")
    p.add_argument("--ports", metavar="X1,X2,...",
                   help="mechanical ports at these positions in units of L, each in [0, 1), at most 4: per port j an "
                        "input F_port_j [N] (a point force spread by the SPH kernel) and an output v_port_j "
                        "[m s^-1] (its power-conjugate velocity), and the parameter area [m^2] (default: no ports)")
    p.add_argument("--out", required=True, metavar="FILE.fmu")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    from ..errors import UserError
    from ..fmu.package import check_options, package_fmu
    from ..runio import check_output_path
    from ..scene import load_scene

    out = check_output_path(args.out)
    if out.suffix.lower() != ".fmu":
        raise UserError(f"--out: '{out}' must end in .fmu")
    fmi = int(args.fmi)
    from ..rom.registry import MODELS, fmu_model_names
    if args.model not in fmu_model_names():
        raise UserError(f"--model: {args.model!r} is out of range (allowed: {', '.join(fmu_model_names())})")
    scene = load_scene(args.scene)
    check_options(scene, k=args.modes, n_freeze=args.n_freeze, probes=args.probes, fmi=fmi,
                  integrator=args.integrator, model=args.model)
    from ..fmu.package import check_ports
    ports = check_ports(args.ports, args.model)
    s = package_fmu(scene, out, k=args.modes, n_freeze=args.n_freeze, probes=args.probes, fmi=fmi,
                    integrator=args.integrator, progress=not args.quiet, model=args.model, ports=ports)
    from ..rom.operators import INPUT_TOLERANCE
    added = " (+ the force profile direction, not in the POD span)" if s.augmented else ""
    print(f"fmu {s.scene}: FMI {s.fmi}.0 co-simulation, {s.model} model, wrote {s.path} ({s.size / 1024:.1f} KiB)")
    model = MODELS[s.model]
    if model.basis_kind == "energy":
        print(f"  modes: k = {s.k} energy-weighted POD modes -> k_v = {s.k_v}{added}, k_e = {s.k_rho} "
              f"(specific volume)")
    else:
        print(f"  modes: k = {s.k} POD modes -> k_v = {s.k_v}{added}, k_rho = {s.k_rho}")
    decision = (f"above {INPUT_TOLERANCE:g}: its residual appended to the basis" if s.augmented else
                f"at most {INPUT_TOLERANCE:g}: f projected on the modes (eq. 2.19)")
    print(f"  input projection error of the force profile on the {s.k} POD velocity modes: {s.input_error:.3g} "
          f"({decision})")
    if model.linear:
        print("  advanced by the matrix exponential over each communication step (input held; cached per step "
              "length); parameters dt, n_freeze have no effect")
    else:
        print(f"  integrator {s.integrator}, dt = {s.dt:g} s, n_freeze = {s.n_freeze} (parameters dt, n_freeze)")
    print(f"  probes at x/L = {', '.join(f'{x:g}' for x in s.probes)}: outputs v_probe_1..{len(s.probes)}, "
          f"rho_probe_1..{len(s.probes)}; input f")
    if s.ports:
        print(f"  ports at x/L = {', '.join(f'{x:g}' for x in s.ports)}: inputs F_port_1..{len(s.ports)} [N], outputs "
              f"v_port_1..{len(s.ports)} [m s^-1], parameter area [m^2] (start 1); each port's profile and its "
              f"Krylov directions appended to the basis (profile projection errors on the modes: "
              f"{', '.join(f'{e:.3g}' for e in s.port_errors)})")
    t = s.timings
    print(f"  token {s.token}; fmpy validation: no problems; times: model {t['model']:.2f} s, "
          f"binaries {t['binaries']:.2f} s, package {t['package']:.2f} s")
    return 0
