"""A user's bar that the shadow's complement cannot bound usefully: SI aluminium and steel, a damping graded along the
bar, a hammer force at 600 Hz on a few particles, no integrator or dt named.  Its complement's decay-weighted
variation (u'/α, α ~ 10-50 s^-1) stands against a true response ~ u'/ω (ω ~ 1e4 s^-1): a shadow of MAX_PLANES planes
left bounds 3e3x the true error of an exact model accurate to 1e-4 and a warning at a thousandth of
error_tolerance (`sphrom fmu` on this scene at N = 160).  Where every plane is computed the shadow keeps them all instead
(harness/rom/bounds.py build_shadow, ALL_PLANES, within the C core's limit on planes), and the reference sine that sizes it sits at half the first
*elastic* frequency, not at the rigid motion's decay rate.
"""

import numpy as np
import scipy.linalg as sla

from sphrom.scene import parse_scene

SCENE = """\
[domain]
L = 2.0
T = 0.002

[fields]
rho0 = "where(x < 1.2, 2700, 7850)"
c = "where(x < 1.2, 7.0e10, 2.1e11)"
d = "20 + 80*x/L"

[force]
f = "5e3*sin(2*pi*600*t)*(1 - exp(-t/2e-3))"
profile = "exp(-((x - 0.5)/0.05)**2)"

[sph]
n_particles = 120
"""
PROBES = (0.25, 0.5, 0.66)
H = 1e-5                     # communication step [s]
STEPS = 400


def problem():
    from sphrom.sph.solver import build_problem
    return build_problem(parse_scene(SCENE, "hammer.toml", name="hammer"))


def exact_rows(problem, rows, f, h=H):
    """The full linear SPH's ``rows`` at t = j h under f held over each step from rest, exact in time."""
    from sphrom.rom.bounds import input_columns
    from sphrom.rom.lti import full_linear_system
    n = problem.n
    M = np.zeros((2 * n + 1, 2 * n + 1))
    M[:2 * n, :2 * n] = full_linear_system(problem, list(PROBES)).A.toarray() * h
    M[:2 * n, 2 * n] = input_columns(problem)[:, 0] * h
    E = sla.expm(M)
    x, out = np.zeros(2 * n), []
    for fj in f:
        out.append(rows @ x)
        x = E[:2 * n, :2 * n] @ x + E[:2 * n, 2 * n] * fj
    out.append(rows @ x)
    return np.array(out)


def test_the_reference_sine_sits_at_half_the_first_elastic_frequency():
    """A damping that varies along the bar gives the rigid motion real eigenvalues (|λ| ~ d); the reference sine's
    angular frequency is half the smallest |Im λ| of the full linear SPH's A (numpy's eigenvalues, an independent
    path), within 1e-9."""
    from sphrom.rom.bounds import build_shadow
    from sphrom.rom.lti import full_linear_system
    p = problem()
    lam = np.linalg.eigvals(full_linear_system(p, list(PROBES)).A.toarray())
    real = lam[np.abs(lam.imag) <= 1e-9 * np.abs(lam).max()]
    assert np.abs(real).max() >= 0.5 * float(np.min(p.d))          # the premise: the rigid motion decays, |λ| ~ d
    elastic = np.abs(lam.imag)[np.abs(lam.imag) > 1e-9 * np.abs(lam).max()]
    shadow = build_shadow(p, PROBES)
    assert abs(shadow.info["omega_ref"] - 0.5 * elastic.min()) <= 1e-9 * elastic.min()
    assert shadow.info["omega_ref"] > 10 * float(np.max(p.d))      # not the rigid motion's decay (|λ| ~ d)


def test_the_shadow_keeps_every_plane_and_the_bound_is_the_true_error():
    """Where the largest cut's complement is a sizeable part of the in-band response, the shadow keeps every plane:
    under the scene's own force its rows are the exact-in-time truth (within 1e-9 of their largest) and their
    certified error stays at round-off; the bound of a model (here a 6-plane shadow, an accurate stand-in) is then
    its true error within 1e-6 of the signal, effectivity 1."""
    from sphrom.rom.bounds import ALL_PLANES_ABOVE, build_shadow, output_rows, run_shadow
    p = problem()
    shadow = build_shadow(p, PROBES)
    assert shadow.info["criterion"][max(shadow.info["criterion"])] > ALL_PLANES_ABOVE   # the premise of the case
    t = np.arange(STEPS) * H
    f = np.asarray(p.scene.force(t), float) * np.ones(STEPS)
    C = output_rows(p, PROBES)[0]
    truth = exact_rows(p, C, f)
    y, cert = run_shadow(shadow, np.full(STEPS, H), f[:, None], np.zeros((STEPS, 1)))
    P = len(PROBES)
    scale = np.abs(truth[:, :P]).max()
    assert np.abs(y[:, :P] - truth[:, :P]).max() <= 1e-9 * scale
    assert cert[:, :P].max() <= 1e-8 * scale
    model, _ = run_shadow(build_shadow(p, PROBES, order=6), np.full(STEPS, H), f[:, None], np.zeros((STEPS, 1)))
    error = np.abs(model[:, :P] - truth[:, :P])
    bound = np.abs(model[:, :P] - y[:, :P]) + cert[:, :P]
    assert np.all(error <= bound)
    assert error.max() > 1e-4 * scale                              # the stand-in model has an error to bound
    assert np.abs(bound - error).max() <= 1e-6 * scale


def test_every_plane_stays_within_what_the_c_core_loads():
    """The shadow keeps every plane only up to the C core's limit on its planes (MAX_SHADOW_PLANES of the resource
    layout): a rubber bar of 1083 particles with a local damping kept 1083 when the limit was the modes' 1024, and
    its FMU did not instantiate."""
    from sphrom.fmu.layout import LIMITS
    from sphrom.rom.bounds import ALL_PLANES, MAX_PLANES, PORT_ALL_PLANES
    assert max(ALL_PLANES, MAX_PLANES, PORT_ALL_PLANES) <= LIMITS["MAX_SHADOW_PLANES"][0]
