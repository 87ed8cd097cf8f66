import os

import numpy as np
import pytest

from harness.scene import derive_scene, load_scene

os.environ.setdefault("MPLBACKEND", "Agg")


def small_scene(base="multimode", T=0.5, n=32, dt=None, integrator="euler", every=None, **fields):
    """A built-in scene shrunk for tests: N particles, horizon T."""
    changes = {"domain": {"T": T}, "sph": {"n_particles": n, "integrator": integrator}}
    snaps = load_scene(base).snapshots
    if "window" in snaps and snaps["window"][1] > T:          # keep the snapshots inside the run
        changes["snapshots"] = {"count": min(snaps["count"], 20), "window": [0.0, T]}
    if dt is not None:
        changes["sph"]["dt"] = dt
    if every is not None:
        changes["sph"]["every"] = every
    if fields:
        changes["fields"] = {k: v for k, v in fields.items() if k in ("rho0", "v0", "c", "d")}
        force = {k: v for k, v in fields.items() if k in ("f", "profile")}
        if force:
            changes["force"] = force
    return derive_scene(load_scene(base), changes)


def fmu_scene(case):
    """The FMU tests' scenes. forced: damped_forced shrunk (d = 10, three-tone force); unforced: multimode shrunk
    (d = f = 0)."""
    if case == "forced":
        return small_scene("damped_forced", T=0.5, n=32)
    return small_scene("multimode", T=0.5, n=32)


@pytest.fixture
def tmp_out(tmp_path):
    return tmp_path


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Every test session gets its own SPH-run cache."""
    os.environ["SPHROM_CACHE"] = str(tmp_path_factory.mktemp("sphrom-cache"))
