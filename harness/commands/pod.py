"""``sphrom pod``: POD bases of a scene (eq. 2.15) from the full SPH (cached)."""

from ..options import add_quiet, add_scene, modes_pair, positive_float
from .snapshot_options import add_snapshot_options

# deferred imports below (inside the handlers): start-up time, the parsers of every command import nothing heavy


def add_parser(sub):
    p = sub.add_parser("pod", help="POD bases of velocity and density snapshots",
                       description="Run the full SPH of SCENE (or reuse a cached run of the same settings), take "
                                   "velocity and density snapshots, and write their POD bases (thin SVD, eq. 2.15), "
                                   "singular values, the reduced operators and initial reduced coordinates at the "
                                   "chosen mode count, to a basis file.")
    add_scene(p)
    add_snapshot_options(p)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--modes", type=modes_pair, metavar="K|KV,KRHO",
                   help="mode counts stored with the operators (default the scene's)")
    g.add_argument("--energy", type=positive_float, metavar="TOL",
                   help="choose k as the fewest modes leaving out at most TOL of the snapshot energy")
    p.add_argument("--augment-input", action="store_true",
                   help="append the force direction to the velocity basis when the POD modes miss part of it "
                        "(default: project it on the POD modes, as the paper does)")
    p.add_argument("--out", required=True, metavar="BASIS.h5")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):
    import numpy as np

    from ..errors import UserError, exact
    from ..pod.basis import modes_for_energy
    from ..pod.io import write_basis
    from ..pod.pipeline import automatic_modes, basis_for_scene
    from ..rom.operators import build_operators
    from ..runio import check_output_path, check_run_memory
    from ..scene import announce, load_scene
    from .snapshot_options import strategy_from_args

    out = check_output_path(args.out)
    scene = load_scene(args.scene)
    spec = strategy_from_args(args, scene)
    announce(scene, "pod")
    check_run_memory(scene, "pod", modes=max(args.modes) if args.modes else None)   # beyond the memory: refused
    basis, run_ = basis_for_scene(scene, spec, progress=not args.quiet)
    rv, rr = basis.max_modes
    if args.energy is not None:
        if args.energy >= 1:
            raise UserError(f"--energy: {exact(args.energy)} is out of range (allowed: 0 < TOL < 1)")
        k_v, k_r = modes_for_energy(basis.sigma_v, args.energy), modes_for_energy(basis.sigma_rho, args.energy)
    else:
        if args.modes is None and "modes" not in scene.rom:
            k, why = automatic_modes(basis)
            print(f"scene {scene.name}: rom.modes: {why}")
        k_v, k_r = args.modes or ((scene.rom["modes"],) * 2 if "modes" in scene.rom else (k, k))
        if k_v > rv or k_r > rr:
            raise UserError(f"--modes: {k_v},{k_r} is out of range (allowed: at most {rv} velocity and {rr} density "
                            "modes, the rank of these snapshots)")
    ops = build_operators(run_.problem, basis.U_v[:, :k_v], basis.U_rho[:, :k_r],
                          input_direction="augment" if args.augment_input else "auto")
    basis.attrs.update({"default_modes_v": k_v, "default_modes_rho": k_r})
    write_basis(out, basis, scene, extra={"operators": ops.basis_file_group()})
    energy_left = lambda s, k: float(1 - np.sum(s[:k] ** 2) / np.sum(s**2))
    print(f"pod {scene.name}: {basis.strategy}; {basis.steps_v.size} velocity and {basis.steps_rho.size} "
          f"density snapshots; rank {rv}, {rr}")
    print(f"  sigma_v / sigma_v[0]:   " + " ".join(f"{x:.2e}" for x in basis.sigma_v[:14] / basis.sigma_v[0]))
    print(f"  sigma_rho / sigma_rho[0]: " + " ".join(f"{x:.2e}" for x in basis.sigma_rho[:14] / basis.sigma_rho[0]))
    print(f"  k_v = {k_v} (energy left out {energy_left(basis.sigma_v, k_v):.2e}), "
          f"k_rho = {k_r} (energy left out {energy_left(basis.sigma_rho, k_r):.2e})")
    if not np.isnan(ops.input_error):
        print(f"  force direction: projection error {ops.input_error:.3e} in the POD velocity modes"
              + ("; appended to the basis" if ops.augmented else "; projected (--augment-input appends it)"))
    sph_txt = "reused cached run" if run_.reused else f"{basis.timings['sph']:.3f} s"
    print(f"  offline: full SPH {sph_txt}, SVD {basis.timings['svd'] * 1e3:.2f} ms, "
          f"operators {ops.timings['operators'] * 1e3:.2f} ms")
    print(f"wrote {out}")
    return 0
