"""One vocabulary for the command line: canonical option names with every older name kept as an alias, list
options parsed by one set of argparse types (one-line exit-2 errors naming the option), ``--quiet`` wherever
there is progress, and option names known only to the command layer (the library names fields)."""

import argparse
import ast
import re
from pathlib import Path

import pytest

from sphrom.cli import COMMANDS, build_parser, main, parse
from sphrom import options as opt
from sphrom.errors import FieldError, UserError
from sphrom.bench import ALIASES, PROGRAMS, run_program

ROOT = Path(__file__).resolve().parents[1]

# every option string of every subcommand before the vocabulary was unified: each must still parse
PREVIOUS_OPTIONS = {
    "scenes": ['--paths'],
    "sph": ['--alpha', '--dt', '--every', '--integrator', '--n-particles', '--out', '--quiet', '--t-end'],
    "pod": ['--augment-input', '--energy', '--modes', '--out', '--quiet', '--random', '--snapshots', '--times',
            '--times-rho', '--times-v', '--window'],
    "rom": ['--augment-input', '--basis', '--freeze', '--hold', '--integrator', '--model', '--modes', '--out',
            '--quiet', '--refresh', '--step'],
    "modes": ['--all', '--freeze', '--kmax', '--models', '--out', '--quiet', '--random', '--snapshots', '--times',
              '--times-rho', '--times-v', '--window'],
    "bench": ['--fmu-scene', '--ks', '--no-fmu', '--no-stress', '--out', '--repeats', '--replot', '--report',
              '--scaling-ks', '--sizes', '--sph-sizes'],
    "bench-sph": ['--integrators', '--out', '--repeats', '--scene', '--sizes'],
    "stress": ['--amplitudes', '--horizons', '--modes', '--no-fmu', '--out', '--quick'],
    "fmu": ['--fmi', '--freeze', '--integrator', '--model', '--modes', '--no-verify', '--out', '--probes', '--quiet',
            '--tolerance'],
    "cosim": ['--force', '--hold-inputs', '--n-freeze', '--out', '--step', '--t-end'],
    "bench-fmu": ['--core-only', '--out', '--quiet', '--repeats', '--sizes', '--steps'],
    "reference": ['--dt', '--every', '--layout', '--n-particles', '--order', '--out', '--quiet', '--resolution',
                  '--solver', '--t-end'],
    "validate": ['--all', '--out', '--quiet', '--repeats'],
    "sweep": ['--out', '--quiet', '--scheduler', '--workers'],
}

# the smallest argv each command parses (its required arguments)
REQUIRED = {
    "scenes": [], "sph": ["tenmode", "--out", "x.h5"], "pod": ["tenmode", "--out", "b.h5"],
    "rom": ["tenmode", "--basis", "b.h5", "--model", "frozen", "--out", "r.h5"], "modes": ["tenmode"],
    "bench": [], "bench-sph": [], "stress": [], "fmu": ["tenmode", "--out", "x.fmu"],
    "cosim": ["x.fmu", "--out", "r.csv"], "bench-fmu": [], "reference": ["tenmode", "--solver", "fd", "--out", "x.h5"],
    "validate": ["tenmode"], "sweep": ["spec.toml", "--out", "r.h5"],
}

# (command, old name, canonical name, value, dest, parsed value)
ALIASES = [
    ("fmu", "--freeze", "--n-freeze", "5", "n_freeze", 5),
    ("rom", "--freeze", "--n-freeze", "5", "n_freeze", 5),
    ("rom", "--tolerance", "--order-tolerance", "0.01", "order_tolerance", 0.01),   # balanced order: one meaning
    ("modes", "--freeze", "--n-freeze", "5", "n_freeze", 5),
    ("cosim", "--freeze", "--n-freeze", "5", "n_freeze", 5),
    ("modes", "--kmax", "--max-modes", "9", "max_modes", 9),
    ("modes", "--models", "--model", "original,frozen", "model", ["original", "frozen"]),
    ("bench", "--ks", "--modes", "8,12", "modes", [8, 12]),
    ("bench", "--sizes", "--n-particles", "100,400", "n_particles", [100, 400]),
    ("bench", "--scaling-ks", "--scaling-modes", "4,8", "scaling_modes", [4, 8]),
    ("bench", "--sph-sizes", "--sph-n-particles", "100,400", "sph_n_particles", [100, 400]),
    ("bench-sph", "--sizes", "--n-particles", "100,400", "n_particles", [100, 400]),
    ("bench-sph", "--integrators", "--integrator", "euler,rk4", "integrator", ["euler", "rk4"]),
    ("bench-sph", "--scene", None, "damped", "scene", "damped"),            # canonical: the positional SCENE
    ("bench-fmu", "--sizes", "--n-particles", "48,96", "n_particles", [48, 96]),
    ("bench-fmu", "--steps", "--step", "0.01,0.002", "step", [0.01, 0.002]),
]


def _parse(argv):
    return parse(build_parser(), argv)


def _subparser(command):
    return build_parser().commands[command]


@pytest.mark.parametrize("command, old, new, value, dest, expect", ALIASES)
def test_old_option_names_parse_to_the_canonical_dest(command, old, new, value, dest, expect):
    base = REQUIRED[command]
    by_old = _parse([command, *base, old, value])
    by_new = _parse([command, *base, new, value] if new else [command, value, *base])
    assert getattr(by_old, dest) == getattr(by_new, dest) == expect
    if new:                   # one argument: the canonical name is the first option string, the alias the second
        action = next(a for a in _subparser(command)._actions if a.dest == dest)
        assert action.option_strings[:2] == [new, old]


@pytest.mark.parametrize("command", sorted(PREVIOUS_OPTIONS))
def test_every_previous_option_still_exists(command):
    assert set(COMMANDS) == set(PREVIOUS_OPTIONS)
    known = {o for a in _subparser(command)._actions for o in a.option_strings}
    assert set(PREVIOUS_OPTIONS[command]) <= known, set(PREVIOUS_OPTIONS[command]) - known


def _program_options(name, _cache={}):
    """The options ``sphrom bench NAME --help`` lists (a program builds its parser inside its main)."""
    if name not in _cache:
        import contextlib
        import io
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert run_program(name, ["--help"]) == 0
        _cache[name] = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", out.getvalue()))
    return _cache[name]


def test_every_option_the_readme_names_parses():
    """Each ``--option`` in a README or docs line that starts with `sphrom COMMAND` is an option of that command."""
    parser = build_parser()
    seen = 0
    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]
    for line in (line for t in texts for line in t.read_text().splitlines()):
        for m in re.finditer(r"`?sphrom ([a-z-]+)([^`]*)`?", line):
            command, rest = m.group(1), m.group(2)
            if command not in parser.commands:
                continue
            known = {o for a in parser.commands[command]._actions for o in a.option_strings}
            program = re.match(r"\s+([a-z_-]+)", rest)
            if command == "bench" and program and program.group(1) in (*PROGRAMS, *ALIASES):   # sphrom bench NAME
                known |= _program_options(program.group(1))
            for option in re.findall(r"(?<![\w-])--[a-z][a-z-]*", re.split(r"&&|\s#\s", rest)[0]):
                assert option in known, (command, option, line)
                seen += 1
    assert seen > 40


def test_scene_is_positional_everywhere():
    parser = build_parser()
    for command, sp in parser.commands.items():
        positional = [a for a in sp._actions if not a.option_strings and a.dest == "scene"]
        if command in ("scenes", "cosim", "sweep", "bench", "stress"):   # no scene, or a list of scenes
            continue
        assert positional and positional[0].metavar == "SCENE", command
    for command in ("bench", "stress"):
        assert [a.metavar for a in parser.commands[command]._actions if not a.option_strings] == ["SCENE"]
    assert _parse(["bench-sph"]).scene == "tenmode" and _parse(["bench-fmu"]).scene == "tenmode"
    assert _parse(["bench-sph", "--repeats", "2", "damped"]).scene == "damped"


def _sources(command):
    """The source of what runs ``command``: its module in sphrom.commands and the code of its handler (a measurement
    program for the aliases of programs; sphrom bench runs the program suite)."""
    import inspect
    from sphrom.bench import suite
    paths = {ROOT / "harness" / "commands" / f"{COMMANDS[command]}.py",
             Path(inspect.getsourcefile(_subparser(command).get_default("handler")))}
    if command == "bench":
        paths.add(Path(inspect.getsourcefile(suite)))
    return "".join(p.read_text() for p in sorted(paths))


def test_quiet_is_accepted_by_every_command_that_shows_progress():
    showing = [c for c in COMMANDS if re.search(r"progress", _sources(c))]
    assert set(showing) >= {"sph", "reference", "pod", "rom", "modes", "fmu", "bench", "bench-sph", "bench-fmu",
                            "stress", "validate", "sweep"}
    for command in showing:
        assert _parse([command, *REQUIRED[command]]).quiet is False
        assert _parse([command, *REQUIRED[command], "--quiet"]).quiet is True, command
        assert "args.quiet" in _sources(command), command          # and it switches the bars off


@pytest.mark.parametrize("command, argv, option", [
    ("fmu", ["tenmode", "--probes", "0.2,1.5"], "--probes"),
    ("fmu", ["tenmode", "--probes", "a,b"], "--probes"),
    ("fmu", ["tenmode", "--probes", ",".join(["0.5"] * 101)], "--probes"),
    ("bench", ["--ks", "0,4"], "--modes/--ks"),
    ("bench", ["--modes", "4,x"], "--modes/--ks"),
    ("bench", ["--sizes", "4"], "--n-particles/--sizes"),
    ("bench", ["--scaling-ks", "4.5"], "--scaling-modes/--scaling-ks"),
    ("bench", ["--sph-n-particles", ""], "--sph-n-particles/--sph-sizes"),
    ("bench-sph", ["--sizes", "100,2"], "--n-particles/--sizes"),
    ("bench-sph", ["--integrator", "euler,heun"], "--integrator/--integrators"),
    ("bench-fmu", ["--sizes", "20"], "--n-particles/--sizes"),
    ("bench-fmu", ["--steps", "0.01,-1"], "--step/--steps"),
    ("stress", ["--amplitudes", "1,0"], "--amplitudes"),
    ("stress", ["--horizons", "nan"], "--horizons"),
    ("stress", ["--modes", "4,1e3"], "--modes"),
    ("pod", ["tenmode", "--window", "0"], "--window"),
    ("pod", ["tenmode", "--window", "2,1"], "--window"),
    ("pod", ["tenmode", "--times", "0,-1"], "--times"),
    ("pod", ["tenmode", "--times-v", "a"], "--times-v"),
    ("modes", ["tenmode", "--models", "original,exact"], "--model/--models"),
    ("rom", ["tenmode", "--modes", "0"], "--modes"),
    ("fmu", ["tenmode", "--freeze", "0"], "--n-freeze/--freeze"),
])
def test_bad_lists_are_argparse_one_line_errors_naming_the_option(tmp_path, capsys, monkeypatch, command, argv,
                                                                  option):
    monkeypatch.chdir(tmp_path)
    assert main([command, *argv, *[a for a in REQUIRED[command] if a not in argv[:1]]]) == 2
    err = capsys.readouterr().err
    assert err.endswith("\n") and len(err.splitlines()) == 1, err
    assert err.startswith(f"sphrom {command}: error: {option}: ") and "allowed" in err, err
    assert list(tmp_path.iterdir()) == []


def test_argparse_errors_are_one_line_without_usage(capsys):
    assert main(["sph", "tenmode"]) == 2
    assert capsys.readouterr().err == "sphrom sph: error: the following arguments are required: --out\n"
    assert main(["sph", "tenmode", "--out", "x.h5", "--bogus", "1"]) == 2
    assert capsys.readouterr().err == "sphrom sph: error: unrecognized arguments: --bogus 1\n"
    assert main(["nosuch"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("sphrom: error: ")
    assert main(["--version"]) == 0


@pytest.mark.parametrize("make, text, expect", [
    (lambda: opt.float_list(2, 2, lo=0.0, increasing=True), "0,1.5", [0.0, 1.5]),
    (lambda: opt.float_list(lo=0, lo_open=True, integral_as_int=True), "1,10,2.5,1e3", [1, 10, 2.5, 1000.0]),
    (lambda: opt.int_list(lo=1), "4,8,", [4, 8]),
    (lambda: opt.int_list(lo=lambda: 48, hi=lambda: 100), "48,100", [48, 100]),
    (lambda: opt.choice_list("a", "b"), "b,a", ["b", "a"]),
    (lambda: opt.int_in(1, 3), " 3 ", 3),
    (lambda: opt.one_of("2", "3"), "3", "3"),
])
def test_types_accept(make, text, expect):
    assert make()(text) == expect


@pytest.mark.parametrize("make, text, allowed", [
    (lambda: opt.float_list(2, 2, lo=0.0, increasing=True), "0,1,2", "2 comma-separated numbers >= 0, increasing"),
    (lambda: opt.float_list(lo=0, lo_open=True), "0", "numbers > 0"),
    (lambda: opt.float_list(hi=1), "inf", "numbers <= 1"),
    (lambda: opt.int_list(lo=lambda: 48, hi=lambda: 100), "101", "integers in [48, 100]"),
    (lambda: opt.int_list(), "1.5", "integers"),
    (lambda: opt.choice_list("a", "b"), "c", "a, b"),
    (lambda: opt.int_in(1, 3), "4", "an integer in [1, 3]"),
    (lambda: opt.modes_pair, "1,2,3", "K or KV,KRHO"),
])
def test_types_reject_with_what_is_allowed(make, text, allowed):
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape(allowed)):
        make()(text)


def test_field_errors_show_the_option_that_set_the_field():
    fmu = _subparser("fmu")
    assert opt.option_message(fmu, FieldError("n_freeze", "0 is out of range")) == "--n-freeze: 0 is out of range"
    assert opt.option_message(fmu, FieldError("k", "99 is out of range")) == "--modes (k): 99 is out of range"
    assert opt.option_message(fmu, FieldError("out", "x")) == "--out: x"
    assert opt.option_message(_subparser("cosim"), FieldError("fmu", "'a': not found")) == "FILE.fmu: 'a': not found"
    assert opt.option_message(fmu, FieldError("window", "x")) == "window: x"     # no such option: the field


def test_the_library_names_fields_not_options(tmp_path):
    """The library's errors name the field and what is allowed; no option name."""
    from sphrom.fmu.run.cosim import force_signal
    from sphrom.pod.io import read_basis
    from sphrom.references.common import check_dt, check_resolution
    from sphrom.runio import check_output_path, read_run
    from sphrom.scene import load_scene
    from sphrom.sweep.table import read_results

    (tmp_path / "junk.h5").write_bytes(b"junk")
    cases = [
        (lambda: check_dt(0.0, 1.0), "dt", "0.0 is out of range (allowed: a number > 0)"),
        (lambda: check_resolution(4), "resolution", "4 is out of range (allowed: an integer in"),
        (lambda: read_basis(tmp_path / "none.h5"), "basis", "not found"),
        (lambda: read_run(tmp_path / "none.h5"), "run", "not found"),
        (lambda: check_output_path(tmp_path / "no" / "x.h5"), "out", "does not exist"),
        (lambda: read_results(tmp_path / "junk.h5"), "out", "cannot be read as HDF5"),
        (lambda: force_signal("nosuch(t)", 1.0, 0.1), "force", "nosuch"),
        (lambda: force_signal("log(t - 1)", 1.0, 0.1), "force", "not finite at t = 0 s"),
        (lambda: force_signal(str(tmp_path / "f.csv"), 1.0, 0.1), "force", "not found"),
        (lambda: load_scene("multimode").with_T(-1.0), "t_end", "out of range (allowed: a number > 0)"),
        (lambda: load_scene("multimode").with_sph(alpha=0.4), "alpha", "0.4 is out of range (allowed: 0.5 < alpha"),
    ]
    for call, field, text in cases:
        with pytest.raises(FieldError) as info:
            call()
        assert info.value.field == field and text in info.value.detail, (field, str(info.value))
        assert str(info.value) == f"{field}: {info.value.detail}" and "--" not in str(info.value)
        assert isinstance(info.value, UserError) and info.value.exit_code == 2


def _raise_strings(path):
    """(line, text) of every string constant inside a ``raise`` statement of the module at ``path``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Raise) and node.exc is not None:
            for sub in ast.walk(node.exc):
                if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                    out.append((sub.lineno, sub.value))
    return out


# the command layer: the commands, the command line and its vocabulary (harness/options.py, which the measurement
# programs share); everything else is library
COMMAND_LAYER = (ROOT / "harness" / "cli.py", ROOT / "harness" / "options.py")
LIBRARY = sorted(p for p in (ROOT / "harness").rglob("*.py")
                 if "commands" not in p.relative_to(ROOT / "harness").parts and p not in COMMAND_LAYER)


@pytest.mark.parametrize("path", LIBRARY, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_error_message_outside_the_commands_quotes_an_option(path):
    quoted = [(line, text) for line, text in _raise_strings(path) if re.search(r"(?<![\w-])--[a-z]", text)]
    assert not quoted, quoted
    tree = ast.parse(path.read_text())
    # nor a message built elsewhere in the style "--option: ..."
    labelled = [(c.lineno, c.value) for c in ast.walk(tree) if isinstance(c, ast.Constant)
                and isinstance(c.value, str) and re.search(r"(?<![\w-])--[a-z][a-z-]*:", c.value)]
    assert not labelled, labelled
    takes_option = [f.name for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                    and "option" in [a.arg for a in f.args.args + f.args.kwonlyargs]]
    assert not takes_option, takes_option
