"""The reduced models' earlier entry point, kept for the callers that name a model by string.

``run_reduced(model, ops, problem, ...)`` is ``get_model(model).run(ops,
problem, ...)`` (:mod:`sphrom.rom.registry`); new code asks the registry.
"""

from __future__ import annotations

from .registry import get_model
from .result import ReducedResult
from .stepping import METHODS, RUNAWAY_FACTOR, runaway_bound

ROMResult = ReducedResult          # the result type's earlier name

__all__ = ["METHODS", "RUNAWAY_FACTOR", "ROMResult", "run_reduced", "runaway_bound"]


def run_reduced(model, ops, problem, *, n_steps, dt, **keywords):
    """Run the registered model ``model`` from step 0 to ``n_steps`` -> ReducedResult.

    The shared arguments of :mod:`sphrom.rom.model` (sample_steps, every, force, bound, progress, state ...)
    and the model's options as keywords (integrator; n_freeze, refresh; step, hold), as
    :func:`sphrom.rom.registry.run_model`.  Raises ValueError for an unknown model or an option of another
    model, SimulationError for a non-finite or runaway state, naming the step and time.
    """
    return get_model(model).run_keywords(ops, problem, n_steps=n_steps, dt=dt, **keywords)
