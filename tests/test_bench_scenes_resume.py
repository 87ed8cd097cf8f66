"""`sphrom bench scenes` over several sittings: the outputs are rewritten after every scene, a run stopped part way
leaves the table of what it measured (saying how many), and --resume measures only the scenes the CSV lacks, with
the rows read back as written (numbers, flags)."""

import pytest

from sphrom.bench import scenes


def fake_row(name, text, facts, folder, progress=False):
    """A measured row's shape without the measurement (the bookkeeping is under test, not the FMUs)."""
    return {**facts, "loaded": True, "integrator_used": "symplectic", "dt": 1e-3, "default_built": True,
            "default_model": "frozen", "default_max_v": 0.01 * facts["n"] / 64, "default_bound_holds": True,
            "default_bound_usefulness": 0.5, "default_warnings": 0, "default_false_alarms": 0,
            "default_cost_ratio": 0.25, "exact_built": True, "exact_model": "exact", "exact_max_v": 1e-3,
            "exact_bound_holds": None, "exact_bound_usefulness": float("nan"), "exact_warnings": 1,
            "exact_false_alarms": 0, "exact_cost_ratio": 0.5, "sph_time_error": 2e-3, "wall_s": 1.25, "note": ""}


def test_a_stopped_run_leaves_its_table_and_resume_measures_the_rest(tmp_path, monkeypatch):
    out, report = tmp_path / "scenes.csv", tmp_path / "B.md"
    argv = ["--count", "3", "--n-max", "80", "--out", str(out), "--report", str(report), "--quiet"]
    measured = []

    def stop_at_third(name, *args, **kw):
        if len(measured) == 2:
            raise KeyboardInterrupt
        measured.append(name)
        return fake_row(name, *args, **kw)
    monkeypatch.setattr(scenes, "measure_scene", stop_at_third)
    with pytest.raises(KeyboardInterrupt):
        scenes.main(argv)
    text = report.read_text()
    assert "**2 of the 3 scenes measured**" in text and "4 s wall" not in text and "| user0_01 |" in text
    first = out.read_text()

    again = []
    monkeypatch.setattr(scenes, "measure_scene", lambda name, *a, **k: again.append(name) or fake_row(name, *a, **k))
    assert scenes.main(argv + ["--resume"]) == 0
    assert again == ["user0_02"]                                   # the two measured rows were kept
    text = report.read_text()
    assert "scenes measured**" not in text and "| user0_02 |" in text and ", 4 s wall, the sum of every scene's" in text
    assert "Built at the first try** (" in text and ": 3 of 3 scenes" in text
    assert out.read_text().splitlines()[:3] == first.splitlines()[:3]  # read back and written again unchanged
    # a corpus of another N range is another corpus: nothing is kept
    again.clear()
    assert scenes.main(argv[:2] + ["--n-max", "300"] + argv[4:] + ["--resume"]) == 0
    assert len(again) == 3
