"""The one result type of every reduced model's run."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .probes import probe_values


@dataclass
class ReducedResult:
    """Samples of a reduced-model run, whatever the model: the whole reduced state z and the model's operators.

    Attributes
    ----------
    model : str
        The model's registry name (:mod:`sphrom.rom.registry`).
    t : ndarray (M,)
        Sample times [s].
    steps : ndarray of int (M,) or None
        Sample indices on the run's time grid, ``t = steps * dt``; None for a
        run sampled at arbitrary times (:func:`sphrom.rom.exact_linear.run_exact`).
    z : ndarray (M, order)
        The reduced state at the samples; ``ops.slices`` name its blocks
        (:mod:`sphrom.rom.protocol`).
    ops : object
        The operators the run used: they name the blocks of z and reconstruct the fields.
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
    z: np.ndarray
    ops: object
    wall_time: float
    offline: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    def block(self, name):
        """The coordinates ``name`` of the state (``ops.slices``), (M, size)."""
        return self.ops.block(self.z, name)

    @property
    def a_v(self):
        """Velocity coordinates, (M, k_v): v = U_v a_v (AttributeError for a state that does not split)."""
        if "velocity" not in self.ops.slices:
            raise AttributeError(f"the {self.model} model's state does not split into velocity coordinates: "
                                 "read z")
        return self.block("velocity")

    @property
    def a_rho(self):
        """The second block of coordinates, (M, k_2): density coordinates (ρ = U_ρ a) on density modes,
        specific-volume coordinates (e = U_e a, ρ = ρ0 / (1 + e)) on energy-weighted modes."""
        names = list(self.ops.slices)
        if names[0] != "velocity" or len(names) != 2:
            raise AttributeError(f"the {self.model} model's state does not split into two blocks: read z")
        return self.block(names[1])

    @cached_property
    def _fields(self):
        return self.ops.fields(self.z)

    @property
    def v(self):
        """Velocity at the particles, (M, N) [m s^-1]."""
        return self._fields[0]

    @property
    def rho(self):
        """Density at the particles, (M, N) [kg m^-3]."""
        return self._fields[1]

    @property
    def probes(self):
        """The probes x/L the model's own outputs ``y`` are defined at (balanced), else None."""
        return self.ops.output_probes

    @cached_property
    def y(self):
        """The model's own probe outputs (M, 2P) at ``probes`` (balanced: y = Cr x_r, probe velocities
        [m s^-1] then probe values of e = ρ0/ρ - 1), None for a model defined by its fields (the POD models,
        whose probe values :meth:`probe_outputs` gives at any probe)."""
        return None if self.probes is None else self.ops.outputs(self.z, None, self.probes)

    def probe_outputs(self, x, L, probes, rho0):
        """The fields interpolated linearly at ``probes`` (x/L) as the FMU does, (M, 2P): the velocities
        [m s^-1], then e = ρ0/ρ - 1 (the balanced model's outputs ``y``, to round-off).

        Parameters
        ----------
        x : ndarray (N,)
            Particle positions [m]; ``L`` the period [m]; ``rho0`` (N,) the initial density [kg m^-3].
        """
        return probe_values(self.v, self.rho, rho0, x, L, probes)
