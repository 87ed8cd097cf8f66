"""The BENCHMARKS.md writers (the sections beside what measures them: sphrom.bench.suite, the library's fmu_sections,
sph_scaling and stress_maps, the programs' own): each section on small inputs is well-formed Markdown, and the
assembled document has the sections of the committed BENCHMARKS.md in its order."""

import math
import re
from pathlib import Path

import pytest

from sphrom.bench import suite
from sphrom.bench.fmu_verify import packaged_fmu_section
from sphrom.bench.lib.fmu_sections import fmu_section, headline_section
from sphrom.bench.lib.sph_scaling import INTEGRATORS, sph_step_section
from sphrom.bench.lib.stress_maps import StressMaps, stress_section
from sphrom.bench.linear_tradeoff import linear_tradeoff_section
from sphrom.bench.suite import BenchResults

ROOT = Path(__file__).resolve().parents[1]
NAN = float("nan")


def _tables(lines):
    """Markdown tables in ``lines``: lists of consecutive lines starting with '|'."""
    tables, cur = [], []
    for line in lines + [""]:
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            tables.append(cur)
            cur = []
    return tables


def _cells(line):
    assert line.startswith("|") and line.endswith("|"), line
    return line[1:-1].split(" | ")


def assert_well_formed(lines):
    """Every table: a header, a separator of --- cells, rows with the header's column count; headings are
    preceded by a blank line; the section ends with a blank line; no NaN printed as 'nan'."""
    assert lines and lines[-1] == "", lines[-3:]
    assert all(isinstance(x, str) and "\n" not in x for x in lines)
    for i, line in enumerate(lines):
        if line.startswith("#") and i:
            assert lines[i - 1] == "", (lines[i - 1], line)
        assert "nan" not in re.sub(r"[A-Za-z_]nan|nan[A-Za-z_]", "", line), line
    tables = _tables(lines)
    for t in tables:
        assert len(t) >= 2, t
        width = len(_cells(t[0]))
        assert all(re.fullmatch(r" ?-+:? ?|---:?", c.strip()) or set(c.strip()) <= set("-:") for c in _cells(t[1]))
        for row in t:
            assert len(_cells(row)) == width, (t[0], row)
    return tables


def _row(scene, method, k, nf, online, err=1e-2):
    return {"scene": scene, "method": method, "k": k, "n_freeze": nf, "online_s": online, "offline_s": 0.1,
            "speedup": 1.0 / online, "err_v_sph": err, "err_rho_sph": NAN, "err_v_ref": 0.09, "err_rho_ref": 0.1}


ROWS = [_row("a", "full SPH", 100, None, 1.0, NAN), _row("a", "frozen", 8, 10, 0.2), _row("a", "frozen", 12, 10, 0.4),
        _row("a", "exact", 8, None, 0.1), _row("b", "full SPH", 100, None, 2.0, NAN), _row("b", "frozen", 8, 10, 0.5)]
SCALING = [{"method": m, "n": n, "k": 0 if m == "full SPH" else 12, "us_per_step": 0.01 * n * (i + 1)}
           for i, m in enumerate(("full SPH", "frozen (n_freeze = 10)")) for n in (100, 400)]
SCALING_K = [{"method": "full SPH", "n": 400, "k": 0, "us_per_step": 4.0}] + [
    {"method": m, "n": 400, "k": k, "us_per_step": k * (i + 1) * 0.1} for i, m in enumerate(("original", "frozen"))
    for k in (4, 8)]
SKIPS = [{"scene": "a", "solver": "full SPH", "specialised_us": 3.4, "general_us": 3.5, "saving": 1 - 3.4 / 3.5}]
DIRECTIONS = [{"scene": "a", "k": 8, "input_error": 0.004, "choice": c, "k_v": 8 + (c == "augment"), "err_v": 0.1,
               "err_rho": NAN, "fmu_rule": "project"} for c in ("project", "augment")]
SPH_STEPS = [{"integrator": i, "n": n, "us_per_step": 0.01 * n * (j + 1), "ns_per_particle_step": 10.0, "steps": 9}
             for j, i in enumerate(INTEGRATORS) for n in (100, 1000, 10000)]
CORE = [{"n": n, "k": 12, "k_v": 12, "k_rho": 12, "n_freeze": 10, "steps": 9, "ns_per_step": 180.0, "ns_min": 170.0,
         "ns_max": 190.0} for n in (100, 400)]
E2E = {"rows": [{"model": m, "step_s": h, "doSteps": round(10 / h), "fmu_e2e_s": 0.06, "fixed_s": 0.01,
                 "core_s": NAN if m == "exact" else 0.05, "us_per_doStep_fmpy": 0.4,
                 "us_per_doStep_bare_call": NAN if m == "exact" else 2.2,
                 "probe_error_v_vs_sph": 0.1 if h == 0.01 else None, "speedup": 12.0}
                for m in ("frozen", "exact") for h in (0.01, 0.001)],
       "sph": {"loop_s": 0.7, "call_s": 0.74, "probe_error_v_vs_exact": 0.08}, "scene": "tenmode", "n": 400,
       "T": 10.0, "internal_steps": 200000, "k_v": 12, "k_rho": 12, "probes": [0.25, 0.5]}
SAME = {"n": 400, "k": 12, "n_freeze": 10, "frozen_ns": 181.0, "sph_ns": 2613.0, "ratio": 14.4, "k_v": 12, "k_rho": 12}
FMU = {"core": CORE, "e2e": E2E, "same": SAME, "repeats": 5}


def _stress_scene(name, fmu):
    methods = ["frozen", "exact"] + (["FMU frozen"] if fmu else [])
    rows = [{"method": m, "dt_factor": f, "amplitude": a, "outcome": "blow-up" if f == 2.0 else "stable",
             "blowup_time": 1.5 if f == 2.0 else None, "energy_growth": math.inf if f == 2.0 else 1.0,
             **({"fmu_error": "t = 1.5 s: runaway" if f == 2.0 else "", "silent_nan": 0}
                if m.startswith("FMU") else {})}
            for m in methods for f in (0.5, 2.0, "paper") for a in (1, 10)]
    hor = [{"method": m, "T": T, "outcome": "stable", "blowup_time": None, "energy_growth": 1.0}
           for m in methods for T in (10.0, 100.0)]
    return {"name": name, "T": 10.0, "dt": 5e-5, "dt_limit": 0.016, "k": 12, "fmu": fmu, "map": rows,
            "horizons": hor, "modes": [{"method": "frozen", "k": 4, "outcome": "stable", "energy_growth": 1.0}],
            "forces": [{"method": m, "force_amplitude": 1.0, "outcome": "stable", "energy_vs_exact": 0.0}
                       for m in methods]}


PACKAGED = [{"scene": sc, "model": m, "k": 12, "k_v": 12, "k_rho": 12, "train_err_v": 1e-2, "train_err_rho": 2e-3,
             "step": 0.01, "step_err_v": 2e-2, "accepted": True, "unseen_err_v": 3e-2, "unseen_err_rho": NAN, "unseen_max_drho": 1e-9, "unseen_start": "rest", "fmu_s": 0.05, "sph_s": 0.7,
             "speedup": 14.0, "tolerance": tol, "meets": None if tol is None else True, "note": ""}
            for sc, tol in (("a", 0.08), ("b", None)) for m in ("frozen", "exact")]
PACKAGED_META = {"command": "python -m sphrom.bench.fmu_verify a b", "repeats": 3, "wall": 60.0, "machine": "m"}

MAPS = StressMaps([_stress_scene("a", True), _stress_scene("b", False)], [1, 10], 12.0)


@pytest.mark.parametrize("section, args, columns", [
    (headline_section, (FMU,), []),
    (suite.savings_section, ([("a", {8: 0.8, 12: 0.6}, 0.95), ("b", {8: 0.75}, None)],), [3]),
    (suite.scene_section, ("a", ROWS[:4], "x/a_time_error.png"), [10]),
    (suite.cost_n_section, (SCALING, [100, 400, 1600], "x/scaling_n.png"), [5]),
    (suite.cost_k_section, (SCALING_K, [4, 8], "x/scaling_k.png"), [4]),
    (suite.skip_section, (SKIPS,), [5]),
    (suite.input_direction_section, (DIRECTIONS, ["a", "b"], 0.01), [8]),
    (sph_step_section, (SPH_STEPS, [100, 1000, 10000], 3), [5]),
    (fmu_section, (FMU,), [8, 11]),
    (lambda rows: packaged_fmu_section(rows, **PACKAGED_META), (PACKAGED,), [17]),
    (stress_section, (MAPS, "sphrom stress a b", "x/stress", 2), [3, 5, 4, 4] * 2),
])
def test_each_section_is_well_formed_markdown(section, args, columns):
    lines = section(*args)
    tables = assert_well_formed(lines)
    assert [len(_cells(t[0])) for t in tables] == columns
    assert lines[0].startswith("#")


def test_sections_without_data_are_empty_and_images_are_given_paths():
    assert headline_section(None) == [] and fmu_section(None) == []
    assert suite.input_direction_section([], ["a"], 0.01) == []
    assert "![time against error](x/a_time_error.png)" in suite.scene_section("a", ROWS[:2], "x/a_time_error.png")
    page = stress_section(MAPS, "sphrom stress a b", "", level=1)
    assert page[0] == "# Stability stress maps" and "## a" in page and "![stress map](a_stress.png)" in page
    assert "Wall time 12 s." in page[2]
    # the FMU paragraph only where the FMU ran, counting its runs and naming the error's time
    fmu_lines = [x for x in page if x.startswith("The FMU (FMI 2")]
    assert len(fmu_lines) == 1 and "t = 1.5 s" in fmu_lines[0] and "**0**" in fmu_lines[0]


def test_the_report_has_the_committed_documents_sections_in_order(tmp_path):
    results = BenchResults(command="sphrom bench a b --repeats 3 --report", version="0", python="3", machine="m",
                           repeats=3, scene_names=["a", "b"], rows=ROWS, savings=[("a", {8: 0.8}, 0.95)],
                           sizes=[100, 400], scaling=SCALING, ks_scaling=[4, 8], scaling_k=SCALING_K, skips=SKIPS,
                           directions=DIRECTIONS, input_tolerance=0.01, sph_sizes=[100, 1000, 10000],
                           sph_steps=SPH_STEPS, fmu=FMU, stress=MAPS, stress_command="sphrom bench --report", wall=3)
    text = suite.report(results, "validation/benchmarks", existing=(ROOT / "BENCHMARKS.md").read_text())
    assert text.endswith("|\n") and "\n\n\n" not in text
    assert_well_formed(text.splitlines() + [""])

    def skeleton(md):
        """Headings with the scene names replaced, in order."""
        out = []
        for line in md.splitlines():
            if line.startswith("#"):
                out.append(re.sub(r"^(#+) (tenmode|damped_forced|damped|heterogeneous|mild_damped_forced|a|b)$",
                                  r"\1 SCENE", re.sub(r"\(.*", "", line).strip()))
        return [h for i, h in enumerate(out) if not (h.endswith("SCENE") and i and out[i - 1] == h)]
    committed = skeleton((ROOT / "BENCHMARKS.md").read_text())
    assert skeleton(text) == committed
    # every image path of the committed document resolves from the repository root, and ours are built alike
    for path in re.findall(r"!\[[^]]*\]\(([^)]+)\)", (ROOT / "BENCHMARKS.md").read_text()):
        assert (ROOT / path).is_file(), path
    assert "![cost against N](validation/benchmarks/scaling_n.png)" in text
    assert "![stress map](validation/benchmarks/stress/a_stress.png)" in text
    assert not (ROOT / "validation" / "benchmarks" / "bench.md").exists()


def test_linear_tradeoff_section_replaces_its_own_section_only(tmp_path):
    """python -m sphrom.bench.linear_tradeoff writes its section into BENCHMARKS.md, before the stress maps: a
    second run replaces it, the other sections stay; the bound's ratio to the measured error is shown where
    there is a bound; sphrom bench --report carries it over."""
    from sphrom.bench.linear_tradeoff import SECTION_TITLE, write_section
    rows = [{"scene": "s", "force": f, "order": 4, "model": m, "state": 4, "online_s": 0.5, "err_sph": 1e-2,
             "err_linear": 2e-5 if m == "balanced" else NAN, "bound": 3e-5 if m == "balanced" else NAN, "note": ""}
            for f in ("training", "unseen") for m in ("balanced", "frozen")]
    text = "\n".join(linear_tradeoff_section(rows, "cmd", 1.0)) + "\n"
    assert text.startswith(SECTION_TITLE) and "### s, training force" in text and "### s, unseen force" in text
    assert "| 4 | balanced | 4 | 0.5000 | 1.000e-02 | 2.000e-05 | 3.000e-05 | 1.50000 |  |" in text
    assert "| 4 | frozen | 4 | 0.5000 | 1.000e-02 | — | — | — |  |" in text
    assert SECTION_TITLE in suite.CARRIED
    page = tmp_path / "B.md"
    page.write_text("# Benchmarks\n\n## A\n\na\n\n## Stability stress maps\n\nz\n")
    write_section(page, text)
    write_section(page, text.replace("cmd", "cmd2"))
    out = page.read_text()
    assert out.count(SECTION_TITLE) == 1 and "cmd2" in out and "`cmd`" not in out and "\n\n\n" not in out
    assert out.index("## A") < out.index(SECTION_TITLE) < out.index("## Stability stress maps") and out.endswith("z\n")
