"""The scalable (Fourier-modal) path of the balanced models and the certified bounds agrees with the dense one."""

import numpy as np
import pytest

from sphrom.rom import modal
from sphrom.rom.balanced import balancing, error_bounds, truncate
from sphrom.rom.lti import full_linear_system
from sphrom.sph.solver import build_problem

from conftest import small_scene

N = 32


def _lti(base, **kw):
    return full_linear_system(build_problem(small_scene(base, n=N, **kw)))


def _transfer(red, omegas, row=0, col=0):
    r = red.Ar.shape[0]
    return np.array([red.Cr[row] @ np.linalg.solve(1j * w * np.eye(r) - red.Ar, red.Br[:, col]) for w in omegas])


@pytest.mark.parametrize("base, kw, bounds", [
    ("damped_forced", {"T": 2.0, "profile": "1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)"}, True),     # bt
    ("multimode", {"T": 1.0}, False),                                                           # galerkin (d = 0)
])
def test_modal_path_equals_the_dense_one_when_it_keeps_every_mode(base, kw, bounds):
    lti = _lti(base, **kw)
    dense = balancing(lti, structure="dense")
    mod = balancing(lti, structure="modal")               # K = (N - 2)/2: every mode but the alternating one
    assert mod.basis is not None and mod.system.order == 2 * (N - 1)
    # to the round-off of the Gramians' square-root factors (eigh of P: sqrt(eps) of |P| in the small values)
    assert np.allclose(mod.hsv[:10], dense.hsv[:10], rtol=0, atol=1e-6 * dense.hsv[0])
    r = 6
    rd, rm = truncate(lti, dense, r), truncate(lti, mod, r)
    assert rm.V.shape == (lti.order, r)                   # lifted to the particles
    w = np.geomspace(0.1, 50, 7)
    for col in (0, 1):                                    # the transfer functions (invariant under a change of basis),
        gd, gm = _transfer(rd, w, col=col), _transfer(rm, w, col=col)     # to the Gramians' round-off (above)
        assert np.allclose(gm, gd, rtol=0, atol=1e-4 * np.max(np.abs(gd)) + 1e-14)
    if not bounds:                                        # (the undamped bounds' bisection: 30 s, in the bench)
        return
    bd = error_bounds(lti, rd, structure="dense")
    bm = error_bounds(lti, rd, structure="modal")
    # the initial-state error is the same exact computation but for the dropped (alternating) mode, whose part
    # is the tail: they differ by at most the tail (triangle inequality), to round-off of the output energies
    scale = float(np.max(bd["full_output_norm"]))
    gap = np.abs(bm["initial_state_error"] - bd["initial_state_error"])
    assert np.all(gap <= bm["initial_state_tail"] + 1e-6 * scale)
    assert np.all(bm["initial_state_error_bound"] >= bd["initial_state_error"])
    # both force bounds are certified upper ends: each is above the other's lower end
    assert np.all(bm["force_error_bound"] >= bd["factor"] * bd["hinf"][:, 0] * (1 - 1e-6))
    assert np.all(bd["force_error_bound"] >= bm["factor"] * bm["hinf"][:, 0] * (1 - 1e-6))


def test_tail_bounds_hold_with_few_modes():
    """With K = 4 of 15 wavenumbers the bound is the intermediate's plus the dropped modes' tail, and it stays above
    the error of the full system computed densely."""
    lti = _lti("damped_forced", T=2.0, profile="1 + sin(2*pi*x/L) + cos(10*pi*x/L) + sin(18*pi*x/L)")
    red = truncate(lti, balancing(lti, structure="dense"), 6)
    dense = error_bounds(lti, red, structure="dense")
    ms = modal.modal_system(lti, wavenumbers=4)
    b = modal.error_bounds(lti, red, error_bounds, ms=ms)
    assert np.all(b["force_tail"] > 0) and np.all(b["initial_state_tail"] > 0)
    assert np.all(b["initial_state_error_bound"] >= dense["initial_state_error"])
    assert np.all(b["force_error_bound"] >= dense["hinf"][:, 0] * dense["factor"])
    # the tail's H∞ bound is above the dropped part's response sampled on a fine grid (dense solves)
    A = lti.dense()
    V = ms.basis
    P = V @ V.T                                                        # projector on the kept modes
    rows = np.arange(lti.n_probes)
    for w in np.concatenate([np.linspace(0, 40, 161), np.abs(ms.s * ms.g[ms.dropped].imag)]):
        x = np.linalg.solve(1j * w * np.eye(lti.order) - A, lti.B[:, 0])
        tail = np.abs(lti.C[rows] @ (x - P @ x))
        assert np.all(tail <= b["force_tail"] * (1 + 1e-9))


def test_modal_structure_choices():
    lti = _lti("damped_forced", T=1.0)
    assert not modal.applies(lti) and modal.applies(lti, "modal")     # auto: dense up to N = 1000
    with pytest.raises(ValueError, match="structure"):
        modal.applies(_lti("heterogeneous", T=1.0), "modal")          # a jump in c: not circulant
    with pytest.raises(ValueError, match="structure"):
        modal.applies(lti, "fft")


@pytest.mark.parametrize("base", ["damped_forced", "multimode"])
def test_free_outputs_through_every_mode_equal_the_dense_exponential(base):
    from sphrom.rom.lti import sample_outputs
    lti = _lti(base, T=1.0)
    ms = modal.modal_system(lti, wavenumbers=4)
    h, k = 1e-3, 1000
    y = sample_outputs(lti.dense(), None, lti.C[:3], lti.x0, h, np.zeros(k + 1))
    assert np.max(np.abs(modal.free_outputs(ms, np.arange(3), np.arange(k + 1) * h) - y)) <= 1e-12 * np.max(np.abs(y))
