"""The registry of the reduced models: one entry per model, looked up by name.

Each model module defines its :class:`~sphrom.rom.model.ReducedModel`
(``MODEL``: name, description, properties, builder, solver, options type,
truncate); this module lists them, one line per model.  A new model is one new
module and one line here.  Code elsewhere asks a model's properties
(``get_model(name).linear``, ``.uses_n_freeze``, ``.needs_basis``,
``.fmu_kind``), runs it through ``.build`` / ``.run`` (with ``.options(...)``) /
``.truncate``, and reads its operators through the protocol of
:mod:`sphrom.rom.protocol`; it never compares model names.
"""

from __future__ import annotations

from . import balanced_model, exact_linear, frozen, linearized, original
from .model import ReducedModel

MODELS: dict[str, ReducedModel] = {m.name: m for m in (
    original.MODEL,
    linearized.MODEL,
    frozen.MODEL,
    exact_linear.MODEL,
    balanced_model.MODEL,
)}
MODEL_NAMES = tuple(MODELS)


def get_model(name) -> ReducedModel:
    """The registry entry of ``name``; ValueError naming the allowed models otherwise."""
    try:
        return MODELS[name]
    except (KeyError, TypeError):
        raise ValueError(f"reduced model {name!r} is not one of {', '.join(MODEL_NAMES)}") from None


def model_names(**properties):
    """Names of the models whose properties equal ``properties``, in registry order.

    ``model_names(linear=False)``: the time-stepped models; ``model_names(fmu_kind=None)``: the models that
    cannot be packaged as an FMU.
    """
    return tuple(name for name, m in MODELS.items() if all(getattr(m, k) == v for k, v in properties.items()))


def pod_model_names(**properties):
    """Names of the models built on a POD basis (``needs_basis``), filtered by ``properties`` as
    :func:`model_names`: the models the POD benchmarks and stress maps compare (the balanced model needs no
    basis and has its own measurement, ``python -m sphrom.bench.balanced_measure``)."""
    return model_names(needs_basis=True, **properties)


def fmu_model_names():
    """The models that can be packaged as an FMU (``fmu_kind`` set)."""
    return tuple(name for name, m in MODELS.items() if m.fmu_kind is not None)
