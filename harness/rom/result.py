"""The one result type of every reduced model's run."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


@dataclass
class ReducedResult:
    """Samples of a reduced-model run, whatever the model.

    Attributes
    ----------
    model : str
        The model's registry name (:mod:`harness.rom.registry`).
    t : ndarray (M,)
        Sample times [s].
    steps : ndarray of int (M,) or None
        Sample indices on the run's time grid, ``t = steps * dt``; None for a
        run sampled at arbitrary times (:func:`harness.rom.exact_linear.run_exact`).
    a_v : ndarray (M, k_v)
        Velocity coordinates: v = U_v a_v.
    a_rho : ndarray (M, k_2)
        The second block of reduced coordinates: density coordinates (ρ = U_ρ a)
        for models on density modes, specific-volume coordinates (e = U_e a,
        ρ = ρ0 / (1 + e)) for models on energy-weighted modes.  A model whose
        state does not split into two blocks (``ops.whole_state``: balanced,
        whose coordinates each mix v and e) holds its whole state in ``a_v``
        and none here (k_2 = 0); its operators reconstruct both fields from it.
    ops : object
        The operators the run used; they reconstruct the fields.
    wall_time : float
        Online time of the run [s] (the time loop, not the setup).
    offline : dict
        Offline times [s] of the operators (``operators``, ``tensor`` ...).
    settings : dict
        The run's settings (model, integrator or step, k_v, k_rho or k_e ...).
    y : ndarray (M, 2P) or None
        The model's own probe outputs, for a model defined by its outputs
        (balanced: y = Cr x_r, probe velocities [m s^-1] then probe values of
        e = ρ0/ρ - 1); None for the POD models, whose probe values come from
        their fields (:meth:`probe_outputs`, which every model has).
    probes : ndarray (P,) or None
        Probe positions x/L of ``y``.
    """

    model: str
    t: np.ndarray
    steps: np.ndarray | None
    a_v: np.ndarray
    a_rho: np.ndarray
    ops: object
    wall_time: float
    offline: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    y: np.ndarray | None = None
    probes: np.ndarray | None = None

    @cached_property
    def v(self):
        """Velocity at the particles, (M, N) [m s^-1]."""
        return self.ops.velocity(self.a_v)

    @cached_property
    def rho(self):
        """Density at the particles, (M, N) [kg m^-3]."""
        return self.ops.density(self.a_v if getattr(self.ops, "whole_state", False) else self.a_rho)

    def probe_outputs(self, x, L, probes, rho0):
        """The fields interpolated linearly at ``probes`` (x/L) as the FMU does, (M, 2P): the velocities
        [m s^-1], then e = ρ0/ρ - 1 (the balanced model's outputs ``y``, to round-off).

        Parameters
        ----------
        x : ndarray (N,)
            Particle positions [m]; ``L`` the period [m]; ``rho0`` (N,) the initial density [kg m^-3].
        """
        return probe_values(self.v, self.rho, rho0, x, L, probes)

    @property
    def z(self):
        """The whole reduced state [a_v, a_rho], (M, k_v + k_2)."""
        return np.concatenate([self.a_v, self.a_rho], axis=1)


def probe_values(v, rho, rho0, x, L, probes):
    """Fields (M, N) at ``probes`` (x/L), linear between particles as the FMU does, (M, 2P): v [m s^-1], then
    e = ρ0/ρ - 1 (the rows of :func:`harness.rom.lti.full_linear_system`'s C)."""
    from .operators import probe_rows
    e = np.asarray(rho0)[None, :] / np.asarray(rho) - 1.0
    return np.concatenate([probe_rows(np.asarray(v).T, x, L, probes).T, probe_rows(e.T, x, L, probes).T], axis=1)
