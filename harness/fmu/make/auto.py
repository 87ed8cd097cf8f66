"""``sphrom fmu --model auto``: the step that chooses the model, by packaging and measuring every candidate."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from ...errors import FieldError, SimulationError, ToleranceError
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
        best = min(good, key=_cost)
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


def _cost(summary):
    """An FMU's cost per simulated second over the full SPH's (:attr:`sphrom.fmu.check.verify.Verification.cost_ratio`:
    the median of pairs of runs), inf where it was not measured."""
    r = summary.verification.cost_ratio
    return r if r == r else float("inf")


DEFAULT_MODEL = "frozen"        # sphrom fmu without --model
FALLBACK_MODEL = "exact"        # ... where the default model's FMU misses the accuracy or costs more than this one


def default_candidates(scene, folder, options):
    """[(FMUSummary or None, verdict or None)]: the :data:`DEFAULT_MODEL`'s and the :data:`FALLBACK_MODEL`'s FMUs
    packaged into ``folder`` and measured (``options``: :func:`package_fmu`'s, ``tolerance`` the accuracy; the same
    truth where their steps agree): the verdict of :func:`sphrom.fmu.check.verify.acceptance`, and the cost per
    simulated second of each (:func:`sphrom.fmu.check.verify.measure_cost`) from which :func:`choose_default` keeps
    the cheaper of those that meet the accuracy.  A default model that cannot be packaged for the scene (a
    FieldError: the frozen model's dt floor) is (None, why)."""
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
    return tried


def choose_default(tried, out):
    """(the chosen FMUSummary, a one-line note or '') of :func:`default_candidates`: the candidate that meets the
    accuracy at the lowest cost per simulated second; the note says why it is not the default model.
    ToleranceError naming both verdicts when none meets it."""
    good = [s for s, verdict in tried if verdict is None]
    if not good:
        raise ToleranceError(f"{tried[0][1]}; the {FALLBACK_MODEL} model too: {tried[-1][1].split('; remedy')[0]}; "
                             f"'{out}' was not written (an existing file is unchanged)")
    best = min(good, key=_cost)
    first, why = tried[0]
    if best is first:
        return best, ""
    reason = (why.split("; remedy")[0] if why else f"the {DEFAULT_MODEL} FMU meets the accuracy at "
              f"{_cost(first):.3g}x the full SPH's cost per simulated second")
    keep = f"--model {DEFAULT_MODEL}" if not why else f"--model {DEFAULT_MODEL} --tolerance above its error"
    return best, (f"{reason}; wrote the {best.model} model's FMU, which meets it at {_cost(best):.3g}x (the cheaper; "
                  f"{keep} keeps the {DEFAULT_MODEL} one)")


def cheaper_settings(summary, options):
    """[(words, changes of :func:`package_fmu`'s options)]: the cheaper configurations of the model of ``summary``
    that packaging tries, in turn, where its FMU costs more per simulated second than the full SPH: fewer modes
    (a half and a quarter of its k, where k was not given: ``options["k"]`` None; the bounds kept), then its
    certified error bounds left out (where it has them: the shadow's stepping is a part of each doStep) at its k and
    at fewer modes."""
    fewer = [] if options.get("k") is not None or options.get("vary") else \
        list(dict.fromkeys(k for k in (summary.k // 2, summary.k // 4) if 1 <= k < summary.k))
    no_bounds = "no certified error bounds (no *_error_bound outputs, no error_tolerance warning)"
    out = [(f"fewer modes (k = {k} against {summary.k})", {"k": k}) for k in fewer]
    if summary.shadow_order > 0:
        out.append((no_bounds, {"error_bounds": False}))
        out += [(f"fewer modes (k = {k} against {summary.k}) and {no_bounds}", {"k": k, "error_bounds": False})
                for k in fewer]
    return out


def cheaper_if_slower(scene, folder, first, options):
    """(FMUSummary, note): ``first`` (a packaged and measured FMU in ``folder``) and '' where it costs at most the
    full SPH per simulated second (or was not measured); else the first of :func:`cheaper_settings` whose FMU meets
    the accuracy (packaging's verdict) and costs at most the full SPH's, with a one-line note of what was changed and
    why; else ``first`` and '' (its verification then says, loudly, that it is slower: the terminal's warning and the
    FMU's page).  Each configuration is packaged and measured as ``first`` was; its page says why it was chosen."""
    v = first.verification
    if v is None or v.cost is None or not v.slower:
        return first, ""
    before = (f"the {first.model} FMU at k = {first.k}" + (" with certified error bounds" if first.shadow_order else "")
              + f" costs {v.cost_ratio:.3g}x the full SPH per simulated second ({v.cost.why()})")
    for i, (words, change) in enumerate(cheaper_settings(first, options)):
        note = f"{before}; packaging chose {words}"
        try:
            s = package_fmu(scene, Path(folder) / f"cheaper-{i}.fmu", model=first.model, references=v.refs,
                            **{**options, **change, "choice": note})
        except (FieldError, ToleranceError, SimulationError):       # not accurate, or not possible: the next one
            continue
        if not s.verification.slower:
            return s, f"{note}: {s.verification.cost_ratio:.3g}x, the accuracy met"
    return first, ""


def package_model(scene, out, model, options):
    """``sphrom fmu --model MODEL``: (FMUSummary at ``out``, note) of :func:`package_fmu` (``options`` its options),
    or of the cheaper configuration :func:`cheaper_if_slower` takes where that FMU costs more per simulated second
    than the full SPH."""
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="sphrom-fmu-") as tmp:
        first = package_fmu(scene, Path(tmp) / f"{model}.fmu", model=model, **options)
        best, note = cheaper_if_slower(scene, tmp, first, options)
        with atomic_path(out) as final:
            shutil.copyfile(best.path, final)
        best.path = out
    return best, note


def default_choice(scene, folder, options, out):
    """(the chosen FMUSummary, a one-line note or '', :func:`default_candidates`'s list) of ``sphrom fmu`` without
    ``--model``, packaged into ``folder``: :func:`choose_default` (the cheaper of the candidates that meet the
    accuracy; ToleranceError naming ``out`` when none does), then :func:`cheaper_if_slower` where it costs more per
    simulated second than the full SPH."""
    tried = default_candidates(scene, folder, options)
    best, note = choose_default(tried, out)
    own = {**options, "n_freeze": options.get("n_freeze") if best.model == DEFAULT_MODEL else None,
           "integrator": None}
    best, cheaper = cheaper_if_slower(scene, folder, best, own)
    return best, "; ".join(n for n in (note, cheaper) if n), tried


def package_default(scene, out, options):
    """``sphrom fmu`` without ``--model`` (nor the frozen model's own options): (FMUSummary at ``out``, note) of
    :func:`choose_default` over :func:`default_candidates`; nothing is written when no candidate meets the
    accuracy."""
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="sphrom-fmu-") as tmp:
        best, note, _ = default_choice(scene, tmp, options, out)
        with atomic_path(out) as final:
            shutil.copyfile(best.path, final)
        best.path = out
    return best, note
