"""What every reduced model's operators provide: one protocol over the whole reduced state z.

In pyMOR's words, a model's ``build`` is its *reductor* (the full SPH problem and a basis in, a reduced model
out) and its ``run`` *solves* the reduced model; the operators are the reduced model itself.  Whatever the
model, they describe its state the same way:

``order``
    The size of the reduced state z [-].
``slices``
    Named, consecutive slices of z covering it: ``velocity`` and ``density`` coordinates (the models on density
    modes: v = U^v a^v, ρ = U^ρ a^ρ, eq. 2.18), ``velocity`` and ``specific_volume`` (the exact model:
    v = U_v a, e = U_e b), or one ``state`` block (the balanced model, whose coordinates each mix v and e).
``z0``
    The initial reduced state, (order,).
``fields(z)``
    (v [m s^-1], ρ [kg m^-3]) at the particles, each (M, N), from states z (M, order).
``project(v, rho, problem)``
    The reduced state of full fields (M, N) -> (M, order): the reductor's projection (eq. 2.16 for the density
    models, the energy inner products for the exact one, Wᵀ x for the balanced one).
``outputs(z, problem, probes)``
    The probe outputs (M, 2P): velocities [m s^-1], then e = ρ0/ρ - 1, linear between the particles around each
    probe as the FMU interpolates.  ``output_probes`` are the probes a model is defined by (the balanced model's
    outputs y = Cr x_r, which equal its fields at those probes to round-off), None when any probe will do.
``error_bounds(problem, probes, progress=None)``
    Certified bounds on the probe velocity errors against the full linear SPH
    (:func:`sphrom.rom.balanced.error_bounds`), or None for a model without them.
``ports``, ``port_errors``, ``Bp``
    Mechanical port positions x/L (empty without ports), each port profile's projection error, and the port
    input rows (None without ports; :mod:`sphrom.sph.ports`).
``method``
    The reduction method where a model has a choice (balanced: ``bt``, ``galerkin`` ...), else "".

:class:`Operators` gives the defaults (no bounds, no ports, outputs from the fields); each operators type
(:class:`~sphrom.rom.operators.ReducedOperators`, :class:`~sphrom.rom.exact_linear.LinearOperators`,
:class:`~sphrom.rom.balanced_model.BalancedOperators`) derives from it and overrides what it has.  Code
outside :mod:`sphrom.rom` asks these, never the type of the operators or whether an attribute exists.

Where the next additions go: error-bound outputs computed from the residual of the reduced state are an
``error_bounds`` (or a per-sample ``error_estimate(z, ...)``) of each operators type, the frozen model's from
its residual against a shadow run of the exact linear model (``project`` gives that run's start); input
directions per input channel (the force profile, each mechanical port) are one more protocol member,
``inputs``, naming each channel's column of the operators, which ``run`` and the FMU resources then read for
every model alike (the balanced model's ports included).
"""

from __future__ import annotations

import numpy as np

from .probes import probe_values


class Operators:
    """The protocol's defaults (module docstring); the operators types derive from it."""

    ports = ()                  # port positions x/L; empty: no ports
    port_errors = ()
    Bp = None                   # port input rows (P, ...) at area 1, None without ports
    output_probes = None        # the probes the model's outputs are defined at; None: any
    method = ""

    @property
    def slices(self):
        """{name: slice} of z, consecutive from 0 (module docstring)."""
        raise NotImplementedError

    @property
    def order(self):
        """The size of the reduced state z."""
        return list(self.slices.values())[-1].stop

    def as_state(self, state):
        """A state z of the model as a fresh float array (order,); ValueError naming ``state`` otherwise."""
        z = np.array(state, dtype=float)
        if z.shape != (self.order,):
            raise ValueError(f"state: shape {z.shape} (allowed: ({self.order},), the reduced state z)")
        return z

    def block(self, z, name):
        """The coordinates ``name`` of states z, (M, size) (a view)."""
        return np.atleast_2d(z)[:, self.slices[name]]

    def fields(self, z):
        """(v [m s^-1], ρ [kg m^-3]) at the particles, (M, N) each, from states z (M, order)."""
        raise NotImplementedError

    def project(self, v, rho, problem):
        """The reduced state (M, order) of full fields v [m s^-1], ρ [kg m^-3] of shape (M, N)."""
        raise NotImplementedError

    def outputs(self, z, problem, probes):
        """Probe outputs (M, 2P) of states z: v [m s^-1], then e = ρ0/ρ - 1, interpolated from the fields."""
        v, rho = self.fields(z)
        return probe_values(v, rho, problem.rho0, problem.x, problem.scene.L, probes)

    def error_bounds(self, problem, probes, progress=None):
        """Certified error bounds at ``probes`` (:func:`sphrom.rom.balanced.error_bounds`), None: the model has
        none.  ``progress``: an object with ``update(1)``, called once per probe."""
        return None


def two_blocks(first, second, k_first, k_second):
    """The ``slices`` of a state of two blocks, ``first`` (k_first coordinates) then ``second``."""
    return {first: slice(0, k_first), second: slice(k_first, k_first + k_second)}
