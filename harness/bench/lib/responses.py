"""A reduced model's response to inputs held over communication steps, as an importer drives its FMU: the run
that the input benchmarks (:mod:`sphrom.bench.inputs`) and the tests of every input channel compare with the
full SPH's equations integrated exactly in time (:func:`sphrom.rom.reference.linear_reference`)."""

from __future__ import annotations

import numpy as np


def held(fn, step):
    """``fn`` held over each communication step of ``step`` [s]: its value at the step's start."""
    return lambda t: fn(np.floor(np.asarray(t, float) / step + 1e-9) * step)


def held_response(spec, ops, problem, *, t_end, step, force=None, port_forces=None, from_state=False,
                  options=None):
    """The coordinates that ``ops.velocity`` and ``ops.port_velocity`` take (a^v (M, k_v); the balanced model's
    whole state) of the model ``spec`` with operators ``ops`` at t = n ``step``, n = 0 .. round(t_end / step),
    its inputs held over each step.

    Parameters
    ----------
    spec : ReducedModel
        The model (:func:`sphrom.rom.registry.get_model`).
    t_end, step : float
        Horizon and communication step [s].
    force : callable, optional
        f(t) [m s^-2] along the profile; None: f = 0 (the scene's own force off).
    port_forces : callable, optional
        F(t) -> (len(t), P) [N] of the model's ports; None: none.
    from_state : bool
        Start from the model's initial state (the scene's), else from rest.
    options : dict, optional
        The model's run options (``spec.options``); a linear model is advanced over each step exactly
        (``step``, ``hold="held"``), a time-stepped one with the scene's dt and these (n_freeze, integrator, refresh).

    Returns
    -------
    ndarray (M, k_v or order)
        ``ops.velocity`` of it gives the velocity field, ``ops.port_velocity`` the port velocities.
    """
    inputs = dict(force=held(force, step) if force is not None else (lambda t: 0.0 * np.asarray(t, float)),
                  port_forces=held(port_forces, step) if port_forces is not None else None)
    options = dict(options or {})
    if spec.linear:
        res = spec.run(ops, problem, dt=step, n_steps=int(round(t_end / step)),
                       options=spec.options(step=step, hold="held", **options),
                       state=None if from_state else np.zeros(ops.order), **inputs)
    else:
        dt = problem.scene.sph.dt
        res = spec.run(ops, problem, dt=dt, n_steps=int(round(t_end / dt)), every=int(round(step / dt)),
                       state=None if from_state else ops.initial_state(0.0),
                       options=spec.options(**options), **inputs)
    return ops.block(res.z, "velocity") if "velocity" in ops.slices else np.atleast_2d(res.z)
