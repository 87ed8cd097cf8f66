"""Basis files: the one module that reads and writes them (HDF5, format ``sphrom-basis``).

Layout: attributes ``format``, ``format_version``, ``sphrom_version``,
``strategy``, ``dt`` [s], the scene (``scene.toml`` ...), ``offline_time.*``
[s] and the basis' own attributes (``default_modes_v`` ...); datasets U_v,
U_rho, sigma_v, sigma_rho, steps_v, steps_rho, x [m], the energy-weighted
U_ve, sigma_ve, U_e, sigma_e when present, snapshot_times_v/_rho [s]; and the
group ``operators`` (the reduced operators at the stored mode counts,
:func:`operators_group`).

Errors name the file; the command layer adds the option that named it.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..errors import FieldError
from ..paths import not_a_file
from ..runio import atomic_path, h5_create, scene_attrs
from .basis import Basis

BASIS_FORMAT = "sphrom-basis"
BASIS_VERSION = 1
OPTIONAL = ("U_ve", "sigma_ve", "U_e", "sigma_e")


def operators_group(ops):
    """The ``operators`` group of a basis file from reduced operators (``extra`` of :func:`write_basis`).

    K, b, D, p, a_v0, a_rho0 of :class:`sphrom.rom.operators.ReducedOperators`, the appended input mode when
    the force direction was appended, and the mode counts, input error and offline time as attributes.
    """
    group = {"K": ops.K, "b": ops.b, "D": ops.D, "p": ops.p, "a_v0": ops.a_v0, "a_rho0": ops.a_rho0,
             "attrs": {"k_v": ops.k_v, "k_rho": ops.k_rho, "augmented": int(ops.augmented),
                       "input_error": ops.input_error, "offline_time.operators": ops.timings["operators"]}}
    if ops.augmented:
        group["input_mode"] = ops.U_v[:, -1]
    return group


def write_basis(path, basis: Basis, scene, extra=None):
    """Write a basis file atomically (nothing is left behind on failure).

    ``extra`` maps group paths to dicts of arrays (None entries skipped) and
    an optional ``attrs`` dict, e.g. ``{"operators": operators_group(ops)}``.
    """
    with atomic_path(path) as tmp:
        with h5_create(tmp) as h5:
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
            for name in ("U_v", "U_rho", "sigma_v", "sigma_rho", "steps_v", "steps_rho", "x") + OPTIONAL:
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
    """Read a basis file; FieldError ``basis`` naming the file when it is missing, unreadable or not a basis."""
    path = Path(path)
    if not path.is_file():
        raise FieldError("basis", f"'{path}': {not_a_file(path)}")
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != BASIS_FORMAT:
                raise FieldError("basis", f"'{path}' is not a sphrom basis file")
            if int(h5.attrs["format_version"]) != BASIS_VERSION:
                raise FieldError("basis", f"'{path}' has basis format version {h5.attrs['format_version']} "
                                f"(this sphrom reads {BASIS_VERSION})")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            timings = {k.split(".", 1)[1]: float(v) for k, v in attrs.items() if k.startswith("offline_time.")}
            optional = {name: (h5[name][()] if name in h5 else None) for name in OPTIONAL}
            return Basis(U_v=h5["U_v"][()], U_rho=h5["U_rho"][()], sigma_v=h5["sigma_v"][()],
                         sigma_rho=h5["sigma_rho"][()], steps_v=h5["steps_v"][()], steps_rho=h5["steps_rho"][()],
                         x=h5["x"][()], dt=float(attrs["dt"]), scene_text=attrs["scene.toml"],
                         strategy=attrs["strategy"], timings=timings, attrs=attrs, **optional)
    except OSError as exc:
        raise FieldError("basis", f"'{path}' cannot be read as HDF5 ({exc})") from None
