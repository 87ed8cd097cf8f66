"""Scenes: the paper's test cases as data (TOML files in ``validation/scenes``).

A scene holds the domain (L, T), the fields of eqs. 2.2-2.4 as expressions
(ρ0(x), v0(x), c(x), d(x), the external force f(t) with an optional spatial
profile), the SPH settings of the paper, the paper's POD snapshot settings and
the figures the paper reports, so that reports can quote them.

Every key is checked against the schema, one table (:mod:`sphrom.scene_schema`,
documented in ``docs/user/scenes.md``): an unknown or missing key, a wrong type
or a value out of range is a :class:`~sphrom.errors.UserError` naming the
file, the field and what is allowed.  A scene needs only its physics
([domain], [fields], [force] and [sph] n_particles, dt); the rest has a default
or is chosen by a stated rule (:mod:`sphrom.pod.automatic`), and
:func:`automatic_lines` says what was chosen.

Units (SI, cross-section a = 1 m^2): x, L in m; t, T, dt in s; ρ0 in kg m^-3;
v0 in m s^-1; c in kg m^-1 s^-2 (Young's modulus); d in s^-1; f in m s^-2.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import defaults
from .errors import FieldError, UserError
from .expr import Expr, compile_expr
from .paths import data_dir, exists, is_file, not_a_file
from .scene_schema import (MAX_ALPHA, MAX_DEPTH, MAX_PARTICLES, MAX_REFERENCE_CELLS, MAX_SAMPLE_BYTES, MAX_STEPS,
                           MAX_STEPS_TEXT, MIN_PARTICLES, NAME_PATTERN, NAME_TEXT, SCALE, check_nesting,
                           check_scene_tables, check_text_size, fmt, key, least_every, shown)

INTEGRATORS = key("sph.integrator").range.choices
CLI = "command line"    # the source of settings given as options
X_FIELDS = {  # name: (unit, description)
    name: (key(f"fields.{name}").unit, key(f"fields.{name}").doc) for name in ("rho0", "v0", "c", "d")
}


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
    """A validated scene.  See the module docstring for units.

    ``automatic`` names what the scene file left to a rule (``name``, ``sph.every``, ``snapshots``,
    ``rom.modes``; :func:`sphrom.pod.automatic.automatic_rules`); :func:`automatic_lines` says what the rules
    chose.
    """

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
    automatic: tuple = ()
    spectrum: tuple = ()  # (omega_max [rad s^-1], min d, max d [s^-1]) at the particles: the step's stability

    # -- fields ------------------------------------------------------------
    def field(self, name, x):
        """Evaluate the field ``name`` (rho0, v0, c, d, profile) at ``x`` [m].

        Returns a float array of ``x.shape``.  Raises UserError when a value is
        non-finite or outside its range (scene_schema: 1e-15 <= ρ0, c <= 1e15,
        0 <= d <= 1e15, |v0|, |profile| <= 1e15).
        """
        x = np.asarray(x, dtype=float)
        value = np.broadcast_to(self.fields[name](x=x, L=self.L, T=self.T), x.shape).astype(float)
        path = f"fields.{name}" if name != "profile" else "force.profile"
        _check_values(value, x, key(path), f"{self.source}: {path}", "x", "m")
        return value

    def force(self, t):
        """The force time history f(t) [m s^-2] at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        value = np.broadcast_to(self.f(t=t, L=self.L, T=self.T), t.shape).astype(float)
        _check_values(value, t, key("force.f"), f"{self.source}: force.f", "t", "s")
        return value

    def period(self):
        """T' [s]: the time a wave takes once around the periodic bar, Σ Δx sqrt(ρ0/c) over the particles
        (the paper's T' = L sqrt(ρ0/c) for uniform fields, section 3.1.1)."""
        from .sph.operator import particle_positions
        x = particle_positions(self.L, self.sph.n_particles)
        return float(np.sum(np.sqrt(self.field("rho0", x) / self.field("c", x))) * (self.L / self.sph.n_particles))

    def with_sph(self, source=CLI, stable=True, **changes):
        """A copy with SPH settings changed (``None`` values are ignored), re-validated.

        Errors name the field: the setting (FieldError ``dt``) for settings given on their own
        (``source`` = ``CLI``), else the file and its key (``sph.dt``).  Automatic settings
        (``sph.every``, ``sph.dt``, ``snapshots``) not given here follow the new settings.  A dt above the
        stability limit of the integrator is refused (:func:`sphrom.sph.timestep.refusal`) unless ``stable`` is
        False (the stability benchmarks, which run beyond the limit on purpose).
        """
        changes = {k: v for k, v in changes.items() if v is not None}
        automatic = tuple(a for a in self.automatic if not (a.startswith("sph.") and a[4:] in changes))
        sph = dataclasses.replace(self.sph, **changes)
        placeholder = {"every": MAX_STEPS} if "sph.every" in automatic else {}
        if "sph.dt" in automatic:
            placeholder["dt"] = self.T
        _check_sph(dataclasses.replace(sph, **placeholder), source, self.T)
        scene = dataclasses.replace(self, sph=sph, automatic=automatic)
        if {"n_particles", "alpha"} & set(changes):
            scene = dataclasses.replace(scene, spectrum=_spectrum(scene))
        blame = "integrator" if "integrator" in changes and "dt" not in changes else "dt"
        scene = _stable(scene, source, check=stable, blame=blame)
        if "sph.every" in automatic:
            scene = dataclasses.replace(scene, sph=dataclasses.replace(
                scene.sph, every=automatic_every(scene.T, scene.period(), scene.sph)))
        _check_sph(scene.sph, source, scene.T)
        return _follow(scene)

    def with_T(self, T):
        """A copy with a different horizon T [s] (``None``: unchanged); automatic settings follow it."""
        if T is None:
            return self
        if not (np.isfinite(T) and T > 0):
            raise FieldError("t_end", f"{T!r} is out of range (allowed: a number > 0)")
        if "sph.dt" in self.automatic and 1 / SCALE <= T <= SCALE:          # the dt follows T
            return _follow(_every(_stable(dataclasses.replace(self, T=float(T)), CLI, blame="t_end")))
        if self.sph.dt > T:
            raise FieldError("t_end", f"{T:g} is out of range (allowed: T >= dt = {self.sph.dt:g})")
        if T / self.sph.dt > MAX_STEPS:
            raise FieldError("t_end", f"{T:g} is out of range (allowed: T <= {MAX_STEPS_TEXT} dt = "
                                      f"{MAX_STEPS * self.sph.dt:g} s, at most {MAX_STEPS_TEXT} SPH steps)")
        if not 1 / SCALE <= T <= SCALE:
            raise FieldError("t_end", f"{T!r} is out of range (allowed: a number in [{fmt(1 / SCALE)}, {fmt(SCALE)}] "
                                      "s, as domain.T)")
        return _follow(_every(dataclasses.replace(self, T=float(T))))


def _check_values(value, at, k, where, var, unit):
    """UserError naming ``where`` when a field's values are non-finite or outside ``k.range``."""
    finite = np.isfinite(value)
    if not np.all(finite):
        bad = at[~finite][0]
        raise UserError(f"{where}: non-finite value at {var} = {bad:g} {unit} (allowed: {k.range.text()} "
                        f"{k.unit})".rstrip())
    lo, hi = k.range.lo, k.range.hi
    outside = (value < lo) | (value > hi)
    if np.any(outside):
        i = int(np.argmax(outside))
        raise UserError(f"{where}: {shown(float(value.flat[i]))} at {var} = {float(at.flat[i]):g} {unit} is out of "
                        f"range (allowed: {k.range.text()} {k.unit}".rstrip() + " everywhere)")


def _every(scene):
    """``scene`` with its automatic ``sph.every`` recomputed for its T and SPH settings."""
    if "sph.every" not in scene.automatic:
        return scene
    return dataclasses.replace(scene, sph=dataclasses.replace(
        scene.sph, every=automatic_every(scene.T, scene.period(), scene.sph)))


def _spectrum(scene):
    """(ω_max [rad s^-1], min d, max d [s^-1]) of ``scene``'s particles (:func:`sphrom.sph.timestep.omega_max`)."""
    from .sph.operator import particle_positions
    from .sph.timestep import omega_max
    n = scene.sph.n_particles
    x = particle_positions(scene.L, n)
    c, rho0, d = (scene.field(name, x) for name in ("c", "rho0", "d"))
    return (omega_max(float(c.max()), float(rho0.min()), scene.L, n, scene.sph.alpha), float(d.min()),
            float(d.max()))


def _stable(scene, source, check=True, blame="dt"):
    """``scene`` with its automatic dt chosen (``sph.dt`` in ``scene.automatic``: :func:`automatic_dt`), or its dt
    checked against the stability limit of its integrator (``check``): one line naming the field (``blame``; the
    file's ``sph.dt`` for a scene file) with the limit and the remedy, before any work."""
    from .sph.timestep import automatic_dt, refusal
    w, d_min, d_max = scene.spectrum
    sph = scene.sph

    def fail(detail):
        if source == CLI:
            raise FieldError(blame, detail)
        raise UserError(f"{source}: sph.dt: {detail}")
    if "sph.dt" in scene.automatic:
        dt, limit = automatic_dt(sph.integrator, w, d_min, d_max, scene.T, MAX_STEPS)
        if dt is None:
            fail(f"no step leaves T = {scene.T:g} s within {MAX_STEPS_TEXT} steps of the {sph.integrator} integrator "
                 f"(its stability limit is {limit:.3g} s, omega_max = {w:.4g} rad/s); remedy: a shorter T, fewer "
                 "particles or a softer bar")
        return dataclasses.replace(scene, sph=dataclasses.replace(sph, dt=dt))
    if check:
        reason = refusal(sph.integrator, sph.dt, w, d_min, d_max)
        if reason is not None:
            fail(reason)
    return scene


def _follow(scene):
    """The automatic snapshots of ``scene`` recomputed for its T and SPH settings."""
    if "snapshots" not in scene.automatic:
        return scene
    return dataclasses.replace(scene, snapshots=automatic_snapshots(scene.T, scene.period(), scene.sph))


def _check_sph(sph: SPHSettings, source, T):
    """Check SPH settings; errors name the scene file and key, or (``source`` = ``CLI``) the field."""
    def fail(name, detail):
        if source == CLI:
            raise FieldError(name, detail)
        raise UserError(f"{source}: sph.{name}: {detail}")

    n = sph.n_particles
    if not (MIN_PARTICLES <= n <= MAX_PARTICLES):
        fail("n_particles", f"{n} is out of range (allowed: an integer in [{MIN_PARTICLES}, {MAX_PARTICLES}])")
    _check_alpha(sph.alpha, n, fail)
    if not (sph.dt > 0 and np.isfinite(sph.dt)):
        fail("dt", f"{sph.dt!r} is out of range (allowed: a number > 0)")
    _check_dt(sph.dt, T, lambda detail: fail("dt", detail))
    if sph.integrator not in INTEGRATORS:
        fail("integrator", f"{sph.integrator!r} is out of range (allowed: one of {', '.join(INTEGRATORS)})")
    if not 1 <= sph.every <= MAX_STEPS:
        fail("every", f"{sph.every} is out of range (allowed: an integer in [1, {MAX_STEPS}])")
    steps = int(T / sph.dt)             # <= MAX_STEPS, checked above
    per_sample = n * 8 * 2              # v and rho of N particles [bytes]
    if (steps // sph.every + 2) * per_sample > MAX_SAMPLE_BYTES:
        least = least_every(steps, n)
        need = (steps // sph.every + 2) * per_sample / 2**30
        fail("every", f"{sph.every} stores {steps // sph.every + 2} samples of {n} particles, {need:.1f} GiB "
                      f"(allowed: every >= {least}, at most {MAX_SAMPLE_BYTES / 2**30:g} GiB of samples)")


def _check_alpha(alpha, n, fail):
    hi = n / 4.0
    if not (key("sph.alpha").range.contains(alpha) and alpha < hi):
        fail("alpha", f"{alpha:g} is out of range (allowed: 0.5 < alpha < N/4 = {hi:g} and alpha <= {MAX_ALPHA:g}, "
                      "so that each particle has neighbours, the kernel support 2h stays below L/2 and the "
                      f"operator holds at most {4 * MAX_ALPHA + 1:g} neighbours per particle)")


def _check_dt(dt, T, fail):
    if dt > T:
        fail(f"{dt:g} is out of range (allowed: 0 < dt <= T = {T:g})")
    if T / dt > MAX_STEPS:
        fail(f"{dt:g} is out of range (allowed: dt >= T / {MAX_STEPS_TEXT} = {T / MAX_STEPS:g} s "
             f"for T = {T:g} s, at most {MAX_STEPS_TEXT} SPH steps)")


# --------------------------------------------------------------------------
# automatic choices (the rules: sphrom.pod.automatic)
# --------------------------------------------------------------------------
def run_steps(T, dt):
    """The steps of a run to T [s] by dt [s]: sphrom.sph.solver.step_count's rule (n with n dt = T to 1e-9
    relative, else floor(T/dt)), here because the solver imports this module
    (tests/test_scene_minimal.py checks that the two agree)."""
    ratio = T / dt
    n = int(round(ratio))
    return n if abs(ratio - n) <= 1e-9 * max(1.0, ratio) else int(np.floor(ratio))


def automatic_every(T, period, sph):
    """``sph.every`` when the scene leaves it out (:data:`sphrom.pod.automatic.AUTO_EVERY_RULE`)."""
    from .pod.automatic import automatic_every as rule
    return rule(T, period, sph.dt, run_steps(T, sph.dt), sph.n_particles)


def automatic_snapshots(T, period, sph):
    """``[snapshots]`` when the scene leaves it out (:data:`sphrom.pod.automatic.AUTO_SNAPSHOTS_RULE`)."""
    from .pod.automatic import automatic_snapshots as rule
    return rule(T, period, sph.dt, run_steps(T, sph.dt), sph.n_particles)


def automatic_lines(scene):
    """One line per choice the loader made for ``scene`` by a rule (nothing for a scene that gives them all,
    as every built-in scene does); the mode count is chosen later, by the POD (sphrom.pod.pipeline)."""
    from .pod.snapshots import describe
    lines = []
    if "name" in scene.automatic:
        origin = "the file name" if scene.source.endswith(f"{scene.name}.toml") else "no name in the scene text"
        lines.append(f"scene {scene.name}: name from {origin} ({scene.source})")
    from .sph.timestep import DT_FRACTION, dt_limit
    if "sph.integrator" in scene.automatic:
        lines.append(f"scene {scene.name}: sph.integrator = {scene.sph.integrator} (the default: below its stability "
                     "limit no mode grows; the paper's euler where a scene names it)")
    if "sph.dt" in scene.automatic:
        w, d_min, d_max = scene.spectrum
        limit = dt_limit(scene.sph.integrator, w, d_max, d_min)
        lines.append(f"scene {scene.name}: sph.dt = {scene.sph.dt:.4g} s (automatic: {scene.sph.dt / limit:.3g} of the "
                     f"stability limit {limit:.3g} s of {scene.sph.integrator}, omega_max = {w:.4g} rad/s; "
                     f"{run_steps(scene.T, scene.sph.dt)} steps to T; rule: {DT_FRACTION:g} of the limit, T a whole "
                     "number of steps)")
    if "sph.every" in scene.automatic:
        lines.append(f"scene {scene.name}: sph.every = {scene.sph.every} (automatic: a sample every "
                     f"{scene.sph.every * scene.sph.dt:.4g} s; T' = {scene.period():.4g} s, the wave's time once "
                     "around the bar)")
    if "snapshots" in scene.automatic:
        lines.append(f"scene {scene.name}: snapshots {describe(scene.snapshots)} s (automatic: uniform over the "
                     f"training run, count = 200 T/T' = {200 * scene.T / scene.period():.4g} within [20, 1000], "
                     "the run's steps and 4 GiB)")
    return lines


def stability_lines(scene):
    """The warnings (one line each, no prefix) every command that runs the full SPH of ``scene`` says before it:
    its integrator amplifying some mode more than 100-fold over the run (explicit Euler on a lightly damped bar,
    :func:`sphrom.sph.timestep.warnings`), with the remedy.  A dt above the stability limit never gets here: the
    loader refuses it."""
    from .sph.timestep import warnings
    w, d_min, _ = scene.spectrum
    return warnings(scene.sph.integrator, scene.sph.dt, w, d_min, scene.T)


def announce(scene, command):
    """What a command says about ``scene`` before any work: the automatic choices (stdout, :func:`automatic_lines`)
    and the stability warnings (stderr, ``sphrom COMMAND: warning: ...``, :func:`stability_lines`)."""
    import sys
    for line in automatic_lines(scene):
        print(line)
    for line in stability_lines(scene):
        print(f"sphrom {command}: warning: {line}", file=sys.stderr)


# --------------------------------------------------------------------------
def builtin_dir() -> Path:
    """The folder of the built-in scenes (``validation/scenes`` in the repository)."""
    return data_dir("scenes")


def builtin_names():
    return sorted(p.stem for p in builtin_dir().glob("*.toml"))


def _printable(text):
    """A path as it goes into one-line messages (control characters escaped)."""
    return text if text.isprintable() else repr(text)


def load_scene(spec) -> Scene:
    """Load a scene by built-in name (``multimode``) or by path to a TOML file.

    A scene without ``name`` is named after its file (``my_bar.toml``: ``my_bar``).

    Raises
    ------
    UserError
        When the scene does not exist or does not validate.
    """
    spec = str(spec)
    path = Path(spec)
    shown_spec = _printable(spec)
    if not (spec.endswith(".toml") or exists(path)):
        candidate = builtin_dir() / f"{spec}.toml"
        if not exists(candidate):
            raise UserError(f"scene '{shown_spec}': no such built-in scene and no such file "
                            f"(built-in: {', '.join(builtin_names())})")
        path = candidate
    if not is_file(path):
        raise UserError(f"scene file '{shown_spec}': {not_a_file(path)}")
    source = _printable(str(path))
    try:
        check_text_size(path.stat().st_size, source)
        text = path.read_text(encoding="utf-8-sig")        # a byte-order mark is no TOML statement
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"scene file '{shown_spec}': cannot be read ({exc})") from None
    return parse_scene(text, source, name=path.stem)


DEFAULT_NAME = "scene"      # the name of a scene text without one that is not read from a file


def parse_scene(text: str, source: str = "<scene>", name: str | None = None) -> Scene:
    """Parse and validate scene TOML ``text``; ``source`` names it in errors, ``name`` is the name when the
    text has none (:func:`load_scene`: the file name; else :data:`DEFAULT_NAME`)."""
    text = text.removeprefix("\ufeff")           # a byte-order mark (an editor's) is no TOML statement
    check_text_size(len(text.encode("utf-8", "surrogatepass")), source)
    check_nesting(text, source)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{source}: not valid TOML ({exc})") from None
    except RecursionError:
        raise UserError(f"{source}: nested too deep for the TOML parser (allowed: at most "
                        f"{MAX_DEPTH} levels of [ ] and {{ }})") from None
    data = check_scene_tables(raw, source)
    automatic = []
    if "name" not in data:
        name = DEFAULT_NAME if name is None else name
        if not NAME_PATTERN.fullmatch(name):
            raise UserError(f"{source}: name: {shown(name)} (the file name) is out of range (allowed: {NAME_TEXT}); "
                            "give name = \"...\" in the file or rename it")
        data["name"] = name
        automatic.append("name")
    data.setdefault("title", data["name"])
    for k in ("section", "summary"):
        data.setdefault(k, key(k).default)
    domain = data["domain"]
    fields_data = {name_: data["fields"].get(name_, key(f"fields.{name_}").default) for name_ in X_FIELDS}
    force = data.get("force", {})
    sph_data = data["sph"]
    sph_data.setdefault("alpha", key("sph.alpha").default)
    if "integrator" not in sph_data:
        from .sph.timestep import DEFAULT_INTEGRATOR
        automatic.append("sph.integrator")
        sph_data["integrator"] = DEFAULT_INTEGRATOR
    if "dt" not in sph_data:
        automatic.append("sph.dt")
        sph_data["dt"] = domain["T"]            # replaced below, once the fields give the stability limit
    if "every" not in sph_data:
        automatic.append("sph.every")
        sph_data["every"] = MAX_STEPS            # replaced below, once the fields give T'
    sph = SPHSettings(**sph_data)
    _check_sph(sph, source, domain["T"])

    fields = {}
    for name_ in X_FIELDS:
        fields[name_] = compile_expr(fields_data[name_], key(f"fields.{name_}").variables, f"{source}: fields.{name_}")
    fields["profile"] = compile_expr(force.get("profile", key("force.profile").default), key("force.profile").variables,
                                     f"{source}: force.profile")
    f = compile_expr(force.get("f", key("force.f").default), key("force.f").variables, f"{source}: force.f")

    snaps = data.get("snapshots")
    if snaps is not None:
        _check_snapshot_spec(snaps, f"{source}: snapshots")
    else:
        automatic.append("snapshots")
        snaps = {}
    rom = data.get("rom", {})
    if "modes" not in rom:
        automatic.append("rom.modes")
    rom.setdefault("n_freeze", [defaults.N_FREEZE])
    for k in ("modes", "accel_modes"):
        for i, value in enumerate(np.atleast_1d(rom.get(k, []))):
            if value > sph.n_particles:
                raise UserError(f"{source}: rom.{k}{'' if k == 'modes' else f'[{i}]'}: {value} is out of range "
                                f"(allowed: an integer in [1, N = {sph.n_particles}], the modes of a POD basis of "
                                "N particles)")
    paper = data.get("paper", {})
    _check_paper(paper, source, domain["L"], domain["T"], sph.n_particles)

    scene = Scene(name=data["name"], title=data["title"], section=data["section"], summary=data["summary"],
                  L=domain["L"], T=domain["T"], fields=fields, f=f, sph=sph,
                  snapshots=snaps, rom=rom, paper=paper, source=source, text=text, automatic=tuple(automatic))
    # Evaluate every field once on the default particles so that a bad
    # expression (division by zero, a negative density) fails at load time.
    from .sph.operator import particle_positions
    x = particle_positions(scene.L, sph.n_particles)
    for name_ in fields:
        scene.field(name_, x)
    scene.force(np.linspace(0.0, scene.T, 257))
    scene = _stable(dataclasses.replace(scene, spectrum=_spectrum(scene)), source)
    return _follow(_every(scene))


def _check_paper(paper, source, L, T, n):
    """The bounds of [paper] that depend on L, T and N."""
    dx, dt = paper.get("reference_dx"), paper.get("reference_dt")
    if dx is not None and L / dx > MAX_REFERENCE_CELLS:
        raise UserError(f"{source}: paper.reference_dx: {shown(dx)} is out of range (allowed: reference_dx >= L / "
                        f"{MAX_REFERENCE_CELLS:.0e} = {L / MAX_REFERENCE_CELLS:g} m, at most "
                        f"{MAX_REFERENCE_CELLS:.0e} cells)".replace("e+0", "e"))
    if dt is not None:
        _check_dt(dt, T, lambda detail: _raise(f"{source}: paper.reference_dt: {detail}"))
    for path, value in (("mode_threshold", paper.get("mode_threshold")),
                        *((f"snapshot_studies[{i}].mode_threshold", s.get("mode_threshold"))
                          for i, s in enumerate(paper.get("snapshot_studies", [])))):
        if value is not None and value > n:
            raise UserError(f"{source}: paper.{path}: {value} is out of range (allowed: an integer in [1, N = {n}])")
    for i, run in enumerate(paper.get("runs", [])):
        where = f"{source}: paper.runs[{i}]"
        _check_alpha(run["alpha"], run["n_particles"], lambda name, detail: _raise(f"{where}.{name}: {detail}"))
        _check_dt(run["dt"], T, lambda detail: _raise(f"{where}.dt: {detail}"))
    for i, study in enumerate(paper.get("snapshot_studies", [])):
        _check_snapshot_spec(study, f"{source}: paper.snapshot_studies[{i}]")


def _raise(message):
    raise UserError(message)


def _check_snapshot_spec(spec, where):
    kinds = [k for k in ("count", "times", "times_v") if k in spec]
    if len(kinds) != 1:
        raise UserError(f"{where}: give exactly one of count (with window), times, or times_v/times_rho "
                        "(or leave [snapshots] out: chosen automatically)")
    if "count" in spec and "window" not in spec:
        raise UserError(f"{where}.window: missing key (required with count)")
    if ("times_v" in spec) != ("times_rho" in spec):
        raise UserError(f"{where}: times_v and times_rho go together")
    if "random" in spec and "count" not in spec:
        raise UserError(f"{where}.random: needs count and window (random times in the window)")


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


_TOML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\t": "\\t"}


def _toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return repr(int(value))
    if isinstance(value, float):
        return repr(float(value))           # a numpy float's repr is not TOML (np.float64(...))
    if isinstance(value, str):
        return '"' + "".join(_TOML_ESCAPES.get(ch, ch if ch.isprintable() else f"\\u{ord(ch):04x}" if ord(ch) < 0x10000
                                 else f"\\U{ord(ch):08x}") for ch in value) + '"'
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
    if isinstance(base, Scene):
        data.setdefault("name", base.name)          # a scene named after its file keeps its name
    merge(data, changes)
    name = data.get("name", "scene")
    return parse_scene(dump_toml(data), source or f"<{name} variant>")
