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


def model_description(fmi: int, *, token, scene, data, k_requested, step_size, stop_time, input_error,
                      model="frozen"):
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
    """
    from ..rom.registry import get_model

    probes = [{"j": j + 1, "x": f"{x:g}", "v_vr": VR_V_PROBE + j, "rho_vr": VR_RHO_PROBE + j,
               "v_index": FIXED_VARIABLES + 1 + j, "rho_index": FIXED_VARIABLES + 1 + data.n_probes + j}
              for j, x in enumerate(data.probe_x)]
    outputs = ([{"vr": p["v_vr"], "index": p["v_index"]} for p in probes]
               + [{"vr": p["rho_vr"], "index": p["rho_index"]} for p in probes])
    augmented = data.k_v > k_requested
    modes = (f"k_v = {data.k_v} velocity modes ({k_requested} POD modes"
             + (" + the force profile direction" if augmented else "") + f"), k_rho = {data.k_rho} density modes")
    where = ", ".join(f"{x:g}" for x in data.probe_x)
    spec = get_model(model)
    if spec.basis_kind == "energy":
        modes = modes.replace("density modes", "specific-volume modes")
    if spec.linear:
        stepping = ("advanced over each communication step by the matrix exponential (input held, or linear "
                    "with fmi2SetRealInputDerivatives in FMI 2), so dt and n_freeze have no effect")
    else:
        stepping = (f"{data.integrator} integrator, internal dt = {data.dt:g} s, n_freeze = {data.n_freeze} by "
                    "default")
    description = (f"{spec.title} of the SPH mass-spring-damper scene '{scene.name}' ({scene.title}; "
                   f"N = {scene.sph.n_particles}, L = {scene.L:g} m): {modes}; {stepping}; probes at x/L = {where}; "
                   f"input projection error {input_error:.3g}.")
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
        "dt": number(data.dt),
        "profile": scene.fields["profile"].text,
        # FMI 2 only: the exact linear model integrates f + (df/dt) tau over a step exactly
        "can_interpolate_inputs": "true" if spec.linear else "false",
        "input_hold": ("held over each communication step, or linear with the derivative of "
                       "fmi2SetRealInputDerivatives" if spec.linear else "held over each communication step"),
    }
    # FMI 3 fixedInternalStepSize only where there is one: the linear model steps by the matrix exponential
    internal_step = [] if spec.linear else [{}]
    ports, port_units = port_variables(data)
    outputs += [{"vr": p["v_vr"], "index": p["v_index"]} for p in ports]
    if ports:
        values["description"] += (f" Mechanical ports at x/L = {', '.join(p['x'] for p in ports)}: inputs "
                                  "F_port_j [N], outputs v_port_j [m s^-1], parameter area [m^2].")
    return render(template(f"fmi{fmi}.xml"), values,
                  {"probes": probes, "outputs": outputs, "internal_step": internal_step, "ports": ports,
                   "port_units": port_units})


def port_variables(data):
    """(one item per port, [{area_index}] or []) for the templates' ``ports`` and ``port_units`` blocks.

    The port variables follow the probes' (FMI 2 indices): area, F_port_1..P, v_port_1..P.
    """
    x = data.sections.get("PORTX")
    if x is None:
        return [], []
    base = FIXED_VARIABLES + 2 * data.n_probes + 1          # area's index
    n = x.shape[1]
    ports = [{"j": j + 1, "x": f"{xj:g}", "f_vr": VR_F_PORT + j, "v_vr": VR_V_PORT + j,
              "f_index": base + 1 + j, "v_index": base + 1 + n + j} for j, xj in enumerate(x[0])]
    return ports, [{"area_index": base}]


def build_description() -> str:
    """sources/buildDescription.xml of the FMI 3 FMU."""
    return template("buildDescription.xml")
