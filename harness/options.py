"""The command line's vocabulary: argparse types, shared arguments, and option names for library fields.

Shared by the commands (:mod:`sphrom.commands`) and the measurement programs (:mod:`sphrom.bench`), below both.

Every type raises ``argparse.ArgumentTypeError`` with what is allowed, so a bad
value is argparse's own one-line error naming the option (exit status 2).
The library names fields (``n_freeze``, ``dt``, ``out``); only this layer
knows which option sets a field (:func:`option_message`).
"""

import argparse
import math


def min_particles():
    """``sphrom.scene.MIN_PARTICLES``, imported when a value is parsed (``--help`` stays light)."""
    from .scene import MIN_PARTICLES
    return MIN_PARTICLES


def max_particles():
    """``sphrom.scene.MAX_PARTICLES``, imported when a value is parsed."""
    from .scene import MAX_PARTICLES
    return MAX_PARTICLES


def max_probes():
    """``sphrom.fmu.resources.MAX_PROBES``, imported when a value is parsed."""
    from .fmu.resources import MAX_PROBES
    return MAX_PROBES


class LazyChoices:
    """argparse ``choices`` read on first use (a value's check, ``--help``, an error): building the parser imports
    nothing heavy.  ``load()`` returns the choices (e.g. the model registry's names, which import numba)."""

    def __init__(self, load):
        self._load = load
        self._values = None

    def _get(self):
        if self._values is None:
            self._values = tuple(self._load())
        return self._values

    def __iter__(self):
        return iter(self._get())

    def __contains__(self, value):
        return value in self._get()

    def __len__(self):
        return len(self._get())


class LazyHelp(argparse._StoreAction):
    """A stored option whose help text is ``help()`` (a callable), made when ``--help`` shows it."""

    @property
    def help(self):
        return self._help() if callable(self._help) else self._help

    @help.setter
    def help(self, value):
        self._help = value


# The most timed repeats of a benchmark point: a median of 1000 is already exact enough; 1e18 would never end.
MAX_REPEATS = 1000
# The largest integer any option takes: a 64-bit signed integer (numba, HDF5 attributes, numpy indices).
INT_MAX = 2**63 - 1


def _number(text, kind, allowed):
    try:
        value = kind(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'} "
                                         f"(allowed: {allowed})") from None
    if kind is float and not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: {allowed})")
    if kind is int and abs(value) > INT_MAX:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: {allowed}, at most 2^63 - 1)")
    return value


def integer(text):
    """Any integer (its range is checked where the value is used)."""
    return _number(str(text).strip(), int, "an integer")


def number(text):
    """Any finite number (its range is checked where the value is used)."""
    return _number(text, float, "a finite number")


def positive_float(text):
    """A finite number > 0."""
    value = _number(text, float, "a number > 0")
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: a number > 0)")
    return value


def nonneg_float(text):
    """A finite number >= 0."""
    value = _number(text, float, "a number >= 0")
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: a number >= 0)")
    return value


def int_at_least(lo):
    """The type of an integer >= ``lo``."""
    return int_in(lo)


def int_in(lo, hi=None):
    """The type of an integer in [lo, hi] (``hi`` None: no upper bound)."""
    allowed = f"an integer >= {lo}" if hi is None else f"an integer in [{lo}, {hi}]"

    def parse(text):
        value = _number(str(text).strip(), int, allowed)
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{value} is out of range (allowed: {allowed})")
        return value
    parse.__name__ = "integer"
    return parse


def one_of(*choices):
    """The type of one word out of ``choices`` (the error lists them as allowed)."""
    def parse(text):
        if str(text).strip() not in choices:
            raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: {', '.join(choices)})")
        return str(text).strip()
    parse.__name__ = "choice"
    return parse


def _bounds(lo, hi, lo_open, hi_open=False):
    if lo is None and hi is None:
        return "numbers"
    if hi is None:
        return f"numbers {'>' if lo_open else '>='} {lo:g}"
    if lo is None:
        return f"numbers {'<' if hi_open else '<='} {hi:g}"
    return f"numbers in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _value(bound):
    """A bound, or the value of a callable one (a library constant imported only when parsing)."""
    return bound() if callable(bound) else bound


def _list(text, kind, min_count, max_count, lo, hi, lo_open, increasing, what, hi_open=False, distinct=False):
    count = (f"{min_count}" if max_count == min_count else
             f"{min_count} or more" if max_count is None else f"{min_count} to {max_count}")
    allowed = f"{count} comma-separated {what}" + (", increasing" if increasing else ", distinct" if distinct else "")
    parts = [p.strip() for p in str(text).split(",")]
    if parts and parts[-1] == "":              # a trailing comma
        parts.pop()
    try:
        values = [kind(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of {'integers' if kind is int else 'numbers'} "
                                         f"(allowed: {allowed})") from None
    if not min_count <= len(values) <= (max_count or len(values)):
        raise argparse.ArgumentTypeError(f"{text!r} has {len(values)} values (allowed: {allowed})")
    for v in values:
        if not math.isfinite(v) or (lo is not None and (v <= lo if lo_open else v < lo)) \
                or (hi is not None and (v >= hi if hi_open else v > hi)) or (kind is int and abs(v) > INT_MAX):
            raise argparse.ArgumentTypeError(f"{v!r} in {text!r} is out of range (allowed: {allowed})")
    if increasing and any(b <= a for a, b in zip(values, values[1:])):
        raise argparse.ArgumentTypeError(f"{text!r} is not increasing (allowed: {allowed})")
    if distinct and len(set(values)) != len(values):
        twice = next(v for i, v in enumerate(values) if v in values[:i])
        raise argparse.ArgumentTypeError(f"{twice!r} is given twice in {text!r} (allowed: {allowed})")
    return values


def float_list(min_count=1, max_count=None, lo=None, hi=None, lo_open=False, increasing=False, integral_as_int=False,
               hi_open=False, distinct=False):
    """The type of a comma-separated list of finite numbers, ``0,0.4,0.8`` -> [0.0, 0.4, 0.8].

    Parameters
    ----------
    min_count, max_count : int or callable
        How many values (``max_count`` None: no limit).
    lo, hi : float or callable, optional
        Bounds of every value (a callable is called when parsing); ``lo_open`` excludes ``lo`` itself,
        ``hi_open`` ``hi``.
    increasing : bool
        Values strictly increasing.
    distinct : bool
        No value twice.
    integral_as_int : bool
        Values written without a point or exponent come back as int (``10`` -> 10, ``1.5`` -> 1.5).
    """
    def parse(text):
        low, high = _value(lo), _value(hi)
        values = _list(text, float, _value(min_count), _value(max_count), low, high, lo_open, increasing,
                       _bounds(low, high, lo_open, hi_open), hi_open=hi_open, distinct=distinct)
        if integral_as_int:
            parts = [p.strip() for p in str(text).split(",") if p.strip()]
            values = [int(v) if not any(c in p for c in ".eEnN") else v for p, v in zip(parts, values)]
        return values
    parse.__name__ = "list of numbers"
    return parse


def int_list(min_count=1, max_count=None, lo=None, hi=None):
    """The type of a comma-separated list of integers in [lo, hi] (bounds as in :func:`float_list`),
    ``4,8,12`` -> [4, 8, 12]."""
    def parse(text):
        low, high = _value(lo), _value(hi)
        what = _bounds(low, high, False).replace("numbers", "integers")
        return _list(text, int, _value(min_count), _value(max_count), low, high, False, False, what)
    parse.__name__ = "list of integers"
    return parse


def choice_list(*choices):
    """The type of a comma-separated list of words out of ``choices``, ``euler,rk4`` -> ['euler', 'rk4']."""
    def parse(text):
        values = [p.strip() for p in str(text).split(",") if p.strip()]
        if not values:
            raise argparse.ArgumentTypeError(f"{text!r} is empty (allowed: comma-separated {', '.join(choices)})")
        for v in values:
            if v not in choices:
                raise argparse.ArgumentTypeError(f"{v!r} is out of range (allowed: comma-separated "
                                                 f"{', '.join(choices)})")
        return values
    parse.__name__ = "list of choices"
    return parse


def modes_pair(text):
    """``12`` -> (12, 12); ``12,8`` -> (k_v, k_rho) = (12, 8)."""
    try:
        parts = [int(p) for p in str(text).split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not K or KV,KRHO (allowed: positive integers)") from None
    if len(parts) not in (1, 2) or min(parts) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: K or KV,KRHO with integers >= 1)")
    return (parts[0], parts[-1])


# ---------------------------------------------------------------------------
# arguments every command spells the same way
# ---------------------------------------------------------------------------

def add_quiet(p):
    """``--quiet``: no progress bars (every command that shows progress has it)."""
    p.add_argument("--quiet", action="store_true", help="no progress bars")


# n_freeze is an FMI Integer parameter of the FMU (32 bits) wherever it goes.
N_FREEZE_MAX = 2**31 - 1


def add_n_freeze(p, default=None, help="refresh period n_freeze of the frozen coefficients"):
    """``--n-freeze NF`` (alias ``--freeze``), an integer in [1, 2^31 - 1] (the FMU's Integer parameter)."""
    p.add_argument("--n-freeze", "--freeze", dest="n_freeze", type=int_in(1, N_FREEZE_MAX), default=default,
                   metavar="NF",
                   help=help + ("" if default is None else f" (default {default})"))


def add_order_tolerance(p, *aliases, note=""):
    """``--order-tolerance TOL``: the balanced model's order criterion, its one meaning (``aliases``: the earlier
    names of the option where they meant only this; ``note`` ends the help)."""
    from .defaults import ORDER_TOLERANCE
    p.add_argument("--order-tolerance", *aliases, dest="order_tolerance", type=positive_float, metavar="TOL",
                   help="balanced model: instead of --modes R, its order is the smallest r with 2 sum_{i>r} sigma_i "
                        f"<= TOL 2 sum sigma_i (0 < TOL < 1; default {ORDER_TOLERANCE:g} when neither is given)"
                        + note)


class _SceneOption(argparse.Action):
    """``--scene NAME``: the positional SCENE given as an option (same dest)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, "_scene_given", False):
            parser.error(f"SCENE: given twice ({getattr(namespace, self.dest)!r} and {values!r} with --scene)")
        setattr(namespace, self.dest, values)
        setattr(namespace, "_scene_given", True)


class _ScenePositional(argparse.Action):
    """An optional positional SCENE: its default unless given here or with ``--scene``."""

    def __init__(self, *args, scene_default=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.scene_default = scene_default

    def __call__(self, parser, namespace, values, option_string=None):
        given = getattr(namespace, "_scene_given", False)
        if values is None:
            if not given:
                setattr(namespace, self.dest, self.scene_default)
            return
        if given:
            parser.error(f"SCENE: given twice ({getattr(namespace, self.dest)!r} with --scene and {values!r})")
        setattr(namespace, self.dest, values)
        setattr(namespace, "_scene_given", True)


def add_scene(p, default=None, option_alias=False, help="built-in scene name (see 'sphrom scenes') or a TOML path"):
    """The positional SCENE; optional when ``default`` is given, and then also ``--scene`` when ``option_alias``
    (for commands that took the scene as an option)."""
    if default is None:
        p.add_argument("scene", metavar="SCENE", help=help)
        return
    p.add_argument("scene", metavar="SCENE", nargs="?", action=_ScenePositional, scene_default=default,
                   help=f"{help} (default {default})")
    if option_alias:
        p.add_argument("--scene", dest="scene", action=_SceneOption, metavar="SCENE", help="the same as SCENE")


# ---------------------------------------------------------------------------
# library fields -> options
# ---------------------------------------------------------------------------

# a library field whose option's dest is named otherwise
FIELD_DESTS = {"k": "modes"}


def option_for(parser, field):
    """The canonical option string (or the positional's metavar) of ``parser`` that sets ``field``, or None."""
    dest = FIELD_DESTS.get(field, field)
    for action in parser._actions:
        if action.dest == dest and not isinstance(action, (_SceneOption, argparse._HelpAction)):
            if action.option_strings:
                return action.option_strings[0]
            return action.metavar or action.dest
    return None


def option_message(parser, exc):
    """The message of a FieldError as the command line shows it: the option that set the field, with the
    field's name beside it where they differ (``--n-freeze: ...``, ``--modes (k): ...``; a positional by its
    metavar, ``FILE.fmu: ...``); the library's own message when no argument of ``parser`` sets the field."""
    option = option_for(parser, exc.field)
    if option is None:
        return str(exc)
    if not option.startswith("-") or option.lstrip("-").replace("-", "_") == exc.field:
        return f"{option}: {exc.detail}"
    return f"{option} ({exc.field}): {exc.detail}"


# output options (dest) and, per command, the files written beside an output file (its suffix replaced)
OUTPUTS = ("out", "report")
COMPANIONS = {"sweep": (".csv", ".png")}


def _same_file(a, b):
    """Whether paths ``a`` and ``b`` name one file: the same inode where both exist (links, ``./x``, hard
    links), else the same resolved path."""
    import os
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        try:
            return os.path.realpath(a) == os.path.realpath(b)
        except (OSError, ValueError):
            return False


def _argument_name(action):
    return action.option_strings[0] if action.option_strings else (action.metavar or action.dest)


def check_outputs_spare_inputs(parser, args, command):
    """``UserError`` (one line, exit 2) when an output path of the command (``--out``, ``--report``, and the
    files written beside ``--out``: a sweep's .csv and .png) names one of its input files, given by any
    argument: ``sphrom sph s.toml --out s.toml`` turned the scene into HDF5, ``sphrom cosim X.fmu --force f.csv
    --out f.csv`` replaced the force it read.  Checked before any work; an input is any argument
    value that names an existing regular file."""
    from pathlib import Path

    from .errors import UserError
    from .paths import is_file
    actions = [a for a in parser._actions if a.dest not in ("help", "version")]
    outputs = []
    for action in actions:
        value = getattr(args, action.dest, None)
        if action.dest in OUTPUTS and isinstance(value, str) and value:
            outputs.append((action, value))
            if action.dest == "out":
                outputs += [(action, str(Path(value).with_suffix(s))) for s in COMPANIONS.get(command, ())
                            if Path(value).suffix]
    if not outputs:
        return
    for action in actions:
        if action.dest in OUTPUTS:
            continue
        value = getattr(args, action.dest, None)
        for text in (value if isinstance(value, (list, tuple)) else [value]):
            if not isinstance(text, (str, Path)) or not str(text) or not is_file(text):
                continue
            for out_action, out in outputs:
                if _same_file(out, text):
                    shown = "" if out == getattr(args, out_action.dest) else f" (written beside '{getattr(args, out_action.dest)}')"
                    raise UserError(f"{_argument_name(out_action)}: '{out}'{shown} is the input "
                                    f"{_argument_name(action)} '{text}' of this command: writing it would destroy "
                                    "that input (allowed: an output path that names no input)")
