"""n_freeze chosen per scene when the user gives none (harness/fmu/make/models.py choose_n_freeze).

The rule: the largest candidate whose training error is within 5 % of n_freeze = 1's.  Checked against errors
computed here independently (the frozen model run at each candidate, against the full SPH training run), on a
scene whose force varies in time (the frozen force costs accuracy there) and on a free response (flat errors:
the largest candidate).  The CLI chooses when --n-freeze is not given, keeps the user's value when it is; the
Python API keeps its default of 10.
"""

import zipfile

import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.fmu.make.models import (N_FREEZE_CANDIDATES, N_FREEZE_SLACK, choose_n_freeze, reduced_model,
                                     training_basis)
from sphrom.fmu.make.options import default_modes
from sphrom.rom.registry import get_model
from sphrom.sph.solver import step_count


def _setup(scene):
    basis, run, problem = training_basis(scene, False, None)
    _, ops, problem, _ = reduced_model(scene, default_modes(scene), 10, (0.25, 0.5, 0.66), "euler", progress=False,
                                       problem=problem, made=(basis, run), tensor="always")
    return ops, problem, run


def _error(scene, ops, problem, run, nf):
    spec = get_model("frozen")
    res = spec.run(ops, problem, dt=scene.sph.dt, n_steps=step_count(scene.T, scene.sph.dt), sample_steps=run.steps,
                   options=spec.options(n_freeze=nf))
    v = ops.velocity(res.z[:, :ops.k_v])
    return float(np.linalg.norm(v - run.v) / np.linalg.norm(run.v))


@pytest.mark.parametrize("base", ["damped_forced", "multimode"])
def test_the_largest_candidate_within_the_slack(base):
    scene = small_scene(base, T=2.0, n=48)
    ops, problem, run = _setup(scene)
    chosen, errors = choose_n_freeze(scene, ops, problem, run)
    assert chosen in N_FREEZE_CANDIDATES
    best = _error(scene, ops, problem, run, 1)
    assert errors[1] == pytest.approx(best, rel=1e-12)
    assert _error(scene, ops, problem, run, chosen) <= (1 + N_FREEZE_SLACK) * best
    for larger in (c for c in N_FREEZE_CANDIDATES if c > chosen):
        assert _error(scene, ops, problem, run, larger) > (1 + N_FREEZE_SLACK) * best, larger
    if base == "multimode":                          # a free response: nothing frozen but the coefficients
        assert chosen == max(N_FREEZE_CANDIDATES), errors


def test_the_cli_chooses_unless_told(tmp_path, capsys):
    from sphrom.fmu.resources import unpack
    from sphrom.scene import dump_toml, scene_dict
    path = tmp_path / "scene.toml"
    path.write_text(dump_toml(scene_dict(small_scene("damped_forced", T=1.0, n=48))))
    chosen = {}
    for given in (None, 10):
        out = tmp_path / f"nf-{given}.fmu"
        argv = ["fmu", str(path), "--no-verify", "--quiet", "--out", str(out)]
        assert main(argv + ([] if given is None else ["--n-freeze", str(given)])) == 0
        text = capsys.readouterr().out
        assert ("chosen: the largest whose training error" in text) == (given is None), text
        chosen[given] = unpack(zipfile.ZipFile(out).read("resources/model.bin")).n_freeze
    assert chosen[10] == 10 and chosen[None] in N_FREEZE_CANDIDATES


def test_a_costly_model_is_tried_on_the_first_part_of_the_training_run(monkeypatch):
    """Where one trial at n_freeze = 1 would cost more than N_FREEZE_BUDGET multiply-adds (a port model's large
    basis refreshed from the particles), the candidates run over the training run's first samples only (at least
    N_FREEZE_MIN_SAMPLES): each error equals the one computed here independently over those samples, and the rule
    is the same."""
    from sphrom.fmu.kinds import frozen                               # the frozen kind chooses n_freeze
    scene = small_scene("damped_forced", T=2.0, n=48)
    ops, problem, run = _setup(scene)
    monkeypatch.setattr(frozen, "N_FREEZE_BUDGET", 1.0)              # every run is over budget
    chosen, errors = choose_n_freeze(scene, ops, problem, run)
    m = frozen.N_FREEZE_MIN_SAMPLES
    assert m < len(run.steps)
    steps = np.asarray(run.steps)[:m]
    spec = get_model("frozen")

    def first_part(nf):
        res = spec.run(ops, problem, dt=scene.sph.dt, n_steps=int(steps[-1]), sample_steps=steps,
                       options=spec.options(n_freeze=nf))
        v_ref = np.asarray(run.v)[:m]
        return float(np.linalg.norm(ops.velocity(res.z[:, :ops.k_v]) - v_ref) / np.linalg.norm(v_ref))

    for nf, err in errors.items():
        assert err == pytest.approx(first_part(nf), rel=1e-12), nf
    within = [nf for nf in errors if errors[nf] <= (1 + N_FREEZE_SLACK) * errors[1]]
    assert chosen == max(within)
