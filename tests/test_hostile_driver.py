"""The C test driver on the resources of port and parametric FMUs.

Its state-parameter scenario assumed a model without c, d or ports: the parameter block read at a fixed offset
from the end (ports follow it), c and d expected 0 (a parametric model starts at its start values), every
parameter refused as "no parameter c" (a parametric one is outside its trained range, or fixed); a state
accepted where a refusal was expected leaked.  Every scenario now passes on these resources, release and
the state scenario also under AddressSanitizer (leaks included).
"""

import os
import subprocess
import zipfile

import pytest

from conftest import small_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.package import package_fmu
from sphrom.rom.parametric import parse_vary

SCENARIOS = ["basic", "state", "bad", "resources", "cycles", "threads", "edge", "bound"]
CASES = {"ports-exact": dict(model="exact", ports=[0.3, 0.7]), "ports-frozen": dict(model="frozen", ports=[0.3]),
         "parametric-frozen": dict(model="frozen", vary=["c=0.05:0.2"]),
         "parametric-exact": dict(model="exact", vary=["d=5:15", "c=0.05:0.2"])}


@pytest.fixture(scope="module")
def resources(tmp_path_factory):
    folder = tmp_path_factory.mktemp("driver-resources")
    binaries = ensure_binaries()
    scene = small_scene("damped_forced", T=0.5, n=32)
    out = {}
    for case, options in CASES.items():
        options = dict(options)
        options["vary"] = [parse_vary(text) for text in options.get("vary", [])]
        fmu = folder / f"{case}.fmu"
        package_fmu(scene, fmu, k=6, fmi=2, progress=False, binaries=binaries, **options)
        out[case] = folder / case
        out[case].mkdir()
        (out[case] / "model.bin").write_bytes(zipfile.ZipFile(fmu).read("resources/model.bin"))
    return out


def run_driver(driver, resources, scratch, env=None, scenarios=SCENARIOS):
    scratch.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run([str(driver), str(resources), str(scratch), *scenarios], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=300)
    return proc.returncode, proc.stdout + proc.stderr


@pytest.mark.parametrize("case", sorted(CASES))
def test_driver_on_port_and_parametric_resources(resources, tmp_path, case):
    rc, output = run_driver(ensure_binaries().driver, resources[case], tmp_path / "scratch")
    assert rc == 0, output
    for name in SCENARIOS:
        assert f"scenario {name}: ok" in output, output


def test_driver_state_scenario_leaks_nothing(resources, tmp_path):
    from test_fmu_c import sanitizers_available
    if not sanitizers_available(tmp_path):
        pytest.skip("the C compiler cannot build and run -fsanitize=address,undefined programs")
    san = ensure_binaries(sanitize=True)
    env = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:halt_on_error=1",
           "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1"}
    for case in sorted(CASES):
        rc, output = run_driver(san.driver, resources[case], tmp_path / f"scratch-{case}", env=env,
                                scenarios=["state"])
        assert rc == 0 and "scenario state: ok" in output, output
        assert "LeakSanitizer" not in output and "AddressSanitizer" not in output and "runtime error" not in output
