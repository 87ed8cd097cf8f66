"""What ``sphrom fmu`` asks for, once its options are parsed: the options checked against the scene, then the
packaging they choose.

:func:`package_request` packages one model (:func:`sphrom.fmu.make.package.package_fmu`), the default with its
fallback (:func:`sphrom.fmu.make.auto.package_default`) or every model and the cheapest that meets the tolerance
(:func:`sphrom.fmu.make.auto.package_auto`, :data:`AUTO`); :func:`is_default_request` says when the default model
may be replaced by its fallback.
"""

from __future__ import annotations

from ...pod.pipeline import modes_line
from ...rom.registry import MODELS, fmu_model_names
from .auto import package_auto, package_default, package_model
from .options import check_options, check_port_spacing, check_ports, check_vary
from .package import package_fmu

AUTO = "auto"           # --model auto: every model packaged and measured, the cheapest that meets --tolerance kept


def is_default_request(model=None, *, verify=True, n_freeze=None, integrator=None):
    """Whether :func:`package_request` may write the fallback model (:data:`sphrom.fmu.make.auto.FALLBACK_MODEL`)
    where the default one misses the accuracy or costs more than it: no model was asked for
    (``model`` None), the FMU is measured (``verify``) and none of the default model's own options (``n_freeze``,
    ``integrator``) is given."""
    return model is None and verify and n_freeze is None and integrator is None


def pod_modes_line(scene, model, k=None, progress=True):
    """The line that says the POD mode count the scene's model takes (:func:`sphrom.pod.pipeline.modes_line`:
    runs the full SPH and the POD now, cached), where ``model`` (or one of :data:`AUTO`'s) has a POD basis and
    ``k`` is not given; None otherwise."""
    if k is None and (model == AUTO or MODELS[model].basis_kind is not None):
        return modes_line(scene, progress=progress) or None
    return None


def package_request(scene, out, model, *, by_default=False, k=None, n_freeze=None, probes, fmi=2, integrator=None,
                    progress=True, verify=True, tolerance=None, vary=(), ports=None, bounds=False,
                    order_tolerance=None):
    """Check the options against ``scene`` and package the FMU ``out`` that :func:`check_request` chose.

    Parameters
    ----------
    scene : Scene
    out : Path
    model : str
        A model of :func:`sphrom.rom.registry.fmu_model_names` or :data:`AUTO` (with ``tolerance``).
    by_default : bool
        :func:`is_default_request`: the default model, or its fallback where that one misses the accuracy.
    k, n_freeze, probes, fmi, integrator, progress, verify, tolerance, bounds, order_tolerance :
        :func:`sphrom.fmu.make.package.package_fmu`'s options (``k``: the POD mode count or the order).
    vary : list of str
        ``c=LO:HI`` / ``d=LO:HI`` texts (:func:`sphrom.fmu.make.options.check_vary`).
    ports : str or list or None
        The port positions x/L (:func:`sphrom.fmu.make.options.check_ports`, at least L/N apart).

    Returns
    -------
    (summary, candidates, note)
        The FMUSummary of the FMU written to ``out``; with :data:`AUTO` the FMUSummary of every candidate
        packaged and measured (else None); a one-line note when the default model was replaced (else '').

    Raises
    ------
    FieldError
        An option out of range for the scene (:func:`sphrom.fmu.make.options.check_options`,
        :func:`sphrom.fmu.make.options.check_vary`, :func:`sphrom.fmu.make.options.check_ports`).
    ToleranceError
        No candidate meets the accuracy; nothing is written.
    """
    if model == AUTO:
        for name in fmu_model_names():
            check_options(scene, k=k, n_freeze=n_freeze, probes=probes, fmi=fmi,
                          integrator=None if MODELS[name].linear else integrator, model=name, tolerance=tolerance)
        summary, candidates = package_auto(scene, out, tolerance=tolerance, k=k, n_freeze=n_freeze, probes=probes,
                                           fmi=fmi, integrator=integrator, progress=progress, bounds=bounds)
        return summary, candidates, ""
    check_options(scene, k=k, n_freeze=n_freeze, probes=probes, fmi=fmi, integrator=integrator, model=model,
                  tolerance=tolerance, order_tolerance=order_tolerance, ports=ports or ())
    vary = check_vary(scene, vary, model)
    ports = check_port_spacing(scene, check_ports(ports, model))
    options = dict(k=k, n_freeze=n_freeze, probes=probes, fmi=fmi, integrator=integrator, progress=progress,
                   verify=verify, tolerance=tolerance, vary=vary, ports=ports, bounds=bounds,
                   order_tolerance=order_tolerance)
    if by_default:
        summary, note = package_default(scene, out, options)
        return summary, None, note
    if verify:          # measured: a cheaper configuration where it costs more per simulated second than the SPH
        summary, note = package_model(scene, out, model, options)
        return summary, None, note
    return package_fmu(scene, out, model=model, **options), None, ""
