"""The full SPH's equations linear in J with ports and the force along the profile, integrated exactly in time:
the reference the reduced models' inputs are measured against (:mod:`sphrom.rom.inputs`; tests and the
``inputs`` measurement)."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..sph.ports import port_kernel, port_velocity_rows
from .exact_linear import propagators
from .lti import full_linear_system
from .probes import probe_pairs
from .truth import exact_probe_outputs


def linear_reference(problem, ports, t_end, step, *, force=None, port_forces=None, hold="held", state=True,
                     area=1.0, specific_volume=False):
    """The full SPH's equations linear in J with ports, integrated exactly in time: the reference of the
    reduced models' inputs (dense matrix exponential of the 2N-state system; tests and measurements, N <= ~1000).

    Parameters
    ----------
    problem : SPHProblem
    ports : sequence of float
        Port positions x/L (may be empty).
    t_end, step : float
        Horizon and communication step H [s]: samples at t_n = n H, n = 0 .. round(t_end / H).
    force : callable, optional
        f(t) [m s^-2] along the scene's profile (vectorised); None: no force.
    port_forces : callable, optional
        F(t) -> (len(t), P) [N]; None: no port force.
    hold : {"held", "linear"}
        Inputs over a step: held at the start value, or linear between the end values.
    state : bool
        Start from the scene's initial state (True) or from rest.
    area : float
        Cross-section A [m^2]: the port accelerations are W/(ρ0 A).
    specific_volume : bool
        Also return e = J - 1 = ρ0/ρ - 1 at the particles (M, N) [1].

    Returns
    -------
    t (M,) [s], v (M, N) [m s^-1], v_port (M, P) [m s^-1] (and e (M, N) with ``specific_volume``).
    """
    lti = full_linear_system(problem, [0.5])
    n = problem.n
    cols = []
    if force is not None:
        cols.append(lti.B[:, 0])
    P = len(ports)
    if P:
        Wk = port_kernel(problem, ports)
        cols.extend(np.concatenate([w / lti.w_v / area, np.zeros(n)]) for w in Wk)
    B = np.column_stack(cols) if cols else None
    n_steps = int(round(t_end / step))
    t = np.arange(n_steps + 1) * step

    def inputs(tt):
        parts = []
        if force is not None:
            parts.append(np.asarray(force(tt), float).reshape(tt.size, 1))
        if P:
            parts.append(np.asarray(port_forces(tt), float).reshape(tt.size, P) if port_forces is not None
                         else np.zeros((tt.size, P)))
        return np.hstack(parts)

    phi, g0, g1 = propagators(lti.A.toarray(), B, step)
    u = inputs(t) if B is not None else None
    x = lti.x0.copy() if state else np.zeros(2 * n)
    xs = np.empty((t.size, 2 * n))
    xs[0] = x
    for i in range(n_steps):
        x = phi @ x
        if B is not None:
            x = x + g0 @ u[i] + (0.0 if hold == "held" else g1 @ (u[i + 1] - u[i]))
        xs[i + 1] = x
    v = xs[:, :n] / lti.w_v
    v_port = v @ port_velocity_rows(problem, ports).T if P else np.zeros((t.size, 0))
    if specific_volume:
        return t, v, v_port, xs[:, n:] / lti.w_e
    return t, v, v_port


def exact_probe_reference(problem, probes, t, force, scale=1.0, hold="held"):
    """The truth of the FMUs' certified error bounds at the probes: the full SPH of eqs. 2.10-2.11, exactly linear in
    J (:mod:`.lti`), integrated exactly in time (docs/science/error-bounds.md).  One case of
    :func:`sphrom.rom.truth.exact_probe_outputs`, the one implementation of that truth (packaging's
    verification measures every FMU against it too).

    Parameters
    ----------
    problem : SPHProblem
    probes : sequence of float
        Probe positions x/L.
    t : ndarray (M,)
        Communication points [s], uniformly spaced from 0.
    force : ndarray (M,)
        f at the points [m s^-2], along the scene's profile.
    scale : float
        The initial state: scale x the scene's (v = scale v0, ρ = ρ0).
    hold : {"held", "linear"}
        f held over each step at its start value, or linear between the points (input derivatives).

    Returns
    -------
    (v (M, P) [m s^-1], ρ (M, P) [kg m^-3]): at the probes, interpolated linearly between the two particles around
    each (v as the FMU does; ρ = Σ_m w_m ρ0_m / (1 + e_m)).

    Notes
    -----
    The explicit-Euler SPH the validation also runs differs from it by its own time-step error (and its nonlinearity
    in ρ: eqs. 2.10-2.11 are exactly linear in J).
    """
    if hold not in ("held", "linear"):
        raise ValueError(f"hold: {hold!r} (allowed: held, linear)")
    t = np.asarray(t, float)
    f = np.broadcast_to(np.asarray(force, float), t.shape)
    v, rho = exact_probe_outputs(problem, probes, t, f[:, None], [scale], interpolate=hold == "linear")
    return v[:, :, 0], rho[:, :, 0]
