import os

import numpy as np
import pytest

from sphrom.scene import derive_scene, load_scene

os.environ.setdefault("MPLBACKEND", "Agg")


def fmu_models():
    """Every registered reduced model that can be packaged as an FMU (the registry's, in its order): what a test of
    "every model's FMU" iterates over, instead of typing their names."""
    from sphrom.rom.registry import fmu_model_names
    return list(fmu_model_names())


def model_per_kind(**properties):
    """One registered model per FMU model kind (sphrom.fmu.kinds), the first of the registry's models of that kind
    whose properties equal ``properties`` (``needs_basis=True``: the models on a POD basis, which have a training
    envelope and a parametric form): what a test of "every kind" iterates over."""
    from sphrom.fmu import layout
    from sphrom.rom.registry import MODELS
    out = []
    for kind in layout.KINDS:
        names = [name for name, m in MODELS.items() if m.fmu_kind == kind.number
                 and all(getattr(m, k) == v for k, v in properties.items())]
        out += names[:1]
    return out


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
def _signals_at_their_defaults():
    """SIGINT and SIGTERM at Python's defaults for the session.  A shell starts a background job (``pytest &``
    without job control: CI runners, nohup) with SIGINT ignored, and sphrom keeps an ignored signal ignored (as it
    should), so the in-process signal tests and the children they start would test their launcher instead."""
    import signal
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    if previous[signal.SIGINT] is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if previous[signal.SIGTERM] is signal.SIG_IGN:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for sig, handler in previous.items():
        signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Every test session gets its own SPH-run cache."""
    os.environ["SPHROM_CACHE"] = str(tmp_path_factory.mktemp("sphrom-cache"))


# the order of modelDescription's elements in the FMI 2 and 3 schemas (each optional)
FMU_ELEMENT_ORDER = ["ModelExchange", "CoSimulation", "ScheduledExecution", "UnitDefinitions", "TypeDefinitions",
                     "LogCategories", "DefaultExperiment", "VendorAnnotations", "ModelVariables", "ModelStructure"]


def assert_units_through_declared_types(path):
    """Every unit of the FMU's variables comes through a declared type of <TypeDefinitions> (as in the
    Reference-FMUs; importers such as fmi-sim refuse a unit on the variable), every declared unit is defined,
    the elements are in schema order, and fmpy reads each variable's contract unit from its declared type."""
    import xml.etree.ElementTree as ET
    import zipfile

    import fmpy

    from sphrom.fmu.variables import lookup
    root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    fmi3 = root.get("fmiVersion").startswith("3")
    tags = [child.tag for child in root]
    assert tags == sorted(tags, key=FMU_ELEMENT_ORDER.index)
    units = {u.get("name") for u in root.find("UnitDefinitions")}
    types = root.find("TypeDefinitions")
    if fmi3:
        declared = {t.get("name"): t.get("unit") for t in types if t.tag == "Float64Type"}
    else:
        declared = {t.get("name"): t.find("Real").get("unit") for t in types.findall("SimpleType")}
    assert declared and set(declared.values()) <= units
    variables = root.find("ModelVariables")
    reals = list(variables.iter("Float64" if fmi3 else "Real"))
    assert len(reals) >= 5
    for element in reals:
        assert element.get("unit") is None and element.get("declaredType") in declared
    for v in fmpy.read_model_description(str(path)).modelVariables:
        row, _ = lookup(v.name)                         # the unit the variable table gives it
        unit = row.unit or None
        if v.type in ("Real", "Float64"):
            assert v.unit is None and v.declaredType.unit == unit, v.name
        else:
            assert unit is None and v.declaredType is None, v.name


def load_changed(data, change):
    """The C core's load of ``data`` (a model kind's data) packed after ``change(sections)`` edited a copy of its
    sections: the loader tests' one way to hand the core a malformed file (raises CoreError naming the problem)."""
    import copy

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.resources import pack
    from sphrom.fmu.run.core import Core
    bad = copy.deepcopy(data)
    change(bad.sections)
    return Core(ensure_binaries().core).load(pack(bad))


def mixed_steps(dt):
    """(steps, t): communication steps whole (10 ms), shortened and sub-dt (``dt`` the FMU's internal step [s]), and
    the points t = 0, cumsum(steps): the rate tests' schedule for inputs linear over each step."""
    import numpy as np
    steps = [0.01] * 8 + [2.5 * dt, 0.3 * dt, 7.3 * dt, 13.03 * dt]
    return steps, np.concatenate([[0.0], np.cumsum(steps)])


def fmu_maker(folder, default_model="frozen", k=6, probes=(0.25, 0.5, 0.66), scene_of=None, default_case="forced",
              **options):
    """make(model, fmi, case) -> (path, the model kind's data): the FMU of ``scene_of(case)`` (default
    ``fmu_scene(case)``) packaged into ``folder`` with package_fmu's ``options`` once per (model, fmi, case) and its
    resources read back."""
    import zipfile

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.package import package_fmu
    from sphrom.fmu.resources import unpack
    binaries = ensure_binaries()
    made = {}

    def make(model=default_model, fmi=2, case=default_case):
        key = (model, fmi, case)
        if key not in made:
            path = folder / f"{model}-{fmi}-{case}.fmu"
            package_fmu((scene_of or fmu_scene)(case), path, k=k, fmi=fmi, probes=probes, progress=False,
                        binaries=binaries, model=model, **options)
            made[key] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[key]

    return make


@pytest.fixture(scope="session")
def channel_port_fmu(tmp_path_factory):
    """(path, data): a frozen FMI 2 FMU of the shrunk damped_forced scene (k = 6, probes 0.25 and 0.5) with ports at
    0.3 and 0.7 and the port channel, packaged once per session (tests/test_fmu_ports_rates.py,
    tests/test_fmu_wave_rates.py)."""
    import zipfile

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.package import package_fmu
    from sphrom.fmu.resources import unpack
    path = tmp_path_factory.mktemp("channel-port-fmu") / "frozen-2.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, fmi=2, probes=(0.25, 0.5), progress=False,
                binaries=ensure_binaries(), model="frozen", ports=(0.3, 0.7))
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    assert "PCSCAL" in data.sections
    return path, data


@pytest.fixture(scope="session")
def hostile_scene(tmp_path_factory):
    """The hostile-input tests' small files, made through the command line once per session: a scene
    (damped_forced, N = 32, T = 0.2), its POD basis, a frozen FMI 2 FMU (not measured)."""
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(small_scene("damped_forced", T=0.2, n=32).text)
    return path


@pytest.fixture(scope="session")
def hostile_basis(hostile_scene, tmp_path_factory):
    from sphrom.cli import main
    out = tmp_path_factory.mktemp("basis") / "b.h5"
    assert main(["pod", str(hostile_scene), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def hostile_fmu(hostile_scene, tmp_path_factory):
    from sphrom.cli import main
    out = tmp_path_factory.mktemp("fmu") / "f.fmu"
    assert main(["fmu", str(hostile_scene), "--modes", "4", "--no-verify", "--out", str(out), "--quiet"]) == 0
    return out
