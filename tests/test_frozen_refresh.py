"""The frozen model's refresh (eq. 2.23 projected): the tensor T symmetric in (a, b, p) bit for bit, equal to the
O(N k²) particle product to round-off; in the C core the tensor path and the path that keeps T by its symmetry
give the same bits, and so do a run that skips refreshes of unchanged inputs (at rest) and one that refreshes
every time."""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.models import reduced_model
from sphrom.fmu.resources import pack
from sphrom.fmu.run.core import Core
from sphrom.rom.operators import pair_index, refresh_tensor


def test_tensor_is_symmetric_bit_for_bit_and_equals_the_particle_product():
    rng = np.random.default_rng(7)
    n, k_r, k_v = 60, 5, 4
    U, GU, inv_rho0 = rng.standard_normal((n, k_r)), rng.standard_normal((n, k_v)), 1.0 / (1.0 + rng.random(n))
    T = refresh_tensor(U, GU, inv_rho0)
    index = {tuple(pair): i for i, pair in enumerate(pair_index(k_r))}
    w = lambda a, b: 1.0 if a == b else 2.0                                  # noqa: E731
    for (a, b), i in index.items():
        for p in range(k_r):
            x, y, z = sorted((a, b, p))
            assert np.array_equal(T[i, p], w(a, b) * (T[index[(x, y)], z] / w(x, y)))
    a_rho = rng.standard_normal(k_r)
    M = sum(a_rho[a] * a_rho[b] * T[i] for (a, b), i in index.items())
    rho = U @ a_rho
    direct = U.T @ ((rho * rho * inv_rho0)[:, None] * GU)                   # M = U^ρᵀ diag(ρ²/ρ0) G U^v
    assert np.max(np.abs(M - direct)) <= 1e-13 * np.max(np.abs(direct))


@pytest.fixture(scope="module")
def model():
    scene = small_scene("damped_forced", T=0.5, n=32)
    data, *_ = reduced_model(scene, 6, 10, [0.5], "euler", progress=False)
    core = Core(ensure_binaries().core)
    m = core.load(pack(data))
    yield m
    m.close()


def run(model, *, path, skip, scale, n_freeze, steps=3000):
    """The reduced state after ``steps`` internal steps under f = 0.05 sin(0.7 j) per block of 10 steps."""
    model.set_refresh(path=path, skip=skip)
    model.reset()
    model.set_initial_state_scale(scale)
    model.set_n_freeze(n_freeze)
    for j in range(steps // 10):
        model.set_input(0.0 if scale == 0.0 else 0.05 * np.sin(0.7 * j))
        model.advance(10)
    return model.reduced_state().view(np.uint64)


@pytest.mark.parametrize("scale", [1.0, 0.0])
def test_c_refresh_paths_and_skip_give_the_same_bits(model, scale):
    reference = run(model, path="tensor", skip=False, scale=scale, n_freeze=1)
    for path in ("tensor", "symmetric"):
        for skip in (False, True):
            assert np.array_equal(run(model, path=path, skip=skip, scale=scale, n_freeze=1), reference)
    assert np.array_equal(run(model, path="symmetric", skip=True, scale=scale, n_freeze=7),
                          run(model, path="tensor", skip=False, scale=scale, n_freeze=7))


def test_refresh_setter_names_the_problem(model):
    from sphrom.fmu.run.core import CoreError
    with pytest.raises(KeyError):
        model.set_refresh(path="sideways")
    with pytest.raises(CoreError, match="no particle sections"):      # this model keeps the tensor
        model.set_refresh(path="particles")
    assert model.core.lib.rom_frozen_set_refresh(model.model, 0, 2, model._msg, 1024) != 0
    assert b"allowed: path -1, 0, 1 (no particle sections); skip -1, 0, 1" in model._msg.value
