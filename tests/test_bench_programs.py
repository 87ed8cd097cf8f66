"""Every measurement program is reachable through one entry point, ``sphrom bench NAME`` (``--list``), without
ambiguity against the whole report's ``sphrom bench [SCENE ...]``, and its module stays ``python -m``-able; the
commands it once was are aliases that say so; measurement lives in one package (the programs and their library,
sphrom.bench and sphrom.bench.lib) with no loop among the packages around it."""

import ast
import contextlib
import importlib
import io
import json
import subprocess
import sys
from pathlib import Path

import pytest

from sphrom.bench import ALIASES, COMMANDS, PROGRAMS, list_lines, program_of
from sphrom.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "data"))
from package_deps import dependencies, imports, two_way  # noqa: E402

NAMES = sorted([*PROGRAMS, *ALIASES])
# what a program's --help must not load: the compiled and slow imports (numpy is the command line's own)
SLOW = ("numba", "scipy", "matplotlib", "dask", "distributed", "fmpy", "skfem", "pde", "sphrom.rom.registry",
        "sphrom.sph.solver")


def test_program_names_are_no_scene_names():
    """The first word of ``sphrom bench WORD`` decides: a program's name (or an alias) is never a built-in scene's."""
    from sphrom.scene import builtin_names
    assert not set(NAMES) & set(builtin_names())
    assert all(program_of(a) in PROGRAMS for a in ALIASES) and all(program_of(n) in PROGRAMS for n in COMMANDS.values())


def test_list_has_one_line_per_program(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out == list_lines() and len(out) == len(PROGRAMS)
    for name, line in zip(PROGRAMS, out):
        assert line.startswith(name + " ") and "; takes " in line and "; writes " in line
    for alias, a in ALIASES.items():            # an alias is named on its program's line
        assert f"sphrom bench {alias}" in out[list(PROGRAMS).index(a.program)]
    for command, name in COMMANDS.items():
        assert f"sphrom {command}" in out[list(PROGRAMS).index(program_of(name))]


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_program_modules_have_main(name):
    module = importlib.import_module(PROGRAMS[name].module)
    assert callable(module.main)


def test_every_module_of_the_package_is_a_program_or_the_library():
    """harness/bench/ holds the programs (one module each) and lib/, the library they share; nothing else but the
    step worker that sph_stencil runs as a script in another checkout."""
    programs = {PROGRAMS[n].module.rsplit(".", 1)[1] for n in PROGRAMS}
    here = {p.stem for p in (ROOT / "harness" / "bench").glob("*.py")} - {"__init__"}
    assert here - programs == {"sph_step_worker"}
    assert {p.name for p in (ROOT / "harness" / "bench").iterdir() if p.is_dir() and p.name != "__pycache__"} == {"lib"}
    for path in (ROOT / "harness" / "bench" / "lib").glob("*.py"):      # no program hides in the library
        names = {n.name for n in ast.parse(path.read_text()).body if isinstance(n, ast.FunctionDef)}
        assert "main" not in names and "__main__" not in path.read_text(), path


@pytest.mark.parametrize("name", NAMES)
def test_help_and_bad_option_through_sphrom_bench(name, capsys):
    """``sphrom bench NAME --help`` is the program's own help (exit 0); a bad option is one line, exit 2."""
    assert main(["bench", name, "--help"]) == 0
    out = capsys.readouterr().out
    assert f"usage: sphrom bench {name} " in out
    assert ("An alias of `sphrom bench " in out) == (name in ALIASES)
    assert main(["bench", name, "--no-such-option"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--no-such-option" in err[0] and err[0].startswith(f"sphrom bench {name}: error:")


def _options(parser):
    return {o for a in parser._actions for o in a.option_strings}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_old_commands_are_aliases_that_say_so(command, capsys):
    """``sphrom bench-sph`` and the other commands that became programs run the program under their old name, with
    exactly its options, and their help (``sphrom --help``, ``sphrom COMMAND --help``) says whose alias they are."""
    name = COMMANDS[command]
    parser = build_parser()
    module = importlib.import_module(PROGRAMS[program_of(name)].module)
    assert parser.commands[command].get_default("handler") is module.run
    with contextlib.redirect_stdout(io.StringIO()) as out:
        assert main(["bench", name, "--help"]) == 0
    assert main([command, "--help"]) == 0
    help_text = capsys.readouterr().out
    assert help_text.splitlines()[0].startswith(f"usage: sphrom {command} ")
    assert f"An alias of `sphrom bench {name}`" in " ".join(help_text.split())
    program_help = out.getvalue()
    for option in _options(parser.commands[command]) - {"-h", "--help"}:
        assert option in program_help, option
    assert main(["--help"]) == 0
    listing = " ".join(capsys.readouterr().out.split())
    assert f"{command} alias of sphrom bench {name}:" in listing


def test_fmu_speed_is_fmu_with_the_defaults_of_bench_fmu():
    """One program under two names: the same options and measurements; ``fmu`` re-measures BENCHMARKS.md's FMU
    sections by default, ``fmu-speed`` (the command ``sphrom bench-fmu``) prints and writes files only when asked."""
    from sphrom.bench import fmu
    from sphrom.parser import Parser

    parsed = {}
    for name in ("fmu", "fmu-speed"):
        p = Parser(prog=name)
        fmu.add_arguments(p, name)
        parsed[name] = (vars(p.parse_args([])), _options(p))
    (a, options_a), (b, options_b) = parsed["fmu"], parsed["fmu-speed"]
    assert options_a == options_b
    assert (a["out"], a["report"], b["out"], b["report"]) == ("validation/benchmarks", "BENCHMARKS.md", None, None)
    assert {k: v for k, v in a.items() if k not in ("out", "report", "called_as")} == \
        {k: v for k, v in b.items() if k not in ("out", "report", "called_as")}
    assert build_parser().commands["bench-fmu"].get_default("called_as") == "fmu-speed"


def test_python_m_alias_still_runs():
    """``python -m sphrom.bench.NAME`` (named by the docs and BENCHMARKS.md) is the same program, and the sweep's
    measurement answers under its old name too."""
    done = subprocess.run([sys.executable, "-m", "sphrom.bench.port_rates", "--help"], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0 and "python -m sphrom.bench.port_rates" in done.stdout
    done = subprocess.run([sys.executable, "-m", "sphrom.sweep.measure", "--help"], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0 and "--sph-spec" in done.stdout, done.stderr


def test_scenes_still_go_to_the_whole_report(capsys):
    """``sphrom bench SCENE ...`` (no program name first) is the report's command: a bad scene is its error."""
    assert main(["bench", "no_such_scene", "--replot", "--out", "/nonexistent-sphrom"]) == 2
    assert "sphrom bench" in capsys.readouterr().err


# inputs builds its --case choices from derived scenes (scipy) before it parses: a follow-up, left while another
# change edits that module's calls into the models
HELP_LOADS_SCIPY = {"inputs"}


def test_program_help_loads_nothing_slow():
    """``sphrom bench NAME --help`` answers before a program loads what it measures with (numba, fmpy, scipy,
    matplotlib, dask): the programs import those inside their functions, and say so."""
    script = (f"import contextlib, io, json, sys\nfrom sphrom.cli import main\nslow = {SLOW!r}\nfound = {{}}\n"
              f"for name in {sorted(set(NAMES) - HELP_LOADS_SCIPY)!r}:\n"
              "    with contextlib.redirect_stdout(io.StringIO()):\n"
              "        main(['bench', name, '--help'])\n"
              "    loaded = sorted(m for m in sys.modules if any(m == s or m.startswith(s + '.') for s in slow))\n"
              "    if loaded:\n"
              "        found[name] = loaded[:3]\n"
              "        break\n"
              "print(json.dumps(found))\n")
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == {}


def _module(path):
    parts = path.relative_to(ROOT / "harness").with_suffix("").parts
    return ".".join(("sphrom", *(parts[:-1] if parts[-1] == "__init__" else parts)))


def _sphrom_imports(path):
    return imports(path, _module(path))


def test_programs_apart_from_the_library():
    """No module outside the measurement package imports a program, but the command line that runs them (the
    validation report uses the library, sphrom.bench.lib); the library imports no program and not their registry;
    a program imports no other program (what programs share lives in sphrom.bench.lib)."""
    programs = {p.module for p in PROGRAMS.values()}
    is_program = lambda m: any(m == p or m.startswith(p + ".") for p in programs)    # noqa: E731
    for path in (ROOT / "harness").rglob("*.py"):
        parts = path.relative_to(ROOT / "harness").parts
        if parts[0] == "bench" or parts[0] == "commands" or parts == ("cli.py",):
            continue
        bad = {m for m in _sphrom_imports(path) if is_program(m) or m == "sphrom.bench"}
        assert not bad, (path, bad)
    for path in (ROOT / "harness" / "bench" / "lib").glob("*.py"):
        bad = {m for m in _sphrom_imports(path) if is_program(m) or m == "sphrom.bench"}
        assert not bad, (path, bad)
    for path in (ROOT / "harness" / "bench").glob("*.py"):
        me = _module(path)
        bad = {m for m in _sphrom_imports(path) if is_program(m) and not m.startswith(me)}
        assert not bad, (path, bad)


def test_no_two_way_dependency_around_measurement():
    """Measurement's packages and those around it import one way only: the commands and the validation report use
    measurement, measurement uses the sweep library, never back (tests/data/package_deps.py lists every pair)."""
    around = {"sphrom.bench", "sphrom.bench.lib", "sphrom.commands", "sphrom.sweep", "sphrom.report"}
    assert two_way(dependencies(ROOT), around) == []
