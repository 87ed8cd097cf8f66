"""Mechanical ports: point forces F_j [N] spread by the SPH kernel, port velocities Σ_i W(x_i - x_j, h) v_i Δx.

The full SPH with port forces (:mod:`harness.sph.ports`), the reduced models that take them as inputs (frozen,
exact), the FMU's F_port_j / v_port_j / area against those models, and a coupled example (the FMU and a lumped
mass-spring exchanging force and velocity each communication step) against one full SPH of the coupled system.
"""

import numpy as np
import pytest

from conftest import small_scene
from harness.errors import FieldError
from harness.sph.ports import momentum_weights, parse_ports, port_accelerations, port_velocity_rows, run_sph_ports
from harness.sph.solver import build_problem


def port_forces(t):
    """Two port forces [N] that no model was trained on."""
    t = np.atleast_1d(np.asarray(t, float))
    return 1e-3 * np.stack([np.sin(5 * t + 0.3), np.cos(2 * t) ** 2], axis=-1)


def test_port_force_changes_total_momentum_by_its_impulse():
    """d/dt Σ m_i v_i = Σ_j F_j S_j (m_i = ρ0 A Δx, S_j = Σ_i W_ij Δx): the SPH pressure conserves momentum, so
    with d = f = 0 the momentum gained over the run is the port impulse, to round-off (explicit Euler sums the
    forces at t_n exactly so), for any area A (the mass per length ρ0 A scales out); S_j is 1 to 1e-5."""
    scene = small_scene("multimode", T=0.5, n=32)
    problem = build_problem(scene)
    assert not problem.terms["damping"]
    ports = [0.1, 0.6]
    S = momentum_weights(problem, ports)
    assert np.all(np.abs(S - 1.0) < 1e-5)
    dt = scene.sph.dt
    n = int(round(scene.T / dt))
    impulse = dt * float(np.sum(port_forces(np.arange(n) * dt) @ S))
    for area in (1.0, 2.5):
        run = run_sph_ports(scene, ports, forces=lambda t: port_forces(t)[0], area=area, problem=problem, every=100)
        gained = run.momentum[-1] - run.momentum[0]
        assert abs(gained - impulse) <= 1e-12 * abs(impulse) + 1e-18
        assert abs(impulse) > 1e-5
    free = run_sph_ports(scene, ports, problem=problem, every=100)
    assert abs(free.momentum[-1] - free.momentum[0]) < 1e-18


def test_port_power_is_force_times_port_velocity():
    """Σ_i (ρ0 A Δx) v_i a_i = Σ_j F_j v_port_j: v_port is the velocity power-conjugate to F."""
    problem = build_problem(small_scene("multimode", T=0.5, n=32))
    ports = [0.2, 0.55]
    rng = np.random.default_rng(1)
    v, F, area = rng.normal(size=problem.n), rng.normal(size=2), 0.7
    a = F @ port_accelerations(problem, ports, area)
    power = float(np.sum(problem.rho0 * area * problem.neighbours.dx * v * a))
    assert power == pytest.approx(float(F @ (port_velocity_rows(problem, ports) @ v)), rel=1e-13)


@pytest.mark.parametrize("text", ["", "0.5,x", "1.0", "-0.1", "nan", "0.3,0.3", ",".join(["0.1"] * 9)])
def test_bad_ports_are_one_line_errors(text):
    with pytest.raises(FieldError, match="^ports: "):
        parse_ports(text)
