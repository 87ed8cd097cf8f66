"""POD bases (eq. 2.15) of velocity and density snapshots, and basis files.

    X = Û Σ̂ V̂ᵀ  (thin SVD),  U = first k columns of Û          (2.15)

Velocity and density get separate bases (U^v, U^ρ of eq. 2.18), with their
own counts k_v, k_ρ.  The snapshots are not centred (the paper's POD), so the
first density mode is the near-uniform ρ ≈ ρ0.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import h5py
import numpy as np

from .. import __version__
from ..errors import FieldError
from ..runio import atomic_path, scene_attrs

BASIS_FORMAT = "sphrom-basis"
BASIS_VERSION = 1


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
    u, s, _ = np.linalg.svd(np.asarray(snapshots, dtype=float), full_matrices=False)
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
        The scene's TOML text (the basis is rebuilt into a Scene with it).
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
    # Energy-weighted bases of the exact linear model (harness.rom.exact_linear):
    # velocity modes orthonormal in Σ ρ0 u w, specific-volume modes (e = ρ0/ρ - 1)
    # orthonormal in Σ c u w.
    U_ve: np.ndarray | None = None
    sigma_ve: np.ndarray | None = None
    U_e: np.ndarray | None = None
    sigma_e: np.ndarray | None = None

    @property
    def max_modes(self):
        return self.U_v.shape[1], self.U_rho.shape[1]

    def scene(self):
        from ..scene import parse_scene
        return parse_scene(self.scene_text, "<basis scene>")


def weighted_pod(snapshots, weight):
    """POD in the inner product Σ_i weight_i u_i w_i: modes U with Uᵀ diag(weight) U = I."""
    root = np.sqrt(np.asarray(weight, float))
    u, s = pod(root[:, None] * snapshots)
    return u / root[:, None], s


def build_basis(v_samples, rho_samples, sample_steps, steps_v, steps_rho, x, dt, scene, strategy, weights=None):
    """POD of the snapshots at ``steps_v`` / ``steps_rho`` among stored samples.

    ``v_samples`` and ``rho_samples`` have shape (M, N) at ``sample_steps``.
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
                  steps_rho=np.asarray(steps_rho), x=np.asarray(x), dt=float(dt), scene_text=scene.text,
                  strategy=strategy, timings={"svd": svd})
    if weights is not None:
        rho0, c = weights
        t0 = time.perf_counter()
        basis.U_ve, basis.sigma_ve = weighted_pod(v_samples[[index[int(s)] for s in steps_v]].T, rho0)
        e = rho0[None, :] / rho_samples[[index[int(s)] for s in steps_rho]] - 1.0
        basis.U_e, basis.sigma_e = weighted_pod(e.T, c)
        basis.timings["svd_energy"] = time.perf_counter() - t0
    return basis


def write_basis(path, basis: Basis, scene, extra=None):
    """Write a basis file atomically (HDF5, format ``sphrom-basis``).

    ``extra`` maps group paths to dicts of arrays (e.g. reduced operators).
    """
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as h5:
            h5.attrs["format"] = BASIS_FORMAT
            h5.attrs["format_version"] = BASIS_VERSION
            h5.attrs["sphrom_version"] = __version__
            h5.attrs["strategy"] = basis.strategy
            h5.attrs["dt"] = basis.dt
            for k, v in scene_attrs(scene).items():
                h5.attrs[k] = v
            for k, v in basis.timings.items():
                h5.attrs[f"offline_time.{k}"] = v
            for k, v in basis.attrs.items():
                h5.attrs[k] = v
            for name in ("U_v", "U_rho", "sigma_v", "sigma_rho", "steps_v", "steps_rho", "x",
                         "U_ve", "sigma_ve", "U_e", "sigma_e"):
                if getattr(basis, name) is not None:
                    h5.create_dataset(name, data=getattr(basis, name))
            h5.create_dataset("snapshot_times_v", data=basis.steps_v * basis.dt).attrs["units"] = "s"
            h5.create_dataset("snapshot_times_rho", data=basis.steps_rho * basis.dt).attrs["units"] = "s"
            h5["x"].attrs["units"] = "m"
            for group, arrays in (extra or {}).items():
                g = h5.require_group(group)
                for name, arr in arrays.items():
                    if isinstance(arr, dict):
                        for k, v in arr.items():
                            g.attrs[k] = v
                    elif arr is not None:
                        g.create_dataset(name, data=np.asarray(arr))


def read_basis(path) -> Basis:
    """Read a basis file; FieldError ``basis`` when missing or not a basis."""
    from pathlib import Path
    path = Path(path)
    if not path.is_file():
        raise FieldError("basis", f"'{path}' not found")
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != BASIS_FORMAT:
                raise FieldError("basis", f"'{path}' is not a sphrom basis file")
            if int(h5.attrs["format_version"]) != BASIS_VERSION:
                raise FieldError("basis", f"'{path}' has basis format version {h5.attrs['format_version']} "
                                          f"(this sphrom reads {BASIS_VERSION})")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            timings = {k.split(".", 1)[1]: float(v) for k, v in attrs.items() if k.startswith("offline_time.")}
            optional = {name: (h5[name][()] if name in h5 else None)
                        for name in ("U_ve", "sigma_ve", "U_e", "sigma_e")}
            return Basis(U_v=h5["U_v"][()], U_rho=h5["U_rho"][()], sigma_v=h5["sigma_v"][()],
                         sigma_rho=h5["sigma_rho"][()], steps_v=h5["steps_v"][()], steps_rho=h5["steps_rho"][()],
                         x=h5["x"][()], dt=float(attrs["dt"]), scene_text=attrs["scene.toml"],
                         strategy=attrs["strategy"], timings=timings, attrs=attrs, **optional)
    except OSError as exc:
        raise FieldError("basis", f"'{path}' cannot be read as HDF5 ({exc})") from None
