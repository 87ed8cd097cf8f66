"""The port channel (sphrom.rom.port_channel): the full linear SPH's response to the port forces in the singular
planes of its coupling, exact in time, its truncation's certified bound, and the wave form of the ports."""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.rom.bounds import output_rows
from sphrom.rom.port_channel import (ChannelState, build_channel, from_sections, probe_outputs, run_channel,
                                     sections, wave_forces)
from sphrom.rom.reference import linear_reference
from sphrom.sph.solver import build_problem

PROBES = (0.25, 0.5, 0.66)


def forces(t):
    t = np.atleast_1d(np.asarray(t, float))
    return 1e-3 * np.stack([np.sin(5 * t + 0.3), np.cos(2 * t) ** 2], axis=-1)


def truth_rows(problem, ports, t_end, step, hold, area):
    """The channel's rows of the full linear SPH integrated exactly in time (dense exponential of 2N states)."""
    P = len(ports)
    _, v, _, e = linear_reference(problem, ports, t_end, step, port_forces=lambda t: forces(t)[:, :P], hold=hold,
                                  state=False, area=area, specific_volume=True)
    C, _, _, _ = output_rows(problem, PROBES, ports)
    x = np.hstack([v * np.sqrt(problem.rho0), e * np.sqrt(problem.c)])
    return x @ C.T


@pytest.mark.parametrize("base", ["multimode", "damped_forced"])
@pytest.mark.parametrize("hold", ["held", "linear"])
def test_channel_is_the_full_linear_sph_exact_in_time(base, hold):
    """Every row (probe v, e at the probes' particles, port v) of the channel equals the full linear SPH under the
    same port forces (held or linear over each step) to round-off, undamped and damped, with an area; the channel
    keeps the planes the ports excite, and its certified bound is round-off."""
    problem = build_problem(small_scene(base, T=1.0, n=40))
    ports = (0.3, 0.7)
    ch = build_channel(problem, ports, PROBES)
    assert not ch.truncated and ch.planes == ch.info["excited"]
    t = np.arange(101) * 0.01
    got = run_channel(ch, t, lambda tt: forces(tt), area=2.0, hold=hold)
    want = truth_rows(problem, ports, 1.0, 0.01, hold, 2.0)
    scale = np.abs(want).max(axis=0)
    assert np.all(scale > 0)
    assert np.all(np.abs(got - want).max(axis=0) <= 1e-11 * scale)


def test_one_port_excites_one_plane_of_each_degenerate_pair():
    """On a uniform bar each wavenumber's cos and sin share a singular value; rotated within the pair, one plane
    carries the port's input and the other none, so one port keeps about half the planes, exactly (the response is
    the full one: test above), and two ports at other places need both."""
    problem = build_problem(small_scene("multimode", T=1.0, n=40))
    one, two = build_channel(problem, (0.5,), PROBES), build_channel(problem, (0.3, 0.7), PROBES)
    assert one.planes <= problem.n // 2 + 2 < two.planes
    t = np.arange(51) * 0.02
    got = probe_outputs(one, run_channel(one, t, lambda tt: forces(tt)[:, :1]))[2][:, 0]
    _, _, vp = linear_reference(problem, (0.5,), 1.0, 0.02, port_forces=lambda tt: forces(tt)[:, :1], state=False)
    assert np.abs(got - vp[:, 0]).max() <= 1e-11 * np.abs(vp).max()


@pytest.mark.parametrize("base", ["multimode", "damped_forced"])
def test_truncated_channel_is_certified_and_its_static_correction_helps(base):
    """Keeping fewer planes than the ports excite: the rows add the dropped planes' static correction (the e rows)
    and the certified bound covers the error at every communication point; under a slow force the static correction
    makes the e rows closer to the truth than the kept planes alone."""
    problem = build_problem(small_scene(base, T=2.0, n=40))
    ports = (0.3, 0.7)
    ch = build_channel(problem, ports, PROBES, max_planes=12)
    assert ch.truncated and np.any(ch.static != 0) and np.all(ch.gain >= 0)
    t = np.arange(201) * 0.01
    want = truth_rows(problem, ports, 2.0, 0.01, "held", 1.0)
    state = ChannelState(ch)
    bare = ChannelState(ch)
    F = forces(t)
    worst = 0.0
    static_err, bare_err = [], []
    for n in range(t.size - 1):
        state.fmu_step(0.01, F[n])
        bare.fmu_step(0.01, F[n])
        got, cert = state.rows(F[n]), state.cert()
        assert np.all(np.abs(got - want[n + 1]) <= cert)
        worst = max(worst, float(np.max(np.abs(got - want[n + 1]) / np.maximum(cert, 1e-300))))
        e_rows = slice(len(PROBES), 3 * len(PROBES))
        static_err.append(np.abs(got - want[n + 1])[e_rows])
        bare_err.append(np.abs(bare.rows(np.zeros(2)) - want[n + 1])[e_rows])
    assert 0 < worst <= 1
    assert np.linalg.norm(static_err) < np.linalg.norm(bare_err)


def test_sections_round_trip():
    problem = build_problem(small_scene("damped_forced", T=1.0, n=24))
    ch = build_channel(problem, (0.2, 0.6), PROBES, max_planes=10)
    back = from_sections({**sections(ch), "PORTX": np.array([[0.2, 0.6]])})
    for name in ("lam", "beta", "rows", "static", "gain", "pw", "prho0"):
        assert np.array_equal(getattr(back, name), getattr(ch, name)), name
    assert back.dx == ch.dx and back.truncated == ch.truncated and back.ports == ch.ports


def test_no_channel_where_the_planes_are_not_invariant():
    """A damping that varies along the bar couples the planes: no channel (the ports go into the basis as before)."""
    problem = build_problem(small_scene("damped_forced", T=1.0, n=24, d="4 + 3*sin(2*pi*x/L)"))
    assert build_channel(problem, (0.3,), PROBES) is None


@pytest.mark.parametrize("base", ["multimode", "damped_forced"])
def test_wave_form_is_passive_at_any_step(base):
    """The wave form with a mass on each port through a transmission line of impedance Z (the master's digital
    waveguide: each side's reflected wave b = a - F arrives at the other one step later): the total energy (bar,
    masses, the waves in the line) never grows, at steps from 1 ms to 50 ms, undamped and damped; the held force's
    work over a step equals (a² - b²) h / Z exactly, and the forces at the line's two ends are opposite at rest."""
    problem = build_problem(small_scene(base, T=2.0, n=40))
    ports = (0.3, 0.7)
    ch = build_channel(problem, ports, PROBES)
    mass, Z = 0.05, 0.5
    for h in (1e-3, 1e-2, 5e-2):
        state = ChannelState(ch)
        w = np.array([0.3, -0.2])                   # the masses' velocities
        a_bar = np.zeros(2)                         # the waves arriving at the bar and at the masses
        a_mass = np.array([0.01, -0.02])
        energies = []
        for _ in range(int(round(2.0 / h))):
            F = wave_forces(state, h, a_bar, Z, 1.0)
            mean = state.fmu_step(h, F, impedance=0.0)
            b_bar = a_bar - F
            assert np.allclose(h * F * mean, h * (a_bar ** 2 - b_bar ** 2) / Z, rtol=1e-9, atol=1e-18)
            Fm = (2 * a_mass - Z * w) / (1 + Z * h / (2 * mass))   # the mass side: held force, exact mean velocity
            w_mean = w + Fm * h / (2 * mass)
            w = w + Fm * h / mass
            b_mass = a_mass - Fm
            a_bar, a_mass = b_mass, b_bar
            line = h / Z * float(np.sum(a_bar ** 2 + a_mass ** 2))
            energies.append(state.energy() + 0.5 * mass * float(w @ w) + line)
            assert np.all(np.isfinite(w_mean))
        energies = np.array(energies)
        assert np.all(np.diff(energies) <= 1e-12 * energies[0]), (h, np.diff(energies).max())


def test_the_channel_writes_pcscal_in_the_layout_columns():
    """rom.port_channel writes and reads section PCSCAL by the names of the one layout (fmu.layout), kept apart so that
    rom does not import fmu."""
    from sphrom.fmu.layout import SECTIONS
    from sphrom.rom.port_channel import PCSCAL_COLUMNS
    assert SECTIONS["PCSCAL"].columns == PCSCAL_COLUMNS
