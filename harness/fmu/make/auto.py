"""``sphrom fmu --model auto``: the step that chooses the model, by packaging and measuring every candidate."""

from __future__ import annotations

from pathlib import Path

from ...runio import atomic_path
from .package import package_fmu


def package_auto(scene, out, *, tolerance, progress=True, integrator=None, bounds=False, **options):
    """``sphrom fmu --model auto``: the cheapest FMU model whose measured error meets ``tolerance``.

    Every model that can be packaged (:func:`sphrom.rom.registry.fmu_model_names`) is packaged with the same
    options into a temporary folder and measured (:func:`package_fmu` with ``verify``; the truth is computed once
    and shared); the candidates that pass :func:`sphrom.fmu.check.verify.acceptance` at ``tolerance`` (no failure,
    no runaway, every case's v error at most ``tolerance``) are kept, and of those the one whose own work (its doStep
    calls on the training force) is the smallest is moved to ``out``.  ``integrator`` applies to the time-stepped
    models only.  ``bounds``: the a priori bounds of the linear models, off as in ``sphrom fmu`` (they are what
    took minutes; the certified bounds every FMU reports are made either way).

    Returns
    -------
    (FMUSummary of the chosen model at ``out``, list of the FMUSummary of every candidate)

    Raises
    ------
    ToleranceError
        No model meets ``tolerance`` (the message lists each one's verdict); nothing is written.
    """
    import shutil
    import tempfile

    from ...errors import ToleranceError
    from ...rom.registry import fmu_model_names
    from ..check.verify import acceptance
    from ..kinds import for_model
    out = Path(out)
    candidates = []
    refs = None
    with tempfile.TemporaryDirectory(prefix="sphrom-auto-") as tmp:
        for model in fmu_model_names():
            own = integrator if "integrator" in for_model(model).BUILD_OPTIONS else None     # its kind's option
            s = package_fmu(scene, Path(tmp) / f"{model}.fmu", model=model, integrator=own, verify=True,
                            references=refs, progress=progress, bounds=bounds, accept=False, **options)
            refs = s.verification.refs
            candidates.append(s)
        good = [s for s in candidates if acceptance(s.verification, tolerance, s.model) is None]
        if not good:
            errors = ", ".join(f"{s.model} {s.verification.worst.err_v:.3g} ({s.verification.worst.name})"
                               for s in candidates)
            raise ToleranceError(f"no model meets the tolerance {tolerance:g} on every case (largest v errors: "
                                 f"{errors}); '{out}' was not written (an existing file is unchanged)")
        best = min(good, key=lambda s: _cost(s.verification.training))
        with atomic_path(out) as final:
            shutil.copyfile(best.path, final)
        best.path = out
    return best, candidates


def _cost(case):
    """The FMU's own work on a case [s] (its doStep calls), its whole run through fmpy where that was not timed."""
    return case.step_s if case.step_s == case.step_s else case.fmu_s
