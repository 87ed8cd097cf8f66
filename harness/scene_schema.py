"""The scene schema as data: every key a scene file may hold, with its type, unit, default and allowed range.

:data:`TABLES` and :data:`KEYS` are the one description of a scene file.  The loader
(:func:`sphrom.scene.parse_scene`) checks every key, type and static range against them through
:func:`check_scene_tables`, and the user documentation's page is generated from them
(:mod:`sphrom.scene_page`, ``docs/user/scenes.md``).  Bounds that depend on
other keys (alpha < N/4, dt <= T, at most 1e9 steps, modes <= N) are checked by the loader in
:mod:`sphrom.scene` and stated in the ``also`` column of the same rows.

Units (SI, cross-section a = 1 m^2): x, L in m; t, T, dt in s; rho0 in kg m^-3; v0 in m s^-1; c in
kg m^-1 s^-2 (Young's modulus, Pa); d in s^-1; f in m s^-2 (force per unit mass).
"""

from __future__ import annotations

import math
import re
import reprlib
import unicodedata
from dataclasses import dataclass

from .errors import UserError

AUTO = "automatic"      # a default chosen by a stated rule from the rest of the scene (see sphrom.scene)

# Physical quantities: 15 decades either side of 1 in SI units.  Wider than any bar's physics (steel: rho0 =
# 7.8e3 kg m^-3, c = 2e11 Pa; the paper's normalised scenes: rho0 = 1, c = 0.1, L = 1, T = 10), narrow enough
# that every product the SPH and the reduced models form stays a normal float64: the steepest, the squared
# fastest frequency (c/rho0)(2/h)^2 with h = alpha L/N >= 0.5 * 1e-15 / 1e7 = 5e-23 m, is at most
# 1e30 * 1.6e45 = 1.6e75, far from float64's 1.8e308; L = 1e-300 made h^2 underflow to 0 and the kernel
# divide by it.
SCALE = 1e15
WHY_SCALE = ("15 decades either side of 1 in SI units: wider than any bar's physics (steel: rho0 = 7.8e3 kg m^-3, "
             "c = 2e11 Pa), narrow enough that every product the SPH and the reduced models form stays a normal "
             "float64 (the largest, the squared fastest frequency (c/rho0)(2/h)^2 with h >= 5e-23 m, is at most "
             "1.6e75; float64 ends at 1.8e308)")
MIN_PARTICLES = 8
MAX_PARTICLES = 10_000_000
MAX_ALPHA = 4.0
# At most MAX_STEPS SPH steps T/dt in one run.  Step times are n*dt with n exact in float64 far beyond this
# (2^53), and the int64 step counters cannot overflow; the bound is the wall time: at the cheapest step
# (N = MIN_PARTICLES, about a microsecond) 1e9 steps already take the better part of an hour.
MAX_STEPS = 10**9
MAX_STEPS_TEXT = "1e9"
# The stored samples of a full SPH run, v and rho (samples x N float64 each), above this are refused before the
# run: a small `every` over many steps would otherwise fill the memory.
MAX_SAMPLE_BYTES = 4 * 2**30
MAX_FREEZE = 2**31 - 1          # the FMU's n_freeze is a 32-bit integer
MAX_SEED = 2**63 - 1            # stored as a 64-bit integer attribute
MAX_REFERENCE_CELLS = 10**6     # the FD reference's grid, L / reference_dx cells
MAX_TEXT = 1000                 # characters of a free text (title, summary, notes)
MAX_NAME = 64
MAX_DEPTH = 8                   # levels of [ ] and { } in the TOML text (a scene needs 2: [[paper.runs]])
MAX_FILE_BYTES = 2**20          # a scene is a page of text
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,%d}" % (MAX_NAME - 1))
NAME_TEXT = (f"1 to {MAX_NAME} characters from A-Z a-z 0-9 _ . -, the first a letter or a digit (the name goes "
             "into file names: no '/', no '..' at the start, no control character)")


def fmt(value) -> str:
    """A bound for messages and the page: 8, 0.5, 1e-15, 1e15 (exact: no rounding of the value)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    value = float(value)
    if value == int(value) and abs(value) < 1e7:
        return str(int(value))
    for digits in range(1, 18):
        text = f"{value:.{digits}g}"
        if float(text) == value:
            break
    return text.replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


@dataclass(frozen=True)
class Range:
    """An interval [lo, hi] (either end open or absent) or a set of choices."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()
    label: str = ""         # the range in words, when it says more than the interval (alpha: with N/4)

    def contains(self, value) -> bool:
        if value != value:          # NaN is in no range
            return False
        if self.choices:
            return value in self.choices
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        if self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi):
            return False
        return True

    def text(self, kind="number") -> str:
        """``a number > 0``, ``an integer in [8, 10000000]``, ``a number in (0.5, 4]``, ``one of a, b``."""
        if self.label:
            return self.label
        if self.choices:
            return "one of " + ", ".join(str(c) for c in self.choices)
        noun = "an integer" if kind == "integer" else "a number"
        if self.lo is not None and self.hi is not None:
            left, right = "(" if self.lo_open else "[", ")" if self.hi_open else "]"
            return f"{noun} in {left}{fmt(self.lo)}, {fmt(self.hi)}{right}"
        if self.lo is not None:
            return f"{noun} {'>' if self.lo_open else '>='} {fmt(self.lo)}"
        if self.hi is not None:
            return f"{noun} {'<' if self.hi_open else '<='} {fmt(self.hi)}"
        return f"any finite {'integer' if kind == 'integer' else 'number'}"


def least_every(steps, n):
    """The smallest ``sph.every`` whose samples of ``steps`` steps and N = ``n`` particles fit MAX_SAMPLE_BYTES."""
    return -(-steps // max(1, MAX_SAMPLE_BYTES // (n * 16) - 2))


@dataclass(frozen=True)
class Table:
    """A TOML table of a scene (``""`` the top level; ``paper.runs`` an array of tables)."""

    name: str
    required: bool
    doc: str
    array: bool = False


@dataclass(frozen=True)
class Key:
    """One key of a scene file.

    kind: ``name``, ``text``, ``choice``, ``number``, ``integer``, ``expression`` (a string or number over
    the variables in ``unit``'s row; ``range`` bounds its values), ``numbers`` / ``integers`` (a non-empty
    list, ``range`` bounds each item), ``window`` ([t0, t1]).  ``default``: the value used when the key is
    absent (None: stays absent; :data:`AUTO`: a rule of :mod:`sphrom.scene` chooses it, ``default_text``
    says which).  ``also``: the bounds that depend on other keys, checked by the loader.  ``why``: the
    reason of the bounds.  ``example``: a valid value (the tests load a scene with every key at its example).
    """

    table: str
    name: str
    kind: str
    required: bool
    unit: str = ""
    default: object = None
    range: Range | None = None
    doc: str = ""
    also: str = ""
    why: str = ""
    default_text: str = ""
    example: object = None
    variables: tuple = ()

    @property
    def path(self):
        return f"{self.table}.{self.name}" if self.table else self.name


POSITIVE = Range(lo=0.0, lo_open=True)
NONNEG = Range(lo=0.0)
SCALE_POSITIVE = Range(lo=1 / SCALE, hi=SCALE)
SCALE_SIGNED = Range(lo=-SCALE, hi=SCALE)
SCALE_NONNEG = Range(lo=0.0, hi=SCALE)
ALPHA_RANGE = Range(0.5, MAX_ALPHA, lo_open=True, label=f"0.5 < alpha < N/4 and alpha <= {MAX_ALPHA:g}")
WHY_TIME = f"in [0, {fmt(SCALE)}] s, the bounds of T"
WHY_ERROR = "a relative error: any finite number >= 0"

TABLES = [
    Table("", True, "The scene's identity: every key optional."),
    Table("domain", True, "The bar: its length and the simulated horizon."),
    Table("fields", True, "The fields of eqs. 2.2-2.4 as expressions over x [m] (and L, T)."),
    Table("force", False, "The external force per unit mass f(t) profile(x) (eq. 2.3); absent: no force."),
    Table("sph", True, "The full SPH discretisation (section 2.2)."),
    Table("snapshots", False, "The POD snapshots (sections 3.1.2-3.2.1): exactly one of count with window, times, "
                              "or times_v with times_rho.  Absent: chosen automatically (below)."),
    Table("rom", False, "The reduced models' mode counts.  Absent keys: chosen automatically (below)."),
    Table("paper", False, "The figures the paper reports for this scene, quoted beside ours by `sphrom validate` "
                          "and `sphrom sph`.  A scene of your own leaves it out: `sphrom validate` then measures the "
                          "full SPH against the exact solution (uniform c, rho0, d) or the continuum references, and "
                          "the POD and reduced models against the full SPH, with no paper column, no paper runs and "
                          "no snapshot studies; `sphrom sph` prints no paper line."),
    Table("paper.runs", False, "Further SPH settings the paper ran for this scene, with its errors.", array=True),
    Table("paper.snapshot_studies", False, "The paper's snapshot studies of this scene and their outcomes "
                                           "(`sphrom modes`, `sphrom validate`).", array=True),
]


def _snapshot_keys(table):
    return [
        Key(table, "count", "integer", False, "", None, Range(1, MAX_STEPS),
            "snapshots uniform in the window: t0 + i (t1 - t0)/count, i = 0..count-1",
            also="at most the steps of the run in the window; count x N x 16 bytes at most 4 GiB",
            why="a count beyond the run's steps would repeat snapshots", example=20),
        Key(table, "window", "window", False, "s", None, Range(0.0, SCALE),
            "[t0, t1], the time window of count (required with count)", also="t1 <= T when used",
            why=WHY_TIME, example=[0.0, 0.1]),
        Key(table, "times", "numbers", False, "s", None, Range(0.0, SCALE),
            "explicit snapshot times of both fields (rounded to the nearest step)", also="each <= T when used",
            why=WHY_TIME, example=[0.0, 0.05, 0.1]),
        Key(table, "times_v", "numbers", False, "s", None, Range(0.0, SCALE),
            "velocity snapshot times (with times_rho)", also="each <= T when used", why=WHY_TIME,
            example=[0.0, 0.05]),
        Key(table, "times_rho", "numbers", False, "s", None, Range(0.0, SCALE),
            "density snapshot times (with times_v)", also="each <= T when used", why=WHY_TIME,
            example=[0.0, 0.05, 0.1]),
        Key(table, "random", "integer", False, "", None, Range(0, MAX_SEED),
            "with count: count distinct random steps in the window, numpy default_rng(random)",
            why="a seed, stored as a 64-bit integer", example=0),
    ]


KEYS = [
    # -- the top level -----------------------------------------------------------------------------------------
    Key("", "name", "name", False, "", AUTO, None, "the scene's name: in output files, cache files, FMU names",
        why="names go into file names", default_text="the file name without .toml", example="my_bar"),
    Key("", "title", "text", False, "", AUTO, None, "one line saying what the scene is",
        why=f"at most {MAX_TEXT} printable characters (they go into HDF5 attributes and HTML)",
        default_text="the name", example="A bar of my own"),
    Key("", "section", "text", False, "", "", None, "the section of the paper the scene reproduces",
        why=f"at most {MAX_TEXT} printable characters", example="3.1"),
    Key("", "summary", "text", False, "", "", None, "a one-line summary of the settings",
        why=f"at most {MAX_TEXT} printable characters", example="v0 a sine, c = 0.1"),
    # -- [domain] ----------------------------------------------------------------------------------------------
    Key("domain", "L", "number", True, "m", None, SCALE_POSITIVE, "length of the periodic bar [0, L]",
        why=WHY_SCALE, example=1.0),
    Key("domain", "T", "number", True, "s", None, SCALE_POSITIVE, "simulated horizon [0, T] (the training run)",
        also="T >= dt", why=WHY_SCALE, example=0.1),
    # -- [fields] ----------------------------------------------------------------------------------------------
    Key("fields", "rho0", "expression", True, "kg m^-3", None, SCALE_POSITIVE,
        "initial (rest) density rho0(x)", why=WHY_SCALE, example="1", variables=("x", "L", "T")),
    Key("fields", "v0", "expression", False, "m s^-1", "0", SCALE_SIGNED, "initial velocity v0(x)",
        why=WHY_SCALE, example="1e-3*sin(2*pi*x/L)", variables=("x", "L", "T")),
    Key("fields", "c", "expression", True, "kg m^-1 s^-2", None, SCALE_POSITIVE, "Young's modulus c(x)",
        why=WHY_SCALE, example="0.1", variables=("x", "L", "T")),
    Key("fields", "d", "expression", False, "s^-1", "0", SCALE_NONNEG, "damping coefficient d(x)",
        why=WHY_SCALE, example="0", variables=("x", "L", "T")),
    # -- [force] -----------------------------------------------------------------------------------------------
    Key("force", "f", "expression", False, "m s^-2", "0", SCALE_SIGNED, "time history f(t) of the force per "
        "unit mass", why=WHY_SCALE, example="1e-3*cos(t)", variables=("t", "L", "T")),
    Key("force", "profile", "expression", False, "1", "1", SCALE_SIGNED, "spatial profile of the force: the "
        "force at x is f(t) profile(x)", why=WHY_SCALE, example="1", variables=("x", "L", "T")),
    # -- [sph] -------------------------------------------------------------------------------------------------
    Key("sph", "n_particles", "integer", True, "", None, Range(MIN_PARTICLES, MAX_PARTICLES),
        "N, particles at x_i = (i + 1/2) L/N", why=f"at least {MIN_PARTICLES} so that 0.5 < alpha < N/4 "
        "leaves room; at most 1e7, the memory and time of a run on one machine", example=32),
    Key("sph", "alpha", "number", False, "", 1.04, ALPHA_RANGE,
        "h / dx, the smoothing length over the particle spacing",
        why="above 0.5 each particle has neighbours; below N/4 the kernel support 2h stays below L/2 (the "
            f"minimum image); at most {MAX_ALPHA:g}: the operator stores 4 alpha + 1 neighbours per particle, "
            "2.7 GB at N = 1e7 and alpha = 4 (the paper uses 1.04 to 1.2)", example=1.04),
    Key("sph", "dt", "number", False, "s", AUTO, POSITIVE, "time step", also=f"dt <= T and T/dt <= {MAX_STEPS_TEXT} "
        "steps (so dt >= 1e-24 s); at most the stability limit of the integrator (refused above it, naming the "
        "limit)", why=f"at most {MAX_STEPS_TEXT} steps: at the cheapest step (N = 8, about a "
        "microsecond) 1e9 steps take the better part of an hour; above the stability limit the fastest mode grows "
        "at every step", example=1e-3, default_text="automatic (below)"),
    Key("sph", "integrator", "choice", False, "", "symplectic", Range(choices=("euler", "symplectic", "rk4")),
        "time integrator: euler (the paper's explicit Euler), symplectic (rho then v), rk4",
        why="the integrators the SPH has", example="euler", default_text="symplectic (below)"),
    Key("sph", "every", "integer", False, "", AUTO, Range(1, MAX_STEPS), "store a sample every `every` steps "
        "(the errors are measured on the samples)", also="at most 4 GiB of stored samples (v and rho)",
        why=f"at most the steps of the longest run, {MAX_STEPS_TEXT} (a larger every keeps only the first and the "
            "last sample)", example=10,
        default_text="automatic (below)"),
    # -- [snapshots] -------------------------------------------------------------------------------------------
    *_snapshot_keys("snapshots"),
    # -- [rom] -------------------------------------------------------------------------------------------------
    Key("rom", "modes", "integer", False, "", AUTO, Range(1, MAX_PARTICLES), "POD modes k of the reduced models "
        "(`sphrom pod`'s default)", also="modes <= N", why="a POD basis of N particles has at most N modes",
        example=4, default_text="automatic (below)"),
    Key("rom", "accel_modes", "integers", False, "", None, Range(1, MAX_PARTICLES), "the mode counts of the "
        "acceleration study (`sphrom bench`, `sphrom validate`); the FMU's default k is the largest",
        also="each <= N", why="a POD basis of N particles has at most N modes", example=[4],
        default_text="[modes]"),
    Key("rom", "n_freeze", "integers", False, "", "N_FREEZE", Range(1, MAX_FREEZE), "refresh periods of the "
        "frozen coefficients (eq. 2.23) the paper studied (the FMU's n_freeze is an option of `sphrom fmu`)",
        why="the FMU stores n_freeze as a 32-bit integer", example=[1, 10],
        default_text="[10] (harness/defaults.py N_FREEZE)"),
    # -- [paper] -----------------------------------------------------------------------------------------------
    Key("paper", "figures", "text", False, "", None, None, "the paper's figures of this scene",
        why=f"at most {MAX_TEXT} printable characters", example="3.1-3.11"),
    Key("paper", "reference", "choice", True, "", None, Range(choices=("analytic", "fd")), "the paper's "
        "reference solution", why="the references the paper used", example="analytic"),
    Key("paper", "reference_dx", "number", False, "m", None, POSITIVE, "grid spacing of the paper's FD "
        "reference", also=f"L / reference_dx <= {MAX_REFERENCE_CELLS:.0e} cells".replace("e+0", "e"),
        why="the FD grid's memory", example=5e-3),
    Key("paper", "reference_dt", "number", False, "s", None, POSITIVE, "time step of the paper's FD reference",
        also=f"T / reference_dt <= {MAX_STEPS_TEXT} steps", why="as sph.dt", example=1e-4),
    Key("paper", "sph_error_v", "number", True, "", None, NONNEG, "the paper's relative L2 error of v (eq. 3.4)",
        why=WHY_ERROR, example=4.5e-2),
    Key("paper", "sph_error_rho", "number", False, "", None, NONNEG, "the paper's relative L2 error of rho",
        why=WHY_ERROR, example=3.6e-4),
    Key("paper", "mode_threshold", "integer", False, "", None, Range(1, MAX_PARTICLES), "the paper's mode "
        "threshold (smallest k whose POD-MOR error is below the SPH error)", also="<= N",
        why="at most N modes", example=7),
    Key("paper", "cpu_saving", "number", False, "", None, Range(0.0, 1.0), "the paper's CPU saving of the frozen "
        "model, a fraction", why="a fraction", example=0.9),
    Key("paper", "modified_reference_beta", "number", False, "", None, POSITIVE, "the derivative factor of "
        "eq. C.5 (with eq. B.5) of the modified reference", why="a factor > 0", example=1.022),
    Key("paper", "modified_reference_error_v", "number", False, "", None, NONNEG, "the paper's v error against "
        "the modified reference", why=WHY_ERROR, example=0.1),
    Key("paper", "notes", "text", False, "", None, None, "remarks", why=f"at most {MAX_TEXT} printable "
        "characters", example="our choices"),
    Key("paper.runs", "n_particles", "integer", True, "", None, Range(MIN_PARTICLES, MAX_PARTICLES), "N",
        why="as sph.n_particles", example=16),
    Key("paper.runs", "alpha", "number", True, "", None, ALPHA_RANGE, "h / dx", why="as sph.alpha", example=1.06),
    Key("paper.runs", "dt", "number", True, "s", None, POSITIVE, "time step", also="dt <= T, T/dt <= 1e9",
        why="as sph.dt", example=2e-3),
    Key("paper.runs", "sph_error_v", "number", True, "", None, NONNEG, "the paper's v error", why=WHY_ERROR,
        example=0.19),
    Key("paper.runs", "sph_error_rho", "number", False, "", None, NONNEG, "the paper's rho error",
        why=WHY_ERROR, example=1.4e-4),
    Key("paper.runs", "note", "text", False, "", None, None, "what the setting is", why=f"at most {MAX_TEXT} "
        "printable characters", example="N = 16"),
    *_snapshot_keys("paper.snapshot_studies"),
    Key("paper.snapshot_studies", "figure", "text", False, "", None, None, "the paper's figure",
        why=f"at most {MAX_TEXT} printable characters", example="3.5"),
    Key("paper.snapshot_studies", "outcome", "choice", True, "", None,
        Range(choices=("works", "fails", "critical", "larger_error")), "what the paper found",
        why="the outcomes `sphrom modes` compares", example="works"),
    Key("paper.snapshot_studies", "mode_threshold", "integer", False, "", None, Range(1, MAX_PARTICLES),
        "the paper's mode threshold with these snapshots", also="<= N", why="at most N modes", example=7),
    Key("paper.snapshot_studies", "note", "text", False, "", None, None, "remarks",
        why=f"at most {MAX_TEXT} printable characters", example="the minimum data"),
]

_BY_PATH = {k.path: k for k in KEYS}


def key(path) -> Key:
    """The :class:`Key` of a dotted path (``domain.L``, ``paper.runs.dt``)."""
    return _BY_PATH[path]


def accepted_keys():
    """Every dotted key path the loader accepts, in the table's order."""
    return [k.path for k in KEYS]


# ----------------------------------------------------------------------------------------------------------------
# formatting
# ----------------------------------------------------------------------------------------------------------------
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxstring, _REPR.maxother, _REPR.maxlist, _REPR.maxdict = 2, 60, 60, 6, 4


def shown(value) -> str:
    """A user's value in a message: repr (floats exactly, strings escaped, so one line), shortened."""
    if isinstance(value, float):
        return repr(value)
    return _REPR.repr(value)


def type_name(kind):
    return {"name": "a string", "text": "a string", "choice": "a string", "number": "a number",
            "integer": "an integer", "expression": "an expression string or number",
            "numbers": "a list of numbers", "integers": "a list of integers", "window": "a list [t0, t1]"}[kind]


# ----------------------------------------------------------------------------------------------------------------
# checking the TOML text and its tables
# ----------------------------------------------------------------------------------------------------------------
def check_text_size(text_bytes_len, source):
    if text_bytes_len > MAX_FILE_BYTES:
        raise UserError(f"{source}: {text_bytes_len} bytes is out of range (allowed: a scene file of at most "
                        f"{MAX_FILE_BYTES} bytes)")


# The TOML tokens that matter for nesting: strings (multi-line first, a run of up to two more quotes closing them),
# comments, brackets, '=' and newlines.  An unterminated string ends at the line's end (the parser then refuses it).
_TOKENS = re.compile("|".join([
    r'"""(?:[^"\\]|\\.|"(?!""))*"""+',      # multi-line basic string
    r"'''(?:[^']|'(?!''))*'''+",                # multi-line literal string
    r'"(?:[^"\\\n]|\\.)*"?',                 # basic string
    r"'[^'\n]*'?",                             # literal string
    r"#[^\n]*",                                # comment
    r"[\[\]{}=\n]"]), re.S)


def check_nesting(text, source):
    """UserError naming the line and key where ``[`` / ``{`` nest deeper than :data:`MAX_DEPTH` (outside strings
    and comments), before the TOML parser (which recurses, and raised RecursionError at 2,000 levels)."""
    depth, line, line_start, current_key = 0, 1, 0, ""
    for m in _TOKENS.finditer(text):
        token = m.group()
        if token == "\n":
            line, line_start = line + 1, m.end()
        elif token == "=":
            if depth == 0:
                current_key = text[line_start:m.start()].strip()
        elif token in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                where = f"{current_key}: " if current_key else ""
                raise UserError(f"{source}: {where}line {line}: nested more than {MAX_DEPTH} levels deep (allowed: "
                                f"at most {MAX_DEPTH} levels of [ ] and {{ }}; a scene needs 2)")
        elif token in "]}":
            depth = max(0, depth - 1)
        else:                                   # a string or a comment: only its newlines count
            line += token.count("\n")


def _fail(source, path, detail):
    raise UserError(f"{source}: {path}: {detail}")


def _check_text(value, source, path, name=False):
    if name:
        if not NAME_PATTERN.fullmatch(value):
            _fail(source, path, f"{shown(value)} is out of range (allowed: {NAME_TEXT})")
        return value
    if len(value) > MAX_TEXT or any(unicodedata.category(ch).startswith("C") for ch in value):
        _fail(source, path, f"{shown(value)} is out of range (allowed: at most {MAX_TEXT} printable characters, "
                            "no control character)")
    return value


def _check_number(value, k, source, path, integer):
    if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
        allowed = k.range.text("integer" if integer else "number") if k.range else ""
        _fail(source, path, f"expected {'an integer' if integer else 'a number'}, got {shown(value)}"
                            + (f" (allowed: {allowed})" if allowed else ""))
    if not integer:
        value = float(value)
        if not math.isfinite(value):
            _fail(source, path, f"{shown(value)} is out of range (allowed: a finite number"
                                + (f", {k.range.text()}" if k.range else "") + ")")
    if k.range is not None and not k.range.contains(value):
        allowed = k.range.text("integer" if integer else "number")
        _fail(source, path, f"{shown(value)} is out of range (allowed: {allowed})")
    return value


def check_value(value, k: Key, source, path=None):
    """The value of key ``k`` checked for type and static range (lists item by item); UserError naming
    ``source`` and the key's path."""
    path = path or k.path
    kind = k.kind
    if kind in ("name", "text", "choice"):
        if not isinstance(value, str):
            allowed = (NAME_TEXT if kind == "name" else k.range.text() if kind == "choice" else
                       f"at most {MAX_TEXT} printable characters")
            _fail(source, path, f"expected a string, got {shown(value)} (allowed: {allowed})")
        if kind == "choice":
            if not k.range.contains(value):
                _fail(source, path, f"{shown(value)} is out of range (allowed: {k.range.text()})")
            return value
        return _check_text(value, source, path, name=kind == "name")
    if kind in ("number", "integer"):
        return _check_number(value, k, source, path, kind == "integer")
    if kind == "expression":
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            _fail(source, path, f"expected {type_name(kind)}, got {shown(value)}")
        return value
    if kind in ("numbers", "integers", "window"):
        if not isinstance(value, list):
            _fail(source, path, f"expected {type_name(kind)}, got {shown(value)}")
        if not value:
            _fail(source, path, f"[] is out of range (allowed: a non-empty list)")
        items = [_check_number(v, k, source, f"{path}[{i}]", kind == "integers") for i, v in enumerate(value)]
        if kind == "window" and not (len(items) == 2 and items[0] < items[1]):
            _fail(source, path, f"{shown(value)} is out of range (allowed: [t0, t1] with 0 <= t0 < t1 <= "
                                f"{fmt(SCALE)})")
        return items
    raise AssertionError(kind)


def _check_one(table_name, raw, source, where):
    """Validate one table's dict (``where``: its path in messages); returns the checked values."""
    if not isinstance(raw, dict):
        _fail(source, where, f"expected a table, got {shown(raw)}")
    keys = [k for k in KEYS if k.table == table_name]
    children = [t for t in TABLES if t.name and t.name.rpartition(".")[0] == table_name]
    allowed = [k.name for k in keys] + [t.name.rpartition(".")[2] for t in children]
    for name in raw:
        if name not in allowed:
            here = f"{where}.{name}" if where else name
            _fail(source, here, f"unknown key {shown(name)} (allowed: {', '.join(allowed)})")
    out = {}
    for k in keys:
        here = f"{where}.{k.name}" if where else k.name
        if k.name not in raw:
            if k.required:
                _fail(source, here, f"missing key ({type_name(k.kind)} required: {k.doc})")
            continue
        out[k.name] = check_value(raw[k.name], k, source, here)
    for t in children:
        short = t.name.rpartition(".")[2]
        here = f"{where}.{short}" if where else short
        if short not in raw:
            if t.required:
                _fail(source, here, f"missing table [{t.name}] ({t.doc})")
            continue
        if t.array:
            value = raw[short]
            if not isinstance(value, list):
                _fail(source, here, f"expected an array of tables [[{t.name}]], got {shown(value)}")
            out[short] = [_check_one(t.name, item, source, f"{here}[{i}]") for i, item in enumerate(value)]
        else:
            out[short] = _check_one(t.name, raw[short], source, here)
    return out


def check_scene_tables(raw, source):
    """Every key of a parsed scene checked against :data:`KEYS` (names, types, static ranges), as nested dicts
    of the values given (defaults are the loader's: :mod:`sphrom.scene`)."""
    return _check_one("", raw, source, "")
