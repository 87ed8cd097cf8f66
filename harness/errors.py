"""User-facing errors.

A :class:`UserError` is a mistake in what the user gave (a scene file, an
option, a file path).  The CLI prints its message on one line and exits with
status 2; it never shows a traceback for it.
"""


class UserError(Exception):
    """A problem with the user's input, reported as one line, exit status 2."""

    exit_code = 2


class FieldError(UserError):
    """A bad value of one named field (a setting such as ``n_freeze``, ``dt``, ``out``).

    The library names the field and what is allowed; the command line, which
    alone knows option names, may show the option that set the field instead
    (``sphrom.options.option_message``).  ``str(exc)`` is
    ``"<field>: <detail>"``.
    """

    def __init__(self, field, detail):
        super().__init__(f"{field}: {detail}")
        self.field = field
        self.detail = detail


class SimulationError(Exception):
    """A run that failed on its own terms (non-finite state, blow-up).

    Reported as one line with the step and time, exit status 3; nothing
    partial is kept.
    """

    exit_code = 3

    def __init__(self, message, step=None, time=None):
        super().__init__(message)
        self.step = step
        self.time = time


class ToleranceError(SimulationError):
    """A packaged model whose measured error is above the tolerance asked for (``sphrom fmu --tolerance``).

    Reported as one line with the error and the tolerance, exit status 4; the output is not written.
    """

    exit_code = 4


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM received by the command line: a one-line exit, 128 + the signal number.

    ``note``, when given, is what the one line says was written (default: what the command line saw
    committed, "no output written" when nothing).
    """

    def __init__(self, signum, note=None):
        super().__init__(signum)
        self.signum = signum
        self.note = note


def exact(value):
    """A number as text that never rounds it onto a bound: the shorter of ``%g`` and ``repr`` that reads back
    as the same float (``%g`` on a tie): 0.2 -> '0.2', 2.0 -> '2', 0.2000001 -> '0.2000001', 1e-320 -> '1e-320'."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return repr(value)
    forms = [text for text in (f"{value:g}", repr(value)) if float(text) == value or value != value]
    return min(forms, key=len)
