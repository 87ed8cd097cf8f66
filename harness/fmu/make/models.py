"""Step "model" of ``package_fmu``: the reduced model's numbers and operators, made by the model kinds
(:mod:`sphrom.fmu.kinds`: kind 1 the frozen model, kind 2 the exact model on its POD basis and the balanced model
without one) on the steps they share (:mod:`sphrom.fmu.training.steps`: the POD basis, the training envelope, the certified error
bounds' shadow).

:func:`resources` maps a model's ``fmu_kind`` to its kind's packaging step; :func:`operator_resource` packs
operators built elsewhere (a benchmark's own).  The kinds' builders are importable from here under the names
they have always had.
"""

from __future__ import annotations

from ... import defaults
from ..kinds import by_number, kinds, pack
from ..kinds.frozen import (N_FREEZE_BUDGET, N_FREEZE_CANDIDATES, N_FREEZE_MIN_SAMPLES,  # noqa: F401
                            N_FREEZE_SLACK, choose_n_freeze, particle_sections, reduced_model)
from ..kinds.linear import balanced_model, exact_model, linear_bound, linear_bounds  # noqa: F401
from ..training.steps import model_basis, shadow_step, training_basis, training_envelope  # noqa: F401


def resources():
    """{model_kind (ReducedModel.fmu_kind): the kind's packaging step} (:mod:`sphrom.fmu.kinds`: each kind's
    ``resource``, which makes the FMU's numbers and their bytes)."""
    return {number: kind.resource for number, kind in kinds().items()}


def __getattr__(name):
    if name == "RESOURCES":           # the table's former name: resources()
        return resources()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def operator_resource(kind, ops, problem, *, dt, n_freeze=defaults.N_FREEZE, probes=defaults.PROBES,
                      integrator="euler"):
    """(data, bytes) of resources/model.bin of kind ``kind`` (ReducedModel.fmu_kind) from operators built
    elsewhere (a benchmark's own), the runaway bound that of their initial state, as :func:`reduced_model` and
    :func:`exact_model` have it; the initial state is scaled at run time by the FMU's initial_state_scale.  The
    operators are packaged as they are: the frozen model's own (``get_model("frozen").build``, b about the
    projected rest density) give the FMU's frozen model, ``b="paper"`` ones eq. 2.22's variant.  ``dt``,
    ``n_freeze``, ``integrator`` go to a kind that takes them (its ``BUILD_OPTIONS``: the frozen kind)."""
    module = by_number(kind)
    given = {"dt": dt, "n_freeze": n_freeze, "integrator": integrator}
    data = module.from_operators(ops, problem, probes=probes,
                                 **{name: given[name] for name in module.BUILD_OPTIONS})
    return data, pack(data)
