"""The shadow sized against the model's own error (harness/rom/bounds.py choose_planes, model_errors): a reference
channel's complement may reach half the model's error on it, so a more accurate model gets at least as many planes,
and the bound of the model it was sized for stays within 10x of its true error (the built-in heterogeneous bar, and
the hand-written hammer bar of tests/test_shadow_in_band.py: graded damping, an in-band force, whose shadow keeps
every plane).  The models here are modal stand-ins (the shadow's own lowest planes, run by run_shadow): linear,
exact in time, their error the response of the planes they lack."""

import numpy as np

from test_shadow_in_band import H, PROBES, STEPS, exact_rows, problem


def modal_runs(p, planes):
    """``model_runs`` of a modal model keeping the ``planes`` lowest planes (bounds.model_errors' contract:
    (v, rho) (steps, P) after each step, with t = 0 first from the initial state)."""
    from sphrom.rom.bounds import build_shadow, run_shadow
    sh = build_shadow(p, PROBES, order=planes)
    P = len(PROBES)

    def run(h, f, scale):
        f = np.asarray(f, float)
        y, _ = run_shadow(sh, np.full(f.size, h), f[:, None], np.zeros((f.size, 1)), scale=scale)
        y = y if scale else y[1:]
        e = y[:, P:3 * P].reshape(-1, P, 2)
        rho = (sh.pw * sh.prho0 / (1.0 + e)).sum(axis=2)
        return y[:, :P], rho
    return run


def test_a_more_accurate_model_gets_at_least_as_many_planes():
    """heterogeneous (a damping that varies, eigen-planes): the shadow of a coarse modal model (1 plane) has no more
    planes than that of a finer one (12 planes), which has no more than the shadow sized on the target alone (a
    model of unknown, maybe perfect accuracy: its initial state's channel held to the same FREE_TARGET as a known
    model's); the coarse model's error from the initial state, as choose_planes measured it, is above the finer
    one's."""
    from sphrom.rom.bounds import build_shadow
    from sphrom.scene import load_scene
    from sphrom.sph.solver import build_problem
    p = build_problem(load_scene("heterogeneous"))
    coarse = build_shadow(p, PROBES, model_runs=modal_runs(p, 1))
    fine = build_shadow(p, PROBES, model_runs=modal_runs(p, 12))
    alone = build_shadow(p, PROBES)
    assert coarse.planes <= fine.planes <= alone.planes
    assert fine.info["model_error"]["free"] < coarse.info["model_error"]["free"]


def test_the_bound_of_the_model_it_was_sized_for_stays_within_ten_times_its_error():
    """The hammer bar under its own force (not a reference input): the bound of a coarse modal model (6 planes), from
    the shadow sized on its error, is never below its true error against the full linear SPH (exact in time) and
    its largest value is at most 10x the largest true error, per probe."""
    from sphrom.rom.bounds import build_shadow, output_rows, run_shadow
    p = problem()
    runs = modal_runs(p, 6)
    shadow = build_shadow(p, PROBES, model_runs=runs)
    t = np.arange(STEPS) * H
    f = np.asarray(p.scene.force(t), float) * np.ones(STEPS)
    P = len(PROBES)
    truth = exact_rows(p, output_rows(p, PROBES)[0], f)[:, :P]
    y, cert = run_shadow(shadow, np.full(STEPS, H), f[:, None], np.zeros((STEPS, 1)))
    model = np.vstack([np.zeros((1, P)), runs(H, f, 0.0)[0]])
    error = np.abs(model - truth)
    bound = np.abs(model - y[:, :P]) + cert[:, :P]
    assert np.all(error <= bound)
    assert np.all(bound.max(axis=0) <= 10.0 * error.max(axis=0))


SHORT_WAVE = """\
[domain]
L = 1.0
T = 1.0

[fields]
rho0 = "1000"
v0 = "0"
c = "1e4"
d = "2"

[force]
f = "sin(3*t)"
profile = "cos(2*pi*12*x/L)"

[sph]
n_particles = 64
"""


def test_a_short_wave_force_keeps_the_plane_it_reaches_not_those_below():
    """A force profile of one short wavelength reaches a high plane and hardly any below it: the shadow keeps planes
    above some it leaves out (not the lowest ones in a row), and the bound of a modal model of the two lowest planes
    under the scene's force (not a reference input) is never below its true error against the full linear SPH
    (exact in time) and at most 10x it, per probe."""
    from sphrom.rom.bounds import build_shadow, output_rows, run_shadow
    from sphrom.scene import parse_scene
    from sphrom.sph.solver import build_problem
    p = build_problem(parse_scene(SHORT_WAVE, "short_wave.toml", name="short_wave"))
    shadow = build_shadow(p, PROBES)
    kept = np.asarray(shadow.info["kept"])
    assert kept.max() + 1 > kept.size                        # some plane below the highest kept is left out
    h, steps = 1e-3, 1000
    f = np.asarray(p.scene.force(np.arange(steps) * h), float) * np.ones(steps)
    P = len(PROBES)
    truth = exact_rows(p, output_rows(p, PROBES)[0], f, h)[:, :P]
    y, cert = run_shadow(shadow, np.full(steps, h), f[:, None], np.zeros((steps, 1)))
    model = np.vstack([np.zeros((1, P)), modal_runs(p, 2)(h, f, 0.0)[0]])
    error = np.abs(model - truth)
    bound = np.abs(model - y[:, :P]) + cert[:, :P]
    assert np.all(error <= bound)
    assert np.all(bound.max(axis=0) <= 10.0 * error.max(axis=0))
