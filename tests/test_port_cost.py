"""The cost bench's arithmetic and its native driver (harness/bench/port_cost.py, fmu_src/tests/step_cost.c): the
linear models' default block form steps at O(k) multiply-adds where the dense form takes O(k²); the port channel's
share is planes x ports, whatever N; the driver's calibration and a run of a small port FMU answer.  No timing is
asserted (the ratios are measured by ``sphrom bench port_cost``, BENCHMARKS.md)."""

import json
import math
import subprocess
import zipfile

import numpy as np
import pytest

from conftest import small_scene
from sphrom.bench.port_cost import block_sizes, multiply_adds, trig_calls
from sphrom.fmu.kinds.linear import resource
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.sph.solver import build_problem

PROBES = [0.25, 0.5]


def linear(scene, problem, k, blocks, model="exact", ports=()):
    data, _, _ = resource(scene, model, k, 1, PROBES, None, False, problem, bounds=False, ports=ports,
                          build_options={"blocks": blocks}, error_bounds=False)
    return data


@pytest.mark.parametrize("base", ["multimode", "damped_forced"])
def test_block_form_is_the_default_and_its_step_is_linear_in_k(base):
    """Undamped (rotations) and damped: the packaged default is the block form (1 x 1 and 2 x 2 blocks covering the
    state); its model multiply-adds grow linearly with k (k = 3 -> 6: at most 2.2x, at most 8 per state and input),
    the dense form's quadratically (at least 3x); the block form of an undamped one steps its rotations (no sincos
    per step)."""
    scene = small_scene(base, T=0.5, n=40)
    problem = build_problem(scene)
    block, dense = {}, {}
    for k in (3, 6):
        data = linear(scene, problem, k, True)
        assert data.blocks
        sizes = block_sizes(data.A)
        assert set(sizes.tolist()) <= {1, 2} and sizes.sum() == data.k
        assert trig_calls(data) == 0             # an undamped one steps its rotations: no sincos per step
        block[k] = multiply_adds(data)["model"]
        inputs = 1 + (1 if data.B is not None else 0)
        assert block[k] <= 8 * data.k * inputs
        dense[k] = multiply_adds(linear(scene, problem, k, False))["model"]
        assert dense[k] >= data.k ** 2
    assert block[6] <= 2.2 * block[3]
    assert dense[6] >= 3.0 * dense[3]


def test_port_channel_share_is_planes_times_rows_whatever_the_model():
    """The channel's multiply-adds are the same on the frozen and the exact model of one scene (its planes and
    rows, not the model's), and the port FMU adds them to the portless model's own, unchanged."""
    scene = small_scene("damped_forced", T=0.5, n=40)
    problem = build_problem(scene)
    plain = multiply_adds(linear(scene, problem, 4, True))
    ported = multiply_adds(linear(scene, problem, 4, True, ports=(0.3, 0.7)))
    assert plain["channel"] == 0 and ported["channel"] > 0
    assert ported["model"] == plain["model"]                 # the channel takes the port forces, not the model
    assert ported["total"] == pytest.approx(sum(ported[p] for p in ("model", "channel", "shadow", "outputs")))


def test_native_driver_calibrates_and_runs_a_port_fmu(tmp_path):
    """``sphrom_step_cost --calibrate`` gives a positive ns per multiply-add; a run of a small two-port FMU gives
    positive CPU times and finite outputs, the same in its floor run's count of outputs."""
    binaries = ensure_binaries(quiet=True)
    driver = binaries.folder / "sphrom_step_cost"
    if not driver.exists():
        pytest.skip("the native master is built on POSIX only")
    cal = json.loads(subprocess.run([str(driver), "--calibrate", "--repeats", "1"], capture_output=True, text=True,
                                    check=True).stdout)
    assert math.isfinite(cal["ns_per_madd"]) and cal["ns_per_madd"] > 0
    path = tmp_path / "ports.fmu"
    package_fmu(small_scene("damped_forced", T=0.5, n=40), path, k=4, fmi=2, probes=PROBES, progress=False,
                binaries=binaries, model="exact", ports=(0.3, 0.7), bounds=False)
    folder = tmp_path / "ports"
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    assert unpack(zipfile.ZipFile(path).read("resources/model.bin")).blocks
    runs = []
    for extra in ([], ["--floor"]):
        done = subprocess.run([str(driver), str(folder), "--probes", "2", "--ports", "2", "--steps", "200",
                               "--repeats", "1", *extra], capture_output=True, text=True, check=True)
        runs.append(json.loads(done.stdout))
    for r in runs:
        assert r["ns_per_step_cpu"] > 0 and r["outputs"] == 2 * 2 + 2
        assert all(math.isfinite(x) for x in r["last"])
