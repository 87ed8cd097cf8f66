"""Package dependencies of sphrom from its import statements (every one, also those inside functions).

A package is a folder of harness/ (``sphrom.fmu.make`` is harness/fmu/make/); a module's package is its folder, a
package's ``__init__`` belongs to that package.  ``python tests/data/package_deps.py [CHECKOUT]`` prints every
two-way dependency with the imports on each side; :func:`two_way` is what tests/test_bench_programs.py checks.
The loose modules of harness/ itself (the package ``sphrom``: errors, scene, runio, ...) sit under every package
and are left out of the pairs.
"""

import ast
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _modules(harness):
    """{module name: path} of every .py file under ``harness``."""
    out = {}
    for path in harness.rglob("*.py"):
        parts = path.relative_to(harness).with_suffix("").parts
        out[".".join(("sphrom", *(parts[:-1] if parts[-1] == "__init__" else parts)))] = path
    return out


def _package(module, path):
    return module if path.name == "__init__.py" else module.rsplit(".", 1)[0]


def imports(path, module):
    """The sphrom names imported by the file ``path`` of module ``module`` (relative imports resolved)."""
    here = _package(module, path).split(".")
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(here[:len(here) - node.level + 1] + ([base] if base else []))
            out |= {f"{base}.{a.name}" for a in node.names} | {base}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return {m for m in out if m == "sphrom" or m.startswith("sphrom.")}


def dependencies(checkout=ROOT):
    """{package: {other package: [(importing module, imported module), ...]}} over ``checkout``/harness."""
    modules = _modules(Path(checkout) / "harness")
    deps = defaultdict(lambda: defaultdict(list))
    for module, path in modules.items():
        source = _package(module, path)
        for name in imports(path, module):
            while name not in modules and "." in name:       # a name imported from a module: that module
                name = name.rsplit(".", 1)[0]
            target = _package(name, modules[name])
            if target != source:
                deps[source][target].append((module, name))
    return deps


def two_way(deps, packages=None):
    """The pairs (a, b), a < b, of packages that import each other, the top package ``sphrom`` left out;
    ``packages``: only the pairs with one of these."""
    pairs = set()
    for a, targets in deps.items():
        for b in targets:
            if "sphrom" in (a, b) or a >= b or a not in deps.get(b, {}):
                continue
            if packages is None or a in packages or b in packages:
                pairs.add((a, b))
    return sorted(pairs)


if __name__ == "__main__":
    deps = dependencies(sys.argv[1] if len(sys.argv) > 1 else ROOT)
    pairs = two_way(deps)
    for a, b in pairs:
        print(f"{a} <-> {b}")
        for x, y in ((a, b), (b, a)):
            for module, name in sorted(set(deps[x][y])):
                print(f"    {module} -> {name}")
    print(f"{len(pairs)} two-way package dependencies")
