"""The reduced models (eqs. 2.16-2.24 and the exact linear model): one registry, one interface.

``get_model(name)`` gives a model's entry (:class:`ReducedModel`: properties,
``build``, ``run``, ``truncate``); ``get_model(name).run(ops, problem, ...,
options=...)`` is the one way to run a reduced model, and every run returns a
:class:`ReducedResult`.  The operators a model builds answer :class:`Operators`.

Public names::

    get_model, MODELS, MODEL_NAMES, model_names, fmu_model_names   the registry        (registry)
    ReducedModel, BASIS_KINDS, basis_modes                           a model's entry     (model)
    GalerkinOptions, FrozenOptions, LinearOptions                    a model's run options (model)
    Operators                                                        what operators provide (protocol)
    ReducedResult                                                    what a run returns  (result)
    build_operators, ReducedOperators, probe_rows                    eqs. 2.17-2.24      (operators)
    build_linear_operators, LinearOperators                          the exact linear model (exact_linear)
    run_exact                                                        the exact model at any sample times (exact_linear)
    runaway_bound                                                    the blow-up bound   (stepping)
"""

from .exact_linear import LinearOperators, build_linear_operators, run_exact
from .model import BASIS_KINDS, FrozenOptions, GalerkinOptions, LinearOptions, ReducedModel, basis_modes
from .operators import ReducedOperators, build_operators, probe_rows
from .protocol import Operators
from .registry import MODEL_NAMES, MODELS, fmu_model_names, get_model, model_names
from .result import ReducedResult
from .stepping import runaway_bound

__all__ = ["BASIS_KINDS", "FrozenOptions", "GalerkinOptions", "LinearOperators", "LinearOptions", "MODEL_NAMES",
           "MODELS", "Operators", "ReducedModel", "ReducedOperators", "ReducedResult", "basis_modes",
           "build_linear_operators", "build_operators", "fmu_model_names", "get_model", "model_names", "probe_rows",
           "run_exact", "runaway_bound"]
