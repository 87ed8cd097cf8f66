"""The sampled mass-spring loop of `sphrom bench error_bounds_ports` with the full SPH in the FMU's place
(sphrom.bench.lib.ports.loop_map): one step of the map equals the loop's parts stepped on their own (the bar by a
high-order ODE solver, the mass-spring by its exact step), and its spectral radius says whether the loop itself
runs away: above 1 on an undamped bar (the held force feeds it energy), at most 1 on a bar damped enough to
take that energy (d = 2 s^-1 here; d = 0.3 s^-1 is not).  The bench names
that radius where a coupled run stops, so a runaway loop is not read as a fault of the FMU."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sphrom.bench.lib.ports import STIFFNESS, loop_map, loop_radius, mass_spring_step
from sphrom.rom.bounds import input_columns, output_rows
from sphrom.rom.lti import full_linear_system
from sphrom.sph.solver import build_problem

from conftest import small_scene

H = 0.01
PORT = 0.3


def _problem(d):
    return build_problem(small_scene("high_frequency", T=0.5, n=40, d=d))


def test_the_map_is_one_step_of_the_loop():
    problem = _problem("0.3")
    Z = loop_map(problem, PORT, H)
    A = full_linear_system(problem, [0.5]).A
    b = input_columns(problem, (PORT,))[:, 1]
    c = output_rows(problem, [0.5], (PORT,))[0][-1]
    n2 = A.shape[0]
    rng = np.random.default_rng(3)
    state = rng.standard_normal(n2 + 2) * np.r_[np.full(n2, 1e-3), 1e-3, 1e-2]
    x, s, w = state[:n2], state[n2], state[n2 + 1]
    F = STIFFNESS * s                                          # the spring's force at the step's start, held
    bar = solve_ivp(lambda t, y: A @ y + b * F, (0.0, H), x, method="DOP853", rtol=1e-12, atol=1e-16).y[:, -1]
    mass = mass_spring_step(np.array([s, w]), float(c @ x), H)
    expected = np.concatenate([bar, mass])
    assert np.abs(Z @ state - expected).max() <= 1e-8 * np.abs(expected).max()


@pytest.mark.parametrize("d, runs_away", [("0", True), ("2.0", False)])
def test_the_radius_says_whether_the_loop_runs_away(d, runs_away):
    radius = loop_radius(_problem(d), PORT, H)
    if runs_away:
        assert radius > 1.0 + 1e-9
    else:
        assert radius <= 1.0 + 1e-9


def test_no_radius_above_the_dense_limit():
    assert loop_radius(_problem("0"), PORT, H, dense_limit=10) is None
