"""The band the communication step resolves, and the automatic mode count of a linear model.

- :func:`sphrom.fmu.check.verify.energy_band`: the frequency below which 99 % of the kinetic energy lies, in the bar's
  modes reduced to a basis: a motion in one mode of the bar is that mode's frequency, whatever else the basis
  holds; a mode carrying a thousandth of the energy does not raise it (the highest mode's frequency did); the step
  case's band of a profile along one mode is that mode's; the same relative to a bar's own time scale in SI units.
- :func:`sphrom.pod.automatic.automatic_modes`: a linear model (advanced exactly in time) takes the kinetic energy
  criterion's count up to the snapshots' rank and the strain count capped; a time-stepped one is capped (its refresh
  costs O(k^4)).
"""

import math

import numpy as np
import pytest

from sphrom.scene import parse_scene

SCENE = """\
[domain]
L = 1.0
T = {T!r}

[fields]
rho0 = "{rho!r}*(1 + 0.3*cos(2*pi*x/L))"
c = "{c!r}*where(x < 0.4*L, 1.0, 0.2)"
d = "0"
v0 = "0"

[force]
f = "0"
profile = "1"

[sph]
n_particles = 40
"""


def bar(time=1.0, rho=1.0):
    """A two-material bar whose wave time T' scales with ``time`` [s] (density ``rho`` [kg m^-3])."""
    return parse_scene(SCENE.format(T=2.0 * time, rho=rho, c=rho / time ** 2), "band.toml", name="band")


@pytest.fixture(scope="module")
def modes():
    """(problem, omega [rad/s] ascending, Phi (N, N) M-orthonormal) of the unit bar."""
    from sphrom.rom.inputs import bar_modes
    from sphrom.sph.solver import build_problem
    problem = build_problem(bar())
    w, Phi = bar_modes(problem)
    return problem, w, Phi


def test_one_mode_is_its_own_band_whatever_else_the_basis_holds(modes):
    from sphrom.fmu.check.verify import energy_band
    problem, w, Phi = modes
    j = 5
    samples = np.outer(np.sin(np.linspace(0.1, 3.0, 7)), Phi[:, j])       # v(t) = a(t) phi_j
    for U in (np.eye(Phi.shape[0]), Phi[:, :12], Phi[:, [1, j, 20]]):
        assert energy_band(problem, U, samples) == pytest.approx(w[j] / (2 * math.pi), rel=1e-6)


def test_a_high_mode_with_a_thousandth_of_the_energy_does_not_set_the_band(modes):
    from sphrom.fmu.check.verify import energy_band
    from sphrom.rom.inputs import band
    problem, w, Phi = modes
    low, high = 3, Phi.shape[0] - 2
    samples = np.vstack([Phi[:, low], math.sqrt(1e-3) * Phi[:, high]])      # energies 1 and 1e-3
    U = Phi[:, [low, high]]
    assert energy_band(problem, U, samples) == pytest.approx(w[low] / (2 * math.pi), rel=1e-6)
    assert band(problem, U)[1] == pytest.approx(w[high], rel=1e-6)            # the highest mode's frequency
    assert energy_band(problem, U, samples, fraction=0.9999) == pytest.approx(w[high] / (2 * math.pi), rel=1e-6)


def test_the_step_case_band_of_a_profile_along_one_mode(modes):
    from sphrom.fmu.check.verify import energy_band
    problem, w, Phi = modes
    j = 4
    at_rest = np.zeros((3, Phi.shape[0]))
    assert energy_band(problem, np.eye(Phi.shape[0]), at_rest) == 0.0          # no motion, no band
    assert energy_band(problem, np.eye(Phi.shape[0]), at_rest, profile=Phi[:, j], horizon=2.0) == pytest.approx(
        w[j] / (2 * math.pi), rel=1e-6)
    # a rigid profile (a uniform force on a free bar) moves it rigidly: the band is at 0, whatever round-off leaves
    # in the elastic modes
    assert energy_band(problem, np.eye(Phi.shape[0]), at_rest, profile=np.ones(Phi.shape[0]), horizon=2.0) <= (
        1e-6 * w[-1])
    # a rigid motion in the training samples counts at frequency 0 too
    rigid = np.ones(Phi.shape[0]) + 1e-3 * Phi[:, j]
    assert energy_band(problem, np.eye(Phi.shape[0]), np.vstack([rigid, rigid])) <= 1e-6 * w[-1]


def test_the_band_scales_with_the_bars_own_time(modes):
    from sphrom.fmu.check.verify import energy_band
    from sphrom.sph.solver import build_problem
    problem, w, Phi = modes
    TIME, RHO = 1e-4, 7850.0
    steel = build_problem(bar(TIME, RHO))
    samples = np.vstack([Phi[:, 2] + 0.3 * Phi[:, 9], Phi[:, 6]])
    unit = energy_band(problem, Phi[:, :15], samples, profile=Phi[:, 7], horizon=2.0)
    assert energy_band(steel, Phi[:, :15], samples / TIME, profile=Phi[:, 7] / TIME ** 2,
                       horizon=2.0 * TIME) * TIME == pytest.approx(unit, rel=1e-6)


def basis_with(sigma_v, sigma_e):
    """A Basis whose energy-weighted singular values are ``sigma_v`` (velocity) and ``sigma_e`` (specific volume)."""
    from sphrom.pod.basis import Basis
    n = sigma_v.size
    U = np.eye(n)
    return Basis(U_v=U, U_rho=U, sigma_v=sigma_v, sigma_rho=sigma_e, steps_v=np.arange(n), steps_rho=np.arange(n),
                 x=np.linspace(0, 1, n, endpoint=False), dt=1.0, scene_text="", strategy="", U_ve=U, sigma_ve=sigma_v,
                 U_e=U, sigma_e=sigma_e)


def left_out(sigma, k):
    """The fraction of the energy sum sigma^2 that the first k modes leave out."""
    energy = sigma ** 2 / np.sum(sigma ** 2)
    return float(np.sum(energy[k:]))


def test_a_linear_model_takes_the_velocity_count_uncapped_a_time_stepped_one_is_capped():
    from sphrom.pod.automatic import ENERGY_LEFT_OUT, MAX_AUTO_MODES, automatic_modes
    slow, fast = 0.9 ** np.arange(120), 0.1 ** np.arange(120)     # slow decay: more modes than the cap
    k_lin, text_lin = automatic_modes(basis_with(slow, fast), linear=True)
    k_step, text_step = automatic_modes(basis_with(slow, fast))
    assert left_out(slow, k_lin) <= ENERGY_LEFT_OUT < left_out(slow, k_lin - 1)   # the velocity criterion, no fewer
    assert k_step <= MAX_AUTO_MODES < k_lin <= slow.size
    assert "capped" in text_step and f"a linear model: max(k_v, min(k_e + 1, {MAX_AUTO_MODES})) = {k_lin}" in text_step
    # a strain energy spread over many modes (a uniform force on a two-material bar) stays capped
    k_strain = automatic_modes(basis_with(fast, slow), linear=True)[0]
    assert k_strain <= MAX_AUTO_MODES and left_out(fast, k_strain) <= ENERGY_LEFT_OUT
    # fast decay everywhere: both the same count, below the cap
    assert automatic_modes(basis_with(fast, fast), linear=True)[0] == automatic_modes(basis_with(fast, fast))[0] < (
        MAX_AUTO_MODES)
