"""The packages of harness/ import one way: no two packages import each other (tests/data/package_deps.py reads
every import statement, also those inside functions, from the AST; ``python3 tests/data/package_deps.py`` prints
the pairs with the imports on each side)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "data"))
from package_deps import dependencies, two_way  # noqa: E402


def test_no_two_way_package_dependency():
    assert two_way(dependencies(ROOT)) == []


def test_the_check_sees_a_two_way_dependency(tmp_path):
    """The check is not blind: two packages that import each other (one of them inside a function) are found."""
    for name, other in (("a", "b"), ("b", "a")):
        folder = tmp_path / "harness" / name
        folder.mkdir(parents=True)
        (folder / "__init__.py").write_text("")
        (folder / "m.py").write_text(f"def f():\n    from ..{other} import m\n    return m\n")
    assert two_way(dependencies(tmp_path)) == [("sphrom.a", "sphrom.b")]
