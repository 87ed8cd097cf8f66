"""Capture what the scene loader makes of every built-in scene, to prove a change of the loader changes none of it.

    PYTHONPATH=OLD_CHECKOUT python3 tests/data/capture_scenes.py --out tests/data/scenes_reference.npz

Per scene: every attribute of the loaded Scene (name, title, section, summary, L, T, the SPH settings, the
snapshot and reduced-model tables, the paper's table, the TOML text), what is derived from it (the cache key
and the cache file's name, the error steps, the snapshot steps, the FMU's default mode count, the terms the
scene has) and the values of every field on the particles and of the force on 257 times in [0, T].
``tests/test_scene_schema.py`` loads the built-in scenes with the current loader and compares (the numbers
within 4 ulps: the fields go through numpy's transcendental functions, whose last bit depends on the CPU).
The reference in the repository was made with the loader before scenes had defaults (main at 31aafc9).
"""

import argparse
import dataclasses
import json

import numpy as np


def capture():
    from sphrom.cache import run_key
    from sphrom.fmu.make.options import default_modes
    from sphrom.pod.pipeline import error_steps
    from sphrom.pod.snapshots import snapshot_steps
    from sphrom.scene import builtin_names, describe_terms, load_scene
    from sphrom.sph.operator import particle_positions
    from sphrom.sph.solver import step_count

    meta, arrays = {}, {}
    for name in builtin_names():
        s = load_scene(name)
        n = step_count(s.T, s.sph.dt)
        sv, sr = snapshot_steps(s.snapshots, s.sph.dt, n, n_particles=s.sph.n_particles)
        meta[name] = {
            "name": s.name, "title": s.title, "section": s.section, "summary": s.summary, "L": s.L, "T": s.T,
            "sph": dataclasses.asdict(s.sph), "snapshots": s.snapshots, "rom": s.rom, "paper": s.paper,
            "text": s.text, "run_key": run_key(s), "cache_file": f"sph-{s.name}-{run_key(s)}.h5",
            "default_modes": default_modes(s), "terms": describe_terms(s),
        }
        x = particle_positions(s.L, s.sph.n_particles)
        for field in ("rho0", "v0", "c", "d", "profile"):
            arrays[f"{name}/{field}"] = s.field(field, x)
        arrays[f"{name}/force"] = s.force(np.linspace(0.0, s.T, 257))
        arrays[f"{name}/error_steps"] = error_steps(s)
        arrays[f"{name}/snapshot_steps_v"] = sv
        arrays[f"{name}/snapshot_steps_rho"] = sr
    return meta, arrays


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, metavar="FILE.npz")
    args = p.parse_args()
    meta, arrays = capture()
    np.savez_compressed(args.out, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays)
    print(f"wrote {args.out}: {len(meta)} scenes")


if __name__ == "__main__":
    main()
