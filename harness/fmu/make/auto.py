"""``sphrom fmu --model auto``: the step that chooses the model, by packaging and measuring every candidate."""

from __future__ import annotations

from pathlib import Path

from ...runio import atomic_path
from .package import package_fmu


def package_auto(scene, out, *, tolerance, progress=True, integrator=None, **options):
    """``sphrom fmu --model auto``: the fastest FMU model whose measured error meets ``tolerance``.

    Every model that can be packaged (:func:`sphrom.rom.registry.fmu_model_names`) is packaged with the same
    options into a temporary folder and measured (:func:`package_fmu` with ``verify``; the full SPH runs are
    made once and shared); the candidates whose v error on the training force is at most ``tolerance`` are
    kept, and of those the one with the smallest FMU run time on the training force (one run each) is
    moved to ``out``.  ``integrator`` applies to the time-stepped models only.

    Returns
    -------
    (FMUSummary of the chosen model at ``out``, list of the FMUSummary of every candidate)

    Raises
    ------
    ToleranceError
        No model meets ``tolerance`` (the message lists each one's error); nothing is written.
    """
    import shutil
    import tempfile

    from ...errors import ToleranceError
    from ...rom.registry import fmu_model_names
    from ..kinds import for_model
    out = Path(out)
    candidates = []
    refs = None
    with tempfile.TemporaryDirectory(prefix="sphrom-auto-") as tmp:
        for model in fmu_model_names():
            own = integrator if "integrator" in for_model(model).BUILD_OPTIONS else None     # its kind's option
            s = package_fmu(scene, Path(tmp) / f"{model}.fmu", model=model, integrator=own, verify=True,
                            references=refs, progress=progress, **options)
            refs = s.verification.refs
            candidates.append(s)
        good = [s for s in candidates if s.verification.training.err_v <= tolerance]
        if not good:
            errors = ", ".join(f"{s.model} {s.verification.training.err_v:.3g}" for s in candidates)
            raise ToleranceError(f"no model meets the tolerance {tolerance:g} on the training force (v errors: "
                                 f"{errors}); '{out}' was not written (an existing file is unchanged)")
        best = min(good, key=lambda s: s.verification.training.fmu_s)
        with atomic_path(out) as final:
            shutil.copyfile(best.path, final)
        best.path = out
    return best, candidates
