"""The sampled mass-spring loop of `sphrom bench error_bounds_ports` with the full SPH in the FMU's place
(sphrom.bench.lib.ports.loop_map): one step of the map equals the loop's parts stepped on their own (the bar by a
high-order ODE solver, the mass-spring by its exact step), and its spectral radius says whether the loop itself
runs away: above 1 on an undamped bar (the held force feeds it energy), at most 1 on a bar damped enough to
take that energy (d = 2 s^-1 here; d = 0.3 s^-1 is not).  The bench names
that radius where a coupled run stops, so a runaway loop is not read as a fault of the FMU."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sphrom.bench.lib.ports import MASS, STIFFNESS, coupling_force, loop_map, loop_radius, mass_spring_step
from sphrom.rom.bounds import input_columns, output_rows
from sphrom.rom.lti import full_linear_system
from sphrom.sph.solver import build_problem

from conftest import small_scene

H = 0.01
PORT = 0.3


def _problem(d):
    return build_problem(small_scene("high_frequency", T=0.5, n=40, d=d))


@pytest.mark.parametrize("damping", [0.0, 0.1])
def test_the_map_is_one_step_of_the_loop(damping):
    problem = _problem("0.3")
    Z = loop_map(problem, PORT, H, damping)
    A = full_linear_system(problem, [0.5]).A
    b = input_columns(problem, (PORT,))[:, 1]
    c = output_rows(problem, [0.5], (PORT,))[0][-1]
    n2 = A.shape[0]
    rng = np.random.default_rng(3)
    state = rng.standard_normal(n2 + 2) * np.r_[np.full(n2, 1e-3), 1e-3, 1e-2]
    x, s, w = state[:n2], state[n2], state[n2 + 1]
    F = coupling_force((s, w), float(c @ x), damping)          # the force at the step's start, held
    bar = solve_ivp(lambda t, y: A @ y + b * F, (0.0, H), x, method="DOP853", rtol=1e-12, atol=1e-16).y[:, -1]
    mass = mass_spring_step(np.array([s, w]), float(c @ x), H, damping)
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


def test_the_damped_lumped_step_is_exact():
    """The mass-spring-damper's step against a high-order ODE solver: m s'' = -K s - c s', w = s' + v_port."""
    s, w, v_port, damping = 1e-3, 2e-3, -5e-4, 0.1
    rhs = lambda t, y: [y[1], -(STIFFNESS * y[0] + damping * y[1]) / MASS]
    s_end, ds_end = solve_ivp(rhs, (0.0, H), [s, w - v_port], method="DOP853", rtol=1e-13, atol=1e-18).y[:, -1]
    got = mass_spring_step(np.array([s, w]), v_port, H, damping)
    assert np.allclose(got, [s_end, ds_end + v_port], rtol=1e-10, atol=1e-15)


@pytest.mark.parametrize("d", ["0", "0.3"])
def test_a_dashpot_keeps_the_loop_of_an_undamped_bar(d):
    """The bench's mass-spring-damper case (DAMPER): the loop that ran away without the dashpot holds."""
    from sphrom.bench.error_bounds_ports import DAMPER
    problem = _problem(d)
    assert loop_radius(problem, PORT, H) > 1.0 + 1e-9
    assert loop_radius(problem, PORT, H, DAMPER) <= 1.0 + 1e-9
