"""The FMU explains itself: ``sphrom fmu`` measures the FMU it built against the full SPH (numbers stored in the
FMU equal an independent recomputation), ``documentation/index.html`` lists exactly the modelDescription's
variables, ``--tolerance`` refuses a model above it without losing a file, ``--model auto`` keeps the fastest
model that meets it, and every variable of packaged FMUs is a row of the variable table."""

import dataclasses
import math
import re
import zipfile
from html.parser import HTMLParser

import fmpy
import numpy as np
import pytest

from conftest import fmu_scene
from sphrom.cli import main
from sphrom.expr import compile_expr
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.cosim import run_cosim
from sphrom.fmu.make.auto import package_auto
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.variables import lookup, vr
from sphrom.rom.registry import fmu_model_names
from sphrom.sph.solver import build_problem, run_sph

K = 6


@pytest.fixture(scope="module")
def packaged(tmp_path_factory):
    """make(case, model, fmi, verify) -> (path, FMUSummary), packaged once each."""
    binaries = ensure_binaries()
    folder = tmp_path_factory.mktemp("verified")
    made = {}

    def make(case="forced", model="frozen", fmi=2, verify=True):
        key = (case, model, fmi, verify)
        if key not in made:
            path = folder / f"{case}-{model}-{fmi}-{verify}.fmu"
            s = package_fmu(fmu_scene(case), path, k=K, fmi=fmi, model=model, progress=False, binaries=binaries,
                            verify=verify)
            made[key] = (path, s)
        return made[key]

    return make


class _Tables(HTMLParser):
    """The cells of every <table> of a page, by table id, and every src/href attribute."""

    def __init__(self):
        super().__init__()
        self.tables, self.links, self._id, self._row, self._cell = {}, [], None, None, None
        self.open = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag not in ("meta", "img", "br", "col"):                  # void elements
            self.open.append(tag)
        self.links += [attrs[a] for a in ("src", "href") if a in attrs]
        if tag == "table":
            self._id = attrs.get("id", len(self.tables))
            self.tables[self._id] = []
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = ""

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, (tag, self.open[-3:])
        self.open.pop()
        if tag in ("td", "th"):
            self._row.append(self._cell)
            self._cell = None
        elif tag == "tr":
            self.tables[self._id].append(self._row)

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def page(path):
    parser = _Tables()
    parser.feed(zipfile.ZipFile(path).read("documentation/index.html").decode("utf-8"))
    parser.close()
    assert parser.open == []                      # every element closed: a well-formed page
    return parser


def probe_interp(problem, L, probes, a):
    """Linear interpolation at x/L of the particle values (independent of the packager's probe rows)."""
    x = problem.x
    return np.stack([np.interp(p * L, x, a_t) for a_t in a for p in probes]).reshape(len(a), len(probes))


def l2(u, ref, t, base=0.0):
    """sqrt(int sum_j (u - ref)^2 dt / int sum_j (ref - base)^2 dt), trapezoidal in t."""
    num = np.trapezoid(np.sum((u - ref) ** 2, axis=1), t)
    den = np.trapezoid(np.sum((ref - base) ** 2, axis=1), t)
    return float(np.sqrt(num / den))


def independent_fmu_run(path, md, force, T, step, scale):
    """The FMU's probe outputs at the communication points, (v, rho), without sphrom.fmu.check.verify: sphrom cosim's
    loop (f linear with df/dt) where the FMU declares canInterpolateInputs, else fmpy.simulate_fmu (f held)."""
    t = np.arange(int(round(T / step)) + 1) * step
    names = {x.name for x in md.modelVariables}
    if md.fmiVersion == "2.0" and md.coSimulation.canInterpolateInputs:
        res = run_cosim(path, force=force, t_end=T, step=step,
                        initial_state_scale=scale if "initial_state_scale" in names else None)
        assert res.input_derivatives
        table = {n: res.values[:, i] for i, n in enumerate(res.names)}
    else:
        expr = compile_expr(force, ("t", "L", "T"), "force")
        signal = np.zeros(t.size, dtype=[("time", float), ("f", float)])
        signal["time"], signal["f"] = t, np.broadcast_to(expr(t=t, L=1.0, T=T), t.shape)
        start = {"initial_state_scale": scale} if "initial_state_scale" in names else {}
        table = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=step, input=signal, start_values=start)
    return (np.column_stack([table[f"v_probe_{j + 1}"] for j in range(3)]),
            np.column_stack([table[f"rho_probe_{j + 1}"] for j in range(3)]))


def independent_truth(problem, probes, force, T, step, scale, linear):
    """The full SPH linear in J at the communication points, integrated exactly in time without
    sphrom.rom.truth: one dense exponential of the input-augmented system (sphrom.rom.lti's matrices), f
    linear between the points (``linear``) or held; probe values linear between particles (np.interp)."""
    import scipy.linalg as sla
    from sphrom.rom.lti import full_linear_system
    lti = full_linear_system(problem, probes)
    n = problem.n
    t = np.arange(int(round(T / step)) + 1) * step
    u = np.broadcast_to(compile_expr(force, ("t", "L", "T"), "force")(t=t, L=1.0, T=T), t.shape).astype(float)
    M = np.zeros((2 * n + 2, 2 * n + 2))
    M[:2 * n, :2 * n] = lti.A.toarray()
    M[:2 * n, 2 * n] = lti.B[:, 0]
    M[2 * n, 2 * n + 1] = 1.0
    phi = sla.expm(M * step)
    z = np.concatenate([scale * lti.x0, [0.0, 0.0]])
    v, rho = [], []
    for k in range(t.size):
        v.append(z[:n] / lti.w_v)
        rho.append(problem.rho0 / (1.0 + z[n:2 * n] / lti.w_e))
        if k + 1 < t.size:
            z[2 * n] = u[k]
            z[2 * n + 1] = (u[k + 1] - u[k]) / step if linear else 0.0
            z = phi @ z
    return t, np.array(v), np.array(rho)


@pytest.mark.parametrize("case, model, fmi", [("forced", "frozen", 2), ("forced", "frozen", 3),
                                              ("unforced", "exact", 3)])
def test_stored_errors_equal_an_independent_recomputation(packaged, case, model, fmi):
    """The FMU run again here (sphrom cosim's loop, or fmpy.simulate_fmu) against the truth computed here (the full
    SPH linear in J, integrated exactly in time by one dense exponential), at linearly interpolated probes: the
    errors equal the verification's, and the FMU stores them."""
    path, s = packaged(case, model, fmi)
    v = s.verification
    scene = fmu_scene(case)
    problem = build_problem(scene)
    md = fmpy.read_model_description(str(path))
    # measured at the FMU's default step, or (a model exact in time) at a finer one
    assert v.default_step == float(md.defaultExperiment.stepSize) and v.step <= v.default_step * (1 + 1e-12)
    linear = fmi == 2 and md.coSimulation.canInterpolateInputs
    assert v.input == ("linear (df/dt)" if linear else "held")
    has_scale = "initial_state_scale" in {x.name for x in md.modelVariables}
    assert [c.name for c in v.cases] == ["training", "step", "unseen"]
    assert [c.start for c in v.cases] == ["the scene's initial state"] + 2 * ["rest" if has_scale else
                                                                          "the scene's initial state"]
    assert "exactly in time" in v.truth
    for c in v.cases:
        force = scene.f.text if c.name == "training" else c.force
        scale = 0.0 if c.start == "rest" else 1.0
        fmu_v, fmu_rho = independent_fmu_run(path, md, force, scene.T, v.step, scale)
        t, tv, trho = independent_truth(problem, v.probes, force, scene.T, v.step, scale, linear)
        sph_v = probe_interp(problem, scene.L, v.probes, tv)
        sph_rho = probe_interp(problem, scene.L, v.probes, trho)
        rho0 = probe_interp(problem, scene.L, v.probes, problem.rho0[None, :])[0]
        assert c.err_v == pytest.approx(l2(fmu_v, sph_v, t), rel=1e-6, abs=1e-12)
        assert c.max_drho == pytest.approx(np.abs(fmu_rho - sph_rho).max(), rel=1e-6, abs=1e-12 * rho0.max())
        if np.any(np.abs(sph_rho - rho0) > 1e-12 * rho0):
            assert c.err_rho == pytest.approx(l2(fmu_rho - rho0, sph_rho - rho0, t), rel=1e-6, abs=1e-12)
        else:                                   # a uniform force from rest: the truth's density never moves
            assert math.isnan(c.err_rho) and c.name != "training" and c.start == "rest"
        assert 0 <= c.err_v < 0.1 and c.fmu_s > 0 and c.sph_s > 0 and c.step_s > 0
        assert c.bound_holds in (True, None)
    # stored in the FMU: the description (short) and the documentation page
    assert v.sentence() in md.description
    assert f"{v.training.err_v:.2g} on the training force" in md.description
    measured = page(path).tables["measured"]
    assert [row[0] for row in measured[1:]] == ["training", "step", "unseen"]
    for row, c in zip(measured[1:], v.cases):
        assert float(row[3]) == pytest.approx(c.err_v, rel=5e-3)                # 3 digits
        assert (row[4] == "-") if math.isnan(c.err_rho) else float(row[4]) == pytest.approx(c.err_rho, rel=5e-3), \
            (row, c.err_rho)
    png = zipfile.ZipFile(path).read("documentation/probes.png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("fmi, model, verify", [(2, "frozen", True), (3, "frozen", True), (3, "exact", False),
                                                (2, "exact", False)])
def test_documentation_lists_exactly_the_model_description_variables(packaged, fmi, model, verify):
    path, s = packaged("forced", model, fmi, verify)
    md = fmpy.read_model_description(str(path))
    doc = page(path)
    rows = doc.tables["variables"]
    assert rows[0][:3] == ["name", "value reference", "causality"]
    assert [r[0] for r in rows[1:]] == [v.name for v in md.modelVariables]
    for r, var in zip(rows[1:], md.modelVariables):
        unit = var.unit or (var.declaredType.unit if var.declaredType is not None else None)
        assert int(r[1]) == var.valueReference and r[2] == var.causality and r[5] == (unit or "-")
    # self-contained: the only resource is the plot beside it, present exactly when measured
    names = zipfile.ZipFile(path).namelist()
    assert "documentation/index.html" in names
    assert doc.links == (["probes.png"] if verify else [])
    assert ("documentation/probes.png" in names) == verify
    text = zipfile.ZipFile(path).read("documentation/index.html").decode()
    assert "http:" not in text and "https:" not in text and "<script" not in text
    assert s.scene in text and f"<code>{model}</code>" in text
    assert ("Not measured" in text) == (not verify)
    headings = re.findall(r"<h2>(.*?)</h2>", text)
    assert len(headings) == len(set(headings)) and "Variables" in headings, headings
    assert fmpy.validation.validate_fmu(str(path)) == []


def test_tolerance_failure_is_one_line_and_loses_nothing(tmp_path, capsys):
    scene_file = tmp_path / "forced.toml"
    scene_file.write_text(fmu_scene("forced").text)
    out = tmp_path / "model.fmu"
    out.write_bytes(b"an earlier FMU")
    args = ["fmu", str(scene_file), "--modes", str(K), "--out", str(out), "--quiet"]
    assert main(args + ["--tolerance", "1e-9"]) == 4
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "accuracy 1e-09" in err[0] and "not written" in err[0] and "remedy:" in err[0], err
    assert out.read_bytes() == b"an earlier FMU"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["forced.toml", "model.fmu"]
    # met: written, and the measurement printed
    assert main(args + ["--tolerance", "0.5"]) == 0
    text = capsys.readouterr().out
    assert "accuracy 0.5 on the v error of every case: met" in text and "unseen" in text
    assert fmpy.validation.validate_fmu(str(out)) == []
    assert main(args + ["--model", "auto"]) == 2                     # auto needs a tolerance
    assert "needs --tolerance" in capsys.readouterr().err


def test_model_auto_keeps_the_fastest_model_meeting_the_tolerance(tmp_path):
    scene = fmu_scene("forced")
    best, candidates = package_auto(scene, tmp_path / "auto.fmu", tolerance=10.0, k=K, progress=False)
    assert {c.model for c in candidates} >= {"frozen", "exact"}
    # the cheapest per simulated second: packaging's own figure, the median of pairs of runs
    assert best.verification.cost is not None
    assert best.verification.cost_ratio == min(c.verification.cost_ratio for c in candidates)
    md = fmpy.read_model_description(str(tmp_path / "auto.fmu"))
    assert best.verification.sentence() in md.description
    errors = {c.model: c.verification.training.err_v for c in candidates}
    # the models at one communication step measured on the same truth (a model exact in time may take a coarser one)
    for step in {c.verification.step for c in candidates}:
        assert len({id(c.verification.refs) for c in candidates if c.verification.step == step}) == 1
    tight = min(errors.values()) * 1.0001
    best2, _ = package_auto(scene, tmp_path / "auto2.fmu", tolerance=tight, k=K, progress=False)
    assert best2.model == min(errors, key=errors.get)


def test_every_variable_of_packaged_fmus_is_a_row_of_the_table(packaged):
    """Every variable of packaged FMUs (both POD models, FMI 2 and 3) is a row of harness/fmu/variables.py (or a
    member of a family row) with its value reference, causality and unit; the linear model declares neither
    n_freeze nor dt, which do nothing there."""
    for model, fmi in [("frozen", 2), ("frozen", 3), ("exact", 2), ("exact", 3)]:
        path, _ = packaged("forced", model, fmi, False)
        names = set()
        for var in fmpy.read_model_description(str(path)).modelVariables:
            row, j = lookup(var.name)
            assert row is not None, f"{var.name} is not a row of harness/fmu/variables.py"
            unit = var.unit or (var.declaredType.unit if var.declaredType is not None else None) or ""
            ref = vr(row.display, j)
            assert (ref, row.causality, row.unit) == (var.valueReference, var.causality, unit), var.name
            names.add(var.name)
        assert ({"n_freeze", "dt"} <= names) == (model == "frozen"), (model, fmi)


def test_the_benchmark_section_is_replaced_in_place_or_put_before_the_stress_maps():
    from sphrom.bench.fmu_verify import SECTION_HEADING
    from sphrom.bench.lib.document import replace_section
    doc = "# Benchmarks\n\n## The FMU\n\ntext\n\n## Stability stress maps\n\nmaps\n"
    first = replace_section(doc, SECTION_HEADING, [SECTION_HEADING, "", "| a |", ""])
    assert first == ("# Benchmarks\n\n## The FMU\n\ntext\n\n" + SECTION_HEADING + "\n\n| a |\n\n"
                     "## Stability stress maps\n\nmaps\n")
    second = replace_section(first, SECTION_HEADING, [SECTION_HEADING, "", "| b |", ""])
    assert second == first.replace("| a |", "| b |")
    assert replace_section("# B\n", SECTION_HEADING, [SECTION_HEADING, "", "x"]) == f"# B\n\n{SECTION_HEADING}\n\nx\n\n"


def test_the_benchmark_writes_its_table_from_the_measurement(tmp_path):
    """python -m sphrom.bench.fmu_verify on a small scene: the CSV rows and the section of the report carry
    the verification's errors; the speed-up is the ratio of the medians."""
    import csv

    from sphrom.bench.fmu_verify import SECTION_HEADING
    from sphrom.bench.fmu_verify import main as bench_main
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(fmu_scene("forced").text)
    report = tmp_path / "B.md"
    report.write_text("# Benchmarks\n\n## Stability stress maps\n\nmaps\n")
    assert bench_main([str(scene_file), "--repeats", "1", "--out", str(tmp_path), "--report", str(report),
                       "--quiet"]) == 0
    rows = list(csv.DictReader(open(tmp_path / "fmu_verify.csv")))
    assert [r["model"] for r in rows] == list(fmu_model_names())
    text = report.read_text()
    assert text.index(SECTION_HEADING) < text.index("## Stability stress maps")
    for r in rows:
        assert float(r["speedup"]) == pytest.approx(float(r["sph_s"]) / float(r["fmu_s"]))
        assert f"| {r['model']} |" in text and f"{float(r['train_err_v']):.3e}" in text
        assert float(r["tolerance"]) == fmu_scene("forced").paper["sph_error_v"]


@pytest.mark.parametrize("case", ["forced", "unforced"])
def test_stepped_sph_error_against_the_truth_equals_an_independent_run(case):
    """The stepped full SPH's own error against the truth (what `sphrom fmu` prints beside the FMU's) equals the
    error of an independent stepped run sampled at the communication points (verify.sph_reference) against the
    same truth at the same points, and without a force it shrinks with the SPH's dt (the time-step error)."""
    from sphrom.cache import cached_sph
    from sphrom.fmu.check import verify
    from sphrom.pod.pipeline import error_steps
    from sphrom.scene import derive_scene
    from sphrom import defaults
    scene = fmu_scene(case)
    step = 0.01
    refs = verify.references(scene, step, defaults.PROBES, True)
    err_v, _, points = refs["_stepped_error"]
    _, _, _, (t, v_true, rho_true, rho0, _) = refs["training"]
    _, v, rho, _, _ = verify.sph_reference(scene, scene.f.text, 1.0, step, defaults.PROBES)
    stored = cached_sph(scene, error_steps(scene), progress=False).steps   # the run references() reads
    at = np.flatnonzero(np.isin(np.round(t / scene.sph.dt).astype(np.int64), stored))
    assert points == at.size >= 2
    again, _, _ = verify.case_errors(v[at], rho[at], v_true[at], rho_true[at], rho0, t[at])
    assert math.isclose(err_v, again, rel_tol=1e-9)
    if case == "unforced":        # f = 0: no input sampling in the truth, the difference is the time-step error
        finer = derive_scene(scene, {"sph": {"dt": scene.sph.dt / 4, "every": 4 * scene.sph.every}})
        assert verify.references(finer, step, defaults.PROBES, True)["_stepped_error"][0] < err_v / 2


def test_an_fmu_the_core_refuses_to_load_is_a_failed_case_with_its_reason(packaged, tmp_path):
    """A model.bin the C core refuses (here a section cut short) fails the check like a failed step: RuntimeError
    naming the instantiation and the loader's reason (fmpy alone says "Failed to instantiate model"; packaging then
    exits non-zero in one line instead of a traceback)."""
    import zipfile

    from sphrom.fmu.check.verify import fmu_case
    path, _ = packaged(verify=False)
    bad = tmp_path / "bad.fmu"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(bad, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            dst.writestr(item, data[:len(data) // 2] if item.filename == "resources/model.bin" else data)
    with pytest.raises(RuntimeError, match=r"the FMU did not instantiate: .*model\.bin"):
        fmu_case(bad, np.zeros(3), np.array([0.0, 0.01, 0.02]))
