"""``sphrom fmu --model auto``: the step that chooses the model, by packaging and measuring every candidate."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from ...errors import FieldError, ToleranceError
from ...rom.registry import fmu_model_names
from ...runio import atomic_path
from ..check.verify import acceptance
from ..kinds import for_model
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


def verdicts(chosen, candidates, tolerance):
    """[(FMUSummary, verdict)] of :func:`package_auto`'s ``candidates``, the verdict in words: the ``chosen`` one,
    one that meets ``tolerance`` at a higher cost, or one that does not meet it."""
    return [(c, "chosen: the cheapest that meets it" if c is chosen else
             "meets it, costlier" if acceptance(c.verification, tolerance) is None else "does not meet it")
            for c in candidates]


def _cost(case):
    """The FMU's own work on a case [s] (its doStep calls), its whole run through fmpy where that was not timed."""
    return case.step_s if case.step_s == case.step_s else case.fmu_s


DEFAULT_MODEL = "frozen"        # sphrom fmu without --model
FALLBACK_MODEL = "exact"        # ... where the default model's FMU misses the accuracy or is slower than the full SPH


def default_candidates(scene, folder, options):
    """[(FMUSummary or None, verdict or None)]: the :data:`DEFAULT_MODEL`'s FMU packaged into ``folder`` and measured
    (``options``: :func:`package_fmu`'s, ``tolerance`` the accuracy), then, where it misses the accuracy
    (:func:`sphrom.fmu.check.verify.acceptance`, the verdict) or its own work per simulated second is above the full
    SPH's, the :data:`FALLBACK_MODEL`'s (measured on the same truth).  A default model that cannot be packaged for the
    scene (a FieldError: the frozen model's dt floor) is (None, why)."""
    tried, refs = [], None
    for model in (DEFAULT_MODEL, FALLBACK_MODEL):
        try:
            s = package_fmu(scene, Path(folder) / f"{model}.fmu", model=model, accept=False, references=refs,
                            **{**options, "n_freeze": options.get("n_freeze") if model == DEFAULT_MODEL else None,
                               "integrator": None})
        except FieldError as exc:           # a setting this model cannot take (the frozen model's dt floor)
            if model != DEFAULT_MODEL:
                raise
            tried.append((None, f"the {model} model cannot be packaged for this scene ({exc})"))
            continue
        refs = s.verification.refs
        verdict = acceptance(s.verification, options.get("tolerance"), model)
        tried.append((s, verdict))
        if verdict is None and s.verification.training.cost_ratio <= 1:
            break
    return tried


def choose_default(tried, out):
    """(the chosen FMUSummary, a one-line note or '') of :func:`default_candidates`: the candidate that meets the
    accuracy at the lowest cost per simulated second; the note says why it is not the default model.
    ToleranceError naming both verdicts when none meets it."""
    good = [s for s, verdict in tried if verdict is None]
    if not good:
        raise ToleranceError(f"{tried[0][1]}; the {FALLBACK_MODEL} model too: {tried[-1][1].split('; remedy')[0]}; "
                             f"'{out}' was not written (an existing file is unchanged)")
    best = min(good, key=lambda s: s.verification.training.cost_ratio)
    first, why = tried[0]
    if best is first:
        return best, ""
    reason = (why.split("; remedy")[0] if why else f"the {DEFAULT_MODEL} FMU's own work per simulated second is "
              f"{first.verification.training.cost_ratio:.3g}x the full SPH's")
    keep = f"--model {DEFAULT_MODEL}" if not why else f"--model {DEFAULT_MODEL} --tolerance above its error"
    return best, (f"{reason}; wrote the {best.model} model's FMU, which meets the accuracy at "
                  f"{best.verification.training.cost_ratio:.3g}x the full SPH's cost ({keep} keeps the "
                  f"{DEFAULT_MODEL} one)")


def package_default(scene, out, options):
    """``sphrom fmu`` without ``--model`` (nor the frozen model's own options): (FMUSummary at ``out``, note) of
    :func:`choose_default` over :func:`default_candidates`; nothing is written when no candidate meets the
    accuracy."""
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="sphrom-fmu-") as tmp:
        best, note = choose_default(default_candidates(scene, tmp, options), out)
        with atomic_path(out) as final:
            shutil.copyfile(best.path, final)
        best.path = out
    return best, note
