"""The binary contract written once (harness/fmu/layout.py) and the model kinds as units (harness/fmu/kinds/): the
generated files are current, the Python writer and reader follow the spec's offsets, every kind of the spec has its
Python module and its C table, and no code outside the kind modules asks a model's data class."""

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from sphrom.fmu import layout
from sphrom.fmu.kinds import by_number, kind_of, kinds, model_words
from sphrom.fmu.resources import pack, unpack

ROOT = Path(__file__).parents[1]


def test_generated_files_are_current():
    """fmu_src/rom_layout.h and docs/internals/resources.md's format are what the spec generates now."""
    assert layout.stale() == [], f"stale: {layout.stale()} (run {layout.COMMAND})"


def test_records_add_up():
    """Each record's offsets follow its fields' sizes, and pack / unpack are inverses."""
    for record in (layout.HEADER, layout.SECTION, layout.TRAILER, layout.STATE_HEADER, layout.FROZEN_HEAD):
        at = 0
        for f in record.fields:
            assert record.offset(f.name) == at
            at += layout.TYPES[f.type][1]
        assert record.size == at
    values = {"magic": b"SPHROMRS", "format_version": 4, "model_kind": 1, "k_v": 3, "k_rho": 2, "n_probes": 1,
              "flags": 3, "runaway_bound": 1e6, "L": 0.5}
    assert layout.HEADER.unpack(layout.HEADER.pack(values)) == values


@pytest.mark.parametrize("number", [k.number for k in layout.KINDS])
def test_pack_follows_the_spec(number):
    """model.bin of every kind: the shared header's fields at the spec's offsets, the kind's own header after it,
    the arrays in the spec's order, and unpack gives the same numbers back (the same bytes again)."""
    import struct
    data = by_number(number).example(np.random.default_rng(number))
    blob = pack(data)
    header = layout.HEADER.unpack(blob)
    assert header["model_kind"] == number and header["format_version"] == layout.FORMAT_VERSION
    assert struct.unpack_from("<I", blob, layout.HEADER.offset("k_v"))[0] == data.k_v
    spec = layout.KIND_BY_NUMBER[number]
    at = layout.HEADER.size + (spec.head.size if spec.head else 0)
    first = spec.body[0].name
    assert np.frombuffer(blob, "<f8", count=getattr(data, first).size, offset=at).tolist() == \
        getattr(data, first).tolist()
    back = unpack(blob)
    assert kind_of(back) is kind_of(data) and pack(back) == blob
    for array in spec.body:
        mine, theirs = getattr(data, array.name), getattr(back, array.name)
        assert (mine is None and theirs is None) or np.array_equal(mine, theirs), array.name
    if spec.head is not None:                     # the kind's own header's fields at the spec's offsets
        for f in spec.head.fields:
            stored = struct.unpack_from("<" + layout.TYPES[f.type][0], blob, layout.resource_offset(spec.name, f.name))
            assert stored[0] == spec.head.unpack(blob, layout.HEADER.size)[f.name]


@pytest.mark.parametrize("number", [k.number for k in layout.KINDS])
def test_the_core_runs_every_kind(number):
    """The C core loads each kind's example, steps it (held input) and gives finite outputs, through its kind's
    table (the same file the Python reader reads back)."""
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.core import Core
    data = by_number(number).example(np.random.default_rng(number))
    model = Core(ensure_binaries().core).load(pack(data))
    try:
        assert model.kind == number
        model.set_input(1e-3)
        for i in range(3):
            model.do_step(i * 1e-3, 1e-3)
        v, rho = model.outputs(data.n_probes)
        assert np.all(np.isfinite(v)) and np.all(np.isfinite(rho))
    finally:
        model.close()


def test_every_kind_is_one_unit():
    """Each kind of the spec has its module (with what the other code asks of a kind) and its C table; the words
    of every registry model that has an FMU kind are its kind's."""
    from sphrom.rom.registry import MODELS
    needed = ("NUMBER", "Data", "BUILD_OPTIONS", "INTERNAL_STEP", "INITIAL_STATE", "OUTPUT_DERIVATIVE_ORDER", "MODELS",
              "file_fields", "from_file", "min_k_rho", "from_operators", "resource", "parametric", "model_name",
              "integrator", "parameter_starts", "stepping", "model_rows", "usage", "example")
    sources = {p.name: p.read_text() for p in (ROOT / "fmu_src").glob("*.c")}
    for number, module in kinds().items():
        assert [name for name in needed if not hasattr(module, name)] == [], module.__name__
        assert module.NUMBER == number and module.Data.KIND == number
        spec = layout.KIND_BY_NUMBER[number]
        defined = [name for name, text in sources.items()
                   if re.search(rf"^const RomKindOps \*{spec.c_table}\(void\)", text, re.M)]
        assert len(defined) == 1, spec.c_table
    packaged = {name for name, m in MODELS.items() if m.fmu_kind is not None}
    assert set(model_words()) == packaged
    for name in packaged:
        assert name in by_number(MODELS[name].fmu_kind).MODELS


DATA_CLASSES = {"ModelData", "ExactData", "Data"}


def isinstance_on_model_data(path):
    """(line, text) of each isinstance / type test on a model kind's data class in the Python file ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) in ("isinstance", "issubclass") and \
                len(node.args) == 2:
            target = node.args[1]
            names = target.elts if isinstance(target, ast.Tuple) else [target]
            for n in names:
                name = n.attr if isinstance(n, ast.Attribute) else getattr(n, "id", None)
                if name in DATA_CLASSES:
                    found.append((node.lineno, ast.unparse(node)))
        if isinstance(node, ast.Compare) and isinstance(node.left, ast.Call) and \
                getattr(node.left.func, "id", None) == "type":
            for n in node.comparators:
                name = n.attr if isinstance(n, ast.Attribute) else getattr(n, "id", None)
                if name in DATA_CLASSES:
                    found.append((node.lineno, ast.unparse(node)))
    return found


def test_no_isinstance_on_model_data_outside_the_kinds():
    """Code asks the kind (sphrom.fmu.kinds.kind_of), never a model's data class, outside harness/fmu/kinds/."""
    kinds_folder = ROOT / "harness" / "fmu" / "kinds"
    offenders = {}
    for path in sorted([*(ROOT / "harness").rglob("*.py"), *(ROOT / "tests").rglob("*.py")]):
        if kinds_folder in path.parents:
            continue
        found = isinstance_on_model_data(path)
        if found:
            offenders[str(path.relative_to(ROOT))] = found
    assert offenders == {}


def test_the_isinstance_finder_finds_one(tmp_path):
    """The check above can fail."""
    path = tmp_path / "x.py"
    path.write_text("from m import ModelData\nif isinstance(d, (int, ModelData)):\n    pass\nok = type(d) is r.ExactData\n")
    assert [line for line, _ in isinstance_on_model_data(path)] == [2, 4]
