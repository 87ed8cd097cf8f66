"""sphrom sweep with one parametric FMU by default when the grid varies c or d.

A grid of several d on a scene with uniform c and d packages exactly ONE FMU (trained over the grid's [min, max])
and sets d per run; its rows equal direct runs of that FMU at each d, and differ from the per-value FMUs' rows by
no more than the two FMUs' errors against the full SPH measured in the same study (the parametric error level);
``parametric = false`` packages one FMU per value, as before; a scene with a non-uniform c falls back to one FMU
per value with a note naming fields.c.
"""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.variables import vr
from sphrom.norms import relative_l2
from sphrom.sweep.fmus import sweep_dir
from sphrom.sweep.spec import load_spec
from sphrom.sweep.table import read_results
from sphrom.sweep.worker import probe_stats

D_VALUES = (6.0, 9.0, 12.0)
SPEC = """
scene = "scene.toml"
t_end = 0.5
step = 0.01
probes = [0.25, 0.66]
compare_sph = true
{top}
[grid]
shape = ["sine"]
amplitude = [1e-2]
frequency = [1.0]
d = [6.0, 9.0, 12.0]
k = [4]
"""


@pytest.fixture
def packaging(monkeypatch):
    """Every call of package_fmu by the sweep during the test: a list of its ``vary`` arguments."""
    import sphrom.sweep.fmus as package                # (the sweep's name for it: it imports package_fmu at its top)
    calls = []
    real = package.package_fmu

    def counting(*args, **kwargs):
        calls.append(tuple((r.name, r.lo, r.hi) for r in kwargs.get("vary", ())))
        return real(*args, **kwargs)
    monkeypatch.setattr(package, "package_fmu", counting)
    return calls


def sweep(folder, top, scene, capsys):
    (folder / "scene.toml").write_text(scene.text)
    (folder / "spec.toml").write_text(SPEC.format(top=top))
    out = folder / "results.h5"
    assert main(["sweep", str(folder / "spec.toml"), "--workers", "1", "--out", str(out), "--quiet"]) == 0
    rows, _ = read_results(out)
    return {r["d"]: r for r in rows}, capsys.readouterr().err


def direct(row, d=None):
    """The probe velocities of the row's FMU run by hand (d set when given), and their statistics."""
    t = np.arange(51) * 0.01
    f = 1e-2 * np.sin(2 * np.pi * 1.0 * t[:-1])
    with FMU(sweep_dir() / f"fmu-{row['fmu']}.fmu") as s:
        if d is not None:
            s.set_real([vr("d")], [d])
        s.initialize(n_freeze=10, initial_state_scale=1)
        v = s.run([0.01] * 50, f)[:, :2]
    return t, v, probe_stats(t, v, (0.0, 0.5))


def test_grid_of_d_shares_one_parametric_fmu_and_agrees_with_per_value_fmus(tmp_path, packaging, capsys,
                                                                            record_property):
    scene = small_scene("damped_forced", T=0.5, n=32)          # uniform c = 1, d = 10
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    shared, err = sweep(tmp_path / "a", "", scene, capsys)
    assert packaging == [(("d", 6.0, 12.0),)]                   # ONE FMU, over the grid's [min, max]
    assert "one parametric FMU over d in [6, 12]" in err and "parametric = false" in err
    assert sorted(shared) == list(D_VALUES) and len({r["fmu"] for r in shared.values()}) == 1
    del packaging[:]
    apart, err = sweep(tmp_path / "b", "parametric = false", scene, capsys)
    assert packaging == [(), (), ()]                            # opt-out: one FMU per value
    assert "parametric" not in err
    assert sorted(apart) == list(D_VALUES) and len({r["fmu"] for r in apart.values()}) == 3
    for d in D_VALUES:
        p, q = shared[d], apart[d]
        assert p["status"] == q["status"] == "ok"
        t, v_p, stats_p = direct(p, d)
        _, v_q, stats_q = direct(q)
        for name in ("v_max", "v_rms", "v_final"):              # the rows are these runs, bitwise
            assert [p[f"{name}_{j}"] for j in (1, 2)] == list(stats_p[name])
            assert [q[f"{name}_{j}"] for j in (1, 2)] == list(stats_q[name])
        # the measured parametric error level: both FMUs' errors against the full SPH at this d (eq. 3.4, in
        # the same study); by the triangle inequality ||p - q|| <= (e_p + e_q) ||s|| <= (e_p + e_q) ||q|| / (1 - e_q)
        e_p, e_q = p["sph_err_v"], q["sph_err_v"]
        gap = relative_l2(v_p, v_q, t)
        record_property(f"d={d:g}", {"parametric_vs_per_value": gap, "sph_err_parametric": e_p,
                                     "sph_err_per_value": e_q})
        print(f"d = {d:g}: parametric against per-value FMU {gap:.3e}; against the full SPH: parametric "
              f"{e_p:.3e}, per value {e_q:.3e}")
        assert 0 < e_p < 0.05 and 0 < e_q < 0.05
        assert gap <= (e_p + e_q) / (1 - e_q)
        # and the statistics within it: |rms(p) - rms(q)| <= rms(p - q) per probe (points equally weighted)
        diff = np.sqrt(np.mean((v_p - v_q) ** 2, axis=0))
        assert np.all(np.abs(stats_p["v_rms"] - stats_q["v_rms"]) <= diff * (1 + 1e-12))
    # d matters: the shared FMU's rows differ between the grid's values
    assert abs(shared[6.0]["v_rms_1"] - shared[12.0]["v_rms_1"]) > 1e-3 * shared[12.0]["v_rms_1"]


def test_non_uniform_c_scene_falls_back_to_one_fmu_per_value_with_a_note(tmp_path, packaging, capsys):
    scene = small_scene("heterogeneous", T=0.5, n=32)           # c jumps at L/2
    folder = tmp_path
    (folder / "scene.toml").write_text(scene.text)
    text = SPEC.format(top="").replace("d = [6.0, 9.0, 12.0]", "d = [0.5, 1.0]").replace("t_end = 0.5",
                                                                                        "t_end = 0.1")
    text = text.replace("compare_sph = true", "compare_sph = false")
    (folder / "spec.toml").write_text(text)
    spec = load_spec(folder / "spec.toml")
    assert len({e.variant_inputs() for e in spec.entries}) == 2 and not any(e.parametric for e in spec.entries)
    assert len(spec.notes) == 1 and "non-uniform c (fields.c = " in spec.notes[0]
    out = folder / "results.h5"
    assert main(["sweep", str(folder / "spec.toml"), "--workers", "1", "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "grid.d: one FMU per value" in err and "non-uniform c" in err
    assert packaging == [(), ()]
    rows, _ = read_results(out)
    assert len({r["fmu"] for r in rows}) == 2 and all(r["status"] == "ok" for r in rows)


@pytest.mark.parametrize("top, message", [
    ("parametric = 3", "parametric: 3 is out of range (allowed: true, false, or a table"),
    ("parametric = \"yes\"", "parametric: 'yes' is out of range"),
])
def test_bad_parametric_value_is_one_line(tmp_path, capsys, top, message):
    (tmp_path / "scene.toml").write_text(small_scene("damped_forced", T=0.5, n=32).text)
    (tmp_path / "spec.toml").write_text(SPEC.format(top=top))
    out = tmp_path / "r.h5"
    assert main(["sweep", str(tmp_path / "spec.toml"), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err, err
    assert not out.exists()


def test_parametric_true_is_the_default_and_a_table_still_sets_the_range(tmp_path):
    (tmp_path / "scene.toml").write_text(small_scene("damped_forced", T=0.5, n=32).text)
    specs = {}
    for name, top in (("default", ""), ("true", "parametric = true"), ("table", "[parametric]\nd = [5.0, 15.0]")):
        (tmp_path / f"{name}.toml").write_text(SPEC.format(top=top))
        specs[name] = load_spec(tmp_path / f"{name}.toml")
    assert [e.id for e in specs["default"].entries] == [e.id for e in specs["true"].entries]
    assert {e.parametric for e in specs["default"].entries} == {(("d", 6.0, 12.0),)}
    assert {e.parametric for e in specs["table"].entries} == {(("d", 5.0, 15.0),)}
    # a model that cannot be parametric keeps one FMU per value for its own entries, with a note
    (tmp_path / "models.toml").write_text(SPEC.format(top="").replace("k = [4]", 'k = [4]\nmodel = ["frozen", '
                                                                                  '"balanced"]'))
    mixed = load_spec(tmp_path / "models.toml")
    assert {e.model: e.parametric for e in mixed.entries if e.model == "frozen"} == {"frozen": (("d", 6.0, 12.0),)}
    assert all(e.parametric == () for e in mixed.entries if e.model == "balanced")
    assert len({e.variant_inputs() for e in mixed.entries}) == 1 + len(D_VALUES)
    assert any("grid.model: balanced cannot be parametric" in note for note in mixed.notes)
    (tmp_path / "out.toml").write_text(SPEC.format(top="[parametric]\nd = [7.0, 15.0]"))
    with pytest.raises(Exception, match=r"grid.d: 6.0 is outside the parametric range \[7, 15\]"):
        load_spec(tmp_path / "out.toml")
