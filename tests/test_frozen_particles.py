"""The frozen model's particle refresh (fmu_src/rom_frozen.c refresh_particles, sections PART*).

Where the refresh tensor costs more than the particles (a large basis: here a port model with its ports in the
basis, the build option ``port_channel=False``; the port channel leaves the model portless), packaging stores U^rho,
G U^v and 1/ρ0 and the core refreshes M from them.  Checked: the choice (particles for a port model on a small
scene, the tensor for k = 12 on N = 400); the FMU's core against the Python frozen model with
``refresh="direct"`` bit for bit; the particle path against the tensor path on the same model: other bits, the
difference measured and bounded; the loader's refusals of incomplete or wrong sections.
"""

import zipfile

import numpy as np
import pytest

from conftest import fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.models import particle_sections, reduced_model
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import pack, unpack
from sphrom.fmu.run.core import Core, CoreError
from sphrom.rom.registry import get_model
from sphrom.scene import load_scene
from sphrom.sph.solver import build_problem

PORTS = (0.3, 0.7)
BASIS_PORTS = {"port_channel": False}    # the ports in the basis (its large k: the particle refresh)


@pytest.fixture(scope="module")
def port_model(tmp_path_factory):
    """(model.bin bytes, its ModelData) of the small forced scene's frozen FMU with two ports (k = 6)."""
    path = tmp_path_factory.mktemp("particles") / "ports.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, progress=False, ports=list(PORTS), bounds=False,
                error_bounds=False, build_options=BASIS_PORTS)
    blob = zipfile.ZipFile(path).read("resources/model.bin")
    return blob, unpack(blob)


def test_packaging_chooses_the_particles_where_they_cost_less(port_model):
    _, data = port_model
    assert {"PARTUR", "PARTGUV", "PARTIR0"} <= set(data.sections) and data.T is None
    scene = load_scene("tenmode")
    data12, ops, problem, _ = reduced_model(scene, 12, 10, [0.5], "euler", progress=False)
    assert particle_sections(ops, problem) == {}                    # k = 12, N = 400: the tensor


def test_the_core_equals_the_python_direct_refresh_bitwise(port_model):
    """The core's particle refresh sums in refresh_direct_path's order: 2000 internal steps (n_freeze 1 and 7)
    from the scene's initial state give the Python model's (refresh="direct") reduced state bit for bit."""
    from sphrom.fmu.check.python_cosim import FrozenCosim
    blob, data = port_model
    core = Core(ensure_binaries().core)
    for n_freeze in (1, 7):
        model = core.load(blob)
        try:
            assert model.refresh["path"] == "particles"
            model.set_n_freeze(n_freeze)
            model.advance(2000)
            ref = FrozenCosim(data, n_freeze=n_freeze)
            ref.do_step(2000 * data.dt, 0.0)
            v, rho = ref.outputs()
            got = model.outputs(data.n_probes)
            np.testing.assert_array_equal(got[0], v)
            np.testing.assert_array_equal(got[1], rho)
        finally:
            model.close()


def test_particles_against_the_tensor_path(port_model):
    """The same model packed with its refresh tensor (and without the particle sections): other bits (another
    order of the sums), the same run to 1e-12 of the outputs' swing over 20 000 internal steps."""
    from sphrom import defaults
    blob, data = port_model
    with_tensor, *_ = reduced_model(fmu_scene("forced"), 6, data.n_freeze, defaults.PROBES, data.integrator,
                                    progress=False, ports=PORTS, tensor="always", build_options=BASIS_PORTS)
    assert with_tensor.T is not None and "PARTUR" not in with_tensor.sections
    core = Core(ensure_binaries().core)
    runs = {}
    for path, bytes_ in (("particles", blob), ("tensor", pack(with_tensor))):
        model = core.load(bytes_)
        try:
            # the tensor model refreshes from the tensor or its symmetric storage (chosen at load by measured
            # cost: the same bits either way)
            assert model.refresh["path"] in ({"particles"} if path == "particles" else {"tensor", "symmetric"})
            rows = []
            for _ in range(20):
                model.advance(1000)
                rows.append(np.concatenate(model.outputs(data.n_probes)))
            runs[path] = np.array(rows)
        finally:
            model.close()
    P = data.n_probes
    for part in (slice(0, P), slice(P, 2 * P)):                      # v, then rho
        diff = np.max(np.abs(runs["particles"][:, part] - runs["tensor"][:, part]))
        swing = np.ptp(runs["tensor"][:, part])
        assert diff <= 1e-12 * swing, (diff, swing)
    assert not np.array_equal(runs["particles"], runs["tensor"])


def test_the_fmu_carries_no_tensor_where_the_particles_replace_it(port_model):
    """n_pairs = 0 in the header, no tensor bytes: the file is smaller than the tensor alone would be; the core
    refuses the tensor paths on it, naming why; packing a model without the tensor and without the particles
    is refused."""
    import copy
    blob, data = port_model
    assert data.T is None
    n_pairs = data.k_rho * (data.k_rho + 1) // 2
    assert len(blob) < 8 * n_pairs * data.k_rho * data.k_v
    model = Core(ensure_binaries().core).load(blob)
    try:
        with pytest.raises(CoreError, match="no tensor"):
            model.set_refresh(path="tensor")
    finally:
        model.close()
    bare = copy.deepcopy(data)
    for tag in ("PARTUR", "PARTGUV", "PARTIR0"):
        bare.sections.pop(tag)
    with pytest.raises(ValueError, match="particle sections"):
        pack(bare)


@pytest.mark.parametrize("change, words", [
    (lambda s: s.pop("PARTGUV"), "come together"),
    (lambda s: s.__setitem__("PARTIR0", -s["PARTIR0"]), "1/rho0 is > 0"),
    (lambda s: s.__setitem__("PARTUR", s["PARTUR"][:-1]), "PARTUR"),
])
def test_the_loader_refuses_wrong_particle_sections(port_model, change, words):
    from conftest import load_changed
    with pytest.raises(CoreError, match=words):
        load_changed(port_model[1], change)


def test_the_python_models_paths_agree():
    """The registry's frozen model, refresh "direct" and "tensor", on the port model: the same run to 1e-12."""
    scene = fmu_scene("forced")
    problem = build_problem(scene)
    data, ops, problem, _ = reduced_model(scene, 6, 10, [0.5], "euler", progress=False, problem=problem,
                                          ports=PORTS, tensor="always", build_options=BASIS_PORTS)
    spec = get_model("frozen")
    z = {r: spec.run(ops, problem, dt=scene.sph.dt, n_steps=2000, every=100,
                     options=spec.options(refresh=r)).z for r in ("direct", "tensor")}
    assert np.max(np.abs(z["direct"] - z["tensor"])) <= 1e-12 * np.max(np.abs(z["tensor"]))
