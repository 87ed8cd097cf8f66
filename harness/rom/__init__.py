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

from ..lazy import lazy_exports

# imported from their modules on first use: importing a leaf of sphrom.rom (probes, parametric) stays light
EXPORTS = {
    "LinearOperators": "exact_linear", "build_linear_operators": "exact_linear", "run_exact": "exact_linear",
    "BASIS_KINDS": "model", "FrozenOptions": "model", "GalerkinOptions": "model", "LinearOptions": "model",
    "ReducedModel": "model", "basis_modes": "model",
    "ReducedOperators": "operators", "build_operators": "operators", "probe_rows": "operators",
    "Operators": "protocol",
    "MODEL_NAMES": "registry", "MODELS": "registry", "fmu_model_names": "registry", "get_model": "registry",
    "model_names": "registry",
    "ReducedResult": "result",
    "runaway_bound": "stepping",
}
__all__ = sorted(EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)
