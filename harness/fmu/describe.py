"""Fill the modelDescription templates (``modelDescription/*.xml``).

The templates hold all the XML; this module only substitutes values:
``{{name}}`` takes one (XML-escaped) value and ``{{#list}} ... {{/list}}``
repeats its body once per item of a list (probes, outputs).
"""

from __future__ import annotations

import datetime as _dt
import re
from xml.sax.saxutils import escape

from .. import __version__
from ..paths import data_dir

VR_V_PROBE = 1000        # fmu_src/rom.h ROM_VR_V_PROBE
VR_RHO_PROBE = 2000      # ROM_VR_RHO_PROBE
VR_INITIAL_STATE_SCALE = 4   # ROM_VR_INITIAL_STATE_SCALE
INITIAL_STATE_SCALE_START = 0.0  # ROM_INITIAL_STATE_SCALE_START: the FMU starts at rest
VR_FORCE_ERROR_BOUND = 8                     # ROM_VR_FORCE_ERROR_BOUND
VR_INITIAL_STATE_ERROR_BOUND = 9             # ROM_VR_INITIAL_STATE_ERROR_BOUND
VR_FORCE_ERROR_BOUND_PROBE = 5000            # ROM_VR_FORCE_ERROR_BOUND_PROBE
VR_INITIAL_STATE_ERROR_BOUND_PROBE = 6000    # ROM_VR_INITIAL_STATE_ERROR_BOUND_PROBE
FIXED_VARIABLES = 3      # FMI 2 indices 1..3: f, n_freeze, dt
VR_AREA = 7              # ROM_VR_AREA: the cross-section, only with ports
VR_F_PORT = 3000         # ROM_VR_F_PORT: F_port_1 ..
VR_V_PORT = 4000         # ROM_VR_V_PORT: v_port_1 ..

_BLOCK = re.compile(r"\{\{#(\w+)\}\}(.*?)\{\{/\1\}\}", re.S)
_FIELD = re.compile(r"\{\{(\w+)\}\}")


def render(template: str, values: dict, lists: dict) -> str:
    """Substitute ``values`` and repeat ``lists`` blocks (see module docstring)."""
    def field(match, scope):
        key = match.group(1)
        if key not in scope:
            raise KeyError(f"template placeholder {{{{{key}}}}} has no value")
        return escape(str(scope[key]), {'"': "&quot;"})

    def block(match):
        body = match.group(2)
        return "".join(_FIELD.sub(lambda m: field(m, {**values, **item}), body) for item in lists[match.group(1)])

    return _FIELD.sub(lambda m: field(m, values), _BLOCK.sub(block, template))


def template(name: str) -> str:
    """The text of ``modelDescription/<name>``."""
    return (data_dir("model_description") / name).read_text(encoding="utf-8")


def number(x) -> str:
    """Shortest text that reads back as the same float (xs:double)."""
    return repr(float(x))


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
                      model="frozen", envelope=None, measured=None, bounds=None, parameters=()):
    """The modelDescription.xml text for FMI version ``fmi`` (2 or 3).

    Parameters
    ----------
    token : str
        GUID / instantiationToken (from the resources).
    scene : Scene
    data : ModelData
        The packed model (sizes, dt, n_freeze, probes).
    k_requested : int
        POD modes asked for (k_v may be one more: the input direction).
    step_size, stop_time : float
        DefaultExperiment [s].
    input_error : float
        Relative projection error of the force profile on the POD velocity modes.
    model : str
        The registered reduced model packaged (its title heads the description).
    envelope : Envelope, optional
        What the basis was trained on (:mod:`harness.fmu.envelope`), appended to the description.
    measured : str, optional
        The verification's sentence (errors against the full SPH, run times), appended to the description.
    bounds : dict, optional
        Linear models: the certified error bounds (:func:`harness.rom.balanced.error_bounds`), declared as
        calculated parameters.
    parameters : sequence of dict
        Parameters of a parametric model (:func:`harness.fmu.parametric.parameter_variables`): name, vr,
        start, min, max, nominal, description; listed after the outputs.
    """
    from ..rom.registry import get_model

    probes = [{"j": j + 1, "x": f"{x:g}", "v_vr": VR_V_PROBE + j, "rho_vr": VR_RHO_PROBE + j,
               "v_index": FIXED_VARIABLES + 1 + j, "rho_index": FIXED_VARIABLES + 1 + data.n_probes + j}
              for j, x in enumerate(data.probe_x)]
    # nominal values from the training envelope: max |v| and rho0 at each probe, the training force amplitude
    # (none for f = 0: a free response trained no force scale)
    for j, p in enumerate(probes):
        v_max = envelope.probe_v_max[j] if envelope is not None else 0.0
        p["v_nominal"] = number(v_max if v_max > 0 else 1.0)
        p["rho_nominal"] = number(envelope.probe_rho0[j] if envelope is not None else 1.0)
    f_nominal = ([{"f_nominal": number(envelope.force_amplitude)}]
                 if envelope is not None and envelope.force_amplitude > 0 else [])
    outputs = ([{"vr": p["v_vr"], "index": p["v_index"]} for p in probes]
               + [{"vr": p["rho_vr"], "index": p["rho_index"]} for p in probes])
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
    if spec.linear:
        stepping = ("advanced over each communication step by the matrix exponential (input held, or linear "
                    "with fmi2SetRealInputDerivatives in FMI 2), so dt and n_freeze have no effect")
    else:
        stepping = (f"{data.integrator} integrator, internal dt = {data.dt:g} s, n_freeze = {data.n_freeze} by "
                    "default")
    description = (f"{spec.title} of the SPH mass-spring-damper scene '{scene.name}' ({scene.title}; "
                   f"N = {scene.sph.n_particles}, L = {scene.L:g} m): {modes}; {stepping}; probes at x/L = {where}"
                   + (f"; input projection error {input_error:.3g}" if input_error == input_error else "")
                   + (f"; error bounds {bound_text(bounds)}" if bounds is not None else "") + ".")
    if envelope is not None:
        description += " Training envelope: " + "; ".join(envelope.lines(linear=spec.linear)) + "."
    if measured:
        description += " " + measured
    values = {
        "model_name": f"sphrom {scene.name}",
        "token": token,
        "description": description,
        "version": __version__,
        "generation_tool": f"sphrom {__version__}",
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "stop_time": number(stop_time),
        "step_size": number(step_size),
        "n_freeze": int(data.n_freeze),
        # FMI 2: after the probes (the outputs keep their indices)
        "initial_state_scale_index": FIXED_VARIABLES + 2 * data.n_probes + 1,
        "dt": number(data.dt),
        "profile": scene.fields["profile"].text,
        # FMI 2 only: the linear models integrate f + (df/dt) tau over a step exactly, the frozen model
        # evaluates it at each refresh of its force term
        "input_hold": "held over each communication step, or linear with the derivative of "
                      "fmi2SetRealInputDerivatives",
        # the linear models give dy/dt = C (A z + B f) exactly (fmu_src/rom.h rom_max_output_derivative_order);
        # the frozen model's trajectory is a discrete map of internal steps: none
        "max_output_derivative_order": 1 if spec.linear else 0,
    }
    # FMI 3 fixedInternalStepSize only where there is one: the linear model steps by the matrix exponential
    internal_step = [] if spec.linear else [{}]
    lists = {"probes": probes, "outputs": outputs, "internal_step": internal_step, "f_nominal": f_nominal}
    last = FIXED_VARIABLES + 2 * data.n_probes + 1          # FMI 2 index of initial_state_scale
    lists.update(bound_lists(bounds, data, last))
    last += len(lists["bounds"]) * 2 + len(lists["bound_probes"]) * 2
    # a parametric model's c, d: FMI 2 indices after everything above
    lists["params"] = [{**p, "index": last + 1 + i} for i, p in enumerate(parameters)]
    last += len(lists["params"])
    # mechanical ports: area, F_port_j, v_port_j after everything above (FMI 2 indices)
    ports, port_units = port_variables(data, last)
    outputs += [{"vr": p["v_vr"], "index": p["v_index"]} for p in ports]
    if ports:
        values["description"] += (f" Mechanical ports at x/L = {', '.join(p['x'] for p in ports)}: inputs "
                                  "F_port_j [N], outputs v_port_j [m s^-1], parameter area [m^2].")
    lists.update({"ports": ports, "port_units": port_units})
    return render(template(f"fmi{fmi}.xml"), values, lists)


def bound_lists(bounds, data, last_index):
    """The template lists of the calculated parameters holding the certified error bounds (none without
    ``bounds``): ``bounds`` (the two largest over the probes), ``bound_probes`` (per probe), ``bound_unknowns``
    (their FMI 2 indices after ``last_index`` and value references, for InitialUnknowns)."""
    if bounds is None:
        return {"bounds": [], "bound_probes": [], "bound_unknowns": []}
    P = data.n_probes
    fb, ib = bounds["force_error_bound"], bounds["initial_state_error_bound"]
    scalars = [{"fb_vr": VR_FORCE_ERROR_BOUND, "ib_vr": VR_INITIAL_STATE_ERROR_BOUND, "fb_index": last_index + 1,
                "ib_index": last_index + 2, "fb_value": f"{max(fb):.6g}", "ib_value": f"{max(ib):.6g}",
                "what": bound_text(bounds)}]
    per_probe = [{"j": j + 1, "x": f"{x:g}", "fb_vr": VR_FORCE_ERROR_BOUND_PROBE + j,
                  "ib_vr": VR_INITIAL_STATE_ERROR_BOUND_PROBE + j, "fb_index": last_index + 3 + j,
                  "ib_index": last_index + 3 + P + j, "fb_value": f"{fb[j]:.6g}", "ib_value": f"{ib[j]:.6g}"}
                 for j, x in enumerate(data.probe_x)]
    unknowns = ([{"vr": VR_FORCE_ERROR_BOUND, "index": last_index + 1},
                 {"vr": VR_INITIAL_STATE_ERROR_BOUND, "index": last_index + 2}]
                + [{"vr": p["fb_vr"], "index": p["fb_index"]} for p in per_probe]
                + [{"vr": p["ib_vr"], "index": p["ib_index"]} for p in per_probe])
    return {"bounds": scalars, "bound_probes": per_probe, "bound_unknowns": unknowns}


def port_variables(data, last_index):
    """(one item per port, [{area_index}] or []) for the templates' ``ports`` and ``port_units`` blocks.

    The port variables follow every other variable (FMI 2 indices after ``last_index``): area, F_port_1..P,
    v_port_1..P.
    """
    x = data.sections.get("PORTX")
    if x is None:
        return [], []
    base = last_index + 1                                   # area's index
    n = x.shape[1]
    ports = [{"j": j + 1, "x": f"{xj:g}", "f_vr": VR_F_PORT + j, "v_vr": VR_V_PORT + j,
              "f_index": base + 1 + j, "v_index": base + 1 + n + j} for j, xj in enumerate(x[0])]
    return ports, [{"area_index": base}]


def build_description() -> str:
    """sources/buildDescription.xml of the FMI 3 FMU."""
    return template("buildDescription.xml")
