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
``sizes``
    {name: size} of those blocks, in their order (``sizes["velocity"]`` is k_v of a POD model).
``z0``, ``initial_state(velocity_scale)``
    The initial reduced state, (order,); and z0 with its velocity coordinates times ``velocity_scale`` (0: the
    initial density or strain with the particles at rest), for a model whose state has a ``velocity`` block.
``as_state(state)``, ``block(z, name)``
    A state checked against the order; the coordinates ``name`` of states z (a view).
``fields(z)``
    (v [m s^-1], ρ [kg m^-3]) at the particles, each (M, N), from states z (M, order).
``velocity(a)``, ``port_velocity(a)``
    v at the particles (M, N) and at the mechanical ports (M, P) [m s^-1] from the velocity coordinates
    (the ``velocity`` block; the whole state of a model without one).
``velocity_probe_rows(problem, probes)``
    Rows (P, size of the velocity coordinates) giving the velocity at ``probes`` from the velocity coordinates,
    linear between the particles around each probe as the FMU interpolates (the probe rows of its modes).
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
``bound_shadow(problem, probes, *, parametric=False, scale_v=None, model_runs=None, truth=None)``
    The certified shadow of the model's outputs (:mod:`sphrom.rom.bounds`): what an FMU's ``*_error_bound``
    outputs are computed from at run time, at ``probes`` and the model's ports; None where it cannot be
    certified.  ``truth``: the truth's matrix the packaging built once (:func:`sphrom.rom.lti.truth_matrix`).
``has_force_input``
    The model takes the scene's force f(t) along its profile (False: the scene has none, or the operators were
    built without its input, ``input_direction="never"``).
``ports``, ``port_errors``, ``Bp``, ``Cp``
    Mechanical port positions x/L (empty without ports), each port profile's projection error, the port input
    rows and the port velocity rows (None without ports; :mod:`sphrom.sph.ports`).
``channel``
    The port channel (:class:`sphrom.rom.port_channel.PortChannel`) that takes every port force of an FMU's model
    (``Bp`` then None: the model's own coordinates see no port force; ``Cp`` their part of v_port), or None.
``port_velocity_rows(problem, ports)``
    Rows (P, size of the velocity coordinates) giving the velocity of ports at ``ports`` (x/L) from the velocity
    coordinates (:func:`sphrom.sph.ports.port_velocity_rows` of the model's velocity fields).
``input_error``, ``augmented``, ``timings``
    The force profile's relative projection error on the velocity modes before any was appended (nan without
    a force or a basis), whether it was appended, and the offline times [s] (``operators`` at least).
``method``
    The reduction method where a model has a choice (balanced: ``bt``, ``galerkin`` ...), else "".

:class:`Operators` gives the defaults (no bounds, no ports, outputs from the fields, the shadow of
:func:`sphrom.rom.bounds.fmu_shadow`); each operators type (:class:`~sphrom.rom.operators.ReducedOperators`,
:class:`~sphrom.rom.exact_linear.LinearOperators`, :class:`~sphrom.rom.balanced_model.BalancedOperators`)
derives from it and overrides what it has.  Code outside :mod:`sphrom.rom` asks these, never the type of the
operators or whether an attribute exists.  A model's own numbers (K, b, A, B, the bases ...) are read by its
packaging alone (:mod:`sphrom.fmu.resources`, the FMU's model.bin of its kind) and by the operators' own
methods, such as :meth:`~sphrom.rom.operators.ReducedOperators.basis_file_group`.
"""

from __future__ import annotations

import numpy as np

from .bounds import fmu_shadow
from .probes import probe_rows, probe_values


class Operators:
    """The protocol's defaults (module docstring); the operators types derive from it."""

    ports = ()                  # port positions x/L; empty: no ports
    port_errors = ()
    Bp = None                   # port input rows (P, ...) at area 1, None without ports
    Cp = None                   # port velocity rows (P, ...), None without ports
    channel = None              # the port channel that takes every port force (sphrom.rom.port_channel), or None
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

    @property
    def velocity_modes(self):
        """The velocity modes U^v (N, k_v) a POD model's velocity is spanned by (its POD modes first), None for a
        model without a POD basis (the balanced one)."""
        return getattr(self, "U_v", None)

    @property
    def sizes(self):
        """{name: size} of the blocks of z, in order (``slices``' lengths)."""
        return {name: s.stop - s.start for name, s in self.slices.items()}

    @property
    def has_force_input(self):
        """The model takes the scene's force f(t) along its profile (module docstring)."""
        raise NotImplementedError

    def as_state(self, state):
        """A state z of the model as a fresh float array (order,); ValueError naming ``state`` otherwise."""
        z = np.array(state, dtype=float)
        if z.shape != (self.order,):
            raise ValueError(f"state: shape {z.shape} (allowed: ({self.order},), the reduced state z)")
        return z

    def block(self, z, name):
        """The coordinates ``name`` of states z, (M, size) (a view)."""
        return np.atleast_2d(z)[:, self.slices[name]]

    def initial_state(self, velocity_scale=1.0):
        """z0 with its velocity coordinates times ``velocity_scale`` (0: set to exactly 0, the particles at
        rest), the other blocks as they are; ValueError for a model whose state has no ``velocity`` block."""
        if "velocity" not in self.slices:
            raise ValueError(f"velocity_scale: the state's blocks are {', '.join(self.slices)} (no velocity block)")
        z = np.array(self.z0, dtype=float)
        v = self.slices["velocity"]
        z[v] = z[v] * velocity_scale if velocity_scale != 0 else 0.0
        return z

    def fields(self, z):
        """(v [m s^-1], ρ [kg m^-3]) at the particles, (M, N) each, from states z (M, order)."""
        raise NotImplementedError

    def velocity(self, a):
        """v at the particles, (M, N) [m s^-1], from velocity coordinates (module docstring)."""
        raise NotImplementedError

    def port_velocity(self, a):
        """v_port = Cp a [m s^-1], (M, P), from velocity coordinates (M, ...) (:mod:`sphrom.sph.ports`);
        ValueError for operators built without ports."""
        if self.Cp is None:
            raise ValueError("port_velocity: the operators have no ports (build them with ports=...)")
        return np.atleast_2d(a) @ self.Cp.T

    def port_velocity_rows(self, problem, ports):
        """Rows (P, k_v): v_port at ``ports`` (x/L) = rows @ a, from the velocity modes U_v of a POD model (the
        balanced model overrides it; :func:`sphrom.sph.ports.port_velocity_rows`)."""
        from ..sph.ports import port_velocity_rows
        return port_velocity_rows(problem, ports) @ self.U_v

    def velocity_probe_rows(self, problem, probes):
        """Rows (P, k_v): v at ``probes`` (x/L) = rows @ a, from the velocity modes U_v of a POD model (the balanced
        model overrides it), linear between the particles as the FMU interpolates (:func:`probe_rows`)."""
        return probe_rows(self.U_v, problem.x, problem.scene.L, probes)

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

    def bound_shadow(self, problem, probes, *, parametric=False, scale_v=None, model_runs=None, truth=None):
        """The certified shadow of the model's outputs at ``probes`` and its ``ports``
        (:func:`sphrom.rom.bounds.fmu_shadow`: planes of the full linear SPH, as many as the model's own error on
        the reference inputs asks for when ``model_runs`` is given), or None
        where it cannot be certified.

        ``parametric``: the shadow of a model over a range of uniform c and d (its planes in pieces about the
        scene's c); ``scale_v`` [m s^-1]: the training run's largest probe velocity (``error_tolerance``'s
        default is a fraction of it; None: the initial state's).  With the port channel the shadow has the port
        velocity rows and no port input columns: the channel is exact for the port forces and adds its own part and
        bound to each row (fmu_src/rom_bound.c).  ``model_runs``: the model's own runs on the reference inputs
        (:func:`sphrom.rom.bounds.model_errors`), which size the shadow against the model's error.  ``truth``: the
        truth's matrix and growth rate the packaging built once for the shadow and the port channel
        (:func:`sphrom.rom.lti.truth_matrix`; None: built by the shadow)."""
        return fmu_shadow(problem, probes, tuple(self.ports), parametric=parametric, scale_v=scale_v,
                          port_inputs=self.channel is None, model_runs=model_runs, truth=truth)


def two_blocks(first, second, k_first, k_second):
    """The ``slices`` of a state of two blocks, ``first`` (k_first coordinates) then ``second``."""
    return {first: slice(0, k_first), second: slice(k_first, k_first + k_second)}
