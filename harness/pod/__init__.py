"""POD (section 2.3): snapshot selection and bases from full SPH runs.

``basis`` is the pure POD (arrays in, modes and singular values out), ``io``
the one reader and writer of basis files, ``snapshots`` the paper's snapshot
strategies, ``pipeline`` the way from a scene to a basis (the cached full SPH
run and the SVD).  A basis is data that the reduced models take: this package
imports nothing of :mod:`sphrom.rom`, which builds on it (the mode sweeps and
snapshot studies are :mod:`sphrom.rom.study`).

Public names::

    pod, weighted_pod, build_basis, Basis, modes_for_energy     the POD of eq. 2.15        (basis)
    read_basis, write_basis, BASIS_FORMAT, BASIS_VERSION         basis files                (io)
    basis_for_scene, error_steps, on_steps                      scene -> cached basis      (pipeline)
    snapshot_steps, describe                                    the snapshot strategies    (snapshots)
"""

from .basis import Basis, build_basis, modes_for_energy, pod, weighted_pod
from .io import BASIS_FORMAT, BASIS_VERSION, read_basis, write_basis
from .pipeline import basis_for_scene, error_steps, on_steps
from .snapshots import describe, snapshot_steps

__all__ = ["BASIS_FORMAT", "BASIS_VERSION", "Basis", "basis_for_scene", "build_basis", "describe", "error_steps",
           "modes_for_energy", "on_steps", "pod", "read_basis", "snapshot_steps", "weighted_pod", "write_basis"]
