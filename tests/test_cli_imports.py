"""Instant commands: building the command line's parsers imports nothing heavy (numpy, numba, scipy, h5py,
matplotlib, dask, fmpy, the model registry), and a co-simulation imports only what it runs (numpy, fmpy): the
time of ``sphrom --help`` is a bare Python start's, and ``sphrom cosim``'s is about that of importing numpy and
fmpy (``sphrom bench fast`` measures both)."""

import json
import subprocess
import sys

import pytest

from sphrom.cli import COMMANDS

HEAVY = ("numpy", "numba", "scipy", "h5py", "matplotlib", "dask", "distributed", "fmpy", "skfem", "pde", "tqdm",
         "threadpoolctl", "sphrom.rom.registry", "sphrom.sph.solver")


def imported_after(code):
    """The heavy modules (HEAVY, or their submodules) imported by ``code`` run in a fresh interpreter."""
    script = (f"import sys\n{code}\nimport json\n"
              f"print(json.dumps(sorted(m for m in sys.modules if any(m == h or m.startswith(h + '.') "
              f"for h in {HEAVY!r}))))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


def test_building_the_parser_imports_nothing_heavy():
    assert imported_after("from sphrom.cli import build_parser\nbuild_parser()") == []


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_each_command_help_imports_nothing_heavy(command):
    """``sphrom COMMAND --help`` (the parser built and its help formatted) but the one that must show the model
    registry's descriptions (rom: its --model help reads them, and imports them only then)."""
    heavy = imported_after("from sphrom.cli import main\n"
                           "import contextlib, io\n"
                           "with contextlib.redirect_stdout(io.StringIO()):\n"
                           f"    main([{command!r}, '--help'])")
    if command == "rom":
        assert "sphrom.rom.registry" in heavy            # the lazy help reads the registry when it is shown
    else:
        assert heavy == [], heavy


def test_a_bad_option_imports_nothing_heavy():
    """An option error (argparse's one line, exit 2) is given before any heavy import."""
    assert imported_after("from sphrom.cli import main\n"
                          "import contextlib, io\n"
                          "with contextlib.redirect_stderr(io.StringIO()):\n"
                          "    assert main(['sph', 'tenmode', '--every', 'x', '--out', 'x.h5']) == 2") == []


def test_cosim_imports_only_numpy_and_fmpy(hostile_fmu, tmp_path):
    heavy = imported_after("from sphrom.cli import main\n"
                           "import contextlib, io\n"
                           "with contextlib.redirect_stdout(io.StringIO()):\n"
                           f"    assert main(['cosim', {str(hostile_fmu)!r}, '--t-end', '0.1', '--out', "
                           f"{str(tmp_path / 'c.csv')!r}]) == 0")
    assert {m.split(".")[0] for m in heavy} <= {"numpy", "fmpy"}, heavy
