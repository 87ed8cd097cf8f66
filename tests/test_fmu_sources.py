"""The C sources as a whole: one list of them (fmu_src/CMakeLists.txt, which packaging reads), no call cycle among
their files, and docs/internals/c-code.md naming every one."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from sphrom.fmu.make.build import cmake_sources, fmi_headers_dir, fmu_sources

ROOT = Path(__file__).parents[1]
SRC = ROOT / "fmu_src"


def c_files():
    """Every .c and .h file of fmu_src/ (paths relative to it)."""
    return sorted(str(p.relative_to(SRC)) for p in SRC.rglob("*") if p.suffix in (".c", ".h") and p.is_file())


def test_every_source_is_in_one_list():
    """Each file of fmu_src/ is named in CMakeLists.txt (a file added without a target fails here), the core and
    instance lists do not overlap, and an FMU's sources/ are those lists plus its adapter."""
    text = (SRC / "CMakeLists.txt").read_text()
    named = set(re.findall(r"[\w/]+\.[ch]\b", text))
    assert [f for f in c_files() if f not in named] == []
    lists = cmake_sources()
    core, instance = lists["SPHROM_CORE_SOURCES"], lists["SPHROM_INSTANCE_SOURCES"]
    assert not set(core) & set(instance) and all((SRC / name).is_file() for name in core + instance)
    assert fmu_sources(3) == [*core, *instance, "fmi3_cs.c"]


def test_c_code_page_names_every_c_file():
    """docs/internals/c-code.md describes every C file (the README says it covers them all)."""
    page = (ROOT / "docs" / "internals" / "c-code.md").read_text()
    missing = [f for f in c_files() if f"`{Path(f).name}`" not in page and f"`fmu_src/{f}`" not in page]
    assert missing == [], f"docs/internals/c-code.md does not name {missing}"


def object_symbols(tmp_path):
    """{file: (defined, undefined)} of the global symbols of each C file of the FMU (core, instance, adapters),
    each compiled on its own to an object file and read with nm."""
    cc = os.environ.get("CC", "cc")
    if not shutil.which(cc) or not shutil.which("nm"):
        pytest.skip("needs a C compiler and nm")
    out = {}
    for name in [*fmu_sources(2), "fmi3_cs.c", "sph.c"]:
        if not name.endswith(".c"):
            continue
        obj = tmp_path / (Path(name).stem + ".o")
        subprocess.run([cc, "-c", "-O1", f"-I{SRC}", f"-I{fmi_headers_dir()}", str(SRC / name), "-o", str(obj)],
                       check=True, capture_output=True)
        listing = subprocess.run(["nm", "-g", str(obj)], check=True, capture_output=True, text=True).stdout
        defined, undefined = set(), set()
        for line in listing.splitlines():
            parts = line.split()
            (undefined if parts[-2] == "U" else defined).add(parts[-1])
        out[name] = (defined, undefined)
    return out


def call_graph(symbols):
    """{file: set of files it calls}: a call by symbol (an undefined symbol another file defines), and a call through
    a model kind's table of operations (``->ops->``, rom_internal.h) to every file that defines a kind's table
    (``const RomKindOps *rom_<kind>_kind(void)``), as rom_internal.h counts them."""
    where = {sym: name for name, (defined, _) in symbols.items() for sym in defined}
    kinds = {name for name in symbols
             if re.search(r"^const RomKindOps \*rom_\w+_kind\(void\)", (SRC / name).read_text(), re.M)}
    graph = {}
    for name, (_, undefined) in symbols.items():
        calls = {where[sym] for sym in undefined if sym in where} - {name}
        if re.search(r"->ops->\w+\s*\(", (SRC / name).read_text()):
            calls |= kinds - {name}
        graph[name] = calls
    return graph


def find_cycle(graph):
    """One cycle of ``graph`` as a list of its nodes (first repeated at the end), or None."""
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_no_call_cycle_among_the_c_files(tmp_path):
    """The files of the FMU call each other without a circle (rom_internal.h draws the graph): each compiled alone,
    its undefined symbols resolved to the file that defines them, calls through a kind's table counted."""
    graph = call_graph(object_symbols(tmp_path))
    assert find_cycle(graph) is None, f"call cycle: {' -> '.join(find_cycle(graph))}"
    # the graph is the one rom_internal.h draws: the kinds and the shared numerics call no file above them
    assert graph["rom_frozen.c"] <= {"rom_bytes.c", "rom_fail.c"}
    assert graph["rom_exact.c"] <= {"rom_bytes.c", "rom_fail.c", "rom_numerics.c", "rom_port.c"}
    assert graph["rom_port.c"] <= {"rom_bytes.c", "rom_fail.c", "rom_numerics.c"}
    assert graph["rom_numerics.c"] == set()
    assert "rom_numerics.c" in graph["rom_bound.c"] and "rom_numerics.c" in graph["rom_exact.c"]


def test_the_cycle_finder_finds_a_cycle():
    """The check above can fail: a graph with a circle is found to have one."""
    assert find_cycle({"a.c": {"b.c"}, "b.c": {"c.c"}, "c.c": {"a.c"}}) == ["a.c", "b.c", "c.c", "a.c"]
    assert find_cycle({"a.c": {"b.c"}, "b.c": set()}) is None
