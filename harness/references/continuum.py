"""The best continuum reference for a scene without an exact solution.

Scenes with uniform c and ρ0 have the exact Fourier solution
(:mod:`.exact`); the others (``heterogeneous``, or any user scene with a
nonuniform c, ρ0 or d) are measured against the finite-element reference of
:mod:`.skfem_ref` with P2 elements on a fine mesh.  On ``heterogeneous`` the
jump of c sends kinks along the characteristics, the references converge at
first order and scikit-fem and py-pde agree to ~3e-4 at this resolution
(``sphrom validate heterogeneous`` measures it), far below the SPH error
(~6e-2) that the reduced models are compared with.

The samples are cached beside the SPH runs (:mod:`sphrom.cache`), keyed by
the scene, the resolution and the requested points and times.
"""

from __future__ import annotations

import hashlib

import h5py
import numpy as np

from .. import __version__
from ..cache import cache_dir
from ..runio import atomic_path, h5_create
from . import skfem_ref

RESOLUTION = 1024        # P2 elements
DT = 1.25e-4             # s, Newmark average acceleration
LABEL = "scikit-fem P2, N = 1024, dt = 1.25e-4 s"


def _key(scene, x, t, resolution, dt):
    h = hashlib.sha256()
    h.update(f"{__version__}\n{scene.text}\n{scene.T!r}\n{resolution}\n{dt!r}\n".encode())
    h.update(np.ascontiguousarray(x, dtype=float).tobytes())
    h.update(np.ascontiguousarray(t, dtype=float).tobytes())
    return h.hexdigest()[:24]


def best_reference(scene, x, t, resolution=RESOLUTION, dt=DT, progress=True):
    """The continuum reference (v, rho, label) at Lagrangian points x and times t.

    Parameters
    ----------
    scene : Scene
    x : ndarray (N,)
        Lagrangian positions [m].
    t : ndarray (M,)
        Times [s], increasing, from 0.
    resolution : int
        P2 elements of the scikit-fem reference.
    dt : float
        Largest Newmark time step [s].

    Returns
    -------
    (v, rho, label)
        v [m s^-1] and ρ [kg m^-3] of shape (M, N), and a label for reports.
    """
    x = np.asarray(x, dtype=float)
    t = np.asarray(t, dtype=float)
    path = cache_dir() / f"ref-{scene.name}-{_key(scene, x, t, resolution, dt)}.h5"
    if path.exists():
        try:
            with h5py.File(path, "r") as h5:
                return h5["v"][()], h5["rho"][()], str(h5.attrs["label"])
        except (OSError, KeyError):
            pass                 # a damaged cache file is simply rebuilt
    ref = skfem_ref.solve(scene, resolution, dt, x, t, order=2, progress=progress)
    label = f"scikit-fem P2, N = {resolution}, dt = {dt:g} s"
    with atomic_path(path) as tmp:
        with h5_create(tmp) as h5:
            h5.create_dataset("v", data=ref.v)
            h5.create_dataset("rho", data=ref.rho)
            h5.attrs["label"] = label
    return ref.v, ref.rho, label
