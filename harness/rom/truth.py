"""The truth an FMU is measured against: the full SPH linear in J, integrated exactly in time.

In the specific volume J = ρ0/ρ the full SPH of eqs. 2.10-2.11 is exactly linear (:mod:`sphrom.rom.lti`,
energy coordinates x = [√ρ0 v; √c e], ẋ = A x + b f); the certified error bounds bound the distance to it
(docs/science/error-bounds.md), and packaging's verification (:mod:`sphrom.fmu.check.verify`) measures every FMU against it, driven by
the very input the FMU gets: f at the communication points, held over each step, or linear to the next point where
the FMU takes input derivatives.  No time step of the truth's own enters: each communication step h is the exact
map of the input-augmented system

    d/dt [x; u; u'] = [[A, b, 0], [0, 0, 1], [0, 0, 0]] [x; u; u']      (u' = 0 when held)

computed to round-off, by a dense matrix exponential (:data:`DENSE_MAX` particles or fewer) or, for larger bars,
by a truncated Taylor series of the sparse operator over s sub-steps with ‖A h / s‖₁ <= :data:`THETA` and
:data:`TERMS` terms (Al-Mohy and Higham's scheme: the truncation error θ^{m+1}/(m+1)! is below 3e-18, the largest
term θ^θ/θ! loses at most two digits to cancellation).  The probe outputs are the FMU's: v linear between the two
particles around a probe, ρ = ρ0/(1 + e) at those particles, then linear.

Cost: the dense path one exponential of order 2N + 2 (a second at N = 500); the sparse path about 7 matrix-vector
products per unit of ‖A‖₁ h, i.e. of the order of ten full-SPH runs of the same horizon.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .lti import full_linear_system
from .probes import probe_pairs

DENSE_MAX = 500            # N up to which the step map is a dense matrix exponential (order 2N + 2)
THETA = 6.0                # ‖A τ‖₁ of a Taylor sub-step (sparse path)
TERMS = 40                 # Taylor terms per sub-step: θ^(m+1)/(m+1)! = 2.4e-18 at θ = 6, m = 40
TRUTH_NAME = "the full SPH linear in J, integrated exactly in time"


def _augmented(A, b, h, scale):
    """The input-augmented generator times h, with the input coordinates scaled (u by ``scale``, u' by scale h) so
    that its columns have norms like A's: [[A h, b h / scale, 0], [0, 0, 1], [0, 0, 0]] (sparse CSR)."""
    n = A.shape[0]
    col = sp.csr_matrix((b * h / scale)[:, None])
    top = sp.hstack([A * h, col, sp.csr_matrix((n, 1))])
    tail = sp.csr_matrix(([1.0], ([0], [n + 1])), shape=(2, n + 2))
    return sp.vstack([top, tail]).tocsr()


def step_map(A, b, h):
    """(apply, scale): ``apply(Z)`` maps augmented states Z (2N + 2, C) = [x; scale u; scale h u'] over one step
    h [s] exactly (module docstring), ``scale`` the input coordinates' factor."""
    A = sp.csr_matrix(A)
    b = np.asarray(b, float)
    a_norm = float(abs(A).sum(axis=0).max()) if A.nnz else 0.0
    scale = max(float(np.abs(b).sum()) / a_norm, 1e-300) if a_norm > 0 and np.any(b) else 1.0
    M = _augmented(A, b, h, scale)
    n = A.shape[0] // 2
    if n <= DENSE_MAX:
        import scipy.linalg as sla
        phi = sla.expm(M.toarray())
        return (lambda Z: phi @ Z), scale
    subs = max(1, math.ceil(float(abs(M).sum(axis=0).max()) / THETA))
    Ms = (M / subs).tocsr()

    def apply(Z):
        for _ in range(subs):
            term, total = Z, Z.copy()
            for j in range(1, TERMS + 1):
                term = (Ms @ term) / j
                total += term
            Z = total
        return Z
    return apply, scale


def exact_probe_outputs(problem, probes, t, inputs, scales, interpolate=False):
    """The truth at the probes, every case at once.

    Parameters
    ----------
    problem : sphrom.sph.solver.SPHProblem
    probes : sequence of float
        Probe positions x/L.
    t : ndarray (M,)
        Communication points [s], uniformly spaced from 0 (t_j = j h).
    inputs : ndarray (M, C)
        f [m s^-2] at the points, one column per case.
    scales : sequence of float (C,)
        The initial state of each case: scale x the scene's (v = scale v0, ρ = ρ0).
    interpolate : bool
        f linear between the points (the FMU's input derivatives), else held over each step.

    Returns
    -------
    (v, rho) : ndarrays (M, P, C)
        Probe velocities [m s^-1] and densities [kg m^-3].
    """
    t = np.asarray(t, float)
    U = np.asarray(inputs, float).reshape(t.size, -1)
    C = U.shape[1]
    lti = full_linear_system(problem, probes)
    n = lti.n
    i0, i1, w = probe_pairs(problem.x, problem.scene.L, np.asarray(probes, float))
    rho0 = problem.rho0
    h = float(t[1] - t[0]) if t.size > 1 else 0.0
    apply, scale = step_map(lti.A, lti.B[:, 0], h) if t.size > 1 else (None, 1.0)
    Z = np.zeros((2 * n + 2, C))
    Z[:2 * n] = lti.x0[:, None] * np.asarray(scales, float)[None, :]
    v_out = np.empty((t.size, len(probes), C))
    rho_out = np.empty_like(v_out)
    for k in range(t.size):
        v = Z[:n] / lti.w_v[:, None]
        rho = rho0[:, None] / (1.0 + Z[n:2 * n] / lti.w_e[:, None])
        v_out[k] = v[i0] * (1 - w)[:, None] + v[i1] * w[:, None]
        rho_out[k] = rho[i0] * (1 - w)[:, None] + rho[i1] * w[:, None]
        if k + 1 < t.size:
            Z[2 * n] = scale * U[k]
            Z[2 * n + 1] = scale * (U[k + 1] - U[k]) if interpolate else 0.0
            Z = apply(Z)
    return v_out, rho_out
