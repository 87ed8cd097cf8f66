"""Scenes: the paper's test cases as data (TOML files in ``validation/scenes``).

A scene holds the domain (L, T), the fields of eqs. 2.2-2.4 as expressions
(ρ0(x), v0(x), c(x), d(x), the external force f(t) with an optional spatial
profile), the SPH settings of the paper, the paper's POD snapshot settings and
the figures the paper reports, so that reports can quote them.

Every key is checked: an unknown or missing key, a wrong type or a value out
of range is a :class:`~harness.errors.UserError` naming the file, the field
and what is allowed.

Units (SI, cross-section a = 1 m^2): x, L in m; t, T, dt in s; ρ0 in kg m^-3;
v0 in m s^-1; c in kg m^-1 s^-2 (Young's modulus); d in s^-1; f in m s^-2.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import FieldError, UserError
from .expr import Expr, compile_expr
from .paths import data_dir, exists, is_file

INTEGRATORS = ("euler", "symplectic", "rk4")
CLI = "command line"    # the source of settings given as options
MIN_PARTICLES = 8
MAX_PARTICLES = 10_000_000
# At most this many SPH steps T/dt in one run.  Step times are n*dt with n exact in float64 far
# beyond this (2^53), and the int64 step counters cannot overflow; the bound is the wall time: at the
# cheapest step (N = MIN_PARTICLES, about a microsecond) 1e9 steps already take the better part of an hour.
MAX_STEPS = 10**9
MAX_STEPS_TEXT = "1e9"
# The stored samples of a full SPH run, v and rho (samples x N float64 each), above this are refused
# before the run: a small `every` over many steps would otherwise fill the memory.
MAX_SAMPLE_BYTES = 4 * 2**30

X_FIELDS = {  # name: (unit, description)
    "rho0": ("kg m^-3", "initial density rho0(x)"),
    "v0": ("m s^-1", "initial velocity v0(x)"),
    "c": ("kg m^-1 s^-2", "Young's modulus c(x)"),
    "d": ("s^-1", "damping coefficient d(x)"),
}


# --------------------------------------------------------------------------
# schema: key -> (type, required, check) ; check(value) returns None or the
# allowed-range text
# --------------------------------------------------------------------------
def _positive(v):
    return None if v > 0 else "a number > 0"


def _nonneg(v):
    return None if v >= 0 else "a number >= 0"


def _fraction(v):
    return None if 0 <= v <= 1 else "a fraction in [0, 1]"


def _window(v):
    if len(v) == 2 and 0 <= v[0] < v[1]:
        return None
    return "[t0, t1] with 0 <= t0 < t1"


def _int_at_least(n):
    return lambda v: None if v >= n else f"an integer >= {n}"


def _one_of(*options):
    return lambda v: None if v in options else "one of " + ", ".join(options)


def _list_of(kind, check=None):
    return ("list", kind, check)


SNAPSHOT_KEYS = {
    "count": (int, False, _int_at_least(1)),
    "window": (_list_of(float), False, _window),
    "times": (_list_of(float), False, None),
    "times_v": (_list_of(float), False, None),
    "times_rho": (_list_of(float), False, None),
    "random": (int, False, _int_at_least(0)),
}

SCHEMA = {
    "name": (str, True, None),
    "title": (str, True, None),
    "section": (str, True, None),
    "summary": (str, True, None),
    "domain": ({
        "L": (float, True, _positive),
        "T": (float, True, _positive),
    }, True, None),
    "fields": ({
        "rho0": ("expr", True, None),
        "v0": ("expr", True, None),
        "c": ("expr", True, None),
        "d": ("expr", True, None),
    }, True, None),
    "force": ({
        "f": ("expr", True, None),
        "profile": ("expr", False, None),
    }, True, None),
    "sph": ({
        "n_particles": (int, True, lambda v: None if MIN_PARTICLES <= v <= MAX_PARTICLES
                        else f"an integer in [{MIN_PARTICLES}, {MAX_PARTICLES}]"),
        "alpha": (float, True, None),   # range depends on N: checked below
        "dt": (float, True, _positive),
        "integrator": (str, True, _one_of(*INTEGRATORS)),
        "every": (int, True, _int_at_least(1)),
    }, True, None),
    "snapshots": (SNAPSHOT_KEYS, True, None),
    "rom": ({
        "modes": (int, True, _int_at_least(1)),
        "accel_modes": (_list_of(int), False, None),
        "n_freeze": (_list_of(int), False, None),
    }, True, None),
    "paper": ({
        "figures": (str, False, None),
        "reference": (str, True, _one_of("analytic", "fd")),
        "reference_dx": (float, False, _positive),
        "reference_dt": (float, False, _positive),
        "sph_error_v": (float, True, _nonneg),
        "sph_error_rho": (float, False, _nonneg),
        "mode_threshold": (int, False, _int_at_least(1)),
        "cpu_saving": (float, False, _fraction),
        "modified_reference_beta": (float, False, _positive),
        "modified_reference_error_v": (float, False, _nonneg),
        "notes": (str, False, None),
        "runs": ("tables", False, {
            "n_particles": (int, True, _int_at_least(MIN_PARTICLES)),
            "alpha": (float, True, _positive),
            "dt": (float, True, _positive),
            "sph_error_v": (float, True, _nonneg),
            "sph_error_rho": (float, False, _nonneg),
            "note": (str, False, None),
        }),
        "snapshot_studies": ("tables", False, {
            **SNAPSHOT_KEYS,
            "figure": (str, False, None),
            "outcome": (str, True, _one_of("works", "fails", "critical", "larger_error")),
            "mode_threshold": (int, False, _int_at_least(1)),
            "note": (str, False, None),
        }),
    }, False, None),        # a scene beyond the paper's eight has no [paper] table
}


def _type_name(kind):
    if isinstance(kind, dict):
        return "a table"
    if isinstance(kind, tuple) and kind[0] == "list":
        return f"a list of {_type_name(kind[1])}"
    return {int: "an integer", float: "a number", str: "a string", "expr": "an expression string or number",
            "tables": "an array of tables"}[kind]


def _check_value(value, kind, where):
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UserError(f"{where}: expected {_type_name(kind)}, got {value!r}")
        value = float(value)
        if not np.isfinite(value):
            raise UserError(f"{where}: {value!r} is out of range (allowed: a finite number)")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise UserError(f"{where}: expected {_type_name(kind)}, got {value!r}")
        return value
    if kind is str:
        if not isinstance(value, str):
            raise UserError(f"{where}: expected {_type_name(kind)}, got {value!r}")
        return value
    if kind == "expr":
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise UserError(f"{where}: expected {_type_name(kind)}, got {value!r}")
        return value
    if isinstance(kind, tuple) and kind[0] == "list":
        if not isinstance(value, list):
            raise UserError(f"{where}: expected {_type_name(kind)}, got {value!r}")
        return [_check_value(v, kind[1], f"{where}[{i}]") for i, v in enumerate(value)]
    raise AssertionError(kind)


def _validate_table(table, schema, where):
    if not isinstance(table, dict):
        raise UserError(f"{where}: expected a table")
    unknown = sorted(set(table) - set(schema))
    if unknown:
        here = f"{where} {unknown[0]}" if where.endswith(":") else f"{where}.{unknown[0]}"
        raise UserError(f"{here}: unknown key '{unknown[0]}' (allowed: {', '.join(schema)})")
    out = {}
    for key, (kind, required, check) in schema.items():
        here = f"{where} {key}" if where.endswith(":") else f"{where}.{key}"
        if key not in table:
            if required:
                raise UserError(f"{here}: missing key ({_type_name(kind)} required)")
            continue
        value = table[key]
        if isinstance(kind, dict):
            out[key] = _validate_table(value, kind, here)
            continue
        if kind == "tables":
            if not isinstance(value, list):
                raise UserError(f"{here}: expected {_type_name(kind)}")
            out[key] = [_validate_table(v, check, f"{here}[{i}]") for i, v in enumerate(value)]
            continue
        value = _check_value(value, kind, here)
        if check is not None:
            items = value if isinstance(kind, tuple) and kind[0] == "list" and key != "window" else [value]
            for item in items:
                problem = check(item)
                if problem is not None:
                    raise UserError(f"{here}: {item!r} is out of range (allowed: {problem})")
        out[key] = value
    return out


# --------------------------------------------------------------------------
@dataclass(frozen=True)
class SPHSettings:
    """Discretisation of the full SPH run (section 2.2).

    Attributes
    ----------
    n_particles : int
        N, particles at x_i = (i + 1/2) L/N, i = 0..N-1.
    alpha : float
        h / Δx, smoothing length over particle spacing.
    dt : float
        Time step Δt [s].
    integrator : str
        ``euler`` (the paper's), ``symplectic`` or ``rk4``.
    every : int
        Store a sample every ``every`` steps.
    """

    n_particles: int
    alpha: float
    dt: float
    integrator: str
    every: int


@dataclass(frozen=True)
class Scene:
    """A validated scene.  See the module docstring for units."""

    name: str
    title: str
    section: str
    summary: str
    L: float
    T: float
    fields: dict          # name -> Expr over x (rho0, v0, c, d, profile)
    f: Expr               # external force time history f(t) [m s^-2]
    sph: SPHSettings
    snapshots: dict
    rom: dict
    paper: dict
    source: str           # file path, for messages and provenance
    text: str             # the TOML text, stored in every output file

    # -- fields ------------------------------------------------------------
    def field(self, name, x):
        """Evaluate the field ``name`` (rho0, v0, c, d, profile) at ``x`` [m].

        Returns a float array of ``x.shape``.  Raises UserError when a value is
        non-finite or outside its physical range (ρ0 > 0, c > 0, d >= 0).
        """
        x = np.asarray(x, dtype=float)
        value = np.broadcast_to(self.fields[name](x=x, L=self.L, T=self.T), x.shape).astype(float)
        where = f"{self.source}: fields.{name}" if name != "profile" else f"{self.source}: force.profile"
        if not np.all(np.isfinite(value)):
            bad = x[~np.isfinite(value)][0]
            raise UserError(f"{where}: non-finite value at x = {bad:g} m")
        if name in ("rho0", "c") and np.any(value <= 0):
            raise UserError(f"{where}: must be > 0 everywhere (min {value.min():g})")
        if name == "d" and np.any(value < 0):
            raise UserError(f"{where}: must be >= 0 everywhere (min {value.min():g})")
        return value

    def force(self, t):
        """The force time history f(t) [m s^-2] at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        value = np.broadcast_to(self.f(t=t, L=self.L, T=self.T), t.shape).astype(float)
        if not np.all(np.isfinite(value)):
            bad = t[~np.isfinite(value)][0]
            raise UserError(f"{self.source}: force.f: non-finite value at t = {bad:g} s")
        return value

    def with_sph(self, source=CLI, **changes):
        """A copy with SPH settings changed (``None`` values are ignored), re-validated.

        Errors name the field: the setting (FieldError ``dt``) for settings given on their own
        (``source`` = ``CLI``), else the file and its key (``sph.dt``).
        """
        changes = {k: v for k, v in changes.items() if v is not None}
        sph = dataclasses.replace(self.sph, **changes)
        _check_sph(sph, source, self.T)
        return dataclasses.replace(self, sph=sph)

    def with_T(self, T):
        """A copy with a different horizon T [s] (``None``: unchanged)."""
        if T is None:
            return self
        if not (np.isfinite(T) and T > 0):
            raise FieldError("t_end", f"{T!r} is out of range (allowed: a number > 0)")
        if self.sph.dt > T:
            raise FieldError("t_end", f"{T:g} is out of range (allowed: T >= dt = {self.sph.dt:g})")
        if T / self.sph.dt > MAX_STEPS:
            raise FieldError("t_end", f"{T:g} is out of range (allowed: T <= {MAX_STEPS_TEXT} dt = "
                                      f"{MAX_STEPS * self.sph.dt:g} s, at most {MAX_STEPS_TEXT} SPH steps)")
        return dataclasses.replace(self, T=float(T))


def _check_sph(sph: SPHSettings, source, T):
    """Check SPH settings; errors name the scene file and key, or (``source`` = ``CLI``) the field."""
    def fail(key, detail):
        if source == CLI:
            raise FieldError(key, detail)
        raise UserError(f"{source}: sph.{key}: {detail}")

    n = sph.n_particles
    if not (MIN_PARTICLES <= n <= MAX_PARTICLES):
        fail("n_particles", f"{n} is out of range (allowed: an integer in [{MIN_PARTICLES}, {MAX_PARTICLES}])")
    hi = n / 4.0
    if not (0.5 < sph.alpha < hi):
        fail("alpha", f"{sph.alpha:g} is out of range (allowed: 0.5 < alpha < N/4 = {hi:g}, "
                      "so that each particle has neighbours and the kernel support 2h stays below L/2)")
    if not (sph.dt > 0 and np.isfinite(sph.dt)):
        fail("dt", f"{sph.dt!r} is out of range (allowed: a number > 0)")
    if sph.dt > T:
        fail("dt", f"{sph.dt:g} is out of range (allowed: 0 < dt <= T = {T:g})")
    if T / sph.dt > MAX_STEPS:
        fail("dt", f"{sph.dt:g} is out of range (allowed: dt >= T / {MAX_STEPS_TEXT} = {T / MAX_STEPS:g} s "
                   f"for T = {T:g} s, at most {MAX_STEPS_TEXT} SPH steps)")
    if sph.integrator not in INTEGRATORS:
        fail("integrator", f"{sph.integrator!r} is out of range (allowed: one of {', '.join(INTEGRATORS)})")
    if sph.every < 1:
        fail("every", f"{sph.every} is out of range (allowed: an integer >= 1)")
    steps = int(T / sph.dt)             # <= MAX_STEPS, checked above
    per_sample = n * 8 * 2              # v and rho of N particles [bytes]
    if (steps // sph.every + 2) * per_sample > MAX_SAMPLE_BYTES:
        least = -(-steps // max(1, MAX_SAMPLE_BYTES // per_sample - 2))
        need = (steps // sph.every + 2) * per_sample / 2**30
        fail("every", f"{sph.every} stores {steps // sph.every + 2} samples of {n} particles, {need:.1f} GiB "
                      f"(allowed: every >= {least}, at most {MAX_SAMPLE_BYTES / 2**30:g} GiB of samples)")


def builtin_dir() -> Path:
    """The folder of the built-in scenes (``validation/scenes`` in the repository)."""
    return data_dir("scenes")


def builtin_names():
    return sorted(p.stem for p in builtin_dir().glob("*.toml"))


def load_scene(spec) -> Scene:
    """Load a scene by built-in name (``multimode``) or by path to a TOML file.

    Raises
    ------
    UserError
        When the scene does not exist or does not validate.
    """
    spec = str(spec)
    path = Path(spec)
    if not (spec.endswith(".toml") or exists(path)):
        candidate = builtin_dir() / f"{spec}.toml"
        if not exists(candidate):
            raise UserError(f"scene '{spec}': no such built-in scene and no such file "
                            f"(built-in: {', '.join(builtin_names())})")
        path = candidate
    if not is_file(path):
        raise UserError(f"scene file '{spec}': not found")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"scene file '{spec}': cannot be read ({exc})") from None
    return parse_scene(text, str(path))


def parse_scene(text: str, source: str = "<scene>") -> Scene:
    """Parse and validate scene TOML ``text``; ``source`` names it in errors."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{source}: not valid TOML ({exc})") from None
    data = _validate_table(raw, SCHEMA, f"{source}:")
    snaps = data["snapshots"]
    _check_snapshot_spec(snaps, f"{source}: snapshots")
    data.setdefault("paper", {})
    for i, study in enumerate(data["paper"].get("snapshot_studies", [])):
        _check_snapshot_spec(study, f"{source}: paper.snapshot_studies[{i}]")

    fields = {}
    for name in X_FIELDS:
        fields[name] = compile_expr(data["fields"][name], ("x", "L", "T"), f"{source}: fields.{name}")
    fields["profile"] = compile_expr(data["force"].get("profile", "1"), ("x", "L", "T"), f"{source}: force.profile")
    f = compile_expr(data["force"]["f"], ("t", "L", "T"), f"{source}: force.f")
    sph = SPHSettings(**data["sph"])
    _check_sph(sph, source, data["domain"]["T"])
    scene = Scene(name=data["name"], title=data["title"], section=data["section"], summary=data["summary"],
                  L=data["domain"]["L"], T=data["domain"]["T"], fields=fields, f=f, sph=sph,
                  snapshots=snaps, rom=data["rom"], paper=data["paper"], source=source, text=text)
    # Evaluate every field once on the default particles so that a bad
    # expression (division by zero, a negative density) fails at load time.
    from .sph.operator import particle_positions
    x = particle_positions(scene.L, sph.n_particles)
    for name in fields:
        scene.field(name, x)
    scene.force(np.linspace(0.0, scene.T, 257))
    return scene


def _check_snapshot_spec(spec, where):
    kinds = [k for k in ("count", "times", "times_v") if k in spec]
    if len(kinds) != 1:
        raise UserError(f"{where}: give exactly one of count (with window), times, or times_v/times_rho")
    if "count" in spec and "window" not in spec:
        raise UserError(f"{where}.window: missing key (required with count)")
    if ("times_v" in spec) != ("times_rho" in spec):
        raise UserError(f"{where}: times_v and times_rho go together")
    for key in ("times", "times_v", "times_rho"):
        if key in spec and (len(spec[key]) == 0 or min(spec[key]) < 0):
            raise UserError(f"{where}.{key}: allowed: a non-empty list of times >= 0")


def describe_terms(scene: Scene, x=None, t=None):
    """Which terms of eqs. 2.10-2.11 a scene actually has, on its discretisation.

    Returns a dict of booleans: ``damping`` (d not identically 0), ``force``
    (f·profile not identically 0), ``uniform_c``, ``uniform_rho0``,
    ``uniform_d``, ``uniform_profile``.  Decided on the values the run will
    use (the particle positions and the step times), not on the text.
    """
    from .sph.operator import particle_positions
    if x is None:
        x = particle_positions(scene.L, scene.sph.n_particles)
    if t is None:
        t = np.linspace(0.0, scene.T, 1025)
    d = scene.field("d", x)
    c = scene.field("c", x)
    rho0 = scene.field("rho0", x)
    profile = scene.field("profile", x)
    g = scene.force(t)
    return {
        "damping": bool(np.any(d != 0)),
        "force": bool(np.any(g != 0) and np.any(profile != 0)),
        "uniform_c": bool(np.all(c == c[0])),
        "uniform_rho0": bool(np.all(rho0 == rho0[0])),
        "uniform_d": bool(np.all(d == d[0])),
        "uniform_profile": bool(np.all(profile == profile[0])),
    }


# --------------------------------------------------------------------------
def scene_dict(scene_or_text):
    """The raw TOML table of a scene (a Scene or TOML text), as nested dicts."""
    text = scene_or_text.text if isinstance(scene_or_text, Scene) else scene_or_text
    return tomllib.loads(text)


def _toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def dump_toml(data, _prefix=""):
    """Write nested dicts (the subset scenes use) as TOML text."""
    lines, tables, arrays = [], [], []
    for key, value in data.items():
        if isinstance(value, dict):
            tables.append((key, value))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            arrays.append((key, value))
        else:
            lines.append(f"{key} = {_toml_value(value)}")
    for key, value in tables:
        name = f"{_prefix}{key}"
        lines.append(f"\n[{name}]")
        lines.append(dump_toml(value, name + "."))
    for key, items in arrays:
        name = f"{_prefix}{key}"
        for item in items:
            lines.append(f"\n[[{name}]]")
            lines.append(dump_toml(item, name + "."))
    return "\n".join(line for line in lines if line != "")


def derive_scene(base, changes, source=None):
    """A new Scene from ``base`` with nested ``changes`` merged in.

    ``changes`` is a dict like ``{"fields": {"d": "1"}, "sph": {"n_particles": 32}}``;
    the result is validated like a file.  Used by tests and parameter sweeps.
    """
    data = scene_dict(base)

    def merge(dst, src):
        for key, value in src.items():
            if isinstance(value, dict) and isinstance(dst.get(key), dict):
                merge(dst[key], value)
            else:
                dst[key] = value
    merge(data, changes)
    name = data.get("name", "scene")
    return parse_scene(dump_toml(data), source or f"<{name} variant>")
