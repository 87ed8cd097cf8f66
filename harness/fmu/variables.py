"""The FMU's variables: every one declared once, here, and everything that lists them generated from it.

One row per variable (a family of one variable per probe or per port is one row whose name holds ``{j}``,
j = 1, 2, ...; its value reference is ``vr + j - 1``): name, value reference, type, causality, variability,
initial, the rule that decides whether an FMU has it, declared type (quantity and unit), start, min, max,
nominal, the modelDescription's description, a one-line summary, and the C functions of
``fmu_src/instance.c`` it maps to.  From the table come:

- ``fmu_src/fmu_variables.h`` (generated, committed): the value-reference ``#define``\\ s, the constant
  start values, and the rows of instance.c's variable table (the getters and setters they name stay
  hand-written C functions in instance.c, and each presence rule is a C predicate ``rule_<name>`` there);
- both modelDescription variable lists and their ModelStructure (:mod:`sphrom.fmu.make.describe`, at packaging:
  the rows present in the FMU, FMI 2 indices counted from them);
- the Python value references (:func:`vr`; the FMU driver :mod:`sphrom.fmu.run.driver`, the parametric FMU
  :mod:`sphrom.fmu.make.parametric`, the sweep's worker :mod:`sphrom.sweep.worker`);
- the variables section of ``sphrom fmu --help`` (:func:`help_text`), of docs/fmu/variables.md (between the generated
  markers) and, through the modelDescription it is rendered from, of the FMU's documentation page.

``python3 -m sphrom.fmu.variables --write`` regenerates every generated file; ``--check`` lists the stale
ones (``tests/test_variables.py`` fails on a stale one, naming it and the command).

Presence: a rule is decided from the packaged model's resources, by the same rule name on both sides: in
Python from the resources written (:func:`facts`), in C from the loaded ``resources/model.bin``
(``rule_<name>`` in instance.c).  A variable that does nothing for a model is not declared by it (the linear
models have no ``n_freeze``, no ``dt``).

Start values: a number here (from :mod:`sphrom.defaults`; the instance applies it after every instantiation
and reset: the FMU starts at rest, whatever the C core's own default), or :class:`From` the packaged model
(``n_freeze`` and ``dt`` from the resource header, ``c``, ``d`` from section PARAMS: the C core takes them from
``resources/model.bin``, the modelDescription declares the same numbers, written from the same data).
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path

from .. import defaults

INT32_MAX = 2**31 - 1


@dataclass(frozen=True)
class From:
    """A value taken from the packaged model (key of the values :mod:`sphrom.fmu.make.describe` passes), with the
    words that say where it comes from (help, docs).  A key without a value omits the attribute."""

    key: str
    words: str


# units: name -> (BaseUnit exponents or None for none, as written in the docs)
UNITS = {
    "s": ({"s": 1}, "s"),
    "m/s": ({"m": 1, "s": -1}, "m s⁻¹"),
    "m/s2": ({"m": 1, "s": -2}, "m s⁻²"),
    "kg/m3": ({"kg": 1, "m": -3}, "kg m⁻³"),
    "1": ({}, "1"),
    "Pa": ({"kg": 1, "m": -1, "s": -2}, "Pa"),
    "1/s": ({"s": -1}, "s⁻¹"),
    "m/s*s^0.5": (None, "m s⁻¹ s^½"),          # m s^-1 s^(1/2): no BaseUnit, whose exponents are integers
    "N": ({"kg": 1, "m": 1, "s": -2}, "N"),
    "m2": ({"m": 2}, "m²"),
    "N.s/m": ({"kg": 1, "s": -1}, "N s m⁻¹"),
}

# declared types (units reach the variables through them, as in the Reference-FMUs): name -> (quantity, unit)
TYPES = {
    "Time": ("Time", "s"),
    "Acceleration": ("Acceleration", "m/s2"),
    "Velocity": ("Velocity", "m/s"),
    "Density": ("Density", "kg/m3"),
    "Scale": ("Scale", "1"),
    "Stiffness": ("Pressure", "Pa"),
    "DampingRate": ("DampingRate", "1/s"),
    "ForceErrorBound": ("ForceErrorBound", "s"),
    "InitialStateErrorBound": ("InitialStateErrorBound", "m/s*s^0.5"),
    "Force": ("Force", "N"),
    "Area": ("Area", "m2"),
    "Impedance": ("MechanicalImpedance", "N.s/m"),
}

# presence rules: name -> (test on the FMU's facts, words).  instance.c holds the C side of each, rule_<name>
# (``always`` is every FMU: no predicate).
RULES = {
    "always": (lambda f: True, "every FMU"),
    "fmi3": (lambda f: f.fmi == 3, "FMI 3 only"),
    "frozen": (lambda f: f.internal_step, "frozen model only"),      # a kind with internal steps (rom.h)
    "bounds": (lambda f: "BOUNDS" in f.sections, "linear models with certified bounds only"),
    "varied_c": (lambda f: "c" in f.varied, "parametric FMU only, --vary c"),
    "varied_d": (lambda f: "d" in f.varied, "parametric FMU only, --vary d"),
    "ports": (lambda f: bool(f.positions.get("port")), "only with --ports"),
    "shadow": (lambda f: "SHSCAL" in f.sections, "FMUs with certified error bounds (N <= 200000; 2500 where d varies)"),
    "shadow_ports": (lambda f: "SHSCAL" in f.sections and bool(f.positions.get("port")),
                     "with certified error bounds and --ports"),
    "channel": (lambda f: "PCSCAL" in f.sections, "with --ports and the port channel (a uniform damping d)"),
}

# families: name -> (what j counts, the C count)
FAMILIES = {"": ("", "COUNT_ONE"), "probe": ("probe", "COUNT_PER_PROBE"), "port": ("port", "COUNT_PER_PORT")}

ROLES = {("independent", "continuous"): "ROLE_INDEPENDENT", ("input", "continuous"): "ROLE_INPUT",
         ("parameter", "fixed"): "ROLE_FIXED", ("output", "continuous"): "ROLE_OUTPUT",
         ("calculatedParameter", "fixed"): "ROLE_CALCULATED"}


@dataclass(frozen=True)
class Variable:
    """One row of the table (module docstring).

    ``type`` is the FMI 3 type name (Float64, Int32; FMI 2: Real, Integer).  ``start``, ``min``, ``max``,
    ``nominal``: a number, a :class:`From` the packaged model, or None (absent).  ``description`` is the
    modelDescription's text, formatted with the FMU's values (:mod:`sphrom.fmu.make.describe`) and, in a family,
    ``j`` and ``x`` (the probe's or port's position x/L).  ``get``, ``set``, ``get_rate``, ``set_rate``: the
    C functions of instance.c (``get_rate``: the first time derivative of an output, ``set_rate``: the rate of
    an input over the next steps); '' for none.
    """

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    initial: str
    rule: str
    declared_type: str | None
    description: str
    summary: str
    get: str
    family: str = ""
    start: object = None
    min: object = None
    max: object = None
    nominal: object = None
    set: str = ""
    get_rate: str = ""
    set_rate: str = ""

    @property
    def display(self):
        """The name as documented: ``v_probe_j`` for the family ``v_probe_{j}``."""
        return self.name.replace("{j}", "j")

    @property
    def unit(self):
        return TYPES[self.declared_type][1] if self.declared_type else ""


_INPUT_HOLD = "{input_hold}"        # FMI 2: held, or linear with fmi2SetRealInputDerivatives; FMI 3: held

VARIABLES = (
    Variable("time", 0, "Float64", "independent", "continuous", "", "fmi3", "Time",
             "simulation time, t_start + n dt inside a step and exactly the communication point after it [s]",
             "simulation time; exactly t_comm + h after each step", get="get_time"),
    Variable("f", 1, "Float64", "input", "continuous", "", "always", "Acceleration",
             "external force per mass f(t); the force field is profile(x) f with profile(x) = {profile}; "
             + _INPUT_HOLD + " [m s^-2]",
             "external force per mass; the field is profile(x) f; held over each communication step, or linear "
             "with an input derivative (FMI 2)",
             get="get_f", set="set_f", set_rate="set_f_rate", start=defaults.FMU_INPUT,
             nominal=From("f_nominal", "the training force's amplitude")),
    Variable("n_freeze", 2, "Int32", "parameter", "fixed", "exact", "frozen", None,
             "refresh period of the frozen coefficients in internal steps (>= 1)",
             "refresh period of the frozen coefficients in internal steps, >= 1",
             get="get_n_freeze", set="set_n_freeze", start=From("n_freeze", "the packaged value, sphrom fmu --n-freeze"), min=1,
             max=INT32_MAX),
    Variable("dt", 3, "Float64", "parameter", "fixed", "exact", "frozen", "Time",
             "internal time step (> 0) [s]",
             "internal time step, > 0 (FMI 3 fixedInternalStepSize)",
             get="get_dt", set="set_dt", start=From("dt", "the scene's dt"), min=0,
             nominal=From("dt", "the scene's dt")),
    Variable("initial_state_scale", 4, "Float64", "parameter", "fixed", "exact", "always", "Scale",
             "initial state = this x the scene's initial deviation from rest (0: the component starts at rest, "
             f"1: the scene's initial velocity v0; -{defaults.MAX_INITIAL_STATE_SCALE:g} to "
             f"{defaults.MAX_INITIAL_STATE_SCALE:g}) [1]",
             "the initial state is this multiple of the scene's deviation from rest: 0 (start) at rest, 1 the "
             f"scene's v0, at most {defaults.MAX_INITIAL_STATE_SCALE:g} in size",
             get="get_initial_state_scale", set="set_initial_state_scale", start=defaults.FMU_INITIAL_STATE_SCALE,
             min=-defaults.MAX_INITIAL_STATE_SCALE, max=defaults.MAX_INITIAL_STATE_SCALE, nominal=1),
    Variable("v_probe_{j}", 1000, "Float64", "output", "continuous", "calculated", "always", "Velocity",
             "velocity at probe {j}, x/L = {x}, interpolated linearly between particles [m s^-1]",
             "velocity at probe j (x_j/L), interpolated linearly between particles",
             family="probe", get="rom_v_probe", get_rate="rom_v_probe_rate",
             nominal=From("v_nominal", "the largest |v| of the training run at the probe")),
    Variable("rho_probe_{j}", 2000, "Float64", "output", "continuous", "calculated", "always", "Density",
             "density at probe {j}, x/L = {x}, interpolated linearly between particles [kg m^-3]",
             "density at probe j, likewise",
             family="probe", get="rom_rho_probe", get_rate="rom_rho_probe_rate", min=0,
             nominal=From("rho_nominal", "rho0 at the probe")),
    Variable("force_error_bound", 8, "Float64", "calculatedParameter", "fixed", "calculated", "bounds",
             "ForceErrorBound",
             "certified bound on the probe velocity error per unit L2 norm of the force, the largest over the "
             "probes (here {fb_max} s); {what} [s]",
             "the largest of the force_error_bound_j", get="get_force_bound_max", min=0),
    Variable("initial_state_error_bound", 9, "Float64", "calculatedParameter", "fixed", "calculated", "bounds",
             "InitialStateErrorBound",
             "certified bound on the L2(0,T) probe velocity error of the free response from the scene's initial "
             "state, the largest over the probes (here {ib_max}; times |initial_state_scale|) [m s^-1 s^0.5]",
             "the largest of the initial_state_error_bound_j", get="get_initial_bound_max", min=0),
    Variable("force_error_bound_{j}", 5000, "Float64", "calculatedParameter", "fixed", "calculated", "bounds",
             "ForceErrorBound",
             "certified bound on the error of v_probe_{j} (x/L = {x}) per unit L2 norm of the force, from rest "
             "(here {fb} s) [s]",
             "||v_probe_j - v_full_j||_L2(0,T) <= this ||f||_L2(0,T) for every force from rest",
             family="probe", get="get_force_bound", min=0),
    Variable("initial_state_error_bound_{j}", 6000, "Float64", "calculatedParameter", "fixed", "calculated",
             "bounds", "InitialStateErrorBound",
             "certified bound on the L2(0,T) error of v_probe_{j} (x/L = {x}) in the free response from the "
             "scene's initial state (here {ib}; times |initial_state_scale|) [m s^-1 s^0.5]",
             "||v_probe_j - v_full_j||_L2(0,T) of the free response from the scene's initial state (times "
             "|initial_state_scale|)",
             family="probe", get="get_initial_bound", min=0),
    Variable("c", 5, "Float64", "parameter", "fixed", "exact", "varied_c", "Stiffness",
             "stiffness (Young's modulus) c, uniform, of the parametric model; fixed before initialization, "
             "within the trained range [kg m^-1 s^-2]",
             "stiffness c; outside the trained range (min, max) refused",
             get="get_c", set="set_c", start=From("c.start", "the scene's c, or the range's midpoint"),
             min=From("c.min", "the trained range"), max=From("c.max", "the trained range"),
             nominal=From("c.nominal", "the larger |bound| of the range")),
    Variable("d", 6, "Float64", "parameter", "fixed", "exact", "varied_d", "DampingRate",
             "damping rate d, uniform, of the parametric model; fixed before initialization, within the trained "
             "range [s^-1]",
             "damping rate d, likewise",
             get="get_d", set="set_d", start=From("d.start", "the scene's d, or the range's midpoint"),
             min=From("d.min", "the trained range"), max=From("d.max", "the trained range"),
             nominal=From("d.nominal", "the larger |bound| of the range")),
    Variable("area", 7, "Float64", "parameter", "fixed", "exact", "ports", "Area",
             "cross-section A of the bar (> 0): a port force F acts on the mass per length rho0 A [m^2]",
             "the cross-section A, > 0",
             get="get_area", set="set_area", start=defaults.FMU_AREA, min=0),
    Variable("F_port_{j}", 3000, "Float64", "input", "continuous", "", "ports", "Force",
             "point force at port {j}, x/L = {x}, spread by the SPH kernel W(x - x_j, h); " + _INPUT_HOLD + " [N]",
             "point force at port j, spread by the SPH kernel",
             family="port", get="get_port_force", set="set_port_force", set_rate="rom_set_port_rate",
             start=defaults.FMU_INPUT),
    Variable("v_port_{j}", 4000, "Float64", "output", "continuous", "calculated", "ports", "Velocity",
             "velocity of port {j}, x/L = {x}: sum_i W(x_i - x_j, h) v_i dx, power-conjugate to F_port_{j} "
             "[m s^-1]",
             "sum_i W(x_i - x_j, h) v_i dx, power-conjugate to F_port_j",
             family="port", get="rom_v_port"),
    Variable("port_impedance", 11, "Float64", "parameter", "fixed", "exact", "channel", "Impedance",
             "the wave (transmission-line) form of the ports: 0, the force form (inputs F_port_j); Z > 0, the inputs "
             "are the incident waves a_port_j and each port's force over a step is held at F = 2 a - Z vbar (vbar "
             "its mean velocity over the step), the reflected wave b_port_j = a - F, which a master passes on as the "
             "incident wave of the component at the line's other end one step later: passive at any communication "
             "step (docs/fmu/coupling.md) [N s m^-1]",
             "0: the force form; Z > 0: the wave form (inputs a_port_j, outputs b_port_j), passive at any step",
             get="get_port_impedance", set="set_port_impedance", start=defaults.FMU_PORT_IMPEDANCE, min=0),
    Variable("a_port_{j}", 3100, "Float64", "input", "continuous", "", "channel", "Force",
             "incident force wave at port {j}, x/L = {x}; " + _INPUT_HOLD + " (the force held on the bar is the "
             "mean of 2 a - Z v over the step); used when port_impedance > 0 (the wave form), F_port_{j} otherwise "
             "[N]",
             "incident force wave at port j (the wave form, port_impedance > 0)",
             family="port", get="rom_port_wave", set="set_port_wave", set_rate="rom_set_port_wave_rate",
             start=defaults.FMU_INPUT),
    Variable("b_port_{j}", 4100, "Float64", "output", "continuous", "calculated", "channel", "Force",
             "reflected force wave at port {j}, x/L = {x}, over the last step: a_port_{j} - F (a_port_{j}'s mean over "
             "the step with an input derivative), F the force held on the bar (the wave form; 0 in the force form) [N]",
             "reflected force wave at port j over the last step (the wave form)",
             family="port", get="rom_port_reflected"),
    Variable("error_tolerance", 10, "Float64", "parameter", "fixed", "exact", "shadow", "Velocity",
             "a logStatusWarning (once) when the certified error bound of a velocity output (v_probe_j, v_port_j) "
             "first exceeds this; 0: no warning (default: 5 % of the training run's largest |v_probe|) [m s^-1]",
             "warn once when a velocity output's certified error bound exceeds this; 0: never",
             get="get_error_tolerance", set="set_error_tolerance", min=0,
             start=From("error_tolerance", "5 % of the training run's largest |v_probe|")),
    Variable("v_probe_{j}_error_bound", 7000, "Float64", "output", "continuous", "calculated", "shadow", "Velocity",
             "certified upper bound of |v_probe_{j} - v_true| now (x/L = {x}), v_true the full linear SPH "
             "(eqs. 2.10-2.11 in J) integrated exactly from the same initial state with the same inputs [m s^-1]",
             "certified bound of |v_probe_j - truth|, the truth the full linear SPH run exactly on the same inputs",
             family="probe", get="rom_v_probe_error_bound", min=0),
    Variable("rho_probe_{j}_error_bound", 8000, "Float64", "output", "continuous", "calculated", "shadow",
             "Density",
             "certified upper bound of |rho_probe_{j} - rho_true| now (x/L = {x}), likewise; infinite where the "
             "certified interval of J reaches 0 [kg m^-3]",
             "certified bound of |rho_probe_j - truth|, likewise",
             family="probe", get="rom_rho_probe_error_bound", min=0),
    Variable("v_port_{j}_error_bound", 9000, "Float64", "output", "continuous", "calculated", "shadow_ports",
             "Velocity",
             "certified upper bound of |v_port_{j} - v_port_true| now (x/L = {x}), likewise [m s^-1]",
             "certified bound of |v_port_j - truth|, likewise",
             family="port", get="rom_v_port_error_bound", min=0),
)

BY_NAME = {v.display: v for v in VARIABLES}


def max_count(family):
    """The most members a family can have (resources.MAX_PROBES, MAX_PORTS; 1 for one variable)."""
    from .resources import MAX_PORTS, MAX_PROBES     # imported on use: ``sphrom --help`` stays light
    return {"": 1, "probe": MAX_PROBES, "port": MAX_PORTS}[family]


# ---------------------------------------------------------------------------------------------------------------
# value references and names
# ---------------------------------------------------------------------------------------------------------------

def vr(name, j=None):
    """The value reference of ``name`` (as documented: ``f``, ``v_probe_j``); of a family's j-th (1-based)."""
    row = BY_NAME[name]
    if not row.family:
        if j is not None:
            raise ValueError(f"{name} is one variable, not a family")
        return row.vr
    if j is None or not 1 <= j <= max_count(row.family):
        raise ValueError(f"{name}: j = {j!r} (allowed: 1 to {max_count(row.family)})")
    return row.vr + j - 1


def concrete_name(row, j=None):
    """The FMI name of ``row`` (of its j-th for a family)."""
    return row.name.replace("{j}", str(j)) if row.family else row.name


def lookup(name):
    """(row, j) of the FMI variable ``name`` (``v_probe_2`` is the row ``v_probe_{j}`` with j = 2; j None for
    one variable), or (None, None)."""
    for row in VARIABLES:
        if not row.family:
            if row.name == name:
                return row, None
            continue
        head, tail = row.name.split("{j}")
        m = re.fullmatch(re.escape(head) + r"([1-9]\d*)" + re.escape(tail), name)
        if m:
            return row, int(m.group(1))
    return None, None


def members(names, name):
    """The indices of ``names`` (FMI names) that are members of the family ``name`` (as documented: ``v_probe_j``
    holds v_probe_2, not v_probe_2_error_bound), in their order."""
    row = BY_NAME[name]
    return [i for i, n in enumerate(names) if lookup(n)[0] is row]


def vr_text(row):
    """The value reference as documented: ``1``, or ``1000+j-1`` for a family."""
    return f"{row.vr}+j-1" if row.family else str(row.vr)


def c_macro(row):
    """The C name of the row's value reference: ROM_VR_ and the name without ``_{j}``, upper case; a family
    whose name would repeat another row's gets its family's name (force_error_bound_{j}:
    ROM_VR_FORCE_ERROR_BOUND_PROBE)."""
    base = row.name.replace("_{j}", "").replace("{j}", "")
    if row.family and any(other.name == base for other in VARIABLES):
        base += "_" + row.family
    return "ROM_VR_" + base.upper()


def allowed_words(row):
    """What a parameter accepts, in the words of the C core's message (the one check: rom.c); '' for none."""
    if row.type == "Int32" and row.min is not None:
        return f"an integer >= {row.min}" if row.max in (None, INT32_MAX) else f"an integer in [{row.min}, {row.max}]"
    return ""


def check_parameter(name, value):
    """``value`` as the FMU's parameter ``name`` accepts it (an int for an Int32), or FieldError naming the field
    and the allowed range in the C core's words: the Python pre-check of :func:`sphrom.fmu.make.package.check_options`
    and ``sphrom cosim``, the same range and message as the FMU's own check."""
    from ..errors import FieldError
    import numpy as np
    row = BY_NAME[name]
    if row.type == "Int32":
        lo, hi = row.min, INT32_MAX if row.max is None else row.max
        ok = not isinstance(value, bool) and isinstance(value, (int, np.integer)) and lo <= value <= hi
        if not ok:
            raise FieldError(name, f"{value!r} is out of range (allowed: {allowed_words(row)})")
        return int(value)
    raise ValueError(f"{name}: only integer parameters have a Python pre-check")


def absent(name, fmu="this FMU", why=None):
    """The FieldError for a value given to the parameter ``name`` that ``fmu`` does not have (it would be ignored):
    ``why`` defaults to the words of the row's rule (n_freeze: frozen model only)."""
    from ..errors import FieldError
    return FieldError(name, f"{fmu} has no parameter {name} ({why or RULES[BY_NAME[name].rule][1]})")


# ---------------------------------------------------------------------------------------------------------------
# presence and the variables of one FMU
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Facts:
    """What decides an FMU's variables: the FMI version, whether its model kind advances by internal steps of dt
    (the kind's ``INTERNAL_STEP``: it then has the parameters n_freeze and dt; C rom_has_internal_step), the
    sections of its resources, the varied parameters and the positions x/L of the probes and ports (the families'
    counts)."""

    fmi: int
    internal_step: bool
    sections: frozenset
    varied: frozenset
    positions: dict

    def count(self, family):
        return len(self.positions.get(family, ())) if family else 1


def facts(data, fmi):
    """The :class:`Facts` of an FMU of FMI version ``fmi`` packed from ``data`` (a model kind's data, as written
    to or read from resources/model.bin): what the C instance reads from the same file."""
    import numpy as np

    from ..rom.parametric import PARAMETERS
    from .layout import column, row
    sections = dict(getattr(data, "sections", {}) or {})
    params = sections.get("PARAMS")
    varied = frozenset(name for name in PARAMETERS
                       if params is not None and params[row("PARAMS", name), column("PARAMS", "varied")] != 0)
    ports = sections.get("PORTX")
    positions = {"probe": tuple(float(x) for x in np.asarray(data.probe_x)),
                 "port": tuple(float(x) for x in ports[0]) if ports is not None else ()}
    return Facts(fmi=int(fmi), internal_step=type(data).INTERNAL_STEP, sections=frozenset(sections), varied=varied,
                 positions=positions)


def present(row, f):
    """Whether the FMU of facts ``f`` has the variable (row) ``row``."""
    return RULES[row.rule][0](f)


def number(x) -> str:
    """Shortest text that reads back as the same float (xs:double)."""
    return repr(float(x))


def _compact(x):
    """A constant as the modelDescription writes it: 0, 1, 0.5."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _cell(row, value, scope):
    """The text of an attribute: a constant, a model value (repr of the float, an integer for Int32), or None."""
    if value is None:
        return None
    if isinstance(value, From):
        value = scope.get(value.key)
        if value is None:
            return None
        return str(int(value)) if row.type == "Int32" else number(value)
    return str(int(value)) if row.type == "Int32" else _compact(value)


def declared(f, values):
    """The variables of the FMU of facts ``f``, in table order (a family's members j = 1, 2, ... together), as
    dicts: row, j, name, vr, type (FMI 3 name), causality, variability, initial, declared_type, unit, start,
    min, max, nominal (texts or None), description (formatted with ``values``, and per family member j and x),
    index (FMI 2: 1-based position).

    ``values`` maps the keys of the table's :class:`From` cells and of its descriptions to the FMU's values;
    under a family's name (``probe``, ``port``) it holds a dict of lists, one value per member."""
    out = []
    for row in VARIABLES:
        if not present(row, f):
            continue
        members = range(1, f.count(row.family) + 1) if row.family else [None]
        for j in members:
            scope = {k: v for k, v in values.items() if k not in FAMILIES}
            if j is not None:
                scope.update({k: v[j - 1] for k, v in values.get(row.family, {}).items()})
                scope.update(j=j, x=f"{f.positions[row.family][j - 1]:g}")
            out.append({"row": row, "j": j, "name": concrete_name(row, j), "vr": row.vr + (j - 1 if j else 0),
                        "type": row.type, "causality": row.causality, "variability": row.variability,
                        "initial": row.initial, "declared_type": row.declared_type, "unit": row.unit,
                        "start": _cell(row, row.start, scope), "min": _cell(row, row.min, scope),
                        "max": _cell(row, row.max, scope), "nominal": _cell(row, row.nominal, scope),
                        "description": row.description.format(**scope), "index": len(out) + 1})
    return out


# ---------------------------------------------------------------------------------------------------------------
# generated texts: fmu_src/fmu_variables.h, sphrom fmu --help, docs/fmu/variables.md's table
# ---------------------------------------------------------------------------------------------------------------

COMMAND = "python3 -m sphrom.fmu.variables --write"
HEADER_FILE = "fmu_src/fmu_variables.h"
TABLE_FILE = "docs/fmu/variables.md"       # the docs page that holds the generated table
TABLE_BEGIN = f"<!-- begin FMU variables: generated by `{COMMAND}` from harness/fmu/variables.py -->"
TABLE_END = "<!-- end FMU variables -->"
README_FILE = "README.md"                  # ... and the README's shorter table, between the same markers


def _start_macro(row):
    return c_macro(row).replace("ROM_VR_", "ROM_", 1) + "_START"


def _c_double(x):
    text = repr(float(x))
    return text if any(c in text for c in ".eE") else text + ".0"


def _c_row(row):
    fields = [f'.name = "{row.name.split("{j}")[0]}"']
    if row.family:
        fields.append(f'.name_tail = "{row.name.split("{j}")[1]}"')
    fields += [f".vr = {c_macro(row)}", f".count = {FAMILIES[row.family][1]}",
               f".type = TYPE_{row.type.upper()}", f".role = {ROLES[(row.causality, row.variability)]}"]
    if row.rule != "always":
        fields.append(f".present = rule_{row.rule}")
    fields.append(f".get_{row.type.lower()} = {row.get}")
    if row.set:
        fields.append(f".set_{row.type.lower()} = {row.set}")
    if row.get_rate:
        fields.append(f".get_rate = {row.get_rate}")
    if row.set_rate:
        fields.append(f".set_rate = {row.set_rate}")
    if row.start is not None and not isinstance(row.start, From):
        fields += [".has_start = 1", f".start = {_start_macro(row)}"]
    return "{" + ", ".join(fields) + "}"


def c_header():
    """The text of fmu_src/fmu_variables.h."""
    width = max(len(c_macro(r)) for r in VARIABLES) + 1
    lines = [f"/* GENERATED by `{COMMAND}` from harness/fmu/variables.py: do not edit.",
             " *",
             " * The FMU's variables (both FMI versions): their value references, the start values the instance",
             " * applies after every instantiation and reset, and the rows of instance.c's table VARIABLES[]",
             " * (FMU_VARIABLE_ROWS).  A family's j-th member (j = 1, 2, ...) has the value reference base + j - 1.",
             " */",
             "#ifndef SPHROM_FMU_VARIABLES_H",
             "#define SPHROM_FMU_VARIABLES_H",
             "",
             "/* value references */"]
    for row in VARIABLES:
        member = f"{row.display}: {row.vr} + j - 1" if row.family else row.name
        unit = f" [{row.unit}]" if row.unit else ""
        rule = "" if row.rule == "always" else f"; {RULES[row.rule][1]}"
        lines.append(f"#define {c_macro(row):<{width}} {str(row.vr) + 'u':<6} /* {row.causality} {member}{unit}{rule} */")
    lines += ["", "/* constant start values (harness/defaults.py) */"]
    for row in VARIABLES:
        if row.start is not None and not isinstance(row.start, From):
            lines.append(f"#define {_start_macro(row)} {_c_double(row.start)}   /* {row.display} */")
    with_rates = [r.display for r in VARIABLES if r.get_rate]
    lines += ["", "/* the outputs whose time derivatives the FMU gives (messages) */",
              f'#define FMU_OUTPUTS_WITH_RATES "{" and ".join(with_rates)}"',
              "",
              "/* the rows of instance.c's VARIABLES[]: the getters, setters and presence rules (rule_<name>) they",
              " * name are instance.c's functions */",
              "#define FMU_VARIABLE_ROWS \\"]
    rows = [_c_row(r) for r in VARIABLES]
    lines += [f"    {text}, \\" for text in rows[:-1]] + [f"    {rows[-1]}", "", "#endif /* SPHROM_FMU_VARIABLES_H */",
                                                          ""]
    return "\n".join(lines)


def _fmi_types(row):
    return {"Float64": "Real / Float64", "Int32": "Integer / Int32"}[row.type]


def _start_words(row):
    if row.start is None:
        return ""
    if isinstance(row.start, From):
        return f"start: {row.start.words}"
    return f"start {_compact(row.start)}"


def help_text():
    """The variable list of ``sphrom fmu --help`` (one line per variable)."""
    lines = ["FMU variables (name [value reference] causality, unit: meaning; where not in every FMU, which have "
             "it):"]
    for row in VARIABLES:
        where = "" if row.rule == "always" else f" ({RULES[row.rule][1]})"
        start = _start_words(row)
        lines.append(f"  {row.display} [{vr_text(row)}] {row.causality}, {row.unit or '-'}: {row.summary}"
                     + (f"; {start}" if start else "") + where)
    return "\n".join(lines) + "\n"


def table_markdown():
    """docs/fmu/variables.md's variable table (the text between the markers)."""
    lines = ["| name [value reference] | causality | type (FMI 2 / 3) | unit | in | meaning |",
             "| --- | --- | --- | --- | --- | --- |"]
    for row in VARIABLES:
        what = ", ".join(w for w in (row.causality, row.variability if row.causality != "independent" else "",
                                     row.initial, _start_words(row)) if w).replace("|", chr(92) + "|")
        unit = UNITS[row.unit][1] if row.unit else "–"
        lines.append(f"| `{row.display}` [{vr_text(row)}] | {what} | {_fmi_types(row)} | {unit} | "
                     f"{RULES[row.rule][1]} | {row.summary.replace('|', chr(92) + '|')} |")
    return "\n".join(lines)


def readme_markdown():
    """The README's variable table (between the markers): every variable, one row each, the columns a user of
    the FMU reads first (docs/fmu/variables.md has the full table)."""
    lines = ["| variable [value reference] | causality | unit | in | meaning |", "| --- | --- | --- | --- | --- |"]
    for row in VARIABLES:
        what = ", ".join(w for w in (row.causality, _start_words(row)) if w).replace("|", chr(92) + "|")
        unit = UNITS[row.unit][1] if row.unit else "–"
        lines.append(f"| `{row.display}` [{vr_text(row)}] | {what} | {unit} | {RULES[row.rule][1]} | "
                     f"{row.summary.replace('|', chr(92) + '|')} |")
    return "\n".join(lines)


def table_page_text(text, table=None):
    """``text`` (docs/fmu/variables.md, or the README with ``table=readme_markdown()``) with the section between
    the markers generated (ValueError without the markers)."""
    begin, end = text.index(TABLE_BEGIN) + len(TABLE_BEGIN), text.index(TABLE_END)
    return text[:begin] + "\n" + (table_markdown() if table is None else table) + "\n" + text[end:]


def generated(root=None):
    """{path relative to the checkout: its text as generated now} of every generated file."""
    from ..paths import repo_root
    root = Path(root or repo_root())
    return {HEADER_FILE: c_header(),
            TABLE_FILE: table_page_text((root / TABLE_FILE).read_text(encoding="utf-8")),
            README_FILE: table_page_text((root / README_FILE).read_text(encoding="utf-8"), readme_markdown())}


def stale(root=None):
    """The generated files whose committed text differs from the table's."""
    from ..paths import repo_root
    from .generated import stale as stale_files
    root = Path(root or repo_root())
    return stale_files(generated(root), root)


def main(argv=None):
    from .generated import main as command_line
    return command_line(argv, prog="python3 -m sphrom.fmu.variables",
                        source="the FMU's variable table (harness/fmu/variables.py)", command=COMMAND,
                        generated=generated)


if __name__ == "__main__":
    sys.exit(main())
