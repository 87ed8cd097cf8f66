"""``sphrom bench``: the measurement programs (:mod:`sphrom.bench`) on the command line, and their command aliases.

``sphrom bench NAME [options]`` runs the program NAME of :data:`sphrom.bench.PROGRAMS` (or an alias of one,
:data:`sphrom.bench.ALIASES`) with its own options; ``sphrom bench --list`` lists them; ``sphrom bench [SCENE ...]
[options]`` (no program name first) is the program ``suite``: run time against error of every method, cost
scaling, skipped terms (BENCHMARKS.md with ``--report``).  The first word decides: a program's name is a program
(no built-in scene has one: tests/test_bench_programs.py), anything else a scene (a scene file named like a
program is given as a path, ./NAME.toml).

The commands ``sphrom bench-sph``, ``sphrom bench-fmu`` and ``sphrom stress`` (:data:`sphrom.bench.COMMANDS`) are
aliases of programs: each takes the program's options and runs it; its help says so.
"""

import argparse
import importlib

from ..bench import ALIASES, COMMANDS, PROGRAMS, alias_note, list_lines, program_of, run_program, suite

USAGE = "sphrom bench NAME [options] | sphrom bench --list | sphrom bench [SCENE ...] [options]"


def add_parser(sub):
    """The command ``bench`` and the commands that are aliases of programs (:data:`sphrom.bench.COMMANDS`)."""
    p = sub.add_parser("bench", help="the measurement programs (sphrom bench NAME, --list); without a NAME, run "
                                     "time against error of every method (BENCHMARKS.md with --report)",
                       usage=USAGE,
                       description="sphrom bench NAME [options] runs the measurement program NAME (sphrom bench "
                                   "--list: one line each; sphrom bench NAME --help: its options). Without a program "
                                   "name first (the program suite): "
                                   + suite.DESCRIPTION[0].lower() + suite.DESCRIPTION[1:])
    suite.add_arguments(p)
    p.add_argument("--list", action="store_true",
                   help="list the measurement programs (what each measures, how long it takes, what it writes)")
    p.set_defaults(handler=run)
    for command, name in COMMANDS.items():
        # the programs that are commands import their measuring modules only when they run (light to import here)
        module = importlib.import_module(PROGRAMS[program_of(name)].module)
        a = sub.add_parser(command, help=f"alias of sphrom bench {name}: {module.HELP}",
                           description=alias_note(name, command) + module.DESCRIPTION)
        if name in ALIASES:
            module.add_arguments(a, name)
        else:
            module.add_arguments(a)
        a.set_defaults(handler=module.run)


def program_args(argv):
    """``sphrom bench NAME ...`` with NAME a program of :data:`sphrom.bench.PROGRAMS` or an alias of one (module
    docstring): the arguments that run it (command ``bench``, its handler), else None (every other command line)."""
    if len(argv) < 2 or argv[0] != "bench" or program_of(argv[1]) not in PROGRAMS:
        return None
    name, rest = argv[1], list(argv[2:])
    return argparse.Namespace(command="bench", handler=lambda args: run_program(name, rest))


def run(args):
    """``sphrom bench --list``, or the program ``suite`` with the parsed options ``args``."""
    if args.list:
        print("\n".join(list_lines()))
        return 0
    return suite.run(args)
