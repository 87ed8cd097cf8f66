"""The ``sphrom`` command line (also ``python -m harness``).

A user's mistake (a bad scene, option or path) is one line on stderr and exit
status 2; a run that fails on its own terms (non-finite state) is one line
and exit status 3.  Neither leaves a partial output file.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from . import __version__
from .errors import SimulationError, UserError

# subcommand name -> module in harness.commands
COMMANDS = {
    "scenes": "scenes",
    "sph": "sph",
    "pod": "pod",
    "rom": "rom",
    "modes": "modes",
    "bench": "bench",
    "bench-sph": "bench_sph",
    "stress": "stress",
    "fmu": "fmu",
    "cosim": "cosim",
    "bench-fmu": "bench_fmu",
    "reference": "reference",
    "validate": "validate",
    "sweep": "sweep",
}


def build_parser():
    parser = argparse.ArgumentParser(
        prog="sphrom",
        description="Reduced-order models of a Lagrangian SPH mass-spring-damper system, "
                    "packaged as an FMU, with the harness that builds and validates them.")
    parser.add_argument("--version", action="version", version=f"sphrom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, module in COMMANDS.items():
        importlib.import_module(f".commands.{module}", __package__).add_parser(sub)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except UserError as exc:
        print(f"sphrom {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except SimulationError as exc:
        print(f"sphrom {args.command}: failed: {exc}", file=sys.stderr)
        return exc.exit_code
    except BrokenPipeError:         # e.g. piped into `head`
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print(f"sphrom {args.command}: interrupted; no output written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
