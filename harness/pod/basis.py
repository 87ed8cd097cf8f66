"""POD bases (eq. 2.15) of velocity and density snapshots: arrays in, modes and singular values out.

    X = Û Σ̂ V̂ᵀ  (thin SVD),  U = first k columns of Û          (2.15)

Velocity and density get separate bases (U^v, U^ρ of eq. 2.18), with their
own counts k_v, k_ρ.  The snapshots are not centred (the paper's POD), so the
first density mode is the near-uniform ρ ≈ ρ0.

Basis files are read and written by :mod:`sphrom.pod.io`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..blas import sized, svd_flops


def pod(snapshots):
    """Thin SVD of a snapshot matrix (eq. 2.15).

    Parameters
    ----------
    snapshots : ndarray, shape (N, m)
        One snapshot per column.

    Returns
    -------
    modes : ndarray, shape (N, min(N, m))
        Orthonormal POD modes, ordered by singular value.
    sigma : ndarray, shape (min(N, m),)
        Singular values, decreasing.
    """
    snapshots = np.asarray(snapshots, dtype=float)
    with sized(svd_flops(*snapshots.shape)):            # one BLAS thread for a small SVD (sphrom.blas)
        u, s, _ = np.linalg.svd(snapshots, full_matrices=False)
    # fix the sign of each mode (largest entry positive) so bases are reproducible
    signs = np.sign(u[np.argmax(np.abs(u), axis=0), np.arange(u.shape[1])])
    signs[signs == 0] = 1.0
    return u * signs, s


def modes_for_energy(sigma, tol):
    """Smallest k with Σ_{i>k} σ_i² <= tol Σ σ_i² (the energy left out)."""
    e = np.asarray(sigma, float) ** 2
    tail = np.append(np.cumsum(e[::-1])[::-1][1:], 0.0) / e.sum()   # Σ_{i>k} σ_i², no cancellation
    return int(np.argmax(tail <= tol) + 1)


@dataclass
class Basis:
    """POD bases of one scene and snapshot strategy.

    Attributes
    ----------
    U_v, U_rho : ndarray (N, r_v), (N, r_rho)
        All POD modes the snapshots give (truncate with ``[:, :k]``).
    sigma_v, sigma_rho : ndarray
        Singular values.
    steps_v, steps_rho : ndarray of int
        Snapshot step indices; times are ``steps * dt``.
    x : ndarray (N,)
        Particle positions [m].
    dt : float
        Time step of the run the snapshots come from [s].
    scene_text : str
        The scene's TOML text.
    strategy : str
        Description of the snapshot strategy.
    timings : dict
        Offline wall times [s]: ``sph`` (0 when reused from the cache), ``svd``.
    """

    U_v: np.ndarray
    U_rho: np.ndarray
    sigma_v: np.ndarray
    sigma_rho: np.ndarray
    steps_v: np.ndarray
    steps_rho: np.ndarray
    x: np.ndarray
    dt: float
    scene_text: str
    strategy: str
    timings: dict = field(default_factory=dict)
    attrs: dict = field(default_factory=dict)
    # Energy-weighted bases of the exact linear model (sphrom.rom.exact_linear):
    # velocity modes orthonormal in Σ ρ0 u w, specific-volume modes (e = ρ0/ρ - 1)
    # orthonormal in Σ c u w.
    U_ve: np.ndarray | None = None
    sigma_ve: np.ndarray | None = None
    U_e: np.ndarray | None = None
    sigma_e: np.ndarray | None = None

    @property
    def max_modes(self):
        return self.U_v.shape[1], self.U_rho.shape[1]


def weighted_pod(snapshots, weight):
    """POD in the inner product Σ_i weight_i u_i w_i: modes U with Uᵀ diag(weight) U = I."""
    root = np.sqrt(np.asarray(weight, float))
    u, s = pod(root[:, None] * snapshots)
    return u / root[:, None], s


def build_basis(v_samples, rho_samples, sample_steps, steps_v, steps_rho, x, dt, scene_text, strategy, weights=None):
    """POD of the snapshots at ``steps_v`` / ``steps_rho`` among stored samples.

    ``v_samples`` and ``rho_samples`` have shape (M, N) at ``sample_steps``
    [m s^-1], [kg m^-3]; ``x`` the particles [m], ``dt`` the run's step [s];
    ``scene_text`` and ``strategy`` are kept with the basis as provenance.
    ``weights = (rho0, c)`` at the particles also gives the energy-weighted
    bases of velocity and specific volume e = ρ0/ρ - 1 (eq. A.9).
    """
    index = {int(s): i for i, s in enumerate(sample_steps)}
    missing = [s for s in np.concatenate([steps_v, steps_rho]) if int(s) not in index]
    if missing:
        raise ValueError(f"snapshot step {missing[0]} not among the stored samples")
    t0 = time.perf_counter()
    U_v, s_v = pod(v_samples[[index[int(s)] for s in steps_v]].T)
    U_r, s_r = pod(rho_samples[[index[int(s)] for s in steps_rho]].T)
    svd = time.perf_counter() - t0
    basis = Basis(U_v=U_v, U_rho=U_r, sigma_v=s_v, sigma_rho=s_r, steps_v=np.asarray(steps_v),
                  steps_rho=np.asarray(steps_rho), x=np.asarray(x), dt=float(dt), scene_text=scene_text,
                  strategy=strategy, timings={"svd": svd})
    if weights is not None:
        rho0, c = weights
        t0 = time.perf_counter()
        basis.U_ve, basis.sigma_ve = weighted_pod(v_samples[[index[int(s)] for s in steps_v]].T, rho0)
        e = rho0[None, :] / rho_samples[[index[int(s)] for s in steps_rho]] - 1.0
        basis.U_e, basis.sigma_e = weighted_pod(e.T, c)
        basis.timings["svd_energy"] = time.perf_counter() - t0
    return basis
