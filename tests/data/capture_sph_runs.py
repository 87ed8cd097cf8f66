"""Capture whole full SPH runs of every built-in scene with one checkout, to compare two checkouts bitwise.

A change of the full SPH's loops that claims to change no number (the fixed-offset stencil layout) runs
this with the code before and after, then compares:

    PYTHONPATH=/work/main python3 tests/data/capture_sph_runs.py --out /tmp/sph_before.npz
    PYTHONPATH=.          python3 tests/data/capture_sph_runs.py --out /tmp/sph_after.npz
    python3 tests/data/capture_sph_runs.py --compare /tmp/sph_before.npz /tmp/sph_after.npz

Captured, through the API both checkouts share (``run_sph``, ``run_sph_ports``, ``build_problem``):

* every built-in scene at its own settings (N, α, Δt, integrator, T: the training run), every stored sample;
* every built-in scene at N = 48 with each integrator (euler, symplectic, rk4) for 2000 steps, every 50th step;
* damped_forced with every field per particle (ρ0, c, d, profile) at N = 48, each integrator;
* run_sph_ports on damped_forced (two ports, a given force and a coupled mass-spring), each integrator;
* the operators the reduced models take: each scene's neighbour lists, weights and G (``Neighbours.matrix``).

``--quick`` keeps the small runs and the operators (no training runs).
"""

import argparse
import sys
import time

import numpy as np

NONUNIFORM = {"rho0": "1 + 0.3*sin(2*pi*x/L)", "c": "where(x/L <= 0.5, 0.1, 0.2)", "d": "10*(1 + x/L)",
              "profile": "1 + 0.5*cos(2*pi*x/L)"}
INTEGRATORS = ("euler", "symplectic", "rk4")


def capture(quick=False):
    from sphrom.scene import builtin_names, derive_scene, load_scene
    from sphrom.sph.ports import mass_spring, run_sph_ports
    from sphrom.sph.solver import build_problem, run_sph
    out = {}
    for name in builtin_names():
        base = load_scene(name)
        nb = build_problem(base).neighbours
        g = nb.matrix().tocsr()
        out[f"{name}/operator/index"], out[f"{name}/operator/weight"] = nb.index, nb.weight
        out[f"{name}/operator/G.data"], out[f"{name}/operator/G.indices"] = g.data, g.indices
        out[f"{name}/operator/G.indptr"] = g.indptr
        if not quick:
            r = run_sph(base, progress=False)
            out[f"{name}/own/v"], out[f"{name}/own/rho"] = r.v, r.rho
        for integ in INTEGRATORS:
            s = base.with_sph(n_particles=48, integrator=integ, every=50).with_T(2000 * base.sph.dt)
            r = run_sph(s, progress=False)
            out[f"{name}/n48/{integ}/v"], out[f"{name}/n48/{integ}/rho"] = r.v, r.rho
    base = load_scene("damped_forced")
    for integ in INTEGRATORS:
        s = derive_scene(base, {"domain": {"T": 0.4}, "sph": {"n_particles": 48, "integrator": integ, "every": 50},
                                "fields": {k: NONUNIFORM[k] for k in ("rho0", "c", "d")},
                                "force": {"profile": NONUNIFORM["profile"]}})
        r = run_sph(s, progress=False)
        out[f"nonuniform/{integ}/v"], out[f"nonuniform/{integ}/rho"] = r.v, r.rho
        s = base.with_sph(n_particles=40, integrator=integ).with_T(0.1)
        pr = run_sph_ports(s, [0.3, 0.7], forces=lambda t: [0.2 * np.sin(7 * t), -0.1],
                           lumped=mass_spring(0.5, 40.0, port=1, n_ports=2, s0=1e-3), every=10)
        for key in ("v", "rho", "v_port", "y"):
            out[f"ports/{integ}/{key}"] = getattr(pr, key)
    return out


def compare(a_path, b_path):
    a, b = np.load(a_path), np.load(b_path)
    keys = sorted(set(a.files) | set(b.files))
    bad = [k for k in keys if k not in a.files or k not in b.files or a[k].dtype != b[k].dtype
           or a[k].shape != b[k].shape or a[k].tobytes() != b[k].tobytes()]
    for k in bad:
        print(f"DIFFERS: {k}")
    n_values = sum(a[k].size for k in keys if k in a.files)
    print(f"{len(keys) - len(bad)} of {len(keys)} arrays equal bit for bit ({n_values} values)")
    return 1 if bad else 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", help="the .npz to write")
    p.add_argument("--quick", action="store_true", help="no training runs at the scenes' own settings")
    p.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = p.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    if not args.out:
        p.error("--out or --compare is needed")
    import sphrom
    t0 = time.perf_counter()
    data = capture(args.quick)
    np.savez(args.out, **data)
    print(f"{sphrom.__file__}: {len(data)} arrays in {time.perf_counter() - t0:.0f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
