"""The prose of the tree: comments, help and documents state claims rather than cite issue numbers."""

import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

ISSUE = re.compile(r"\bissues? (#?\d|#)|\(#\d", re.IGNORECASE)


def _prose_files():
    for folder, patterns in [("harness", ["**/*.py"]), ("fmu_src", ["**/*.c", "**/*.h", "**/*.txt"]),
                             ("tests", ["*.py"]), ("modelDescription", ["*"]), ("validation", ["**/*.md"]),
                             ("docs", ["**/*.md"])]:
        for pattern in patterns:
            yield from (p for p in (ROOT / folder).glob(pattern) if p.is_file())
    yield from (ROOT / name for name in ("README.md", "BENCHMARKS.md") if (ROOT / name).exists())


def test_no_text_cites_an_issue_number_instead_of_the_claim():
    examples = ["target (iss" + "ue 5)", "see (" + "#12)", "Iss" + "ues 4 and 7"]      # split: this file is scanned
    assert all(ISSUE.search(text) for text in examples)
    cited = [(str(p.relative_to(ROOT)), n) for p in _prose_files()
             for n, line in enumerate(p.read_text(errors="replace").splitlines(), 1) if ISSUE.search(line)]
    assert not cited, cited


def _section(text, title):
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else None]


def test_the_code_map_names_paths_that_exist():
    code_map = _section((ROOT / "README.md").read_text(), "Code map")
    paths = [p for p in re.findall(r"`([^`\s]+)`", code_map) if "/" in p or p.endswith(".md")]
    assert len(paths) > 30, paths                       # the map is there and names its modules
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, missing


def test_every_harness_path_in_the_readme_and_the_docs_exists():
    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]
    paths = {(t.name, p) for t in texts
             for p in re.findall(r"(?<![\w/.(])((?:harness|fmu_src|validation|tests)/[\w./-]*[\w/])", t.read_text())}
    missing = sorted((name, p) for name, p in paths if "*" not in p and not (ROOT / p).exists())
    assert len(paths) > 100 and not missing, missing


ROLE = re.compile(r":(mod|func|class|meth|data|attr|exc):`~?([^`<>]+?)`")


def _resolves(target):
    """Whether a dotted name of sphrom (a module, then attributes) exists."""
    bits = target.split(".")
    for i in range(len(bits), 0, -1):
        try:
            obj = importlib.import_module(".".join(bits[:i]))
        except ImportError:
            continue
        for name in bits[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def test_every_cross_reference_in_a_docstring_resolves():
    """Every :mod:/:func:/:class:/... reference to sphrom in the code's docstrings names something that exists,
    relative ones (``:mod:`.verify```) resolved against the module's package as Sphinx would."""
    bad = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        parts = ["sphrom", *path.relative_to(ROOT / "harness").with_suffix("").parts]
        package = parts[:-1] if parts[-1] == "__init__" else parts[:-1]
        text = path.read_text()
        for m in ROLE.finditer(text):
            target = m.group(2).strip()
            if target.startswith("."):
                level = len(target) - len(target.lstrip("."))
                base = package[:len(package) - level + 1]
                target = ".".join(base + ([target.lstrip(".")] if target.lstrip(".") else []))
            if target.split(".")[0] == "sphrom" and not _resolves(target):
                bad.append(f"{path.relative_to(ROOT)}:{text[:m.start()].count(chr(10)) + 1}: {m.group(0)}")
    assert not bad, bad
