"""The ``sphrom`` command line (also ``python -m sphrom``).

A user's mistake (a bad scene, option or path) is one line on stderr and exit
status 2 (``sphrom COMMAND: error: --option: what is allowed``, argparse's
errors included); a run that fails on its own terms (non-finite state) is one
line and exit status 3; SIGINT and SIGTERM are one line "interrupted" and exit
status 128 + the signal (130, 143), saying what was written before them ("no
output written" only when nothing was; :mod:`sphrom.signals`).  None leaves a
partial output file.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys

from . import __version__
from .errors import FieldError, Interrupted, SimulationError, UserError
from .parser import Parser
from .signals import SIGNALS, Guard, current_guard, interrupt_line

# subcommand name -> the module in sphrom.commands that adds it (a module may add several)
COMMANDS = {
    "scenes": "scenes",
    "sph": "sph",
    "pod": "pod",
    "rom": "rom",
    "modes": "modes",
    "bench": "bench",
    "bench-sph": "bench",         # bench-sph, bench-fmu, stress: aliases of measurement programs (sphrom bench NAME)
    "bench-fmu": "bench",
    "stress": "bench",
    "fmu": "fmu",
    "cosim": "cosim",
    "reference": "reference",
    "validate": "validate",
    "sweep": "sweep",
}


def build_parser():
    parser = Parser(
        prog="sphrom",
        description="Reduced-order models of a Lagrangian SPH mass-spring-damper system, "
                    "packaged as an FMU, with the harness that builds and validates them.")
    parser.add_argument("--version", action="version", version=f"sphrom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for module in dict.fromkeys(COMMANDS.values()):
        importlib.import_module(f".commands.{module}", __package__).add_parser(sub)
    parser.commands = dict(sub.choices)          # name -> its parser (errors, option names)
    return parser


def parse(parser, argv=None):
    """Parse ``argv``; an unknown argument is an error of the subcommand it was given to.  ``sphrom bench NAME
    ...`` hands the arguments after NAME to the program NAME (:func:`sphrom.commands.bench.program_args`)."""
    from .commands.bench import program_args
    args = program_args(sys.argv[1:] if argv is None else list(argv))
    if args is not None:
        return args
    args, extra = parser.parse_known_args(argv)
    if extra:
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    return args


def main(argv=None, restore_signals=None):
    """Run ``sphrom`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    SIGINT and SIGTERM are taken over first (:class:`sphrom.signals.Guard`): importing the commands takes
    a second.  ``restore_signals`` (default: when ``argv`` is given, i.e. called from Python) puts the
    previous handlers back at the end and returns.  The program itself (``argv`` None) keeps the guard to
    the end and does not return: once the command is done it runs the exit hooks and leaves
    (:func:`_leave`), so that no moment of its life answers a signal with a silent death.
    """
    restore = argv is not None if restore_signals is None else restore_signals
    guard = Guard()
    with guard.installed(restore=restore):
        code = _guarded(guard, argv)
    if guard.pending:         # a signal between the command's last check and the guard's `finished` (recorded only)
        signum = guard.pending[0]
        guard.acknowledge()
        print(interrupt_line(guard.command, signum, guard.written_text()), file=sys.stderr)
        code = 128 + int(signum)
    if not restore:
        _leave(code)
    return code


def _guarded(guard, argv):
    """Parse ``argv`` and run the command under ``guard``: its exit status, 128 + the signal when one came."""
    try:
        parser = build_parser()
        try:
            args = parse(parser, argv)
        except SystemExit as exc:            # argparse: --help, --version, a bad option (one line)
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        else:
            guard.command = args.command
            import numpy as np
            # a command checks its numbers and says what is wrong in one line; numpy's floating-point
            # warnings (overflow in a square of 1e308, ...) printed before that line are noise
            with np.errstate(all="ignore"):
                code = _run(parser, args)
        guard.raising = False                # from here a signal is only recorded
    except KeyboardInterrupt as exc:
        guard.raising = False
        guard.acknowledge()                  # this signal's line is printed here
        signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
        note = getattr(exc, "note", None) or guard.written_text()
        print(interrupt_line(guard.command, signum, note), file=sys.stderr)
        return 128 + int(signum)
    if guard.pending:                        # a signal whose exception was lost (a finaliser swallowed it)
        signum = guard.pending[0]
        guard.acknowledge()
        print(interrupt_line(guard.command, signum, guard.written_text()), file=sys.stderr)
        return 128 + int(signum)
    return code


def _leave(code):
    """End the program with ``code`` once the command is done: flush, run the exit hooks (logging, dask's),
    and exit without the interpreter's teardown of its modules.  That teardown took 150-300 ms here after
    every output was written, and part of it runs with the default signal handlers back, where a signal
    killed the process without a word; the guard stays installed until the very end instead."""
    import atexit
    import contextlib
    import os
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    # a signal that reached the process but not yet its Python handler (run between bytecodes) would die with
    # os._exit unseen: hold both signals at the C level, then act on one already there
    with contextlib.suppress(Exception):
        signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
        waiting = [sig for sig in SIGNALS if sig in signal.sigpending()]
        if waiting:
            guard = current_guard()
            with contextlib.suppress(Exception):
                sys.stderr.write(interrupt_line(getattr(guard, "command", None), waiting[0],
                                                guard.written_text() if guard else "no output written") + "\n")
                sys.stderr.flush()
            os._exit(128 + int(waiting[0]))
        # one more look at a signal another thread (a BLAS or dask thread, which the mask above does not cover)
        # took and Python has not yet handed to the guard: pthread_sigmask runs the pending handlers (the guard,
        # `finished`, prints the line and leaves with 128 + the signal)
        signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    os._exit(code)


def _run(parser, args):
    try:
        if args.command in parser.commands and "handler" in vars(args):
            from .options import check_outputs_spare_inputs
            check_outputs_spare_inputs(parser.commands[args.command], args, args.command)
        return int(args.handler(args) or 0)
    except FieldError as exc:                    # the library names the field; show the option that set it
        from .options import option_message
        print(f"sphrom {args.command}: error: {option_message(parser.commands[args.command], exc)}",
              file=sys.stderr)
        return exc.exit_code
    except UserError as exc:
        print(f"sphrom {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except SimulationError as exc:
        print(f"sphrom {args.command}: failed: {exc}", file=sys.stderr)
        return exc.exit_code
    except MemoryError as exc:      # a run larger than this machine: one line, what failed and what is available
        from .runio import available_memory, format_bytes
        free = available_memory()
        what = " ".join(str(exc).split())[:160] or "an allocation failed"
        print(f"sphrom {args.command}: failed: out of memory ({what}); this machine has "
              f"{format_bytes(free) if free is not None else 'less'} available: a smaller run fits (fewer "
              "particles, modes or steps)", file=sys.stderr)
        return 3
    except BrokenPipeError:         # e.g. piped into `head`
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
