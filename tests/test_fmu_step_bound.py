"""The work of one doStep is bounded (fmu_src/rom.h): the internal step dt has a floor derived from the model's
own dt (parameter, serialized state) and an absolute one (resources), and one doStep takes at most the internal
steps its work cap allows at the state's k_v, k_rho, n_freeze and ports.  The C driver's scenario "bound"
(tests/test_fmu_c.py) checks every case through both FMI versions, timed and under the sanitizers; here: the
Python twin of the limits equals the C core's, and an importer (fmpy) gets the messages."""

import dataclasses
import time
import zipfile

import pytest

from conftest import fmu_scene
from sphrom.errors import FieldError
from sphrom.fmu.check import python_cosim as pc
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.core import Core, CoreError
from sphrom.fmu.run.driver import FMU as Slave
from sphrom.fmu.make.package import check_options, package_fmu


@pytest.fixture(scope="module")
def frozen_fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bound")
    binaries = ensure_binaries()
    out = {}
    for fmi in (2, 3):
        out[fmi] = folder / f"f{fmi}.fmu"
        package_fmu(fmu_scene("forced"), out[fmi], k=5, fmi=fmi, progress=False, binaries=binaries,
                    verify=False)
    return out


def test_limits_equal_the_c_core(frozen_fmus):
    """rom_step_work, rom_max_steps_per_call and the dt floor: the Python twin's numbers, at several n_freeze."""
    from sphrom.fmu.resources import unpack
    blob = zipfile.ZipFile(frozen_fmus[2]).read("resources/model.bin")
    data = unpack(blob)
    model = Core(ensure_binaries().core).load(blob)
    try:
        kv, kr = data.T.shape[2], data.T.shape[1]
        for n_freeze in (1, 3, 10, 1000):
            model.set_n_freeze(n_freeze)
            work = pc.step_work(kv, kr, n_freeze, damping=data.D is not None)
            assert model.step_work() == pytest.approx(work, rel=1e-15)
            assert model.max_steps_per_call() == pc.max_steps_per_call(kv, kr, n_freeze, damping=data.D is not None)
        floor = pc.dt_floor(data.dt)
        with pytest.raises(CoreError, match=r"parameter dt = .* s is below its floor"):
            model.set_dt(floor * 0.999)
        model.set_dt(floor)
        # at the floor, a step just above the cap is refused naming it; the largest accepted is taken
        cap = model.max_steps_per_call()
        with pytest.raises(CoreError, match=rf"above the cap of {cap:.0f} per doStep"):
            model.do_step(0.0, cap * floor * 1.01)
    finally:
        model.close()


@pytest.mark.parametrize("fmi", [2, 3])
def test_importer_gets_the_limits(frozen_fmus, fmi):
    """Through fmpy: dt below the floor in initialization mode refused at once naming dt and the floor (the
    instance usable after a reset); doStep h = 1e4 s and 1e7 s at the model's dt refused naming the cap, at once."""
    from sphrom.fmu.resources import unpack
    dt = unpack(zipfile.ZipFile(frozen_fmus[fmi]).read("resources/model.bin")).dt
    with Slave(str(frozen_fmus[fmi])) as slave:
        fmu = slave.fmu
        if fmi == 2:
            fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode(**({} if fmi == 2 else {"startTime": 0.0}))
        t0 = time.perf_counter()
        with pytest.raises(Exception):
            slave.set_real([slave.vr["dt"]], [1e-12])
        assert time.perf_counter() - t0 < 0.5
        assert any("dt = 1e-12 s is below its floor" in m and f"{pc.dt_floor(dt):g} s" in m
                   for m in slave.errors()), slave.errors()
        fmu.reset()
        slave.initialize()
        slave.do_step(0.0, 3 * dt)                     # usable after the reset
        for h in (1e4, 1e7):
            t0 = time.perf_counter()
            with pytest.raises(Exception):
                slave.do_step(slave.time(), h)
            assert time.perf_counter() - t0 < 1.0
            assert "above the cap of" in slave.errors()[-1] and "per doStep" in slave.errors()[-1]
            fmu.reset()
            slave.initialize()


def test_packaging_refuses_a_dt_below_the_absolute_floor():
    from test_scene_minimal import MINIMAL_SCENE
    from sphrom.scene import parse_scene
    scene = parse_scene(MINIMAL_SCENE, "my_bar.toml", name="my_bar")
    scene = dataclasses.replace(scene, sph=dataclasses.replace(scene.sph, dt=1e-10))     # the run is never made
    with pytest.raises(FieldError, match=r"dt = 1e-10 s is below the smallest internal step"):
        check_options(scene, k=4)
