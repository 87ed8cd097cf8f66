"""The cubic-spline kernel (eqs. 2.6-2.7) and the appendix-B derivative factors."""

import numpy as np
import pytest
from scipy.integrate import quad

from sphrom.sph.kernel import cubic_spline, cubic_spline_gradient
from sphrom.sph.operator import build_neighbours, derivative_factor, gradient_symbol, particle_positions


@pytest.mark.parametrize("h", [0.013, 0.5, 2.0])
def test_kernel_normalised_and_compact(h):
    total, _ = quad(lambda r: float(cubic_spline(r, h)), -2 * h, 2 * h, points=[-h, 0.0, h])
    assert total == pytest.approx(1.0, abs=1e-12)
    r = np.array([2 * h, 2.0001 * h, 3 * h, -2 * h, -5 * h])
    assert np.all(cubic_spline(r, h) == 0) and np.all(cubic_spline_gradient(r, h) == 0)
    assert cubic_spline(0.0, h) == pytest.approx(2 / (3 * h))


def test_gradient_is_derivative_of_kernel():
    h = 0.7
    r = np.linspace(-1.6, 1.6, 301)
    eps = 1e-6
    numeric = (cubic_spline(r + eps, h) - cubic_spline(r - eps, h)) / (2 * eps)
    np.testing.assert_allclose(cubic_spline_gradient(r, h), numeric, atol=1e-8)
    assert np.all(cubic_spline_gradient(r[r > 0], h) <= 0)          # odd, negative for r > 0


@pytest.mark.parametrize("alpha, paper", [(1.04, 1.003), (1.2, 1.022)])
def test_appendix_b_factor_measured_on_a_sine(alpha, paper):
    """G sin(κx) / (κ cos(κx)) -> 1 + ε of eq. B.5 as κΔx -> 0."""
    L, n = 1.0, 4000
    x = particle_positions(L, n)
    nb = build_neighbours(x, L, alpha * L / n, np.full(n, L / n))
    kappa = 2 * np.pi
    measured = nb.apply(np.sin(kappa * x)) / (kappa * np.cos(kappa * x))
    mask = np.abs(np.cos(kappa * x)) > 0.5
    factor = float(np.median(measured[mask]))
    assert factor == pytest.approx(paper, abs=6e-4)                   # the paper's 3 digits
    b4 = 8 * alpha**-2 - 12 * alpha**-3 + 5 * alpha**-4               # eq. B.4
    assert factor == pytest.approx(b4, rel=1e-5)
    assert derivative_factor(alpha) == pytest.approx(b4, rel=1e-12)


def test_dispersion_term_of_eq_b5():
    """The κ² term of the symbol: D(κ)/κ = (1+ε) - ε̃ κ²Δx² + O(κ⁴Δx⁴), ε̃ = 0.173 at α = 1.04."""
    L, n, alpha = 1.0, 100, 1.04
    nb = build_neighbours(particle_positions(L, n), L, alpha * L / n, np.full(n, L / n))
    sym = gradient_symbol(nb, L)
    dx = L / n
    kd = np.array([0.02, 0.04])
    ratio = sym(kd / dx) / (kd / dx)
    slope = (ratio[0] - ratio[1]) / (kd[1] ** 2 - kd[0] ** 2)
    assert slope == pytest.approx(0.173, abs=2e-3)


def test_neighbour_lists_are_periodic_and_antisymmetric():
    L, n = 2.0, 50
    x = particle_positions(L, n)
    nb = build_neighbours(x, L, 1.04 * L / n, np.full(n, L / n))
    g = nb.matrix().toarray()
    np.testing.assert_allclose(g, -g.T, atol=1e-14)                  # ∇W_ij = -∇W_ji
    assert np.count_nonzero(g[0]) == 4                               # 2 per side when 1 < α < 1.5
    assert g[0, n - 1] != 0 and g[0, n - 2] != 0                     # across the boundary
    np.testing.assert_allclose(g.sum(axis=0), 0.0, atol=1e-12)      # Σ_i ∇W_ij = 0: momentum
