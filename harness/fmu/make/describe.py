"""Assemble an FMU's modelDescription.xml: the templates (``modelDescription/*.xml``) and the variable table.

The templates hold the XML around the variables; ``{{name}}`` takes one (XML-escaped) value,
``{{{name}}}`` one piece of XML, and ``{{#list}} ... {{/list}}`` repeats its body once per item of a list.
The variables, their units and declared types and the ModelStructure come from
:mod:`sphrom.fmu.variables`: the rows the FMU has (its presence rules on the packed resources), FMI 2
indices counted from them, the Outputs and InitialUnknowns listed from their causalities.
"""

from __future__ import annotations

import datetime as _dt
import re
from xml.sax.saxutils import escape

from ... import __version__
from ...paths import data_dir
from ...rom.registry import get_model
from .. import layout, variables
from ..kinds import kind_of, unpack
from ..variables import number
from .build import fmu_sources

_BLOCK = re.compile(r"\{\{#(\w+)\}\}(.*?)\{\{/\1\}\}", re.S)
_RAW = re.compile(r"\{\{\{(\w+)\}\}\}")
_FIELD = re.compile(r"(?<!\{)\{\{(\w+)\}\}(?!\})")


def render(template: str, values: dict, lists: dict, raw=None) -> str:
    """Substitute ``values``, repeat ``lists`` blocks and insert the XML pieces ``raw`` (module docstring)."""
    def field(match, scope):
        key = match.group(1)
        if key not in scope:
            raise KeyError(f"template placeholder {{{{{key}}}}} has no value")
        return escape(str(scope[key]), {'"': "&quot;"})

    def block(match):
        body = match.group(2)
        return "".join(_FIELD.sub(lambda m: field(m, {**values, **item}), body) for item in lists[match.group(1)])

    text = _FIELD.sub(lambda m: field(m, values), _BLOCK.sub(block, template))
    return _RAW.sub(lambda m: (raw or {})[m.group(1)], text)


def template(name: str) -> str:
    """The text of ``modelDescription/<name>`` without its leading comment, which explains the template's
    placeholders to this repository's readers and means nothing inside an FMU."""
    text = (data_dir("model_description") / name).read_text(encoding="utf-8")
    return re.sub(r"\A(<\?xml[^>]*\?>\s*)<!--.*?-->\s*", r"\1", text, count=1, flags=re.S)


def bound_text(bounds):
    """What the certified bounds bound, in one sentence (model description, ``sphrom fmu``)."""
    T = bounds["horizon"]
    if bounds["sigma"]:
        how = (f"through the shifted error system (sigma = {bounds['sigma']:.4g} 1/s, factor e^(sigma T) = "
               f"{bounds['factor']:.4g}), valid on [0, T]")
    else:
        how = "the error system is asymptotically stable (no shift): the force bound holds on any horizon"
    return (f"certified against the full linear SPH (every particle, exact in the specific volume) on "
            f"[0, T = {T:g} s]: "
            f"||v_probe_j - v_full_j||_L2(0,T) <= force_error_bound_j ||f||_L2(0,T) for every force f from rest, "
            f"and <= initial_state_error_bound_j for the free response from the scene's initial state "
            f"(both together: the sum); {how}")


def model_description(fmi: int, *, token, scene, data, k_requested, step_size, stop_time, input_error,
                      model="frozen", envelope=None, measured=None, bounds=None):
    """The modelDescription.xml text for FMI version ``fmi`` (2 or 3).

    Parameters
    ----------
    token : str
        GUID / instantiationToken (from the resources).
    scene : Scene
    data : ModelData or ExactData
        The packed model (sizes, dt, n_freeze, probes, sections): which variables the FMU has and their
        start values come from it, as the C instance takes them from the same resources/model.bin.
    k_requested : int
        POD modes asked for (k_v may be one more: the input direction).
    step_size, stop_time : float
        DefaultExperiment [s].
    input_error : float
        Relative projection error of the force profile on the POD velocity modes.
    model : str
        The registered reduced model packaged (its title heads the description).
    envelope : Envelope, optional
        What the basis was trained on (:mod:`sphrom.fmu.training.envelope`), appended to the description; the
        nominal values of f and the probe outputs.
    measured : str, optional
        The verification's sentence (errors against the full SPH, run times), appended to the description.
    bounds : dict, optional
        Linear models: the report of the certified error bounds (:func:`sphrom.rom.balanced.error_bounds`)
        whose values section BOUNDS holds (default ``data.bounds``), for the words of the description.
    """
    kind = kind_of(data)
    bounds = bounds if bounds is not None else getattr(data, "bounds", None)
    facts = variables.facts(data, fmi)
    declared = variables.declared(facts, variable_values(fmi, scene, data, envelope, bounds))
    augmented = data.k_v > k_requested
    modes = (f"k_v = {data.k_v} velocity modes ({k_requested} POD modes"
             + (" + the force profile direction" if augmented else "") + f"), k_rho = {data.k_rho} density modes")
    where = ", ".join(f"{x:g}" for x in data.probe_x)
    spec = get_model(model)
    if spec.basis_kind == "energy":
        modes = modes.replace("density modes", "specific-volume modes")
    if spec.basis_kind is None:
        modes = (f"order r = {data.k} (its state mixes velocity and specific volume: the probe outputs are rows "
                 f"over the whole state)")
    stepping = kind.stepping(data)
    description = (f"{spec.title} of the SPH mass-spring-damper scene '{scene.name}' ({scene.title}; "
                   f"N = {scene.sph.n_particles}, L = {scene.L:g} m): {modes}; {stepping}; probes at x/L = {where}"
                   + (f"; input projection error {input_error:.3g}" if input_error == input_error else "")
                   + (f"; error bounds {bound_text(bounds)}" if bounds is not None else "") + ".")
    if envelope is not None:
        bounded = "SHSCAL" in (getattr(data, "sections", None) or {})
        description += " Training envelope: " + "; ".join(envelope.lines(linear=spec.linear, bounded=bounded)) + "."
    if measured:
        description += " " + measured
    ports = facts.positions["port"]
    if ports:
        description += (f" Mechanical ports at x/L = {', '.join(f'{x:g}' for x in ports)}: inputs F_port_j [N], "
                        "outputs v_port_j [m s^-1], parameter area [m^2].")
    values = {
        "model_name": f"sphrom {scene.name}",
        "token": token,
        "description": description,
        "version": __version__,
        "generation_tool": f"sphrom {__version__}",
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "stop_time": number(stop_time),
        "step_size": number(step_size),
        **{name: number(v) for name, v in kind.parameter_starts(data).items()},
        # the linear models give dy/dt = C (A z + B f) exactly (fmu_src/rom.h rom_max_output_derivative_order);
        # the frozen model's trajectory is a discrete map of internal steps: none
        "max_output_derivative_order": kind.OUTPUT_DERIVATIVE_ORDER,
    }
    lists = {
        # FMI 3 fixedInternalStepSize only where there is one: the linear model steps by the matrix exponential
        "internal_step": [{}] if kind.INTERNAL_STEP else [],
        "source_files": [{"name": name} for name in fmu_sources(fmi) if name.endswith(".c")],
    }
    raw = {"unit_definitions": unit_definitions(declared), "type_definitions": type_definitions(declared, fmi),
           "model_variables": model_variables(declared, fmi), "model_structure": model_structure(declared, fmi)}
    return render(template(f"fmi{fmi}.xml"), values, lists, raw)


def variable_values(fmi, scene, data, envelope, bounds):
    """The FMU's values the variable table's descriptions and :class:`~sphrom.fmu.variables.From` cells name
    (under ``probe``: one value per probe)."""
    values = {
        "profile": scene.fields["profile"].text,
        # FMI 2 only: the linear models integrate f + (df/dt) tau over a step exactly, the frozen model
        # evaluates it at each refresh of its force term
        "input_hold": ("held over each communication step, or linear with the derivative of "
                       "fmi2SetRealInputDerivatives" if fmi == 2 else "held over each communication step"),
        **kind_of(data).parameter_starts(data),        # the start values of the kind's own parameters
        # nominal values from the training envelope: max |v| and rho0 at each probe, the training force amplitude
        # (none for f = 0: a free response trained no force scale)
        "f_nominal": (envelope.force_amplitude if envelope is not None and envelope.force_amplitude > 0
                      else None),
        "probe": {"v_nominal": [float(envelope.probe_v_max[j]) if envelope is not None
                                and envelope.probe_v_max[j] > 0 else 1.0 for j in range(data.n_probes)],
                  "rho_nominal": [float(envelope.probe_rho0[j]) if envelope is not None else 1.0
                                  for j in range(data.n_probes)]},
    }
    section = getattr(data, "sections", {}).get("BOUNDS")
    if section is not None:
        fb, ib = section[0], section[1]
        values["probe"].update(fb=[f"{x:.6g}" for x in fb], ib=[f"{x:.6g}" for x in ib])
        values.update(fb_max=f"{max(fb):.6g}", ib_max=f"{max(ib):.6g}",
                      what=bound_text(bounds) if bounds is not None else "certified against the full linear SPH")
    if "SHSCAL" in getattr(data, "sections", {}):   # error_tolerance's default (harness/rom/bounds.py sections)
        values["error_tolerance"] = layout.value(data.sections, "SHSCAL", "tolerance")
    params = getattr(data, "sections", {}).get("PARAMS")
    if params is not None:
        from ...rom.parametric import PARAMETERS
        for name in PARAMETERS:                     # rows c, d: varied, start, min, max
            i = layout.row("PARAMS", name)
            start, low, high = (layout.value(data.sections, "PARAMS", column, i) for column in ("start", "min", "max"))
            values.update({f"{name}.start": start, f"{name}.min": low, f"{name}.max": high,
                           f"{name}.nominal": max(abs(low), abs(high))})
    return values


def _attributes(pairs):
    """' name="value"' for every pair whose value is not None (values XML-escaped)."""
    return "".join(f' {k}="{escape(str(v), {chr(34): "&quot;"})}"' for k, v in pairs if v not in (None, ""))


FMI2_TYPES = {"Float64": "Real", "Int32": "Integer"}


def model_variables(declared, fmi):
    """The <ModelVariables> children of the declared variables (FMI 2: ScalarVariable with its index)."""
    lines = []
    for v in declared:
        limits = [("start", v["start"]), ("min", v["min"]), ("max", v["max"]), ("nominal", v["nominal"])]
        head = [("name", v["name"]), ("valueReference", v["vr"]), ("causality", v["causality"]),
                ("variability", v["variability"]), ("initial", v["initial"])]
        if fmi == 2:
            element = FMI2_TYPES[v["type"]]
            lines += [f"    <!-- index {v['index']} -->",
                      f"    <ScalarVariable{_attributes(head)}",
                      f"                   {_attributes([('description', v['description'])])}>",
                      f"      <{element}{_attributes([('declaredType', v['declared_type']), *limits])}/>",
                      "    </ScalarVariable>"]
        else:
            lines += [f"    <{v['type']}{_attributes(head + [('declaredType', v['declared_type'])] + limits)}",
                      f"        {_attributes([('description', v['description'])])}/>"]
    return "\n".join(lines)


def model_structure(declared, fmi):
    """The <ModelStructure> children: every output, then the initial unknowns (the outputs and the calculated
    parameters, initial = calculated), in index order; no dependencies declared (the outputs depend on the
    state)."""
    outputs = [v for v in declared if v["causality"] == "output"]
    initial = [v for v in declared if v["initial"] == "calculated"]
    if fmi == 2:
        lines = ["    <Outputs>", *(f'      <Unknown index="{v["index"]}" dependencies=""/>' for v in outputs),
                 "    </Outputs>", "    <InitialUnknowns>",
                 *(f'      <Unknown index="{v["index"]}" dependencies=""/>' for v in initial), "    </InitialUnknowns>"]
    else:
        lines = [*(f'    <Output valueReference="{v["vr"]}" dependencies=""/>' for v in outputs),
                 *(f'    <InitialUnknown valueReference="{v["vr"]}" dependencies=""/>' for v in initial)]
    return "\n".join(lines)


def _used(declared):
    """The declared types the variables use, in the table's order of types."""
    names = {v["declared_type"] for v in declared}
    return [name for name in variables.TYPES if name in names]


def unit_definitions(declared):
    """The <UnitDefinitions> children: the units of the declared types used."""
    units = {variables.TYPES[name][1] for name in _used(declared)}
    lines = []
    for name, (base, _) in variables.UNITS.items():
        if name not in units:
            continue
        if base is None:
            lines += ["    <!-- no BaseUnit: its exponents are integers -->", f'    <Unit name="{escape(name)}"/>']
        elif not base:
            lines.append(f'    <Unit name="{escape(name)}"/>')
        else:
            lines.append(f'    <Unit name="{escape(name)}"><BaseUnit{_attributes(base.items())}/></Unit>')
    return "\n".join(lines)


def type_definitions(declared, fmi):
    """The <TypeDefinitions> children: the declared types used, each with its quantity and unit."""
    lines = []
    for name in _used(declared):
        quantity, unit = variables.TYPES[name]
        if fmi == 2:
            lines.append(f'    <SimpleType name="{name}"><Real quantity="{quantity}" unit="{escape(unit)}"/></SimpleType>')
        else:
            lines.append(f'    <Float64Type name="{name}" quantity="{quantity}" unit="{escape(unit)}"/>')
    return "\n".join(lines)


def build_description(blob) -> str:
    """sources/buildDescription.xml of the FMI 3 FMU whose resources/model.bin is ``blob``: its sources, and the
    model it holds (read from the resources) in its description."""
    title = get_model(model_name(unpack(blob))).title
    return render(template("buildDescription.xml"), {"description": f"{title}, FMI 3.0 co-simulation"},
                  {"source_files": [{"name": name} for name in fmu_sources(3) if name.endswith(".c")]})


def model_name(data):
    """The registered model a packed model.bin holds (its kind's answer: frozen for kind 1; exact or balanced for
    kind 2, from section LINMODEL)."""
    return kind_of(data).model_name(data)
