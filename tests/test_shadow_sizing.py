"""The shadow's size on an undamped bar (harness/rom/bounds.py choose_planes): the initial state is the only channel
there, and its complement's free response is tabulated, exact at the table's nodes with a cubic Hermite error
Σ |P| (|μ| h)^4 / 384 per mode; the sizing chooses the table's nodes with the planes, so that a finer table leaves
the elastic planes to it (gaussian's exact FMU: 24 planes with at most 4096 nodes).  The bound stays certified:
a modal model's bound from the initial state is never below its true error against the full linear SPH, exact in
time (an independent path: scipy's expm of the full A), over the table's whole span."""

import numpy as np
import scipy.linalg as sla

from sphrom.scene import parse_scene

SCENE = """\
[domain]
L = 1.0
T = 5.0

[fields]
rho0 = "1"
v0 = "1e-3*exp(-200*(x/L - 0.5)**2)"
c = "0.1"
d = "0"

[force]
f = "0"

[sph]
n_particles = 60
"""
PROBES = (0.25, 0.5, 0.66)
H = 0.01                     # communication step [s]


def problem():
    from sphrom.sph.solver import build_problem
    return build_problem(parse_scene(SCENE, "bump.toml", name="bump"))


def test_a_finer_table_leaves_the_initial_state_s_planes_to_it(monkeypatch):
    """The sizing with the table's nodes chosen keeps fewer planes than with at most 4096 nodes (the premise: an
    undamped bar whose initial state reaches planes the coarse table cannot interpolate within the target), and
    its chosen table meets the free channel's allowance: the complement's certified table error at t = 0 is at
    most the target x the largest free response of each row class."""
    import sphrom.rom.bounds as B
    p = problem()
    fine = B.build_shadow(p, PROBES)
    monkeypatch.setattr(B, "TABLE_NODES", (B.MAX_NODES,))
    coarse = B.build_shadow(p, PROBES)
    # the counts are chosen by floating-point thresholds: assert what holds whatever they come to (the sizing tries
    # the coarse cap too and keeps the fewest planes; fewer planes only through a finer table)
    assert fine.planes <= coarse.planes
    assert fine.planes == coarse.planes or fine.info["table_nodes"] > B.MAX_NODES
    comp = fine.comp
    assert comp.values.shape[1] <= fine.info["table_nodes"]
    P = len(PROBES)
    n = p.n
    A = __import__("sphrom.rom.lti", fromlist=["full_linear_system"]).full_linear_system(p, list(PROBES)).A.toarray()
    x0 = np.concatenate([np.sqrt(p.rho0) * p.v0, np.zeros(n)])
    C = B.output_rows(p, PROBES)[0]
    t = np.linspace(0.0, B.TABLE_SPAN * p.scene.T, 801)
    E = sla.expm(A * (t[1] - t[0]))
    x, free = x0.copy(), []
    for _ in t:
        free.append(C @ x)
        x = E @ x
    free = np.abs(np.array(free)).max(axis=0)
    for cls in (slice(0, P), slice(P, 3 * P)):
        assert comp.errors[cls, 0].max() <= B.SHADOW_TARGET * free[cls].max() * (1 + 1e-9)


def test_the_bound_from_the_initial_state_holds_over_the_table_s_span():
    """A modal model (the 6 lowest planes, run by run_shadow) from the initial state, its bound |model - shadow| +
    the shadow's certificate against the full linear SPH stepped by expm: never below the true error over 20 T (the
    table's span, its last step left out: beyond it an undamped complement's free response is bounded by its Hölder
    sum, about the free response itself), and at most 10x the largest true error per output."""
    from sphrom.rom.bounds import TABLE_SPAN, build_shadow, output_rows, run_shadow
    from sphrom.rom.lti import full_linear_system
    p = problem()
    shadow = build_shadow(p, PROBES)
    model = build_shadow(p, PROBES, order=6)
    steps = int(round(TABLE_SPAN * p.scene.T / H)) - 1
    h = np.full(steps, H)
    zero = np.zeros((steps, 1))
    y, cert = run_shadow(shadow, h, zero, zero, scale=1.0)
    ym, _ = run_shadow(model, h, zero, zero, scale=1.0)
    n = p.n
    A = full_linear_system(p, list(PROBES)).A.toarray()
    C = output_rows(p, PROBES)[0]
    E = sla.expm(A * H)
    x = np.concatenate([np.sqrt(p.rho0) * p.v0, np.zeros(n)])
    truth = []
    for _ in range(steps + 1):
        truth.append(C @ x)
        x = E @ x
    truth = np.array(truth)
    P = len(PROBES)
    error = np.abs(ym - truth)[:, :3 * P]
    bound = (np.abs(ym - y) + cert)[:, :3 * P]
    assert np.all(error <= bound)
    assert np.all(bound.max(axis=0) <= 10.0 * error.max(axis=0))


def test_the_criterion_weighs_the_variation_as_the_core_does():
    """A damping that varies along the bar (the fourth generated user scene of `sphrom bench error_bounds`:
    eigen-planes, decay rates from 0.3 to 5 s^-1): the shadow's own complement under the reference sine, its groups'
    gains times the sine's variation at each group's rate (what the C core sums), stays within the target x the
    sine's largest response of each row class, as the sizing judged it: the criterion's term is the bound's."""
    from sphrom.bench.error_bounds import user_scenes
    from sphrom.rom.bounds import (FLOOR, REFERENCE_SPAN, SHADOW_TARGET, build_shadow, decompose, input_columns,
                                   output_rows, reference_responses, sine_variation)
    from sphrom.sph.solver import build_problem
    scene = user_scenes(4)[3]
    p = build_problem(scene)
    assert not np.all(p.d == p.d[0])                      # the premise: eigen-planes, modes of many decay rates
    shadow = build_shadow(p, PROBES)
    comp = shadow.comp
    omega = shadow.info["omega_ref"]
    term = (comp.gain[:, 0, :] * sine_variation(comp.rates, omega, REFERENCE_SPAN * scene.T)[None, :]).sum(axis=1)
    planes = decompose(p)
    C = output_rows(p, PROBES)[0]
    chat = np.moveaxis(planes.right(C.T), 2, 0)
    bhat = planes.left(input_columns(p))
    step_r, sine_r = reference_responses(planes.blocks[0], chat, bhat, scene.T, omega)
    P = len(PROBES)
    for cls in (slice(0, P), slice(P, 3 * P)):
        judged = sine_r[cls, 0].max() > FLOOR * max(step_r[cls, 0].max(), sine_r[cls, 0].max())
        assert judged
        assert term[cls].max() <= SHADOW_TARGET * sine_r[cls, 0].max() * (1 + 1e-9)
