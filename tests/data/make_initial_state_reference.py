"""Write tests/data/initial_state_reference.npz: FMU outputs of the code before ``initial_state_scale``.

Run from the repository root::

    python3 tests/data/make_initial_state_reference.py [--code ROOT]

``--code`` names the checkout whose ``harness`` (and fmu_src/) runs (default this repository).  It was run
once with ``--code`` on the commit before the FMU parameter ``initial_state_scale`` existed (57f8748), when
every FMU started from the scene's initial state; tests/test_fmu_initial_state.py packages the stored
resources (model.bin format 3, rewritten in today's format by tests/old_formats.py: the same numbers) with
today's binaries and holds their outputs at ``initial_state_scale = 1`` bitwise equal to these, FMI 2 and 3,
frozen and exact.

Stored per model (frozen, exact): the resources/model.bin bytes of damped_forced shrunk (the FMU tests'
"forced" scene, k = 6, probes 0.25, 0.5, 0.66), the inputs f held over 60 steps of 10 ms (seeded), and the
outputs at the 61 communication points of the FMI 2 and the FMI 3 FMU.  Bitwise equality assumes the same
compiler and flags as the capture (the core's arithmetic has no fused multiply-add, rom_internal.h).
"""

import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "initial_state_reference.npz"
MODELS = ("frozen", "exact")
H, STEPS, SEED = 0.01, 60, 7


def main():
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from checkout import use_checkout
    use_checkout(__doc__.splitlines()[0])
    from conftest import fmu_scene
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.driver import FMU
    from sphrom.fmu.make.package import package_fmu

    inputs = np.random.default_rng(SEED).normal(0.0, 0.02, STEPS)
    arrays = {"inputs": inputs, "steps": np.full(STEPS, H)}
    folder = Path(tempfile.mkdtemp(prefix="sphrom-isr-"))
    for model in MODELS:
        for fmi in (2, 3):
            path = folder / f"{model}-{fmi}.fmu"
            package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, probes=(0.25, 0.5, 0.66), progress=False,
                        binaries=ensure_binaries(), model=model)
            blob = zipfile.ZipFile(path).read("resources/model.bin")
            if fmi == 2:
                arrays[f"{model}/model_bin"] = np.frombuffer(blob, dtype=np.uint8)
            else:
                assert blob == arrays[f"{model}/model_bin"].tobytes()
            with FMU(path) as s:
                s.initialize()                  # before initial_state_scale: the scene's initial state
                arrays[f"{model}/fmi{fmi}"] = s.run([H] * STEPS, inputs)
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
