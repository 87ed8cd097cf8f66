"""Write tests/data/state_v2_reference.npz: serialized FMU states of state format version 2.

Run from the repository root::

    python3 tests/data/make_state_v2_reference.py [--code ROOT]

``--code`` names the checkout whose ``harness`` (and fmu_src/) runs (default this repository).  It was run once
with ``--code`` on main at fe3c0da, the last code writing state format 2 (magic, header, the kind's blocks,
initial_state_scale, ports' block; no c and d; its model.bin format 3).  Since model.bin format 4 (the frozen
kind's numbers in its own header) such a state can never be restored: tests/test_fmu_state_params.py packages the
stored resources, rewritten in today's format (tests/old_formats.py: the same numbers, another token), and checks
that these blobs are refused naming their version and why (their token is not the FMU's).

Stored per case (parametric frozen and exact: damped_forced shrunk, k = 6, probes 0.25, 0.5, 0.66, c in
[0.05, 0.2], d in [5, 15]; a frozen FMU with a port at 0.3, F_port_1 = 0.05 N): the model.bin bytes, the parameters set before
initialization (c, d at a held-out point, or area), the inputs f held over 40 steps of 10 ms (seeded), the
serialized state after the first 20 steps (FMI 2; the FMI 3 FMU's blob is checked equal) and the outputs at the
21 communication points of the last 20 steps, after restoring it in the same instance.
"""

import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "state_v2_reference.npz"
H, STEPS, SPLIT, SEED = 0.01, 40, 20, 11
VR_C, VR_D, VR_AREA, VR_F_PORT = 5, 6, 7, 3000
F_PORT = 0.05     # [N] at the port, with the area 2.5 m^2
CASES = {"frozen": dict(model="frozen", vary="cd", values={VR_C: 0.13, VR_D: 7.5}),
         "exact": dict(model="exact", vary="cd", values={VR_C: 0.13, VR_D: 7.5}),
         "ports": dict(model="frozen", vary="", values={VR_AREA: 2.5})}


def main():
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from checkout import use_checkout
    use_checkout(__doc__.splitlines()[0])
    from conftest import fmu_scene
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.driver import FMU
    from sphrom.fmu.make.package import package_fmu
    from sphrom.rom import parametric as par

    inputs = np.random.default_rng(SEED).normal(0.0, 0.02, STEPS)
    arrays = {"inputs": inputs, "steps": np.full(STEPS, H), "split": np.array(SPLIT)}
    folder = Path(tempfile.mkdtemp(prefix="sphrom-sv2-"))
    for case, spec in CASES.items():
        vary = [par.Range("c", 0.05, 0.2), par.Range("d", 5.0, 15.0)] if spec["vary"] else ()
        ports = (0.3,) if case == "ports" else None
        blobs = {}
        for fmi in (2, 3):
            path = folder / f"{case}-{fmi}.fmu"
            package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, probes=(0.25, 0.5, 0.66), progress=False,
                        binaries=ensure_binaries(), model=spec["model"], vary=vary, ports=ports, bounds=False)
            model_bin = zipfile.ZipFile(path).read("resources/model.bin")
            if fmi == 2:
                arrays[f"{case}/model_bin"] = np.frombuffer(model_bin, dtype=np.uint8)
            else:
                assert model_bin == arrays[f"{case}/model_bin"].tobytes()
            with FMU(path) as s:
                vrs = sorted(spec["values"])
                s.set_real(vrs, [spec["values"][vr] for vr in vrs])
                s.initialize(initial_state_scale=1)
                if case == "ports":
                    s.set_real([VR_F_PORT], [F_PORT])     # held; in the state
                s.run([H] * SPLIT, inputs[:SPLIT])
                state = s.get_state()
                blobs[fmi] = s.serialize(state)
                s.free_state(state)
                s.set_state(s.deserialize(blobs[fmi]))
                after = s.run([H] * (STEPS - SPLIT), inputs[SPLIT:], t0=SPLIT * H)
            if fmi == 2:
                arrays[f"{case}/outputs"] = after
                arrays[f"{case}/vrs"] = np.array(vrs)
                arrays[f"{case}/values"] = np.array([spec["values"][vr] for vr in vrs])
            else:
                assert np.array_equal(after, arrays[f"{case}/outputs"])
        assert blobs[2] == blobs[3], case
        assert int.from_bytes(blobs[2][8:12], "little") == 2, "not a version 2 state"
        arrays[f"{case}/state"] = np.frombuffer(blobs[2], dtype=np.uint8)
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
