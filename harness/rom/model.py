"""What a reduced model is to the rest of sphrom: its properties as data and one way to build and run it.

Every model module defines one :class:`ReducedModel` (``MODEL``) and
:mod:`harness.rom.registry` lists them.  Code outside the registry asks a
model's properties (``linear``, ``uses_n_freeze``, ``basis_kind`` ...) instead
of comparing model names.

The three callables share one signature across models (keywords a model has no
use for are ignored, so one call serves every model):

``build(problem, basis, k_v, k_rho, *, input_direction="auto", input_tolerance=None, tensor="auto") -> operators``
    The model's operators from the first k_v, k_rho modes of a POD basis
    (:class:`harness.pod.basis.Basis`) of the kind ``basis_kind`` names.
``run(operators, problem, *, dt, n_steps, sample_steps=None, every=1, force=None, integrator=None, n_freeze=10,
refresh="tensor", step=None, hold="linear", state=None, bound=None, progress=False, initial_state_scale=1.0)
-> ReducedResult``
    From t = 0 to ``n_steps * dt`` [s], sampled at ``sample_steps`` (default
    every ``every`` steps and the last); ``force`` f(t) [m s^-2] (default the
    scene's); ``integrator`` one of ``integrators`` (default the first);
    ``n_freeze``, ``refresh`` for models with ``uses_n_freeze``; ``step`` (the
    communication step H [s], default the sample spacing) and ``hold``
    (``linear`` or ``held`` input over a step) for linear models; ``state`` the
    initial reduced coordinates (a_v, a_rho); ``initial_state_scale`` multiplies
    the initial state's deviation from rest (the velocity coordinates; for a
    linear model the whole z, whose rest is z = 0), as the FMU parameter of
    that name (1, the default, leaves the run bit for bit as without it; the
    runaway bound stays that of the unscaled state).  Raises SimulationError on a
    non-finite or runaway state, naming the step and time.  Models with
    ``ports`` also take ``port_forces`` (F(t) -> (len(t), P) [N]) and ``area``
    [m^2] (operators built with ``build(..., ports=X)``).
``truncate(problem, operators, k_v, k_rho) -> operators``
    The operators of the first k_v, k_rho modes, sliced from larger ones
    (equal to ``build`` at the smaller counts, to round-off); only what a
    slice cannot give (an appended input direction, a Schur form) is rebuilt.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..errors import UserError

# basis kind -> (velocity modes, second modes, symbol of the second block, what the modes are)
BASIS_KINDS = {
    "density": ("U_v", "U_rho", "rho", "POD modes of v and ρ (Euclidean inner product, eq. 2.15)"),
    "energy": ("U_ve", "U_e", "J", "POD modes of v and of the specific volume e = ρ0/ρ - 1 in the energy inner "
                                   "products (weights ρ0 and c)"),
    None: (None, None, None, "no POD basis: the model reduces the full linear SPH itself (balanced)"),
}


@dataclass(frozen=True)
class ReducedModel:
    """One reduced model (module docstring).

    Attributes
    ----------
    name : str
        The registry name (``sphrom rom --model NAME``).
    description : str
        One line.
    title : str
        The model's long name (FMU model descriptions).
    linear : bool
        Linear time-invariant, advanced exactly in time (matrix exponential,
        any communication step); no time-integrator error.
    integrators : tuple of str
        The time integrators ``run`` accepts, the default first.
    uses_n_freeze : bool
        The refresh period ``n_freeze`` (and ``refresh``) matter.
    basis_kind : {"density", "energy"} or None
        The modes ``build`` takes (:data:`BASIS_KINDS`); None: the model
        needs no POD basis, ``build`` ignores ``basis`` and takes its order
        from ``k_v`` (or a ``tolerance`` option).
    fmu_kind : int or None
        The ``model_kind`` of the FMU's ``resources/model.bin`` the model is
        packaged as (:mod:`harness.fmu.resources`: 1 the frozen-coefficient
        layout K, b, D̂, p̂, T; 2 the linear layout A, B, z0 and a Schur form);
        None when it cannot be packaged as an FMU.
    build, run, truncate : callable
        Module docstring.
    fmu_input_direction : str
        How the force profile enters the model's FMU (``input_direction`` of
        ``build``): ``"needed"`` appends its residual to the velocity modes
        only when they miss more than 1 % of it (the frozen model: a small
        appended residual is a rough mode its Galerkin coupling excites),
        ``"always"`` appends it whenever it is not in their span to round-off
        (a linear model: the input is then represented exactly).
    ports : bool
        The model takes mechanical port forces as inputs and gives port velocities (``build(..., ports=X)``,
        ``run(..., port_forces=F, area=A)``; :mod:`harness.sph.ports`), so its FMU can have ports.
    """

    name: str
    description: str
    title: str
    linear: bool
    integrators: tuple
    uses_n_freeze: bool
    basis_kind: str | None
    fmu_kind: int | None
    build: Callable
    run: Callable
    truncate: Callable
    fmu_input_direction: str = "needed"
    ports: bool = False

    @property
    def second_symbol(self):
        """Symbol of the second block of coordinates: ``rho`` (density), ``J`` (specific volume), None (no
        second block)."""
        return BASIS_KINDS[self.basis_kind][2]


def basis_modes(basis, kind, k_v, k_rho):
    """The first ``k_v`` velocity and ``k_rho`` second modes of ``basis`` for a basis ``kind``.

    Raises UserError naming the basis field when the basis has no such modes or fewer than asked.
    """
    names = BASIS_KINDS[kind][:2]
    modes = [getattr(basis, name, None) for name in names]
    if any(m is None for m in modes):
        raise UserError(f"the basis has no {' and '.join(names)} ({BASIS_KINDS[kind][3]}; made by an older sphrom): "
                        "rebuild it with 'sphrom pod'")
    for name, U, k in zip(names, modes, (k_v, k_rho)):
        if not 1 <= k <= U.shape[1]:
            raise UserError(f"{k} {name} modes are out of range (allowed: 1 to {U.shape[1]}, the basis' modes)")
    return modes[0][:, :k_v], modes[1][:, :k_rho]
