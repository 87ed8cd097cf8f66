"""The validation report: its measured figures agree with the independent paths they quote."""

import numpy as np
import pytest

from sphrom.cli import main
from sphrom.compare import exact_errors
from sphrom.norms import relative_l2, relative_l2_history
from sphrom.report import accuracy
from sphrom.report.pages import scene_page
from sphrom.sph.solver import run_sph

from conftest import small_scene


def test_error_history_ends_at_the_space_time_error():
    rng = np.random.default_rng(1)
    u, r = rng.normal(size=(9, 6)), rng.normal(size=(9, 6))
    t = np.sort(rng.uniform(0, 2, 9))
    h = relative_l2_history(u, r, t, baseline=0.5)
    assert h[-1] == pytest.approx(relative_l2(u, r, t, baseline=0.5), rel=1e-13)
    assert h[4] == pytest.approx(relative_l2(u[:5], r[:5], t[:5], baseline=0.5), rel=1e-13)


def test_paper_comparison_flags_only_beyond_25_percent():
    scene = small_scene("multimode")
    pv = scene.paper["sph_error_v"]
    prho = scene.paper["sph_error_rho"]
    errors = {"exact": {"v": 1.24 * pv, "rho": 1.26 * prho}}
    rows = {r["quantity"]: r for r in accuracy.paper_comparison(scene, errors)}
    assert rows["v"]["ratio"] == pytest.approx(1.24) and not rows["v"]["flag"]
    assert rows["ρ"]["ratio"] == pytest.approx(1.26) and rows["ρ"]["flag"]
    assert rows["v"]["like_ref"] == "exact"          # multimode: the paper's reference is analytic


def test_scene_page_quotes_the_errors_of_independent_paths(tmp_path):
    """The page's SPH-vs-exact error is the one `sphrom sph` prints, and the
    three continuum references agree with the exact solution and each other."""
    scene = small_scene("damped_forced", T=0.4, n=32, every=40)
    summary = scene_page(scene, tmp_path, repeats=1, progress=False, convergence=False)
    res = run_sph(scene, progress=False)
    direct = exact_errors(scene, res.t, res.x, res.v, res.rho)
    assert summary["best"] == "exact"
    assert summary["sph"]["v"] == pytest.approx(direct["v"], rel=1e-12)
    assert summary["sph"]["rho_var"] == pytest.approx(direct["rho_var"], rel=1e-12)
    for (a, b), e in summary["pairs"].items():
        if "fd" not in (a, b) and "fd-collocated" not in (a, b):
            assert e["v"] < 1e-3 and e["rho_var"] < 1e-2, (a, b, e)
    page = (tmp_path / f"{scene.name}.md").read_text()
    assert f"{direct['v']:.3e}" in page
    # the continuum pair is refined only while it misses the target, and stops as soon as it meets it
    refinement = summary["refinement"]
    assert all(max(ev, er) > 1e-4 for _, _, _, ev, er in refinement[:-1])
    assert len(refinement) == 3 or max(refinement[-1][3:]) <= 1e-4
    assert "refined together" in page
    assert "The exact linear model (beyond the paper) against the original POD-MOR" in page
    assert summary["exact_model"] and all(r["pure_v"] < 1 for r in summary["exact_model"])
    assert (tmp_path / scene.name / f"{scene.name}_modes_sweep.png").stat().st_size > 1000


def test_references_converge_towards_each_other_on_the_jump(tmp_path):
    """heterogeneous: scikit-fem and py-pde differ less as both are refined (order > 0.5)."""
    from sphrom.report.convergence import agreement_section
    scene = small_scene("heterogeneous", T=1.0, n=32, every=50)
    (tmp_path / "h").mkdir()
    _, (dv, drho, order_v, order_rho) = agreement_section(scene, tmp_path / "h", "h", resolutions=(64, 128, 256))
    assert dv < 1e-2 and order_v > 0.5 and order_rho > 0.5


def test_validate_needs_a_scene_or_all(capsys):
    assert main(["validate"]) == 2
    assert "give a SCENE or --all" in capsys.readouterr().err
    assert main(["validate", "multimode", "--all"]) == 2
