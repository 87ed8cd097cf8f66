"""The FMU's variable table (harness/fmu/variables.py): the one declaration of every FMU variable.

The committed files generated from it are current; the value references are the contract; the table is
consistent (value-reference ranges apart, every rule, type and C function it names exists); the C instance and
the Python packaging decide which variables an FMU has alike, on packaged FMUs of every kind; the start values of
n_freeze and dt reach the modelDescription from the resources the C core reads; a linear FMU has no n_freeze and
no dt, and ``sphrom cosim --n-freeze`` on it is a one-line error; n_freeze has one range and one message, the C
core's; an output added to the table is one row (its C getter aside)."""

import dataclasses
import re
import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy.validation import validate_fmu

from conftest import fmu_scene
from sphrom.cli import main
from sphrom.errors import FieldError
from sphrom.fmu import variables
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.core import Core, CoreError
from sphrom.fmu.make.describe import model_description
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.make.archive import write_fmu
from sphrom.fmu.resources import unpack
from sphrom.rom.parametric import Range
from sphrom.rom.registry import get_model

ROOT = Path(__file__).resolve().parents[1]
K = 6

# The contract (docs/fmu/variables.md): every variable's value reference.  Deliberately typed here a second time:
# a change of the table that changes a value reference fails this test.
CONTRACT = {"time": 0, "f": 1, "n_freeze": 2, "dt": 3, "initial_state_scale": 4, "c": 5, "d": 6, "area": 7,
            "force_error_bound": 8, "initial_state_error_bound": 9, "v_probe_j": 1000, "rho_probe_j": 2000,
            "F_port_j": 3000, "v_port_j": 4000, "force_error_bound_j": 5000, "initial_state_error_bound_j": 6000,
            "error_tolerance": 10, "v_probe_j_error_bound": 7000, "rho_probe_j_error_bound": 8000,
            "v_port_j_error_bound": 9000, "port_impedance": 11, "a_port_j": 3100, "b_port_j": 4100}


def test_generated_files_are_current():
    stale = variables.stale(ROOT)
    assert not stale, (f"stale generated file(s) {', '.join(stale)}: run `{variables.COMMAND}` after changing "
                       "harness/fmu/variables.py")


def test_a_changed_table_makes_the_generated_files_stale(tmp_path, monkeypatch):
    """The staleness check sees a change of the table (here: a value reference) in every generated file."""
    for path, text in variables.generated(ROOT).items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text, encoding="utf-8")
    assert variables.stale(tmp_path) == []
    rows = tuple(dataclasses.replace(r, vr=r.vr + 10000) if r.name == "area" else r for r in variables.VARIABLES)
    monkeypatch.setattr(variables, "VARIABLES", rows)
    assert sorted(variables.stale(tmp_path)) == sorted([variables.HEADER_FILE, variables.TABLE_FILE, variables.README_FILE])
    assert variables.main(["--check"]) == 1


def test_value_references_are_the_contract():
    assert {row.display: row.vr for row in variables.VARIABLES} == CONTRACT
    assert variables.vr("v_probe_j", 3) == 1002 and variables.vr("F_port_j", 1) == 3000
    assert variables.lookup("rho_probe_12") == (variables.BY_NAME["rho_probe_j"], 12)
    assert variables.lookup("v_probe_0") == (None, None) and variables.lookup("nope") == (None, None)
    header = (ROOT / variables.HEADER_FILE).read_text()
    for row in variables.VARIABLES:
        assert re.search(rf"^#define {variables.c_macro(row)} +{row.vr}u ", header, re.M), row.name
    assert "ROM_VR_" not in (ROOT / "fmu_src" / "rom.h").read_text()       # one home: moved out of rom.h


def test_the_table_is_consistent():
    rows = variables.VARIABLES
    assert len({r.display for r in rows}) == len(rows) and len({variables.c_macro(r) for r in rows}) == len(rows)
    spans = sorted((r.vr, r.vr + variables.max_count(r.family) - 1, r.name) for r in rows)
    for (_, end, a), (start, _, b) in zip(spans, spans[1:]):
        assert end < start, f"the value references of {a} and {b} overlap"
    instance = (ROOT / "fmu_src" / "instance.c").read_text()
    core = (ROOT / "fmu_src" / "rom.h").read_text()
    defined = (set(re.findall(r"^static \w+ \*?(\w+)\(", instance, re.M))          # (the C build checks them too)
               | set(re.findall(r"^SCALAR_[GS]ETTER\(\w+, (\w+),", instance, re.M))
               | set(re.findall(r"ROM_API \w+ \*?(\w+)\(", core)))
    c_rules = set(re.findall(r"^static int rule_(\w+)\(const Instance", instance, re.M))
    assert c_rules == set(variables.RULES) - {"always"}, "every presence rule has its C predicate and no other"
    for r in rows:
        assert r.rule in variables.RULES and r.family in variables.FAMILIES
        assert r.declared_type is None or r.declared_type in variables.TYPES
        assert "{j}" in r.name if r.family else "{j}" not in r.name
        for fn in (r.get, r.set, r.get_rate, r.set_rate):
            assert not fn or fn in defined, f"{r.name}: C function {fn} is not defined"
        settable = r.causality in ("input", "parameter")
        assert bool(r.set) == settable and (r.start is not None) == settable, r.name
        assert not r.get_rate or r.causality == "output"
        assert not r.set_rate or r.causality == "input"
    for name, (quantity, unit) in variables.TYPES.items():
        assert unit in variables.UNITS, name


def probe_references(slave, f):
    """{value reference: name} of every candidate of the table (each family one member past its count) that the
    C instance answers in initialization mode."""
    md = slave.md
    answered = {}
    for row in variables.VARIABLES:
        members = range(1, f.count(row.family) + 2) if row.family else [None]
        for j in members:
            ref = row.vr + (j - 1 if j else 0)
            getter = getattr(slave.fmu, {("Float64", 2): "getReal", ("Int32", 2): "getInteger",
                                         ("Float64", 3): "getFloat64", ("Int32", 3): "getInt32"}[(row.type, slave.fmi)])
            try:
                getter([ref])
                answered[ref] = variables.concrete_name(row, j)
            except Exception:                       # unknown here: the instance is in the Error state
                slave.fmu.reset()
                enter_initialization(slave, md)
    return answered


def enter_initialization(slave, md):
    if slave.fmi == 2:
        slave.fmu.setupExperiment(startTime=0.0)
        slave.fmu.enterInitializationMode()
    else:
        slave.fmu.enterInitializationMode(startTime=0.0)


CASES = {   # (model, fmi, options): every presence rule on and off somewhere
    "frozen-ports-2": ("frozen", 2, {"ports": [0.3, 0.7], "probes": [0.5]}),     # more ports than probes
    "exact-bounds-3": ("exact", 3, {}),
    "balanced-2": ("balanced", 2, {}),
    "frozen-vary-c-3": ("frozen", 3, {"vary": [Range("c", 0.05, 0.2)]}),
    "exact-vary-d-2": ("exact", 2, {"vary": [Range("d", 5.0, 15.0)], "bounds": False}),
}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("variables")
    binaries = ensure_binaries()
    made = {}

    def make(case):
        if case not in made:
            model, fmi, options = CASES[case]
            path = folder / f"{case}.fmu"
            package_fmu(fmu_scene("forced"), path, k=K, fmi=fmi, progress=False, binaries=binaries, model=model,
                        **options)
            made[case] = path
        return made[case]

    return make


@pytest.mark.parametrize("case", list(CASES))
def test_c_and_python_decide_presence_alike(fmus, case):
    """The value references the C instance answers (from resources/model.bin, rule_<name>) are exactly those the
    modelDescription declares (from the same resources, the same rule names in Python), names included; the
    FMU passes fmpy's validation (FMI 2 and 3 schemas)."""
    path = fmus(case)
    assert validate_fmu(str(path)) == []
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    with FMU(path) as s:
        f = variables.facts(data, s.fmi)
        enter_initialization(s, s.md)
        answered = probe_references(s, f)
        declared = {v.valueReference: v.name for v in s.md.modelVariables}
    assert answered == declared
    model = CASES[case][0]
    assert ("n_freeze" in declared.values()) == ("dt" in declared.values()) == (not get_model(model).linear)


@pytest.mark.parametrize("case", ["exact-bounds-3", "frozen-vary-c-3"])
def test_build_description_names_the_model_the_fmu_holds(fmus, case):
    import xml.etree.ElementTree as ET
    build = ET.fromstring(zipfile.ZipFile(fmus(case)).read("sources/buildDescription.xml"))
    title = get_model(CASES[case][0]).title
    assert build.find("BuildConfiguration").get("description") == f"{title}, FMI 3.0 co-simulation"


def test_fmi2_indices_and_model_structure_are_derived(fmus):
    """FMI 2: each variable's index is its position; Outputs are the outputs, InitialUnknowns the outputs and the
    calculated parameters, in index order."""
    import xml.etree.ElementTree as ET
    root = ET.fromstring(zipfile.ZipFile(fmus("balanced-2")).read("modelDescription.xml"))
    names = [v.get("name") for v in root.find("ModelVariables")]
    causality = {i + 1: v.get("causality") for i, v in enumerate(root.find("ModelVariables"))}
    structure = root.find("ModelStructure")
    outputs = [int(u.get("index")) for u in structure.find("Outputs")]
    initial = [int(u.get("index")) for u in structure.find("InitialUnknowns")]
    assert outputs == [i for i, c in causality.items() if c == "output"]
    assert initial == sorted(i for i, c in causality.items() if c in ("output", "calculatedParameter"))
    assert names[:2] == ["f", "initial_state_scale"] and "force_error_bound_3" in names


def test_start_values_of_n_freeze_and_dt_come_from_the_resources(tmp_path):
    """One channel: the C core takes n_freeze and dt from resources/model.bin; the modelDescription declares the
    numbers written there (and the FMU, instantiated, reads them back)."""
    path = tmp_path / "frozen.fmu"
    package_fmu(fmu_scene("forced"), path, k=K, n_freeze=7, fmi=3, progress=False, model="frozen")
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    md = fmpy.read_model_description(str(path))
    start = {v.name: v.start for v in md.modelVariables}
    assert (int(start["n_freeze"]), float(start["dt"])) == (data.n_freeze, data.dt) == (7, data.dt)
    with FMU(path) as s:
        s.initialize()
        assert s.fmu.getInt32([variables.vr("n_freeze")]) == [7]
        assert s.get_real([variables.vr("dt")])[0] == data.dt
        assert s.get_real([variables.vr("initial_state_scale")])[0] == variables.defaults.FMU_INITIAL_STATE_SCALE


def test_cosim_n_freeze_on_a_linear_fmu_is_a_one_line_error(fmus, tmp_path, capsys):
    out = tmp_path / "out.csv"
    assert main(["cosim", str(fmus("exact-bounds-3")), "--n-freeze", "5", "--t-end", "0.05", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "--n-freeze" in err and "has no parameter n_freeze (frozen model only)" in err
    assert not out.exists()
    assert main(["cosim", str(fmus("frozen-ports-2")), "--n-freeze", "5", "--t-end", "0.05", "--out", str(out)]) == 0


def test_a_parameter_the_fmu_lacks_is_an_error_naming_it(fmus):
    """The Python driver refuses n_freeze and dt for a linear FMU instead of losing them."""
    with FMU(fmus("balanced-2")) as s:
        for name, value in (("n_freeze", 3), ("dt", 1e-3)):
            with pytest.raises(FieldError) as exc:
                s.initialize(**{name: value})
            assert str(exc.value) == f"{name}: this FMU has no parameter {name} (frozen model only)"


def test_n_freeze_has_one_range_and_one_message():
    """The C core is the authority (rom_set_n_freeze); the Python pre-check (package, cosim) accepts the same
    range and refuses in the same words; so does the command line."""
    row = variables.BY_NAME["n_freeze"]
    words = f"is out of range (allowed: {variables.allowed_words(row)})"
    core = Core(ensure_binaries().core)
    from sphrom.fmu.make.models import reduced_model
    data, _, _, _ = reduced_model(fmu_scene("forced"), K, 10, (0.5,), "euler", progress=False)
    from sphrom.fmu.resources import pack
    model = core.load(pack(data))
    for bad in (0, -3, variables.INT32_MAX + 1):
        with pytest.raises(CoreError) as c_error:
            model.set_n_freeze(bad)
        assert words in str(c_error.value)
        with pytest.raises(FieldError) as py_error:
            variables.check_parameter("n_freeze", bad)
        assert str(py_error.value) == f"n_freeze: {bad!r} {words}"
    for good in (1, variables.INT32_MAX):
        model.set_n_freeze(good)
        assert variables.check_parameter("n_freeze", good) == good
    for bad in (True, 2.0, "3"):
        with pytest.raises(FieldError):
            variables.check_parameter("n_freeze", bad)


def test_an_added_output_is_one_row(monkeypatch, tmp_path):
    """A new output row (here a per-probe one, its getter rom_v_probe standing in for its own) appears in both
    modelDescriptions with derived indices and in the model structure, in the C rows and defines, in the help
    and in the docs page's table; the FMUs validate."""
    row = variables.Variable("v_probe_{j}_extra", 9000, "Float64", "output", "continuous", "calculated", "bounds",
                             "Velocity", "an added output at probe {j}, x/L = {x} [m s^-1]", "an added output",
                             family="probe", get="rom_v_probe", min=0)
    monkeypatch.setattr(variables, "VARIABLES", variables.VARIABLES + (row,))
    monkeypatch.setattr(variables, "BY_NAME", {**variables.BY_NAME, row.display: row})
    header = variables.c_header()
    assert "#define ROM_VR_V_PROBE_EXTRA                    9000u" in header
    assert '.name = "v_probe_", .name_tail = "_extra", .vr = ROM_VR_V_PROBE_EXTRA' in header
    assert "v_probe_j_extra [9000+j-1] output" in variables.help_text()
    assert "| `v_probe_j_extra` [9000+j-1] |" in variables.table_markdown()
    scene = fmu_scene("forced")
    path = tmp_path / "exact.fmu"
    package_fmu(scene, path, k=K, fmi=2, progress=False, model="exact")
    blob = zipfile.ZipFile(path).read("resources/model.bin")
    data = unpack(blob)
    for fmi in (2, 3):
        text = model_description(fmi, token=data.token, scene=scene, data=data, k_requested=K, step_size=0.01,
                                 stop_time=scene.T, input_error=float("nan"), model="exact")
        out = tmp_path / f"added-{fmi}.fmu"
        write_fmu(out, fmi=fmi, blob=blob, description=text, binary=getattr(ensure_binaries(), f"fmi{fmi}"))
        assert validate_fmu(str(out)) == []
        md = fmpy.read_model_description(str(out))
        added = [v for v in md.modelVariables if v.name.endswith("_extra")]
        assert [(v.name, v.valueReference) for v in added] == [(f"v_probe_{j}_extra", 9000 + j - 1)
                                                               for j in (1, 2, 3)]
        assert [u.variable.name for u in md.outputs][-3:] == [v.name for v in added]
        assert [u.variable.name for u in md.initialUnknowns][-3:] == [v.name for v in added]
