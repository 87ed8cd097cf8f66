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


def test_past_the_table_the_modes_left_out_may_reach_the_model_allowance(monkeypatch):
    """heterogeneous, a model 5 % off (the modal model of 12 planes with its velocity and its density's change
    scaled by 1.05): past the free response table the complement's modes left out
    (bounded by their size there, each continued one costs the FMU a complex product and its rows' sums per step)
    may reach the free channel's allowance of the model's own error from its initial state, MODEL_FRACTION x it,
    where that is larger than the table's own error (bounds.continued_modes).  Against the shadow whose room is the
    table's error alone: fewer modes continued, the same bound within the table, past it a bound larger by at most
    that allowance (or the round-off share); and the rows' bound holds against the full linear SPH (exact in time)
    from the initial state, over the table's last second and 3 s past its end."""
    import scipy.linalg as sla

    import sphrom.rom.bounds as bounds
    from sphrom.rom.bounds import output_rows
    from sphrom.rom.lti import full_linear_system
    from sphrom.scene import load_scene
    from sphrom.sph.solver import build_problem
    p = build_problem(load_scene("heterogeneous"))
    modal = modal_runs(p, 12)

    def runs(h, f, scale):
        v, rho = modal(h, f, scale)
        rho = np.asarray(rho)
        return 1.05 * np.asarray(v), rho[0] + 1.05 * (rho - rho[0])
    coarse = bounds.build_shadow(p, PROBES, model_runs=runs)
    rule = bounds.continued_modes
    monkeypatch.setattr(bounds, "continued_modes", lambda modes, decayed, budget, values, fixed, floor=None:
                        rule(modes, decayed, budget, values, fixed))      # the room of the table's own error alone
    tight = bounds.build_shadow(p, PROBES, model_runs=runs)
    monkeypatch.undo()
    t_end = coarse.comp.t_end
    assert 0 < t_end == tight.comp.t_end
    assert coarse.comp.cont_mu.size < tight.comp.cont_mu.size
    h = 0.01
    plan = np.array([t_end - 1.0] + [h] * 400)
    zero = np.zeros((plan.size, 1))
    y, cert = bounds.run_shadow(coarse, plan, zero, zero, scale=1.0)
    _, cert_tight = bounds.run_shadow(tight, plan, zero, zero, scale=1.0)
    t = np.concatenate([[0.0], np.cumsum(plan)])
    late = t > t_end
    assert late.sum() > 250
    np.testing.assert_allclose(cert[~late], cert_tight[~late], rtol=1e-14, atol=0)
    room = np.maximum(np.asarray(coarse.info["free_model_room"]),
                      bounds.CONT_SHARE * bounds.ROUNDOFF * coarse.row_norm * coarse.x0_norm) * (1 + 1e-9)
    assert np.all(cert[late] - cert_tight[late] <= room[None, :]), np.max(cert[late] - cert_tight[late] - room)
    lti = full_linear_system(p, list(PROBES))
    A = lti.A.toarray()
    x, out = lti.x0.copy(), [output_rows(p, PROBES)[0] @ lti.x0]
    maps = {s: sla.expm(A * s) for s in set(plan.tolist())}
    for s in plan:
        x = maps[s] @ x
        out.append(output_rows(p, PROBES)[0] @ x)
    truth = np.array(out)
    assert np.all(np.abs(y - truth) <= cert), np.max(np.abs(y - truth) - cert)
