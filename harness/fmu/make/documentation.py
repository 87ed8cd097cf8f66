"""``documentation/index.html`` of an FMU: the page that explains the FMU to someone who never saw its training.

FMI 2.0 and 3.0 both name ``documentation/index.html`` the entry point of an
FMU's documentation (FMI 1.0 used ``_main.html``).  The page is self-contained
(inline CSS, no script, no network resource; the one image, ``probes.png``,
sits beside it) and holds: the scene, the model, every variable of the
modelDescription.xml it is packed with (read from that XML, which
:mod:`harness.fmu.make.describe` generated from the variable table
:mod:`harness.fmu.variables`, so a row added to the table appears here
without a change to this module; the table adds which FMUs have each), the
training envelope in words (when the model carries one) and the tagged
sections of ``resources/model.bin`` with their numbers, and the measured errors and run times of
:mod:`harness.fmu.check.verify`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from html import escape

DOC_INDEX = "documentation/index.html"
DOC_PLOT = "documentation/probes.png"

_STYLE = """body{font-family:sans-serif;max-width:60em;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1em}th,td{border:1px solid #bbb;padding:2px 6px;text-align:left;
vertical-align:top;font-size:90%}th{background:#eee}code{font-size:95%}img{max-width:100%}"""

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


def _table(header, rows, table_id=None):
    ident = f' id="{table_id}"' if table_id else ""
    lines = [f"<table{ident}>", "<tr>" + "".join(f"<th>{escape(h)}</th>" for h in header) + "</tr>"]
    for row in rows:
        lines.append("<tr>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>")
    return lines + ["</table>"]


def _number(x, spec=".3g"):
    try:
        return format(float(x), spec)
    except (TypeError, ValueError):
        return escape(str(x))


def _matrix(a, limit=24):
    """A small array as text (its first ``limit`` numbers otherwise)."""
    import numpy as np
    a = np.asarray(a, float)
    flat = a.ravel()
    text = ", ".join(f"{x:.4g}" for x in flat[:limit])
    return text + (f", ... ({flat.size} numbers)" if flat.size > limit else "")


def scene_section(scene):
    rows = [("name", f"<code>{escape(scene.name)}</code>"), ("title", escape(scene.title)),
            ("paper section", escape(str(scene.section))), ("summary", escape(scene.summary)),
            ("L [m]", _number(scene.L, "g")), ("T [s]", _number(scene.T, "g")),
            ("N particles", str(scene.sph.n_particles)), ("h / dx (alpha)", _number(scene.sph.alpha, "g")),
            ("SPH dt [s]", _number(scene.sph.dt, "g")), ("SPH integrator", escape(scene.sph.integrator))]
    for name in ("rho0", "v0", "c", "d", "profile"):
        if name in scene.fields:
            rows.append((f"field {name}(x)", f"<code>{escape(scene.fields[name].text)}</code>"))
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
    if spec.linear:
        rows.append(("time stepping", "the matrix exponential over each communication step (exact in time; no "
                                      "internal step, so no parameters dt and n_freeze)"))
    else:
        rows += [("integrator", escape(data.integrator)), ("default n_freeze", str(data.n_freeze)),
                 ("default internal dt [s]", _number(data.dt, "g"))]
    rows.append(("instantiation token", f"<code>{escape(data.token)}</code>"))
    return ["<h2>Model</h2>", *_table(("quantity", "value"), rows)]


def variables_section(description_xml):
    from ..variables import RULES, lookup
    rows = []
    for v in variables(description_xml):
        limits = " ".join(f"{k} {v[k]}" for k in ("min", "max", "nominal") if v[k])
        row, _ = lookup(v["name"])
        rows.append((f"<code>{escape(v['name'])}</code>", str(v["value_reference"]), escape(v["causality"]),
                     escape(v["variability"]), escape(v["type"]), escape(v["unit"] or "-"),
                     escape(v["start"] or "-"), escape(limits or "-"),
                     escape(RULES[row.rule][1] if row is not None else "-"), escape(v["description"])))
    return ["<h2>Variables</h2>",
            "<p>Every variable of this FMU's modelDescription.xml (value references are the contract; the "
            "variable table of sphrom, harness/fmu/variables.py, declares them and which FMUs have each).</p>",
            *_table(("name", "value reference", "causality", "variability", "type", "unit", "start",
                     "min / max / nominal", "in", "description"), rows, table_id="variables")]


def sections_section(sections):
    """The tagged sections of resources/model.bin with their numbers: the training envelope's (under an h3,
    after the envelope in words of :func:`envelope_section`), then the others; [] without sections."""
    if not sections:
        return []
    import numpy as np

    from ..resources import SECTION_TAGS
    sections = {tag: np.atleast_2d(np.asarray(values, dtype=float)) for tag, values in sections.items()}
    envelope = [tag for tag in sections if "envelope" in SECTION_TAGS.get(tag, "").lower()]
    lines = []
    if envelope:
        lines += ["<h3>The training envelope's numbers</h3>",
                  "<p>What the model was trained on, as recorded at packaging (the FMU warns once when a run "
                  "leaves it).</p>",
                  *_table(("section", "what", "values"),
                          [(f"<code>{escape(t)}</code>", escape(SECTION_TAGS.get(t, "")), _matrix(sections[t]))
                           for t in envelope])]
    rest = [t for t in sections if t not in envelope]
    if rest:
        lines += ["<h2>Other numbers in resources/model.bin</h2>",
                  *_table(("section", "what", "shape", "values"),
                          [(f"<code>{escape(t)}</code>", escape(SECTION_TAGS.get(t, "")),
                            "x".join(map(str, sections[t].shape)), _matrix(sections[t])) for t in rest])]
    return lines


def verification_section(verification, tolerance=None):
    if verification is None:
        return ["<h2>Measured accuracy and speed</h2>",
                "<p>Not measured: this FMU was packaged without the verification against the full SPH "
                "(<code>sphrom fmu</code> measures it by default).</p>"]
    v = verification
    rows = []
    for c in v.cases:
        rows.append((escape(c.name), f"<code>{escape(c.force)}</code>", escape(c.start), _number(c.err_v),
                     "-" if c.err_rho != c.err_rho else _number(c.err_rho), _number(c.max_drho),
                     _number(c.fmu_s, ".4g"), _number(c.sph_s, ".4g"),
                     f"{c.speedup:.3g}x", escape(c.note or "")))
    lines = ["<h2>Measured accuracy and speed</h2>",
             f"<p>This FMU, run through fmpy at its default communication step h = {v.step:g} s over T = "
             f"{v.T:g} s (input {escape(v.input)}), against the full SPH model it was trained on (f at every "
             "internal step), at the probes. Errors: relative L2 of eq. 3.4 (square-root form, trapezoidal in "
             "time, over all probes) of the velocity and of rho - rho0 ('-' where the full SPH's rho - rho0 is 0, "
             "as under a uniform force from rest: then the largest density difference says it). Times: one run "
             "each on the packaging machine, setup excluded: the FMU's is its run through fmpy on an instantiated FMU (initialize, "
             "inputs, doSteps, outputs), the full SPH's its compiled time loop.</p>",
             *_table(("force", "f(t) [m s^-2]", "from", "v error", "rho - rho0 error", "max |rho - rho_SPH| "
                      "[kg m^-3]", "FMU [s]",
                      "full SPH [s]", "speed-up", "note"), rows, table_id="measured")]
    lines += channel_lines(v)
    if tolerance is not None:
        lines.append(f"<p>Tolerance on the training-force v error and on every input channel's: {tolerance:g} "
                     "(met).</p>")
    lines += ["<p><img src=\"probes.png\" alt=\"probe velocity of the FMU (dashed) and of the full SPH (solid) "
              "for the training and the unseen force\"></p>"]
    return lines


def channel_lines(verification):
    """The table of every input channel's measurement (:mod:`harness.fmu.check.channels`), none when not measured."""
    if not getattr(verification, "channels", None):
        return []
    from ..check.channels import HORIZON
    rows = [(escape(c.channel), escape(c.case), f"<code>{escape(c.force)}</code>", escape(c.output), _number(c.err),
             _number(c.sph_s, ".4g"), escape(c.note or "")) for c in verification.channels]
    return ["<h3>Every input channel</h3>",
            f"<p>Each input alone from rest, held over each step, over min(T, {HORIZON:g} s), against the full SPH "
            "with the same input (the scene's own force off): a constant (the static deflection and the rigid "
            "motion) and a slow sine (a quarter of the bar's lowest elastic frequency). Error: eq. 3.4 of the "
            "output named (f: the probe velocities; F_port_j: its own port velocity). See docs/fmu/ports.md.</p>",
            *_table(("channel", "case", "input", "output", "error", "full SPH [s]", "note"), rows,
                    table_id="channels")]


def envelope_section(envelope, linear):
    """What the basis was trained on (:class:`harness.fmu.make.envelope.Envelope`) and what the FMU checks at run
    time; nothing when the FMU carries no envelope."""
    if envelope is None:
        return []
    items = "".join(f"<li>{escape(line)}</li>" for line in envelope.lines(linear=linear))
    return ["<h2>Training envelope</h2>", f"<ul>{items}</ul>"]


def index_html(*, scene, spec, data, k, input_error, augmented, description_xml, verification=None,
               tolerance=None, envelope=None):
    """The text of documentation/index.html (module docstring)."""
    from ... import __version__
    title = f"sphrom FMU: {spec.name} model of scene {scene.name}"
    body = [f"<h1>{escape(title)}</h1>",
            f"<p>{escape(spec.title)} of the 1D SPH mass-spring-damper scene <code>{escape(scene.name)}</code>, "
            f"packaged by sphrom {escape(__version__)}. Input <code>f</code> (force per mass along the force "
            "profile), outputs the velocity and density at the probes.</p>"]
    body += scene_section(scene)
    body += model_section(spec, data, k, input_error, augmented)
    body += variables_section(description_xml)
    body += envelope_section(envelope, spec.linear)
    body += sections_section(getattr(data, "sections", {}))
    body += verification_section(verification, tolerance)
    return "\n".join(["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
                      f"<title>{escape(title)}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>", *body,
                      "</body>", "</html>", ""])
