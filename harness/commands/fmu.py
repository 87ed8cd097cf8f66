"""``sphrom fmu``: package a scene's reduced model (frozen-coefficient or exact linear) as an FMU."""


def add_parser(sub):
    p = sub.add_parser("fmu", help="package a scene's reduced model as an FMI 2.0/3.0 co-simulation FMU",
                       description="Build the frozen-coefficient reduced model of SCENE (eqs. 2.19-2.24: full SPH "
                                   "and POD reused from the cache or run now, the force profile as input direction), "
                                   "write its numbers to resources/model.bin, build or reuse the binary with CMake, "
                                   "zip the FMU, validate it with fmpy and print a summary. Input f [m s^-2]; "
                                   "outputs v_probe_j [m s^-1] and rho_probe_j [kg m^-3]; parameters n_freeze, dt.")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or TOML file")
    p.add_argument("--modes", metavar="K",
                   help="POD modes k (default: the largest of the scene's rom.accel_modes)")
    p.add_argument("--freeze", metavar="NF", default="10",
                   help="default refresh period n_freeze of the frozen coefficients (default 10)")
    p.add_argument("--probes", metavar="X1,X2,...", default="0.25,0.5,0.66",
                   help="probe positions in units of L, in [0, 1] (default 0.25,0.5,0.66)")
    p.add_argument("--fmi", metavar="2|3", default="2", help="FMI version (default 2)")
    p.add_argument("--integrator", metavar="euler|symplectic",
                   help="time integrator of the frozen model (default: the scene's)")
    p.add_argument("--model", metavar="frozen|exact", default="frozen",
                   help="reduced model: frozen (eqs. 2.19-2.24, internal dt; default) or exact (the exact linear "
                        "model in the specific volume, advanced by the matrix exponential over each "
                        "communication step)")
    p.add_argument("--out", required=True, metavar="FILE.fmu")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(handler=run)


def _integer(text, option, lo):
    from ..errors import UserError
    try:
        value = int(str(text).strip())
    except ValueError:
        raise UserError(f"{option}: {text!r} is not an integer (allowed: an integer >= {lo})") from None
    if value < lo:
        raise UserError(f"{option}: {value} is out of range (allowed: an integer >= {lo})")
    return value


def run(args):
    from ..errors import UserError
    from ..fmu.package import check_options, package_fmu, parse_probes
    from ..runio import check_output_path
    from ..scene import load_scene

    out = check_output_path(args.out)
    if out.suffix.lower() != ".fmu":
        raise UserError(f"--out: '{out}' must end in .fmu")
    k = _integer(args.modes, "--modes", 1) if args.modes is not None else None
    n_freeze = _integer(args.freeze, "--freeze", 1)
    probes = parse_probes(args.probes)
    if str(args.fmi).strip() not in ("2", "3"):
        raise UserError(f"--fmi: {args.fmi!r} is out of range (allowed: 2 or 3)")
    fmi = int(args.fmi)
    if args.integrator is not None and args.integrator not in ("euler", "symplectic"):
        raise UserError(f"--integrator: {args.integrator!r} is out of range (allowed: euler, symplectic)")
    from ..rom.registry import MODELS, fmu_model_names
    if args.model not in fmu_model_names():
        raise UserError(f"--model: {args.model!r} is out of range (allowed: {', '.join(fmu_model_names())})")
    scene = load_scene(args.scene)
    check_options(scene, k=k, n_freeze=n_freeze, probes=probes, fmi=fmi, integrator=args.integrator,
                  model=args.model)
    s = package_fmu(scene, out, k=k, n_freeze=n_freeze, probes=probes, fmi=fmi, integrator=args.integrator,
                    progress=not args.quiet, model=args.model)
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
    t = s.timings
    print(f"  token {s.token}; fmpy validation: no problems; times: model {t['model']:.2f} s, "
          f"binaries {t['binaries']:.2f} s, package {t['package']:.2f} s")
    return 0
