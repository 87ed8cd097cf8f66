"""Every measurement program is reachable through one entry point, ``sphrom bench NAME`` (``--list``), without
ambiguity against the whole report's ``sphrom bench [SCENE ...]``, and its module stays ``python -m``-able."""

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

from sphrom.bench import PROGRAMS, list_lines
from sphrom.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_program_names_are_no_scene_names():
    """The first word of ``sphrom bench WORD`` decides: a program's name is never a built-in scene's."""
    from sphrom.scene import builtin_names
    assert not set(PROGRAMS) & set(builtin_names())


def test_list_has_one_line_per_program(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out == list_lines() and len(out) == len(PROGRAMS)
    for name, line in zip(PROGRAMS, out):
        assert line.startswith(name + " ") and "; takes " in line and "; writes " in line


@pytest.mark.parametrize("name", sorted(n for n, p in PROGRAMS.items() if not p.target.startswith("command:")))
def test_program_modules_have_main(name):
    module = importlib.import_module(PROGRAMS[name].target)
    assert callable(module.main)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_help_and_bad_option_through_sphrom_bench(name, capsys):
    """``sphrom bench NAME --help`` is the program's own help (exit 0); a bad option is one line, exit 2."""
    assert main(["bench", name, "--help"]) == 0
    assert "usage: sphrom " in capsys.readouterr().out
    assert main(["bench", name, "--no-such-option"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--no-such-option" in err[0]


def test_python_m_alias_still_runs():
    """``python -m sphrom.bench.NAME`` (named by the docs and BENCHMARKS.md) is the same program."""
    done = subprocess.run([sys.executable, "-m", "sphrom.bench.port_rates", "--help"], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0 and "python -m sphrom.bench.port_rates" in done.stdout


def test_scenes_still_go_to_the_whole_report(capsys):
    """``sphrom bench SCENE ...`` (no program name first) is the report's command: a bad scene is its error."""
    assert main(["bench", "no_such_scene", "--replot", "--out", "/nonexistent-sphrom"]) == 2
    assert "sphrom bench" in capsys.readouterr().err


def _imports(path):
    """The sphrom modules a file imports (relative imports resolved)."""
    import ast
    mod = ".".join(("sphrom", *path.relative_to(ROOT / "harness").with_suffix("").parts))
    package = mod.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            out |= {base} | {f"{base}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return {m for m in out if m.startswith("sphrom")}


def test_programs_apart_from_the_library():
    """The validation report and the library import no measurement program; a program imports no other program
    (what programs share lives in sphrom.measure)."""
    programs = {p.target for p in PROGRAMS.values() if not p.target.startswith("command:")}
    for folder in ("harness/report", "harness/measure", "harness/fmu", "harness/rom", "harness/sph", "harness/pod"):
        for path in (ROOT / folder).rglob("*.py"):
            bad = {m for m in _imports(path) if m.startswith("sphrom.bench") and not m.startswith("sphrom.bench.lib")}
            assert not bad, (path, bad)
    for path in (ROOT / "harness/bench").glob("*.py"):
        me = ".".join(("sphrom", *path.relative_to(ROOT / "harness").with_suffix("").parts))
        bad = {m for m in _imports(path) if m in programs and m != me}
        assert not bad, (path, bad)
