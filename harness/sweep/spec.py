"""SPEC.toml of ``sphrom sweep``: parsing, validation, entries, force shapes.

A spec names a scene and grids; their Cartesian product is the study::

    title = "tenmode: forces against damping"     # optional
    scene = "tenmode"          # built-in name, or a scene TOML (relative to this file)
    t_end = 10.0               # co-simulation horizon [s] (default: the scene's T)
    step = 0.01                # communication step [s]; t_end a whole number of steps
    window = [5.0, 10.0]       # window of the probe statistics [s] (default [0, t_end])
    probes = [0.25, 0.5, 0.66] # probe positions x/L (outputs v_probe_j, rho_probe_j)
    fmi = 2                    # FMI version of the FMUs (2 or 3)
    compare_sph = false        # true, false, or a sub-grid: { shape = ["sine"], d = [0.1] }
    parametric = true          # default: one parametric FMU over grid.c / grid.d (below); false: one per value

    [grid]                     # each a list, a single value, or {start, stop, count, spacing}
    shape = ["sine", "square"] # sine, cosine, square, chirp, step, or an expression in t, T, A, F
    amplitude = [1e-3, 1e-2]   # A [m s^-2]
    frequency = { start = 0.05, stop = 2.0, count = 20, spacing = "log" }   # F [Hz]
    c = [0.1]                  # Young's modulus [kg m^-1 s^-2]   } set per run on one parametric FMU, or
    d = [0.1, 1.0]             # damping [s^-1]                   } (parametric = false) a scene variant each
    profile = ["1"]            # force profile over x (expression) } a scene variant each: own full SPH run,
                                                                   # POD basis and FMU
    k = [12]                   # POD modes                         }
    model = ["frozen"]         # frozen | exact                    }
    n_freeze = [10]            # refresh period, an FMU parameter set per run

    [parametric]               # optional: ONE parametric FMU over these ranges (sphrom fmu --vary) instead
    c = [0.05, 0.2]            # of one FMU (full SPH run, POD) per value of grid.c / grid.d; every grid
    d = [0.0, 5.0]             # value must lie inside its range; c and d are set per run as FMU parameters

Without a ``[parametric]`` table, a grid.c or grid.d of two or more values on a scene with uniform c and d
gets the same by default: ONE parametric FMU per (profile, k, model) trained over [min, max] of the grid's
values of each varied parameter (frozen and exact models; a note says so).  ``parametric = false`` (a top-level
key) opts out: one FMU, with its own full SPH run and POD, per value, as a table-less spec had before.  A scene
with a non-uniform c or d, or a model that cannot be parametric (balanced), falls back to one FMU per value
with a note naming the field or model.

The force is f(t) = shape(t; A, F) at the communication points t_j = j step,
held over each step (the FMU's input), times the variant's profile(x).
Built-in shapes (T = t_end): sine A sin(2 pi F t), cosine A cos(2 pi F t),
square A sign(sin(2 pi F t)), chirp A sin(pi F t^2 / T) (the frequency rises
linearly from 0 to F at T), step A.

Every entry has an id: a hash of its inputs (and of the scene's text), so
that a rerun recognises finished entries whatever the order of the grids.

Every mistake is a :class:`~sphrom.errors.UserError` naming the file, the
field and the allowed range, raised before any work.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import sys
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .. import defaults
from ..errors import UserError, exact
from ..expr import compile_expr, shown
from ..fmu.make.options import default_modes
from ..fmu.resources import MAX_PROBES
from ..paths import exists, is_file, not_a_file
from ..scene import builtin_dir, derive_scene, load_scene

SHAPES = {
    "sine": "A*sin(2*pi*F*t)",
    "cosine": "A*cos(2*pi*F*t)",
    "square": "A*sign(sin(2*pi*F*t))",
    "chirp": "A*sin(pi*F*t**2/T)",
    "step": "A",
}
SCENE_GRIDS = ("c", "d", "profile", "k", "model")       # one FMU per combination
PARAMETER_GRIDS = ("c", "d")                             # ... or one parametric FMU over their values
PARAMETRIC_MODELS = ("frozen", "exact")                  # the POD models sphrom.fmu.make.parametric can make
RUN_GRIDS = ("shape", "amplitude", "frequency", "n_freeze")
GRIDS = SCENE_GRIDS + RUN_GRIDS
TOP_KEYS = ("title", "scene", "t_end", "step", "window", "probes", "fmi", "compare_sph", "grid", "parametric")
MAX_ENTRIES = 1_000_000
MAX_STEPS = 10_000_000
DEFAULT_STEP = defaults.STEP
DEFAULT_FREEZE = defaults.N_FREEZE
UNITS = {"amplitude": "m s^-2", "frequency": "Hz", "c": "kg m^-1 s^-2", "d": "s^-1", "t_end": "s", "step": "s",
         "window": "s"}


@dataclass(frozen=True)
class Entry:
    """One co-simulation of the study (and its full SPH run when compared).

    Attributes
    ----------
    id : str
        16 hex digits, a hash of every input below (not of ``index``).
    index : int
        Position in the expanded grid (for ordering only).
    scene, scene_sha : str
        Scene name and a hash of its TOML text.
    c, d : float or None
        Young's modulus [kg m^-1 s^-2] and damping [s^-1]; None: the scene's.
    profile : str or None
        Force profile expression over x; None: the scene's.
    k : int
        POD modes.
    model : str
        ``frozen`` or ``exact``.
    shape : str
        Built-in shape name or expression in t, T, A, F.
    amplitude : float
        A [m s^-2].
    frequency : float
        F [Hz].
    n_freeze : int
        Refresh period of the frozen coefficients (the FMU parameter).
    t_end, step : float
        Horizon and communication step [s].
    window : tuple of float
        Window of the probe statistics [s].
    probes : tuple of float
        Probe positions x/L.
    fmi : int
    compare_sph : bool
        Also run the full SPH at the same settings and compare.
    """

    id: str
    index: int
    scene: str
    scene_sha: str
    c: float | None
    d: float | None
    profile: str | None
    k: int
    model: str
    shape: str
    amplitude: float
    frequency: float
    n_freeze: int
    t_end: float
    step: float
    window: tuple
    probes: tuple
    fmi: int
    compare_sph: bool
    parametric: tuple = ()      # ((name, lo, hi), ...): c / d set per run on one parametric FMU

    def variant_inputs(self):
        """What selects the FMU: (scene_sha, c, d, profile, k, model, fmi, probes), and the parametric ranges
        (a parameter of a parametric FMU does not select it: its c or d is None)."""
        names = {p[0] for p in self.parametric}
        base = (self.scene_sha, None if "c" in names else self.c, None if "d" in names else self.d, self.profile,
                self.k, self.model, self.fmi, self.probes)
        return base + ((self.parametric,) if self.parametric else ())

    def parameter_values(self, scene):
        """{name: value} of the parameters set on a parametric FMU (the scene's value where the grid has None)."""
        return {name: (getattr(self, name) if getattr(self, name) is not None else scene_value(scene, name))
                for name, _, _ in self.parametric}

    def as_dict(self):
        return asdict(self)


@dataclass
class Spec:
    """A validated spec.

    Attributes
    ----------
    source : str
        The file, for messages.
    text : str
        Its TOML text (stored in the results).
    scene : Scene
        The base scene.
    entries : list of Entry
    notes : list of str
        What the spec decided that a user should know (the parametric FMU and its ranges, or why not).
    grids : dict
        Grid name -> list of values as expanded (None: the scene's value).
    compare : dict or bool
        The ``compare_sph`` setting as given.
    """

    source: str
    text: str
    title: str
    scene: object
    t_end: float
    step: float
    window: tuple
    probes: tuple
    fmi: int
    grids: dict
    compare: object
    entries: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    @property
    def steps(self):
        """Communication steps per run."""
        return int(round(self.t_end / self.step))


def _fail(where, message):
    raise UserError(f"{where}: {message}")


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _number(value, where, check=None, allowed="a finite number"):
    if not _is_number(value) or not math.isfinite(value):
        _fail(where, f"{value!r} is out of range (allowed: {allowed})")
    value = float(value)
    if check is not None and not check(value):
        _fail(where, f"{value!r} is out of range (allowed: {allowed})")
    return value


def _integer(value, where, lo, hi, allowed):
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        _fail(where, f"{value!r} is out of range (allowed: {allowed})")
    return int(value)


def _range_values(table, where, check, allowed):
    """{start, stop, count, spacing} -> list of floats."""
    keys = {"start", "stop", "count", "spacing"}
    unknown = sorted(set(table) - keys)
    if unknown:
        _fail(f"{where}.{unknown[0]}", f"unknown key (allowed: start, stop, count, spacing)")
    for key in ("start", "stop", "count"):
        if key not in table:
            _fail(f"{where}.{key}", "missing key (a range needs start, stop, count)")
    start = _number(table["start"], f"{where}.start", check, allowed)
    stop = _number(table["stop"], f"{where}.stop", check, allowed)
    count = _integer(table["count"], f"{where}.count", 1, 100_000, "an integer in [1, 100000]")
    spacing = table.get("spacing", "linear")
    if spacing not in ("linear", "log"):
        _fail(f"{where}.spacing", f"{spacing!r} is out of range (allowed: linear, log)")
    if spacing == "log":
        if not (start > 0 and stop > 0):
            _fail(where, "a log range needs start > 0 and stop > 0")
        values = np.geomspace(start, stop, count)
    else:
        values = np.linspace(start, stop, count)
    # 12 significant digits: the same spec gives the same ids on any machine
    return [float(f"{v:.12g}") for v in values]


def _grid_values(raw, name, where, scene):
    """Validated list of values of grid ``name`` (``raw`` as in the file)."""
    here = f"{where}: grid.{name}"
    numeric = {
        "amplitude": (None, "a finite number [m s^-2]"),
        "frequency": (lambda v: v >= 0, "a finite number >= 0 [Hz]"),
        "c": (lambda v: v > 0, "a finite number > 0 [kg m^-1 s^-2]"),
        "d": (lambda v: v >= 0, "a finite number >= 0 [s^-1]"),
    }
    if isinstance(raw, dict):
        if name not in numeric:
            _fail(here, "a {start, stop, count} range is for amplitude, frequency, c, d only")
        check, allowed = numeric[name]
        return _range_values(raw, here, check, allowed)
    values = raw if isinstance(raw, list) else [raw]
    if not values:
        _fail(here, "an empty list (allowed: at least one value)")
    out = []
    for i, value in enumerate(values):
        at = f"{here}[{i}]" if isinstance(raw, list) else here
        if name in numeric:
            check, allowed = numeric[name]
            out.append(_number(value, at, check, allowed))
        elif name == "n_freeze":              # the FMU's parameter: its range and words (harness/fmu/variables.py)
            from ..fmu.variables import BY_NAME, allowed_words
            row = BY_NAME["n_freeze"]
            out.append(_integer(value, at, row.min, row.max, allowed_words(row)))
        elif name == "k":
            n = scene.sph.n_particles
            out.append(_integer(value, at, 1, n, f"an integer in [1, N = {n}]"))
        elif name == "model":
            from ..rom.registry import fmu_model_names          # the models an FMU can hold
            if value not in fmu_model_names():
                _fail(at, f"{value!r} is out of range (allowed: {', '.join(fmu_model_names())})")
            out.append(value)
        elif name == "shape":
            if not isinstance(value, str) or not value.strip():
                _fail(at, f"{value!r} is out of range (allowed: {', '.join(SHAPES)}, or an expression in t, T, A, F)")
            compile_expr(SHAPES.get(value, value), ("t", "T", "A", "F"), at)
            out.append(value)
        elif name == "profile":
            if isinstance(value, bool) or not isinstance(value, (str, int, float)):
                _fail(at, f"{value!r} is out of range (allowed: an expression in x, L, T)")
            compile_expr(value, ("x", "L", "T"), at)
            out.append(str(value))
    if len(set(out)) != len(out):
        _fail(here, "a value is repeated (allowed: distinct values)")
    return out


def shape_expr(shape):
    """The compiled force shape (an :class:`~sphrom.expr.Expr` in t, T, A, F)."""
    return compile_expr(SHAPES.get(shape, shape), ("t", "T", "A", "F"), f"shape {shown(shape)}")


def force_at(entry, times):
    """f(t) [m s^-2] of ``entry`` at ``times`` [s] (may be non-finite: the caller checks)."""
    times = np.asarray(times, dtype=float)
    expr = shape_expr(entry.shape)
    value = expr(t=times, T=entry.t_end, A=entry.amplitude, F=entry.frequency)
    return np.broadcast_to(value, times.shape).astype(float)


def scene_value(scene, name):
    """A uniform field of the scene as a number (its text parsed), else nan."""
    try:
        return float(scene.fields[name].text)
    except ValueError:
        return float("nan")


def resolve_scene(value, where, spec_path):
    """The base scene: a built-in name, else a path (relative to the spec's folder)."""
    if not isinstance(value, str) or not value.strip():
        _fail(f"{where}: scene", f"{value!r} is out of range (allowed: a built-in scene name or a scene TOML path)")
    if exists(builtin_dir() / f"{value}.toml") and not value.endswith(".toml"):
        return load_scene(value)
    path = Path(value)
    if not path.is_absolute() and spec_path is not None:
        path = Path(spec_path).parent / path
    if not is_file(path):
        from ..scene import builtin_names
        _fail(f"{where}: scene", f"'{value}' not found (allowed: a built-in scene, {', '.join(builtin_names())}, "
                                 f"or a scene TOML path relative to the spec)")
    return load_scene(path)


def _compare_selection(raw, grids, where):
    """compare_sph -> a predicate on an entry's inputs (dict)."""
    here = f"{where}: compare_sph"
    if isinstance(raw, bool):
        return lambda inputs: raw
    if not isinstance(raw, dict):
        _fail(here, f"{raw!r} is out of range (allowed: true, false, or a table of grid values)")
    subset = {}
    for name, value in raw.items():
        if name not in GRIDS:
            _fail(f"{here}.{name}", f"unknown key (allowed: {', '.join(GRIDS)})")
        values = value if isinstance(value, list) else [value]
        grid = grids[name]
        for v in values:
            if (float(v) if _is_number(v) and name not in ("k", "n_freeze") else v) not in grid:
                _fail(f"{here}.{name}", f"{v!r} is not a value of grid.{name} (allowed: "
                                        f"{', '.join(repr(g) for g in grid)})")
        subset[name] = [float(v) if _is_number(v) and name not in ("k", "n_freeze") else v for v in values]
    return lambda inputs: all(inputs[name] in values for name, values in subset.items())


def entry_id(inputs):
    """16 hex digits of sha256 over the entry's inputs (canonical JSON)."""
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def parse_spec(text, source="<spec>", spec_path=None) -> Spec:
    """Parse and validate spec TOML ``text``; ``source`` names it in errors.

    Raises
    ------
    UserError
        Naming the file, the field and the allowed range.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{source}: not valid TOML ({exc})") from None
    unknown = sorted(set(raw) - set(TOP_KEYS))
    if unknown:
        _fail(f"{source}: {unknown[0]}", f"unknown key (allowed: {', '.join(TOP_KEYS)})")
    if "scene" not in raw:
        _fail(f"{source}: scene", "missing key (a built-in scene name or a scene TOML path)")
    if "grid" not in raw or not isinstance(raw["grid"], dict):
        _fail(f"{source}: grid", "missing table [grid] (at least amplitude)")
    title = raw.get("title", "")
    if not isinstance(title, str):
        _fail(f"{source}: title", "expected a string")
    scene = resolve_scene(raw["scene"], source, spec_path)

    t_end = _number(raw.get("t_end", scene.T), f"{source}: t_end", lambda v: v > 0, "a finite number > 0 [s]")
    step = _number(raw.get("step", min(DEFAULT_STEP, t_end)), f"{source}: step", lambda v: 0 < v <= t_end,
                   f"a finite number in (0, t_end = {t_end:g}] [s]")
    ratio = t_end / step
    if ratio > MAX_STEPS:               # before round(): t_end 1e308 over a small step is inf
        _fail(f"{source}: step", f"{step!r} gives {ratio:.3g} steps to t_end = {t_end:g} s "
                                 f"(allowed: at most {MAX_STEPS})")
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        _fail(f"{source}: step", f"{step!r} is out of range (allowed: t_end / step a whole number; "
                                 f"t_end / step = {ratio:.6g})")
    if round(ratio) > MAX_STEPS:
        _fail(f"{source}: step", f"{step!r} gives {round(ratio)} steps (allowed: at most {MAX_STEPS})")
    window = raw.get("window", [0.0, t_end])
    if not (isinstance(window, list) and len(window) == 2 and all(_is_number(w) for w in window)
            and 0 <= window[0] < window[1] <= t_end * (1 + 1e-12)):
        _fail(f"{source}: window", f"{window!r} is out of range (allowed: [t0, t1] with 0 <= t0 < t1 <= "
                                   f"t_end = {t_end:g} [s])")
    window = (float(window[0]), float(window[1]))
    probes = raw.get("probes", [0.25, 0.5, 0.66])
    if not (isinstance(probes, list) and 1 <= len(probes) <= MAX_PROBES):
        _fail(f"{source}: probes", f"{probes!r} is out of range (allowed: a list of 1 to {MAX_PROBES} "
                                   f"distinct positions x/L in [0, 1))")
    probes = tuple(_number(p, f"{source}: probes[{i}]", lambda v: 0 <= v < 1,
                           "a position x/L in [0, 1) (the bar is periodic: 1 is 0)")
                   for i, p in enumerate(probes))
    if len(set(probes)) != len(probes):
        _fail(f"{source}: probes", f"{list(probes)!r} gives a position twice (allowed: distinct positions x/L)")
    fmi = raw.get("fmi", 2)
    if fmi not in (2, 3) or isinstance(fmi, bool):
        _fail(f"{source}: fmi", f"{fmi!r} is out of range (allowed: 2 or 3)")

    grid_raw = raw["grid"]
    unknown = sorted(set(grid_raw) - set(GRIDS))
    if unknown:
        _fail(f"{source}: grid.{unknown[0]}", f"unknown key (allowed: {', '.join(GRIDS)})")
    if "amplitude" not in grid_raw:
        _fail(f"{source}: grid.amplitude", "missing key (a list of force amplitudes [m s^-2])")
    defaults = {"shape": ["sine"], "c": [None], "d": [None], "profile": [None], "k": [default_modes(scene)],
                "model": ["frozen"], "n_freeze": [DEFAULT_FREEZE]}
    grids = {}
    for name in GRIDS:
        if name in grid_raw:
            grids[name] = _grid_values(grid_raw[name], name, source, scene)
        elif name == "frequency":
            uses_f = [s for s in grids["shape"] if shape_expr(s).depends_on("F")]
            if uses_f:
                _fail(f"{source}: grid.frequency", f"missing key (shape {uses_f[0]!r} uses the frequency F [Hz])")
            grids[name] = [0.0]
        else:
            grids[name] = defaults[name]
    count = math.prod(len(v) for v in grids.values())
    if count > MAX_ENTRIES:
        _fail(f"{source}: grid", f"{count} entries (allowed: at most {MAX_ENTRIES})")
    compare = raw.get("compare_sph", False)
    selected = _compare_selection(compare, grids, source)

    notes = []
    parametric, auto = _parametric_ranges(raw.get("parametric"), grids, scene, source, notes)
    variants = _check_variants(scene, grids, source)
    scene_sha = hashlib.sha256(scene.text.encode()).hexdigest()[:16]
    entries = []
    for index, combo in enumerate(itertools.product(*(grids[n] for n in GRIDS))):
        inputs = dict(zip(GRIDS, combo))
        cmp = bool(selected(inputs))
        key = {**inputs, "scene_sha": scene_sha, "t_end": t_end, "step": step, "window": list(window),
               "probes": list(probes), "fmi": fmi, "compare_sph": cmp}
        shared = parametric if not auto or inputs["model"] in PARAMETRIC_MODELS else ()
        if shared:
            key["parametric"] = [list(p) for p in shared]
        entries.append(Entry(id=entry_id(key), index=index, scene=scene.name, scene_sha=scene_sha,
                             t_end=t_end, step=step, window=window, probes=probes, fmi=fmi, compare_sph=cmp,
                             parametric=shared, **inputs))
    if auto and parametric:
        others = [m for m in grids["model"] if m not in PARAMETRIC_MODELS]
        if others:
            varied = " and ".join("grid." + p[0] for p in parametric)
            notes.append(f"grid.model: {', '.join(others)} cannot be parametric: one FMU per value of {varied} "
                         f"for {'it' if len(others) == 1 else 'them'}")
    if any(e.compare_sph for e in entries):
        dt = scene.sph.dt
        r = step / dt
        if abs(r - round(r)) > 1e-9 * max(1.0, r):
            _fail(f"{source}: step", f"{step!r} is out of range with compare_sph (allowed: a whole number of "
                                     f"SPH steps dt = {dt:g} s)")
    spec = Spec(source=source, text=text, title=title, scene=scene, t_end=t_end, step=step, window=window,
                probes=probes, fmi=fmi, grids=grids, compare=compare, entries=entries, notes=notes)
    spec.variants = variants
    return spec


def _parametric_ranges(raw, grids, scene, source, notes):
    """The ``parametric`` key -> (((name, lo, hi), ...) sorted by name, automatic); () when there is none.

    A table: each key c or d, [lo, hi] with 0 < lo < hi (c) or 0 <= lo < hi (d); the scene's field uniform; every
    value of grid.c / grid.d (the scene's value where the grid has none) inside [lo, hi].  Absent or ``true``: the
    grid's own [min, max] of each of c, d with two or more values (:func:`_automatic_ranges`); ``false``: none.
    Appends to ``notes`` what was decided.
    """
    if raw is None or raw is True:
        return _automatic_ranges(grids, scene, source, notes), True
    if raw is False:
        return (), False
    here = f"{source}: parametric"
    if not isinstance(raw, dict) or not raw:
        _fail(here, f"{raw!r} is out of range (allowed: true, false, or a table with c = [lo, hi] and/or "
                    f"d = [lo, hi])")
    out = []
    for name in sorted(raw):
        at = f"{here}.{name}"
        if name not in ("c", "d"):
            _fail(at, "unknown key (allowed: c, d)")
        value = raw[name]
        # a subnormal bound (below 2.2e-308) keeps only a few of its digits
        lo_ok = (lambda v: v >= sys.float_info.min) if name == "c" else (lambda v: v == 0 or v >= sys.float_info.min)
        if not (isinstance(value, list) and len(value) == 2 and all(_is_number(v) and math.isfinite(v)
                                                                    for v in value)
                and lo_ok(value[0]) and value[0] < value[1]):
            _fail(at, f"{value!r} is out of range (allowed: [lo, hi] with {'0 < lo' if name == 'c' else '0 <= lo'}"
                      f" < hi [{UNITS[name]}], lo 0 or a normal number >= {sys.float_info.min:.4g})")
        lo, hi = float(value[0]), float(value[1])
        base = scene_value(scene, name)
        if math.isnan(base):
            _fail(at, f"scene '{scene.name}' has a non-uniform {name} (fields.{name} = "
                      f"{scene.fields[name].text!r}); a parametric FMU needs a uniform {name}")
        for v in grids[name]:
            v = base if v is None else v
            if not lo <= v <= hi:
                _fail(f"{source}: grid.{name}", f"{v!r} is outside the parametric range [{exact(lo)}, {exact(hi)}] "
                                                f"(allowed: values inside parametric.{name})")
        out.append((name, lo, hi))
    _note_parametric(out, grids, notes, "the [parametric] table")
    return tuple(out), False


def _automatic_ranges(grids, scene, source, notes):
    """((name, min, max), ...) of grid.c / grid.d with two or more values, when the scene's c and d are uniform
    (a parametric model needs both: :func:`sphrom.rom.parametric.parameter_space`); else () with a note."""
    varied = [name for name in PARAMETER_GRIDS if len(grids[name]) > 1]
    if not varied:
        return ()
    for name in PARAMETER_GRIDS:
        if math.isnan(scene_value(scene, name)):
            grids_text = " and ".join(f"grid.{v}" for v in varied)
            notes.append(f"{grids_text}: one FMU per value (its own full SPH run and POD): scene '{scene.name}' "
                         f"has a non-uniform {name} (fields.{name} = {scene.fields[name].text!r}), and a "
                         f"parametric FMU needs uniform c and d")
            return ()
    out = tuple((name, min(grids[name]), max(grids[name])) for name in varied)
    _note_parametric(out, grids, notes, "the grid's [min, max]; parametric = false for one FMU per value")
    return out


def _note_parametric(ranges, grids, notes, origin):
    counts = ", ".join(f"{len(grids[name])} value{'s' if len(grids[name]) > 1 else ''} of grid.{name}"
                       for name, _, _ in ranges)
    spans = ", ".join(f"{name} in [{exact(lo)}, {exact(hi)}]" for name, lo, hi in ranges)
    notes.append(f"{counts}: one parametric FMU over {spans} ({origin}), {' and '.join(n for n, _, _ in ranges)} "
                 f"set per run")


def _check_variants(scene, grids, source):
    """Build (and so validate) every scene variant; returns {(c, d, profile): Scene}."""
    variants = {}
    for c, d, profile in itertools.product(grids["c"], grids["d"], grids["profile"]):
        variants[(c, d, profile)] = variant_scene(scene, c, d, profile, f"{source}: grid (c = {c}, d = {d}, "
                                                                        f"profile = {profile})")
    return variants


def variant_scene(scene, c=None, d=None, profile=None, source=None):
    """The scene with uniform c [kg m^-1 s^-2], d [s^-1] and a force profile (None: unchanged)."""
    changes = {}
    if c is not None or d is not None:
        changes["fields"] = {}
        if c is not None:
            changes["fields"]["c"] = repr(float(c))
        if d is not None:
            changes["fields"]["d"] = repr(float(d))
    if profile is not None:
        changes["force"] = {"profile": profile}
    if not changes:
        return scene
    return derive_scene(scene, changes, source)


def load_spec(path) -> Spec:
    """Read and validate SPEC.toml at ``path`` (UserError when missing or invalid)."""
    path = Path(path)
    if not is_file(path):
        raise UserError(f"SPEC.toml '{path}': {not_a_file(path)}")
    try:
        text = path.read_text(encoding="utf-8-sig")        # a byte-order mark is no TOML statement
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"SPEC.toml '{path}': cannot be read ({exc})") from None
    return parse_spec(text, str(path), spec_path=path)
