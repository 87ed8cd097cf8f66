"""The packaging steps every model kind shares (:mod:`sphrom.fmu.kinds`' ``resource`` calls them): the scene's POD
basis and its training run, the training envelope (:mod:`.envelope`) and the certified error bounds' shadow.

They ask nothing of a kind (the kinds build on them, never the other way round).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...cache import cached_sph
from ...errors import FieldError
from ...pod.pipeline import basis_for_scene, error_steps, training_steps
from ...rom.bounds import fmu_shadow_applies, sections
from ...rom.lti import truth_matrix
from ...rom.port_channel import model_ports
from ...rom.model import BASIS_KINDS
from ...sph.solver import build_problem
from .. import layout
from ..resources import pack, probe_pairs
from .envelope import measure


def model_basis(scene, spec, k, progress=True, problem=None, made=None):
    """(basis, problem) of ``scene`` for the model ``spec``: its POD basis, with k checked against the modes of the
    model's basis kind (FieldError naming the field ``k`` or ``model``).  ``made``: the (basis, run) of
    :func:`sphrom.pod.pipeline.basis_for_scene` already made for this scene (not made again)."""
    problem = problem or build_problem(scene)
    basis, _ = made or basis_for_scene(scene, progress=progress, problem=problem)
    available = spec.available_modes(basis)
    if available is None:
        raise FieldError("model", f"{spec.name}: the basis of scene '{scene.name}' has no "
                                  f"{' and '.join(BASIS_KINDS[spec.basis_kind][:2])} modes")
    if k > min(available):
        raise FieldError("k", f"{k} is out of range (allowed: 1 to {min(available)}, the POD modes of scene "
                              f"'{scene.name}')")
    return basis, problem


def training_envelope(scene, ops, problem, probes, linear, progress=False, run=None):
    """The :class:`~sphrom.fmu.training.envelope.Envelope` of the model ``ops``: its ranges over the scene's cached
    full SPH training run (:mod:`sphrom.fmu.training.envelope`)."""
    if run is None:
        _, run = basis_for_scene(scene, progress=progress, problem=problem)
    return measure(scene, ops, problem, run, probes, linear)


def training_basis(scene, progress, problem, extra_steps=()):
    """(basis, run, problem): the scene's POD basis and its cached training run, made once for the model and its
    training envelope (one SPH load and one POD).  ``extra_steps``: more samples the same run stores (the
    communication points a verification reads: the training run is then not run again for it)."""
    problem = problem or build_problem(scene)
    basis, run = basis_for_scene(scene, progress=progress, problem=problem, extra_steps=extra_steps)
    # the envelope is measured on the samples the model asks for (error and snapshot steps), not on whatever
    # else the cache holds from other commands: the same resources whatever the cache's history
    keep = np.isin(run.steps, np.union1d(error_steps(scene), np.union1d(basis.steps_v, basis.steps_rho)))
    if not keep.all():
        run = dataclasses.replace(run, t=run.t[keep], v=run.v[keep], rho=run.rho[keep], steps=run.steps[keep])
    return basis, run, problem


def packaging_truth(problem, ports=(), build_options=None, error_bounds=True, parametric=False):
    """The truth's matrix and growth rate (:func:`sphrom.rom.lti.truth_matrix`) of a packaging, built once for its
    port channel (:func:`sphrom.rom.port_channel.attach`) and its shadow (:func:`shadow_step`), or None where
    neither is built: no port channel (:func:`sphrom.rom.port_channel.model_ports`) and no shadow (``error_bounds``
    False, or :func:`sphrom.rom.bounds.fmu_shadow_applies` not)."""
    channel = model_ports(problem, ports, build_options)[2]
    shadow = bool(error_bounds) and fmu_shadow_applies(problem, parametric)
    return truth_matrix(problem) if channel or shadow else None


def shadow_step(data, ops, problem, probes, parametric=False, truth=None):
    """The certified error bounds' shadow of every output of the model ``ops`` (its probes and ports, the
    operators' ``bound_shadow``) into ``data.sections`` (SH*, :mod:`sphrom.rom.bounds`;
    the FMU's outputs ``*_error_bound`` and parameter ``error_tolerance``), its default tolerance from the training
    run's largest |v_probe| (section ENVPROBE; a model without a training envelope, the balanced one: the same
    figure from the scene's cached training run, :func:`training_probe_speed`); nothing where the C core cannot
    certify (more than FMU_MAX_PARTICLES particles, a parametric model whose d is not uniform).  A damping d that
    is not uniform gives the eigen-planes of A (:mod:`sphrom.rom.bounds`).  ``parametric``: the shadow of a parametric
    FMU (its planes in pieces of c and d, sections SHPIECE and SHPARAM; the C core assembles them at the FMU's c
    and d).  ``truth``: the packaging's truth's matrix (:func:`packaging_truth`; None: the shadow builds its own)."""
    envelope = data.sections.get("ENVPROBE")
    scale_v = (float(np.max(envelope[layout.row("ENVPROBE", "v_max")])) if envelope is not None else
               training_probe_speed(problem, probes))
    shadow = ops.bound_shadow(problem, probes, parametric=parametric, scale_v=scale_v,
                              model_runs=None if parametric else core_runs(data), truth=truth)
    if shadow is not None:
        data.sections.update(sections(shadow))


def core_runs(data):
    """The model of ``data`` (its sections so far, no SH*) run by the C core, as
    :func:`sphrom.rom.bounds.model_errors` asks: ``run(h, f, scale)`` -> (v, ρ) (steps, P) after each step of h [s]
    under f held over each step, from rest (scale 0) or from the initial state (scale 1: the outputs at t = 0
    first), and with ports v_port (steps, ports) too (no port force: the model's own part of it).  The shadow is sized against the model's own error on its reference inputs; the FMU's own core, so
    the error is the FMU's.  The binaries are built (or found in the cache) on the first run."""
    blob = pack(dataclasses.replace(data, sections={k: v for k, v in data.sections.items()
                                                    if not k.startswith("SH")}))

    def run(h, f, scale):
        from ..run.core import built_core
        model = built_core().load(blob)
        try:
            model.reset(0.0)
            model.set_initial_state_scale(float(scale))
            P, ports = data.n_probes, model.n_ports
            v, rho, v_port = [], [], []

            def read():
                out = model.outputs(P)
                v.append(out[0])
                rho.append(out[1])
                if ports:
                    v_port.append(model.port_velocities())
            if scale:
                read()
            for i, fi in enumerate(np.asarray(f, float)):
                model.set_input(float(fi))
                model.do_step(i * h, h)
                read()
            return (np.array(v), np.array(rho)) + ((np.array(v_port),) if ports else ())
        finally:
            model.close()
    return run


def training_probe_speed(problem, probes):
    """The training run's largest |v| at the probes [m s^-1] (the scene's cached full SPH run, on its stored samples,
    the probes linear between particles as the envelope's ENVPROBE): what a model without a training envelope (the
    balanced model) scales its default error_tolerance by, as every other model does."""
    steps = training_steps(problem.scene)          # the samples the envelope is measured on (training_basis)
    run = cached_sph(problem.scene, steps, progress=False, problem=problem)
    i0, i1, w = probe_pairs(problem.x, problem.scene.L, np.asarray(probes, float))
    keep = np.isin(run.steps, steps)
    v = run.v[keep][:, i0] * (1.0 - w) + run.v[keep][:, i1] * w
    return float(np.max(np.abs(v)))
