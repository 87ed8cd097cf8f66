"""Packaging measures every input channel (harness/fmu/check/channels.py): f and each port force, constant, slow
and in band, and each port closed by a spring-mass-damper, against the full SPH.

On a small damped bar with two ports the exact FMU follows the full SPH on every case within 2e-2 (the
assertion's message prints each case's error), the coupled case included (its error holds the co-simulation's
coupling error at 10 ms steps, so the coupled error is not zero).  The spring-mass-damper stepped exactly equals its closed form; its
parameters follow the bar.
"""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.check.channels import measure_channels, smd_parameters, smd_step
from sphrom.fmu.make.package import package_fmu
from sphrom.sph.solver import build_problem

PORTS = (0.3, 0.7)


@pytest.fixture(scope="module")
def exact_port_fmu(tmp_path_factory):
    scene = small_scene("damped_forced", T=2.0, n=48)
    path = tmp_path_factory.mktemp("channels") / "exact-ports.fmu"
    package_fmu(scene, path, progress=False, ports=list(PORTS), model="exact", bounds=False, error_bounds=False)
    return scene, path


def test_every_channel_of_a_port_fmu(exact_port_fmu):
    scene, path = exact_port_fmu
    cases = measure_channels(path, scene, ports=PORTS)
    got = {(c.channel, c.case): c for c in cases}
    expected = {("f", case) for case in ("constant", "slow", "in band")}
    expected |= {(f"F_port_{j}", case) for j in (1, 2) for case in ("constant", "slow", "in band", "coupled")}
    assert set(got) == expected
    for key, c in got.items():
        assert np.isfinite(c.err) and c.err < 2e-2, (key, c.err, c.note)
    assert got[("F_port_1", "coupled")].err > 1e-4          # the coupling's own error is there: not a copy


def test_the_spring_mass_damper_step_is_its_closed_form():
    """s'' + (c/m) s' + (k/m) s = 0 with the port at rest: the exact step against the underdamped closed form."""
    m, k, c = 0.2, 30.0, 0.4
    y, h, t = np.array([1e-3, 0.0]), 0.01, 0.0
    wn, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta ** 2)
    for _ in range(300):
        y = smd_step(y, 0.0, h, m, k, c)
        t += h
    s = 1e-3 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert y[0] == pytest.approx(s, rel=1e-9, abs=1e-15)


def test_the_coupled_case_parameters_follow_the_bar():
    scene = small_scene("damped_forced", T=2.0, n=48)
    problem = build_problem(scene)
    m, k, c, s0 = smd_parameters(scene, problem, 0.01)
    bar = float(np.sum(problem.rho0) * problem.neighbours.dx)
    assert m == pytest.approx(0.1 * bar)
    assert c == pytest.approx(0.2 * np.sqrt(k * m))                  # 10 % of critical
    assert s0 > 0 and k > 0
