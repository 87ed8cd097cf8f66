"""sphrom harness: full SPH, POD reduced models, FMU packaging and validation.

The package follows the paper (Fang, Song, Fraser, Huang, "POD-based
model-order reduction of SPH for a 1D mass-spring-damper system"); equation
numbers in comments refer to it.
"""

__version__ = "0.1.0"


def _take_signals_when_run():
    """When this package is the program (``python -m sphrom``, the ``sphrom`` script), SIGINT and SIGTERM end
    it with the command line's one line ("sphrom: interrupted (SIGINT); no output written", exit 128 + the
    signal) until :func:`sphrom.cli.main` installs its own handler: without this, a signal while Python
    imports the command line was a KeyboardInterrupt traceback (SIGINT) or a silent death (SIGTERM).
    Imported as a library, nothing changes."""
    import os
    import signal
    import sys
    argv = getattr(sys, "orig_argv", [])
    if argv[1:3] != ["-m", "sphrom"] and not (len(argv) > 1 and os.path.basename(argv[1]) == "sphrom"):
        return

    def leave(signum, frame):
        os.write(2, f"sphrom: interrupted ({signal.Signals(signum).name}); no output written\n".encode())
        os._exit(128 + signum)
    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, leave)


_take_signals_when_run()
