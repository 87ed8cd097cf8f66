"""Write tests/data/registry_reference.npz: reduced-model runs of the code before the registry.

Run from the repository root (``python3 tests/data/make_registry_reference.py``).  It was run once on the
code before the reduced models went behind one interface (sphrom.rom.registry); tests/test_registry.py
holds the registry's runs bitwise equal to these arrays, so the refactoring changed no number.

Stored per case: the bases the operators were built from (so the test needs no SPH run or SVD), the
operators, the sampled reduced coordinates and, at every tenth sample, v and rho at the particles.  Bitwise equality assumes the same numpy/scipy/BLAS
build as the capture (the runs themselves are compiled loops; the exact model's uses scipy's expm).
"""

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
os.environ.setdefault("SPHROM_CACHE", tempfile.mkdtemp(prefix="sphrom-cache-"))   # the full SPH runs afresh

from conftest import small_scene  # noqa: E402
from sphrom.pod.pipeline import basis_for_scene  # noqa: E402
from sphrom.sph.solver import build_problem, step_count  # noqa: E402


def scenes():
    """Two small scenes: damped and forced with uniform fields; a density and stiffness jump, forced, d = 0."""
    yield "damped", small_scene("damped_forced", T=0.3, n=24, every=10)
    yield "hetero", small_scene("heterogeneous", T=0.3, n=24, every=10, rho0="1 + 0.2*cos(2*pi*x/L)",
                                f="1e-2*sin(10*t)", profile="1 + 0.5*cos(2*pi*x/L)")


# (label, model, options); k_v = 5, k_rho = 4 unless the label says otherwise
RUNS = [
    ("original-euler", "original", {"integrator": "euler"}),
    ("original-symplectic", "original", {"integrator": "symplectic"}),
    ("original-rk4", "original", {"integrator": "rk4"}),
    ("linearized-euler", "linearized", {"integrator": "euler"}),
    ("linearized-rk4", "linearized", {"integrator": "rk4"}),
    ("frozen-euler-tensor", "frozen", {"integrator": "euler", "n_freeze": 7, "refresh": "tensor"}),
    ("frozen-symplectic-direct", "frozen", {"integrator": "symplectic", "n_freeze": 3, "refresh": "direct"}),
    ("frozen-augmented", "frozen", {"integrator": "euler", "n_freeze": 4}),
    ("exact-linear", "exact", {"hold": "linear", "step": 0.004}),
    ("exact-held", "exact", {"hold": "held", "step": 0.01}),
    ("exact-free", "exact", {"hold": "linear", "step": 0.01, "force": None}),
]


def main(out=ROOT / "tests" / "data" / "registry_reference.npz"):
    from sphrom.rom.exact_linear import build_linear_operators, run_exact
    from sphrom.rom.operators import build_operators
    from sphrom.rom.registry import get_model

    arrays = {}
    for tag, scene in scenes():
        problem = build_problem(scene)
        basis, _ = basis_for_scene(scene, {"count": 12, "window": [0, 0.3]}, progress=False, problem=problem)
        n = step_count(scene.T, scene.sph.dt)
        steps = np.arange(0, n + 1, 50)
        U_v, U_rho, U_ve, U_e = basis.U_v[:, :5], basis.U_rho[:, :4], basis.U_ve[:, :5], basis.U_e[:, :4]
        arrays.update({f"{tag}/U_v": U_v, f"{tag}/U_rho": U_rho, f"{tag}/U_ve": U_ve, f"{tag}/U_e": U_e,
                       f"{tag}/steps": steps})
        ops = build_operators(problem, U_v, U_rho)
        aug = build_operators(problem, U_v, U_rho, input_direction="augment")
        lin = build_linear_operators(problem, U_ve, U_e)
        for name, o in (("ops", ops), ("aug", aug)):
            for field in ("U_v", "K", "b", "D", "p", "T", "a_v0", "a_rho0"):
                if getattr(o, field) is not None:
                    arrays[f"{tag}/{name}/{field}"] = getattr(o, field)
        for field in ("U_v", "A", "B", "z0"):
            arrays[f"{tag}/lin/{field}"] = getattr(lin, field)
        for label, model, opts in RUNS:
            opts = dict(opts)
            if model == "exact":
                force = opts.pop("force", scene.force)
                res = run_exact(lin, steps * scene.sph.dt, force=force, **opts)
                a_v, a_rho = res.z[:, :lin.k_v], res.z[:, lin.k_v:]
            else:
                o = aug if label == "frozen-augmented" else ops
                spec = get_model(model)
                res = spec.run(o, problem, n_steps=n, dt=scene.sph.dt, sample_steps=steps, options=spec.options(**opts))
                a_v, a_rho = res.a_v, res.a_rho
            arrays[f"{tag}/{label}/a_v"] = a_v
            arrays[f"{tag}/{label}/a_rho"] = a_rho
            arrays[f"{tag}/{label}/v"] = res.v[::10]          # reconstructions at a few samples
            arrays[f"{tag}/{label}/rho"] = res.rho[::10]
    np.savez_compressed(out, **arrays)
    print(f"wrote {out} ({len(arrays)} arrays)")


if __name__ == "__main__":
    main()
