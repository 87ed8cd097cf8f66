"""The port channel's outputs are computed once per step and kept (fmu_src/rom_port.c: the rows, the density shifts,
the rows' bounds and the model's own v_port at the step's end): reading them any number of times, or never, changes
nothing, and whatever moves the state (a step, initial_state_scale, a restored FMU state) is read anew.  The
equalities are exact: the same arithmetic on the same state (an exact round trip), whatever the CPU."""

import numpy as np

from sphrom.fmu.run.driver import FMU
from sphrom.fmu.variables import vr

H = 1e-3                                       # the communication step [s]
F_PORT = [vr("F_port_j", j) for j in (1, 2)]


def port_forces(t):
    """Two smooth port forces [N] at time t [s]."""
    return [2e-3 * np.sin(2 * np.pi * 7 * t), -1e-3 * np.cos(2 * np.pi * 3 * t)]


def outputs(s):
    """Every output of the FMU: the model's (v_probe, rho_probe, v_port) and their certified error bounds."""
    names = list(s.model_outputs) + sorted(n for n in s.vr if n.endswith("_error_bound"))
    return s.get_real([s.vr[n] for n in names])


def run(s, n0, n1, read):
    """Steps n0 .. n1 - 1 of H with the port forces set before each; every output read twice after each step when
    ``read``."""
    for n in range(n0, n1):
        s.set_input(1e-3 * np.sin(2.0 * n * H))
        s.set_real(F_PORT, port_forces(n * H))
        s.do_step(n * H, H)
        if read:
            outputs(s)
            outputs(s)


def test_reading_every_step_or_never_gives_the_same_run(channel_port_fmu):
    path, _ = channel_port_fmu
    ends = []
    for read in (True, False):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            run(s, 0, 60, read)
            ends.append(outputs(s))
    assert np.all(np.isfinite(ends[0]))
    assert np.array_equal(ends[0], ends[1])


def test_a_restored_state_is_read_anew(channel_port_fmu):
    path, _ = channel_port_fmu
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        run(s, 0, 20, True)
        state = s.get_state()
        saved = outputs(s)
        run(s, 20, 21, False)
        next_step = outputs(s)
        run(s, 21, 40, True)
        assert not np.array_equal(outputs(s), saved)            # the state moved on
        s.set_state(state)
        assert np.array_equal(outputs(s), saved)
        run(s, 20, 21, False)                                     # the step from the restored state: as before
        assert np.array_equal(outputs(s), next_step)
        s.free_state(state)


def test_initial_state_scale_set_after_a_read_is_read_anew(channel_port_fmu):
    """v_port read at the scene's initial state (its model part kept), then initial_state_scale changed before the
    first step: the outputs are those of an FMU set up with that scale from the start."""
    path, _ = channel_port_fmu
    scale = vr("initial_state_scale")
    fresh = []
    with FMU(path) as s:
        s.fmu.setupExperiment(startTime=0.0)
        s.set_real([scale], [1.0])
        s.fmu.enterInitializationMode()
        at_one = outputs(s)
        s.set_real([scale], [0.5])
        s.fmu.exitInitializationMode()
        fresh.append(outputs(s))
        run(s, 0, 5, False)
        fresh.append(outputs(s))
    with FMU(path) as s:
        s.initialize(initial_state_scale=0.5)
        assert np.array_equal(outputs(s), fresh[0])
        assert not np.array_equal(at_one, fresh[0])
        run(s, 0, 5, False)
        assert np.array_equal(outputs(s), fresh[1])
