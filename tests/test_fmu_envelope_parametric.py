"""The training envelope of a parametric FMU (``--vary``): the union over the full SPH runs at all the sample
points its basis was trained on, so that no held-out (c, d) inside the trained box warns, and a state far
outside (10x the initial state) still does.  Before, a parametric FMU recorded no envelope at all.
"""

import zipfile

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.training import envelope as E
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr
from sphrom.rom import parametric as par
from sphrom.sph.solver import build_problem

RANGES = [par.Range("c", 0.05, 0.2), par.Range("d", 5.0, 15.0)]
H = 0.01


def scene():
    return small_scene("damped_forced", T=0.5, n=32)


@pytest.fixture(scope="module")
def parametric_fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("envelope-parametric")
    made = {}

    def make(model):
        if model not in made:
            path = folder / f"{model}.fmu"
            # without the certified error bounds: with them, their error_tolerance warns in place of the
            # envelope (docs/science/error-bounds.md), and the envelope's own warning is what is tested here
            package_fmu(scene(), path, k=6, fmi=2, progress=False, binaries=ensure_binaries(), model=model,
                        vary=RANGES, error_bounds=False)
            made[model] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[model]

    return make


def test_envelope_is_the_union_over_the_sample_points(parametric_fmus):
    """ENVRANGE and the strains are those of the runs at every sample point (envelope.union of each run's
    envelope on the FMU's basis), wider than the run at the start value alone; the exact parametric FMU
    records its envelope without run-time checks."""
    from sphrom.fmu.training.envelope import measure
    from sphrom.defaults import PROBES as DEFAULT_PROBES
    sc = scene()
    path, data = parametric_fmus("frozen")
    env = E.Envelope.from_sections(data.sections, data.k_v)
    space = par.parameter_space(build_problem(sc), RANGES)
    points = par.training_points(space)
    _, runs = par.training_basis(sc, points, progress=False)
    ops = par.frozen_at(parametric_model_affine(sc), space.start("c"), space.start("d"))
    each = [measure(sc, ops, build_problem(sc), run, DEFAULT_PROBES, False) for run in runs]
    assert np.array_equal(env.lo, np.min([e.lo for e in each], axis=0))
    assert np.array_equal(env.hi, np.max([e.hi for e in each], axis=0))
    assert env.max_probe_strain == max(e.max_probe_strain for e in each)
    assert env.checks & E.CHECK_COORDINATES and env.checks & E.CHECK_STRAIN
    widths = [e.hi - e.lo for e in each]
    assert np.all(env.hi - env.lo >= np.max(widths, axis=0))
    assert np.any(env.hi - env.lo > 1.01 * np.min(widths, axis=0))        # the points differ: the union is wider
    _, exact = parametric_fmus("exact")
    assert E.Envelope.from_sections(exact.sections, exact.k_v).checks == 0


def parametric_model_affine(sc):
    from sphrom.fmu.make.parametric import parametric_model
    affine, _, _, _ = parametric_model(sc, RANGES, 6, model="frozen", progress=False)
    return affine


def run_at(path, c, d, scale):
    sc = scene()
    n = int(round(sc.T / H))
    with FMU(path) as s:
        s.set_real([vr("c"), vr("d")], [c, d])
        s.initialize(initial_state_scale=scale)
        s.run([H] * n, sc.force(np.arange(n) * H))
        return [text for status, _, text in s.messages if status == 1 and "outside the training envelope" in text]


def test_no_warning_at_held_out_or_sample_points_and_one_far_outside(parametric_fmus):
    """The frozen parametric FMU over the scene's T at 10 held-out (c, d) and at the 5 sample points, the
    scene's own initial state: no warning; 10x the initial state: one warning, naming a coordinate."""
    path, _ = parametric_fmus("frozen")
    space = par.parameter_space(build_problem(scene()), RANGES)
    for c, d in list(par.held_out_points(space, 10)) + list(par.training_points(space)):
        assert run_at(path, c, d, 1.0) == [], (c, d)
    c, d = par.held_out_points(space, 1)[0]
    warnings = run_at(path, c, d, 10.0)
    assert len(warnings) == 1 and "reduced coordinate" in warnings[0], warnings
