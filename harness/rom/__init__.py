"""The reduced models (eqs. 2.16-2.24 and the exact linear model): one registry, one interface.

``get_model(name)`` gives a model's entry (:class:`ReducedModel`: properties,
``build``, ``run``, ``truncate``); every run returns a :class:`ReducedResult`.

Public names::

    get_model, MODELS, MODEL_NAMES, model_names, fmu_model_names   the registry        (registry)
    build_model, run_model, truncate_model                           by model name       (registry)
    ReducedModel, BASIS_KINDS, basis_modes                           a model's entry     (model)
    GalerkinOptions, FrozenOptions, LinearOptions                    a model's run options (model)
    Operators                                                        what operators provide (protocol)
    ReducedResult                                                    what a run returns  (result)
    build_operators, ReducedOperators, probe_rows                    eqs. 2.17-2.24      (operators)
    build_linear_operators, LinearOperators, run_exact               the exact linear model (exact_linear)
    run_reduced                                                      the earlier entry point (common)
    runaway_bound                                                    the blow-up bound   (stepping)
"""

from .common import run_reduced
from .exact_linear import LinearOperators, build_linear_operators, run_exact
from .model import BASIS_KINDS, FrozenOptions, GalerkinOptions, LinearOptions, ReducedModel, basis_modes
from .operators import ReducedOperators, build_operators, probe_rows
from .protocol import Operators
from .registry import (MODEL_NAMES, MODELS, build_model, fmu_model_names, get_model, model_names, run_model,
                       truncate_model)
from .result import ReducedResult
from .stepping import runaway_bound

__all__ = ["BASIS_KINDS", "FrozenOptions", "GalerkinOptions", "LinearOperators", "LinearOptions", "MODEL_NAMES",
           "MODELS", "Operators", "ReducedModel", "ReducedOperators",
           "ReducedResult", "basis_modes", "build_linear_operators", "build_model", "build_operators",
           "fmu_model_names", "get_model", "model_names", "probe_rows", "run_exact", "run_model", "run_reduced",
           "runaway_bound", "truncate_model"]
