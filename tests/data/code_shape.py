"""Shape figures of the harness' Python: the longest functions, the imports inside functions, the two-way packages.

``python3 tests/data/code_shape.py [CHECKOUT] [--top N]`` prints the N (default 15) longest functions and methods of
harness/ (lines from ``def`` to the last line of the body, decorators left out), the number of import statements
that sit inside a function (``import x`` / ``from x import y`` below a ``def``; each statement counts once), the
number of import statements in all, and the two-way package dependencies (:mod:`package_deps`).  The figures of
issue 31's closing note come from here.
"""

import argparse
import ast
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from package_deps import dependencies, two_way  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def functions(harness):
    """[(lines, "path:line name")] of every function and method under ``harness``."""
    out = []
    for path in sorted(Path(harness).rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                out.append((lines, f"{path.relative_to(harness.parent)}:{node.lineno} {node.name}"))
    return out


def imports(harness):
    """(inside functions, in all): the import statements under ``harness``."""
    inside = total = 0
    for path in Path(harness).rglob("*.py"):
        tree = ast.parse(path.read_text())
        nested = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                nested |= {id(n) for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))}
        every = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
        total += len(every)
        inside += sum(id(n) in nested for n in every)
    return inside, total


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout", nargs="?", default=str(ROOT))
    parser.add_argument("--top", type=int, default=15)
    args = parser.parse_args(argv)
    harness = Path(args.checkout) / "harness"
    print(f"{args.top} longest functions (lines):")
    for lines, name in sorted(functions(harness), reverse=True)[:args.top]:
        print(f"  {lines:4d}  {name}")
    inside, total = imports(harness)
    print(f"import statements inside functions: {inside} of {total}")
    print(f"two-way package dependencies: {len(two_way(dependencies(args.checkout)))}")


if __name__ == "__main__":
    main()
