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
        ρ = ρ0 / (1 + e)) for models on energy-weighted modes.
    ops : object
        The operators the run used; they reconstruct the fields.
    wall_time : float
        Online time of the run [s] (the time loop, not the setup).
    offline : dict
        Offline times [s] of the operators (``operators``, ``tensor`` ...).
    settings : dict
        The run's settings (model, integrator or step, k_v, k_rho or k_e ...).
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

    @cached_property
    def v(self):
        """Velocity at the particles, (M, N) [m s^-1]."""
        return self.ops.velocity(self.a_v)

    @cached_property
    def rho(self):
        """Density at the particles, (M, N) [kg m^-3]."""
        return self.ops.density(self.a_rho)

    @property
    def z(self):
        """The whole reduced state [a_v, a_rho], (M, k_v + k_2)."""
        return np.concatenate([self.a_v, self.a_rho], axis=1)
