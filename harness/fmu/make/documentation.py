"""``documentation/index.html`` of an FMU: the page that explains the FMU to someone who never saw its training.

FMI 2.0 and 3.0 both name ``documentation/index.html`` the entry point of an
FMU's documentation (FMI 1.0 used ``_main.html``).  The page is self-contained
(inline CSS, no script, no network resource; the one image, ``probes.png``,
sits beside it) and holds: how to use it, the platforms whose binaries it carries, the scene, the model, every variable of the
modelDescription.xml it is packed with (read from that XML, which
:mod:`sphrom.fmu.make.describe` generated from the variable table
:mod:`sphrom.fmu.variables`, so a row added to the table appears here
without a change to this module; the table adds which FMUs have each), the
training envelope in words (when the model carries one) and the tagged
sections of ``resources/model.bin`` with their numbers, and the measured errors and run times of
:mod:`sphrom.fmu.check.verify`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from html import escape

from .. import layout
from ..check.page import DOC_INDEX  # noqa: F401  (where the page goes)
from ..kinds import kind_of

import numpy as np

from ... import __version__
from ..check.verify import ACCURACY
from ..kinds import model_words
from ..resources import SECTION_TAGS

DOC_PLOT = "documentation/probes.png"

_STYLE = """body{font-family:sans-serif;max-width:60em;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1em;max-width:100%}th,td{border:1px solid #bbb;padding:2px 6px;
text-align:left;vertical-align:top;font-size:90%;overflow-wrap:break-word}th{background:#eee}code{font-size:95%}
table.wide{table-layout:fixed;width:100%}pre{background:#f4f4f4;padding:0.5em;white-space:pre-wrap;
overflow-wrap:anywhere}img{max-width:100%}"""

# units of the scene's fields (the scene schema, docs/user/scenes.md)
FIELD_UNITS = {"rho0": "kg m^-3", "v0": "m s^-1", "c": "Pa = kg m^-1 s^-2", "d": "s^-1", "profile": "1"}

FMI2_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration")


def variables(description_xml):
    """The variables of a modelDescription.xml text, in document order, as dicts: name, value_reference,
    causality, variability, type, unit (through declaredType where the variable has none), start, min, max,
    nominal, description ('' where absent)."""
    root = ET.fromstring(description_xml)
    fmi3 = root.get("fmiVersion", "").startswith("3")
    units = {}
    types = root.find("TypeDefinitions")
    if types is not None:
        for t in types:
            element = t if fmi3 else next((c for c in t if c.tag in FMI2_TYPES), t)
            units[t.get("name")] = element.get("unit", "")
    out = []
    for v in root.find("ModelVariables"):
        if fmi3:
            element, kind = v, v.tag
        else:
            element = next(c for c in v if c.tag in FMI2_TYPES)
            kind = element.tag
        unit = element.get("unit") or units.get(element.get("declaredType"), "")
        out.append({"name": v.get("name"), "value_reference": int(v.get("valueReference")),
                    "causality": v.get("causality", "local"), "variability": v.get("variability", "continuous"),
                    "type": kind, "unit": unit or "", "start": element.get("start", ""),
                    "min": element.get("min", ""), "max": element.get("max", ""),
                    "nominal": element.get("nominal", ""), "description": v.get("description", "")})
    return out


def _table(header, rows, table_id=None, widths=None):
    """An HTML table; ``widths`` (percent per column) makes it a fixed-layout table as wide as the page."""
    ident = f' id="{table_id}"' if table_id else ""
    lines = [f'<table{ident} class="wide">' if widths else f"<table{ident}>"]
    if widths:
        lines.append("<colgroup>" + "".join(f'<col style="width:{w}%">' for w in widths) + "</colgroup>")
    lines += ["<tr>" + "".join(f"<th>{escape(h)}</th>" for h in header) + "</tr>"]
    for row in rows:
        lines.append("<tr>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>")
    return lines + ["</table>"]


def _number(x, spec=".3g"):
    try:
        return format(float(x), spec)
    except (TypeError, ValueError):
        return escape(str(x))


def _short(text, spec=".4g"):
    """A number given as text (an XML attribute) with at most 4 significant digits; other text as it is."""
    try:
        return format(float(text), spec)
    except (TypeError, ValueError):
        return str(text)


def _mean(mean, scale):
    """A mean that is zero up to round-off (|mean| <= 1e-9 of the signal's scale) printed as 0."""
    return "0" if abs(mean) <= 1e-9 * abs(scale) else f"{mean:.3g}"


def scene_section(scene):
    rows = [("name", f"<code>{escape(scene.name)}</code>"), ("title", escape(scene.title)),
            ("paper section", escape(str(scene.section))), ("summary", escape(scene.summary)),
            ("L [m]", _number(scene.L, "g")), ("T [s]", _number(scene.T, "g")),
            ("N particles", str(scene.sph.n_particles)), ("h / dx (alpha)", _number(scene.sph.alpha, "g")),
            ("SPH dt [s]", _number(scene.sph.dt, "g")), ("SPH integrator", escape(scene.sph.integrator))]
    for name in ("rho0", "v0", "c", "d", "profile"):
        if name in scene.fields:
            rows.append((f"field {name}(x) [{FIELD_UNITS[name]}]", f"<code>{escape(scene.fields[name].text)}</code>"))
    rows.append(("force f(t) of the training run [m s^-2]", f"<code>{escape(scene.f.text)}</code>"))
    return ["<h2>Scene</h2>", *_table(("quantity", "value"), rows)]


def model_section(spec, data, k, input_error, augmented):
    basis = "specific volume" if spec.basis_kind == "energy" else "density"
    rows = [("model", f"<code>{escape(spec.name)}</code>: {escape(spec.title)}"),
            ("POD modes k", str(k)),
            ("velocity coordinates k_v", str(data.k_v) + (" (k + the force profile direction)" if augmented else "")),
            (f"{basis} coordinates", str(data.k_rho)),
            ("input projection error of the force profile", _number(input_error)),
            ("probes x/L", ", ".join(f"{x:g}" for x in data.probe_x))]
    rows += kind_of(data).model_rows(data)          # the kind's time stepping
    rows.append(("instantiation token", f"<code>{escape(data.token)}</code>"))
    return ["<h2>Model</h2>", *_table(("quantity", "value"), rows)]


def variables_section(description_xml):
    rows = []
    for v in variables(description_xml):
        limits = ", ".join(f"{k} {_short(v[k])}" for k in ("min", "max", "nominal") if v[k])
        rows.append((f"<code>{escape(v['name'])}</code>", str(v["value_reference"]), escape(v["causality"]),
                     escape(v["variability"]), escape(v["type"]), escape(v["unit"] or "-"),
                     escape(_short(v["start"]) if v["start"] else "-"), escape(limits or "-"),
                     escape(v["description"])))
    return ["<h2>Variables</h2>",
            "<p>Every variable of this FMU's modelDescription.xml (value references are the contract; sphrom's "
            "variable table, harness/fmu/variables.py, declares them). Numbers are shown to 4 digits; the "
            "modelDescription holds them in full.</p>",
            *_table(("name", "value reference", "causality", "variability", "type", "unit", "start",
                     "min, max, nominal", "description"), rows, table_id="variables",
                    widths=(16, 10, 11, 9, 6, 7, 6, 11, 24))]


def _fmi(description_xml):
    """(FMI version text, DefaultExperiment stepSize or None, canInterpolateInputs) of a modelDescription."""
    root = ET.fromstring(description_xml)
    version = root.get("fmiVersion", "")
    cs = root.find("CoSimulation")
    interpolate = cs is not None and cs.get("canInterpolateInputs", "false") == "true"
    experiment = root.find("DefaultExperiment")
    step = experiment.get("stepSize") if experiment is not None else None
    return version, step, interpolate


def _stop_time(description_xml):
    experiment = ET.fromstring(description_xml).find("DefaultExperiment")
    return _short(experiment.get("stopTime", "10")) if experiment is not None else "10"


def usage_section(description_xml, stepping, ports):
    """How to use this FMU: its FMI version, start at rest, communication step, ``stepping`` (its model kind's
    sentence on how it steps, HTML), input derivatives, an example."""
    version, step, interpolate = _fmi(description_xml)
    major = version.split(".")[0]
    step_text = f"its DefaultExperiment stepSize is {escape(_short(step))} s" if step else "any step"
    rates = ("It declares <code>canInterpolateInputs</code>: give <code>fmi2SetRealInputDerivatives</code> of order "
             "1 on its inputs and each input goes linearly over the step (the error is then second order in the "
             "communication step instead of first); without derivatives the inputs are held."
             if interpolate else
             "FMI 3.0 co-simulation has no input derivatives: the inputs are held over each communication step "
             "(for linear inputs inside a step use the FMI 2 FMU, <code>sphrom fmu --fmi 2</code>).")
    example = (f"from fmpy import simulate_fmu\n"
               f"result = simulate_fmu('this.fmu', stop_time={_stop_time(description_xml)}, "
               f"output_interval={_short(step) if step else '0.01'},\n"
               f"                      start_values={{'initial_state_scale': 0.0}})\n"
               f"# or: sphrom cosim this.fmu --force '1e-3*sin(2*pi*t)' --out result.csv")
    return ["<h2>Using this FMU</h2>",
            f"<p>An <b>FMI {escape(version)} co-simulation</b> FMU (FMI {escape(major)}), for a system simulator "
            "or a script. <b>It starts at rest</b>: <code>initial_state_scale</code> starts at 0, so it moves only "
            "when its inputs move it; set it to 1 to replay the scene's initial velocity. Communication step: "
            f"{step_text}. {stepping} {rates}</p>",
            f"<pre>{escape(example)}</pre>",
            "<p>Outputs are the velocity <code>v_probe_j</code> [m/s] and the density <code>rho_probe_j</code> "
            "[kg/m3] at the probes; the input <code>f</code> [m/s2] is a force per unit mass along the scene's "
            "force profile.</p>"]


def platforms_section(platforms, fmi):
    """The platforms whose binaries this FMU carries and the binaries/ folders (``platforms``:
    :class:`sphrom.fmu.make.build.FMUBinaries`), the ones left out and why, and how to build for another."""
    if platforms is None:
        return []
    folders = ", ".join(f"<code>binaries/{escape(b.platform.folder(fmi))}</code>" for b in platforms.builds)
    lines = ["<h2>Platforms</h2>",
             f"<p>Binaries for {escape(platforms.words())}: {folders}. For another platform, rebuild the binary from "
             "<code>sources/</code> (<code>sources/README.txt</code>; <code>fmpy compile this.fmu</code>).</p>"]
    for line in platforms.missing_lines():
        lines.append(f"<p>Packaged without: {escape(line)}.</p>")
    return lines


def ports_section(sections, model=None, passivity=None):
    """The mechanical ports of this FMU, their sign convention, what the ``model`` represents of them exactly and
    what its port map's passivity check found (``passivity``, :class:`sphrom.rom.passivity.PortPassivity`), or
    how to get them."""
    positions = sections.get("PORTX")
    convention = ("<code>F_port_j</code> [N] is the force the connected component exerts <b>on the bar</b> at "
                  "x_j, positive along +x; <code>v_port_j</code> [m/s] is the bar's velocity there, positive along "
                  "+x; the power into the bar is the sum of F_port_j v_port_j. A spring (stiffness k) from port j "
                  "to a mass m: with s the spring's elongation (mass position minus the bar's displacement at the "
                  "port) and w the mass's velocity, set F_port_j = k s at each communication step, read "
                  "v_port_j and advance s' = w - v_port_j, m w' = -k s. The parameter <code>area</code> [m2] is "
                  "the cross-section that turns a force into an acceleration.")
    if positions is None:
        return ["<h2>Ports</h2>",
                "<p>This FMU has no mechanical ports: its only input is <code>f</code>. <code>sphrom fmu SCENE "
                "--ports X1,X2</code> adds ports at x/L = X1, X2 (inputs <code>F_port_j</code>, outputs "
                f"<code>v_port_j</code>). The sign convention: {convention}</p>"]
    xs = ", ".join(f"{x:g}" for x in np.ravel(positions))
    words = model_words().get(model)
    represents = words.ports if words else ""
    return ["<h2>Ports</h2>", f"<p>Mechanical ports at x/L = {xs}. {convention}</p>"] + (
        [f"<p>{represents} The table of input channels below measures each port (a constant, a slow and an in-band "
         "force from rest, and the port closed by a spring-mass-damper) against the full SPH.</p>"]
        if represents else []) + (
        [f"<p>Passivity of the port map (F_port to v_port; <code>sphrom.rom.passivity.port_passivity</code>, "
         f"docs/fmu/ports.md): {escape(passivity.line())}.</p>"] if passivity is not None else [])


def _envelope_rows(sections, probe_x):
    """The training envelope's sections as labelled rows (quantity, value)."""
    rows = []
    if "ENVELOPE" in sections:
        amplitude, band, strain, probe_strain, failure, margin, checks, mean = (
            layout.value(sections, "ENVELOPE", name) for name in ("force_amplitude", "force_band", "max_strain",
                                                                  "max_probe_strain", "failure_strain", "margin",
                                                                  "checks", "force_mean"))
        rows += [("training force amplitude max |f| [m s^-2]", f"{amplitude:.4g}"),
                 ("training force mean [m s^-2]", _mean(mean, amplitude)),
                 ("frequency below which 99 % of the force's energy lies [Hz]", f"{band:.4g}"),
                 ("largest strain |rho0/rho - 1| over the particles / at the probes",
                  f"{strain:.4g} / {probe_strain:.4g}"),
                 ("strain where the density linearization fails", f"{failure:.4g}"),
                 ("margin on the trained ranges", f"{margin:g}"),
                 ("run-time checks", "on" if int(checks) else "none")]
    if "ENVRANGE" in sections:
        rng = sections["ENVRANGE"]
        rows.append((f"ranges of the {rng.shape[1]} reduced coordinates", f"from {rng[0].min():.4g} to "
                     f"{rng[1].max():.4g}; largest half-width {0.5 * (rng[1] - rng[0]).max():.4g}"))
    if "ENVPROBE" in sections:
        rho0, vmax = sections["ENVPROBE"][0], sections["ENVPROBE"][1]
        for j, (r, v) in enumerate(zip(rho0, vmax)):
            x = f", x/L = {probe_x[j]:g}" if j < len(probe_x) else ""
            rows.append((f"probe {j + 1}{x}: rho0 [kg m^-3], training max |v| [m s^-1]", f"{r:.4g}, {v:.4g}"))
    if "ENVPORT" in sections:
        pv, pr = (layout.value(sections, "ENVPORT", name) for name in ("port_v", "port_rho"))
        rows.append(("port coordinates (exact input directions, not checked)",
                      f"{int(pv)} velocity, {int(pr)} density"))
    return rows


def _other_rows(tag, values, probe_x):
    """Labelled rows of a section that is not the envelope's."""
    if tag == "BOUNDS":
        return [(f"probe {j + 1}" + (f", x/L = {probe_x[j]:g}" if j < len(probe_x) else ""),
                 f"force bound {f:.4g} s, initial-state bound {i:.4g} m s^-1 s^0.5")
                for j, (f, i) in enumerate(zip(values[0], values[1]))]
    if tag == "LINMODEL":
        return [("linear model", {1: "exact POD", 2: "balanced"}.get(int(values.ravel()[0]), "?"))]
    if tag == "PORTX":
        return [("port positions x/L", ", ".join(f"{x:g}" for x in values.ravel()))]
    if tag == "PARAMS":
        return [(f"parameter row {j + 1} (varied, start, min, max)", ", ".join(f"{x:.4g}" for x in row))
                for j, row in enumerate(values)]
    largest = float(abs(values).max()) if values.size else 0.0
    size = f"largest magnitude {largest:.4g}" if largest >= 1e-12 or largest == 0 else "all below 1e-12 (round-off)"
    return [(f"{'x'.join(map(str, values.shape))} numbers", size)]


def sections_section(sections, probe_x=(), linear=False, bounded=False):
    """The tagged sections of resources/model.bin, labelled: the training envelope's (under an h3, after the
    envelope in words of :func:`envelope_section`), then the others; [] without sections."""
    if not sections:
        return []

    sections = {tag: np.atleast_2d(np.asarray(values, dtype=float)) for tag, values in sections.items()}
    envelope = [tag for tag in sections if "envelope" in SECTION_TAGS.get(tag, "").lower()]
    lines = []
    if envelope:
        what = ("recorded for this description only: this FMU's run-time signal is its certified error bound"
                if bounded else "recorded for this description only: this FMU checks nothing at run time" if linear
                else "the FMU logs one warning when a run leaves it")
        lines += ["<h3>The training envelope's numbers</h3>",
                  f"<p>What the model was trained on, as recorded at packaging in resources/model.bin ({what}).</p>",
                  *_table(("quantity", "value"), _envelope_rows(sections, list(probe_x)))]
    rest = [t for t in sections if t not in envelope]
    if rest:
        rows = [(f"<code>{escape(t)}</code>: {escape(SECTION_TAGS.get(t, ''))}", escape(q), escape(v))
                for t in rest for q, v in _other_rows(t, sections[t], list(probe_x))]
        lines += ["<h2>Other numbers in resources/model.bin</h2>", *_table(("section", "quantity", "value"), rows)]
    return lines


def verification_section(verification, tolerance=None, choice=""):
    if verification is None:
        return ["<h2>Measured accuracy and speed</h2>",
                "<p>Not measured: this FMU was packaged without the verification against the full SPH "
                "(<code>sphrom fmu</code> measures it by default).</p>"]
    v = verification
    rows = []
    for c in v.cases:
        holds = "-" if c.bound_holds is None else ("holds" if c.bound_holds else "FAILS")
        rows.append((escape(c.name), f"<code>{escape(c.force)}</code>", escape(c.start), _number(c.err_v),
                     "-" if c.err_rho != c.err_rho else _number(c.err_rho), _number(c.max_drho),
                     holds, "-" if c.bound_ratio != c.bound_ratio else _number(c.bound_ratio, ".3g"),
                     str(len(c.warnings)), _number(c.step_s, ".4g"), _number(c.fmu_s, ".4g"),
                     _number(c.sph_s, ".4g"), _number(c.cost_ratio, ".3g"), escape(c.note or "")))
    truth = escape(v.truth or "the full SPH")
    lines = ["<h2>Measured accuracy and speed</h2>",
             f"<p>This FMU, run through fmpy at {_measured_at(v)} over T = "
             f"{v.T:g} s (input {escape(v.input)}), against {truth} (driven by the same input, from the same "
             "state), at the probes. Errors: relative L2 of eq. 3.4 (square-root form, trapezoidal in "
             "time, over all probes) of the velocity and of rho - rho0 ('-' where the truth's rho - rho0 is 0, "
             "as under a uniform force from rest: then the largest density difference says it). Certified bound: "
             "whether v_probe_j_error_bound held at every point, and its largest value over the largest true "
             "error; warnings: those the FMU logged. Times over T, one run each on the packaging machine, setup "
             "excluded: the FMU's own work (the CPU time of its doStep calls), its whole run through fmpy (wall time: "
             "initialize, inputs, doSteps, outputs, Python's per-step overhead included), the full SPH's compiled "
             "time loop (CPU time, the scene's training run); cost ratio = the FMU's own work / the full SPH's "
             "(CPU times: the time other processes took the cores does not count).</p>",
             *_table(("force", "f(t) [m s^-2]", "from", "v error", "rho - rho0 error", "max |rho - rho_true| "
                      "[kg m^-3]", "bound", "bound / error", "warnings", "FMU doStep [s]", "FMU via fmpy [s]",
                      "full SPH [s]", "cost ratio", "note"), rows, table_id="measured")]
    lines += cost_lines(v)
    if choice:
        lines.append(f"<p><strong>Configuration chosen for its cost</strong>: {escape(choice)}.</p>")
    if v.slower:
        why = f" ({escape(v.cost.why())})" if v.cost is not None else ""
        lines.append(f"<p><strong>This FMU is slower than the full SPH it replaces</strong>: its own work per "
                     f"simulated second is {v.cost_ratio:.3g} times the full SPH's on this scene{why}; packaging "
                     "tried the cheaper configurations it knows (fewer modes, no certified error bounds) and none met "
                     "the accuracy at a lower cost. The full SPH may serve better here, or another model.</p>")
    lines += channel_lines(v)
    lines.append(f"<p>Accuracy accepted on every case's v error: {ACCURACY if tolerance is None else tolerance:g} "
                 "(met)" + (" and on every input channel's (met)" if tolerance is not None else "") + ".</p>")
    lines += ["<p><img src=\"probes.png\" alt=\"probe velocity of the FMU (dashed) and of the truth (solid) "
              "for the training, the step and the unseen force\"></p>"]
    return lines


def _measured_at(v):
    """Where the measurement's step is the FMU's default and where it is finer (a model exact in time)."""
    if not v.default_step == v.default_step or abs(v.default_step - v.step) <= 1e-12 * v.step:
        return f"its default communication step h = {v.step:g} s"
    return (f"the communication step h = {v.step:g} s, finer than its default {v.default_step:g} s: a model exact in "
            "time steps at what its input and outputs need, and is measured at the points that resolve its band "
            "(where its error lives), as a time-stepped model is; its cost is that of its default step")


def cost_lines(v):
    """The paragraph on the robust cost per simulated second (:class:`sphrom.fmu.check.verify.Cost`), none when not
    measured."""
    c = v.cost
    if c is None:
        return []
    return [f"<p>Cost per simulated second (what packaging's choice and its verdict use): the FMU's doStep calls in "
            f"steady stepping at its default step, {c.fmu_s:.4g} s per T ({c.steps} steps), against the full SPH's compiled loop, "
            f"{c.sph_s:.4g} s per T ({c.sph_steps} time steps): <strong>{c.ratio:.3g}</strong> (CPU times, the "
            f"median ratio of {c.repeats} pairs of runs timed in turn). The first doStep, {c.setup_s:.3g} s, is a "
            "setup done once per step length (a linear model's maps e<sup>Ah</sup>, the bounds' plane maps, cached "
            "for every later step of that length), as the instantiation: not counted per simulated second.</p>"]


def channel_lines(verification):
    """The table of every input channel's measurement (:mod:`sphrom.fmu.check.channels`), none when not measured."""
    if not getattr(verification, "channels", None):
        return []
    rows = [(escape(c.channel), escape(c.case), f"<code>{escape(c.force)}</code>", escape(c.output), _number(c.err),
             _number(c.sph_s, ".4g"), escape(c.note or "")) for c in verification.channels]
    return ["<h3>Every input channel</h3>",
            f"<p>Each input alone from rest, held over each step, over {verification.channel_horizon:.4g} s, against "
            "the full SPH "
            "with the same input (the scene's own force off): a constant (the static deflection and the rigid "
            "motion), a slow sine (a quarter of the bar's lowest elastic frequency) and an in-band sine (1.5 times "
            "it); each port also closed by a spring-mass-damper, coupled step by step, against the full SPH "
            "integrated together with it (its error includes the coupling's own). Error: eq. 3.4 of the output "
            "named (f: the probe velocities; F_port_j: its own port velocity). See docs/fmu/ports.md.</p>",
            *_table(("channel", "case", "input", "output", "error", "full SPH [s]", "note"), rows,
                    table_id="channels")]


def envelope_section(envelope, linear, bounded=False):
    """What the basis was trained on (:class:`sphrom.fmu.training.envelope.Envelope`) and what the FMU checks at run
    time (``bounded``: its certified error bounds); nothing when the FMU carries no envelope."""
    if envelope is None:
        return []
    items = "".join(f"<li>{escape(line)}</li>" for line in envelope.lines(linear=linear, bounded=bounded))
    return ["<h2>Training envelope</h2>", f"<ul>{items}</ul>"]


def index_html(*, scene, spec, data, k, input_error, augmented, description_xml, verification=None,
               tolerance=None, envelope=None, passivity=None, platforms=None, choice=""):
    """The text of documentation/index.html (module docstring); ``platforms``: the binaries it carries
    (:class:`sphrom.fmu.make.build.FMUBinaries`); ``choice``: why packaging chose this configuration (a cheaper one
    than asked for: :func:`sphrom.fmu.make.auto.cheaper_if_slower`), '' for none."""
    title = f"sphrom FMU: {spec.name} model of scene {scene.name}"
    version, _, _ = _fmi(description_xml)
    sections = getattr(data, "sections", {}) or {}
    body = [f"<h1>{escape(title)}</h1>",
            f"<p>{escape(spec.title)} of the 1D SPH mass-spring-damper scene <code>{escape(scene.name)}</code>, "
            f"packaged by sphrom {escape(__version__)} as an FMI {escape(version)} co-simulation FMU. Input "
            "<code>f</code> (force per mass along the force profile), outputs the velocity and density at the "
            "probes.</p>"]
    body += usage_section(description_xml, kind_of(data).usage(data), sections)
    body += platforms_section(platforms, int(version.split(".")[0] or 2))
    body += ports_section(sections, spec.name, passivity)
    body += scene_section(scene)
    body += model_section(spec, data, k, input_error, augmented)
    body += variables_section(description_xml)
    bounded = "SHSCAL" in sections
    body += envelope_section(envelope, spec.linear, bounded)
    body += sections_section(sections, probe_x=list(getattr(data, "probe_x", ())), linear=spec.linear,
                             bounded=bounded)
    body += verification_section(verification, tolerance, choice)
    return "\n".join(["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
                      f"<title>{escape(title)}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>", *body,
                      "</body>", "</html>", ""])
