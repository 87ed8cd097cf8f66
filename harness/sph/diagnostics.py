"""Invariants of the semi-discrete SPH system (eqs. 2.10-2.11).

With J_i = ρ_i(0)/ρ_i (the specific volume, eq. A.9) the system reads
J̇ = G v, ρ0 v̇ = G (c (J - 1)) - ρ0 d v + ρ0 f, and with an antisymmetric G
(a uniform periodic lattice) it conserves, when d = f = 0:

* total momentum  Σ m_i v_i        (Σ_i G_ij = 0),
* total length    Σ m_i / ρ_i      (= Σ Δx J_i),
* energy          Σ Δx [ρ0_i v_i²/2 + c_i (J_i - 1)²/2].

Each time integrator breaks the last two at its own order.
"""

import numpy as np


def momentum(mass, v):
    """Σ m_i v_i [kg m s^-1] per sample (v of shape (..., N))."""
    return np.asarray(v) @ mass


def total_length(mass, rho):
    """Σ m_i / ρ_i [m] per sample."""
    return (1.0 / np.asarray(rho)) @ mass


def energy(problem, v, rho):
    """Σ Δx [ρ0 v²/2 + c (J - 1)²/2] [J m^-2] per sample, J = ρ0/ρ."""
    dx = problem.neighbours.dx
    v = np.asarray(v)
    j = problem.rho0 / np.asarray(rho)
    return dx * (0.5 * (v**2) @ problem.rho0 + 0.5 * ((j - 1.0) ** 2) @ problem.c)
