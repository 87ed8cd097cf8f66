"""The Python driver of the time-stepped reduced models: sampling, force tables, chunks, progress, failures.

A model's ``run`` wraps its compiled loop as ``advance(n0, n1, g, ptr) ->
(status, ptr, step)`` and hands it to :func:`drive`, which runs it in chunks
from step 0 to ``n_steps``, times the loop alone and turns a bad status
(:mod:`.loops`) into a SimulationError naming the step and time.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import SimulationError
from ..progress import progress_bar

METHODS = {"euler": 0, "symplectic": 1, "rk4": 2}
RUNAWAY_FACTOR = 1e6
CHUNK_WORK = 5e7          # multiply-adds per chunk of steps


def runaway_bound(ops):
    """|a| above this is a runaway: 10⁶ x the largest initial reduced coordinate."""
    return RUNAWAY_FACTOR * max(np.max(np.abs(ops.a_v0)), np.max(np.abs(ops.a_rho0)), 1e-300)


def initial_scale(value):
    """``initial_state_scale`` as a float; ValueError naming it unless it is a finite real number."""
    scale = float(value)
    if not np.isfinite(scale):
        raise ValueError(f"initial_state_scale = {value!r} is out of range (allowed: a finite real number; 1 the "
                         "scene's initial state, 0 at rest)")
    return scale


def start_arrays(ops, state, n_samples, initial_state_scale=1.0):
    """(a_v, a_rho, out_av, out_ar): the initial reduced coordinates (``state`` = (a_v, a_rho), default the
    operators' projections of v0, ρ0) as fresh arrays, and the sample arrays of ``n_samples`` rows.

    ``initial_state_scale`` multiplies the velocity coordinates only (the density coordinates are those of
    ρ0, the rest state), as the FMU's parameter of that name; 1 leaves them bit for bit."""
    av = initial_scale(initial_state_scale) * np.array(ops.a_v0 if state is None else state[0], dtype=float)
    ar = np.array(ops.a_rho0 if state is None else state[1], dtype=float)
    return av, ar, np.empty((n_samples, ops.k_v)), np.empty((n_samples, ops.k_rho))


def sample_grid(n_steps, sample_steps=None, every=1):
    """The sorted, unique sample steps: ``sample_steps``, or every ``every`` steps and the last."""
    if sample_steps is None:
        sample_steps = np.union1d(np.arange(0, n_steps + 1, every), [n_steps])
    return np.unique(np.asarray(sample_steps, dtype=np.int64))


def method_code(integrator, allowed, what):
    """The loops' code of ``integrator``; ValueError when ``allowed`` does not hold it."""
    if integrator not in allowed:
        raise ValueError(f"{what} are defined for {' and '.join(allowed)} only (not {integrator!r})")
    return METHODS[integrator]


def force_table(force, active, method, n0, n1, dt):
    """f at the stage times of steps n0..n1-1, shape (n1 - n0, 3): t_n, t_n + dt/2, t_n + dt (RK4 only).

    Zeros when the input is not ``active``.
    """
    g = np.zeros((n1 - n0, 3))
    if active:
        tn = np.arange(n0, n1) * dt
        g[:, 0] = force(tn)
        if method == 2:
            g[:, 1] = force(tn + 0.5 * dt)
            g[:, 2] = force(tn + dt)
    return g


def drive(name, advance, forces, *, n_steps, dt, cost, bound, progress=False):
    """Run ``advance`` over steps 0..n_steps in chunks of about :data:`CHUNK_WORK` / ``cost`` steps.

    Parameters
    ----------
    name : str
        The model, for the progress bar and the failure message.
    advance : callable
        ``advance(n0, n1, g, ptr) -> (status, ptr, step)``: the compiled loop
        from step n0 to n1 with the force table ``g`` (:func:`force_table`).
    forces : callable
        ``forces(n0, n1) -> g``.
    cost : float
        Multiply-adds per step.
    bound : float
        The runaway bound (for the message).

    Returns
    -------
    float
        Wall time of the loop alone [s].
    """
    chunk = max(1, min(n_steps, int(CHUNK_WORK // max(cost, 1))))
    advance(0, 0, np.zeros((0, 3)), 0)          # load the compiled loop before the clock starts
    ptr, wall, n0 = 0, 0.0, 0
    with progress_bar(total=n_steps, desc=f"rom {name}", unit="step", enabled=progress) as bar:
        while n0 < n_steps:
            n1 = min(n_steps, n0 + chunk)
            g = forces(n0, n1)
            t0 = time.perf_counter()
            status, ptr, bad = advance(n0, n1, g, ptr)
            wall += time.perf_counter() - t0
            if status != 0:
                what = "non-finite" if status == 1 else f"runaway (|a| > {bound:.3g})"
                raise SimulationError(f"{name} reduced state became {what} by step {bad} (t = {bad * dt:.6g} s)",
                                      step=bad, time=bad * dt)
            bar.update(n1 - n0)
            n0 = n1
    return wall
