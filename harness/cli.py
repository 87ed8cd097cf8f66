"""The ``sphrom`` command line (also ``python -m harness``).

A user's mistake (a bad scene, option or path) is one line on stderr and exit
status 2 (``sphrom COMMAND: error: --option: what is allowed``, argparse's
errors included); a run that fails on its own terms (non-finite state) is one
line and exit status 3; SIGINT and SIGTERM are one line "interrupted" and exit
status 128 + the signal (130, 143).  None leaves a partial output file.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys
import threading

from . import __version__
from .errors import FieldError, Interrupted, SimulationError, UserError

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


class Parser(argparse.ArgumentParser):
    """An ArgumentParser (and, through ``add_subparsers``, its subcommands' parsers) whose errors are one line:
    ``sphrom COMMAND: error: --option: what is allowed``, exit status 2, no usage block."""

    def error(self, message):
        if message.startswith("argument "):        # "argument --probes: ..." -> "--probes: ..."
            message = message[len("argument "):]
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")


def build_parser():
    parser = Parser(
        prog="sphrom",
        description="Reduced-order models of a Lagrangian SPH mass-spring-damper system, "
                    "packaged as an FMU, with the harness that builds and validates them.")
    parser.add_argument("--version", action="version", version=f"sphrom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, module in COMMANDS.items():
        importlib.import_module(f".commands.{module}", __package__).add_parser(sub)
    parser.commands = dict(sub.choices)          # name -> its parser (errors, option names)
    return parser


def parse(parser, argv=None):
    """Parse ``argv``; an unknown argument is an error of the subcommand it was given to."""
    args, extra = parser.parse_known_args(argv)
    if extra:
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    return args


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


@contextlib.contextmanager
def _signals_as_exceptions():
    """SIGINT and SIGTERM raise :class:`Interrupted` while a command runs (main thread only).

    An ignored SIGINT (a job started with it ignored) stays ignored.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig, handler in previous.items():
        if not (sig == signal.SIGINT and handler is signal.SIG_IGN):
            signal.signal(sig, _raise_interrupted)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


def main(argv=None):
    parser = build_parser()
    try:
        args = parse(parser, argv)
    except SystemExit as exc:                    # argparse: --help, --version, a bad option (one line)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    with _signals_as_exceptions():
        return _run(parser, args)


def _run(parser, args):
    try:
        return int(args.handler(args) or 0)
    except FieldError as exc:                    # the library names the field; show the option that set it
        from .commands.options import option_message
        print(f"sphrom {args.command}: error: {option_message(parser.commands[args.command], exc)}",
              file=sys.stderr)
        return exc.exit_code
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
    except KeyboardInterrupt as exc:
        signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
        print(f"sphrom {args.command}: interrupted ({signal.Signals(signum).name}); no output written",
              file=sys.stderr)
        return 128 + int(signum)


if __name__ == "__main__":
    sys.exit(main())
