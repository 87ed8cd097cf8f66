"""The linear FMUs in their real eigen-coordinates: A block diagonal (1 x 1 and 2 x 2 blocks),
stepped block by block by the C core, equals the dense form of the same model; the transform's conditioning is
checked (the dense form kept where it is ill-conditioned); the core refuses a file whose A leaves its blocks."""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.kinds.linear import resource, to_blocks
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.resources import pack
from sphrom.fmu.run.core import Core, CoreError
from sphrom.rom.modal import BLOCK_CONDITION, real_blocks
from sphrom.sph.solver import build_problem

PROBES = [0.25, 0.5]


def run(core, blob, ports, steps=150, h=1e-3):
    """Probe v, rho and v_port at each of ``steps`` steps of h under a sine f and cosine port forces."""
    m = core.load(blob)
    try:
        m.set_initial_state_scale(1.0)
        rows = []
        for n in range(steps):
            m.set_input(np.sin(3 * n * h))
            if ports:
                m.set_port_forces([1e-2 * np.cos(5 * n * h)] * len(ports))
            m.do_step(n * h, h)
            v, rho = m.outputs(len(PROBES))
            rows.append(list(v) + list(rho) + (list(m.port_velocities()) if ports else []))
        return np.array(rows)
    finally:
        m.close()


@pytest.mark.parametrize("base,model,ports", [("multimode", "exact", (0.5,)), ("damped_forced", "exact", (0.3, 0.7)),
                                              ("damped_forced", "balanced", ())])
def test_block_form_equals_dense_form(base, model, ports):
    """Undamped (skew: rotations, the free response at t) and damped (real eigenvectors), with ports (the port
    channel's rows over the whole state) and without: every output of the block form equals the dense form's to
    1e-11 of its range over 150 steps; the transform is well conditioned here (kept)."""
    scene = small_scene(base, T=0.5, n=40)
    problem = build_problem(scene)
    core = Core(ensure_binaries(quiet=True).core)
    out = {}
    for blocks in (True, False):
        data, _, blob = resource(scene, model, 6 if model == "exact" else None, 1, PROBES, None, False, problem,
                                 bounds=False, ports=ports, build_options={"blocks": blocks}, error_bounds=False)
        assert data.blocks == blocks
        if blocks:
            assert 1.0 <= data.block_condition <= BLOCK_CONDITION
        out[blocks] = run(core, blob, ports)
    scale = np.abs(out[False]).max(axis=0)
    assert np.all(np.abs(out[True] - out[False]) <= 1e-11 * scale)


def test_real_blocks_reconstructs_a_and_refuses_a_defective_one():
    """A = V L V^-1 to round-off for a random damped A with real and complex eigenvalues, L block diagonal with
    [[a, w], [-w, a]] blocks; a near-defective A (a Jordan block perturbed by 1e-13) is not usable."""
    rng = np.random.default_rng(3)
    A = rng.standard_normal((7, 7)) - 2 * np.eye(7)
    rb = real_blocks(A)
    assert rb.usable
    assert np.allclose(rb.V @ rb.L @ rb.V_inv, A, rtol=0, atol=1e-12 * np.abs(A).max())
    i = 0
    for b in rb.sizes:
        block = rb.L[i:i + b, i:i + b]
        if b == 2:
            assert block[0, 0] == block[1, 1] and block[0, 1] == -block[1, 0] and block[0, 1] > 0
        mask = np.ones(7, bool)
        mask[i:i + b] = False
        assert not np.any(rb.L[i:i + b][:, mask])
        i += b
    jordan = np.array([[-1.0, 1.0, 0.0], [1e-13, -1.0, 1.0], [0.0, 0.0, -2.0]])
    assert not real_blocks(jordan).usable


def test_core_refuses_a_off_its_blocks():
    """A block-diagonal file whose A has an entry outside its blocks is refused at load with a message naming it."""
    scene = small_scene("damped_forced", T=0.5, n=40)
    problem = build_problem(scene)
    data, _, _ = resource(scene, "balanced", None, 1, PROBES, None, False, problem, bounds=False, error_bounds=False)
    data = to_blocks(data)
    assert data.blocks and data.k >= 3
    A = data.A.copy()
    A[0, data.k - 1] = 1e-3
    data.A = A
    with pytest.raises(CoreError, match="outside the blocks"):
        Core(ensure_binaries(quiet=True).core).load(pack(data))
