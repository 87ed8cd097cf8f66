"""What a reduced model is to the rest of sphrom: its properties as data, one way to build and one way to run it.

Every model module defines one :class:`ReducedModel` (``MODEL``) and
:mod:`sphrom.rom.registry` lists them.  Code outside the registry asks a
model's properties (``linear``, ``uses_n_freeze``, ``needs_basis`` ...) instead
of comparing model names, and the operators a model builds answer the protocol
of :mod:`sphrom.rom.protocol` (order, named slices of the state z, fields,
outputs, error bounds and their shadow).

``model.build(problem, basis, k_v, k_rho, **options) -> operators``
    The model's operators from the first k_v, k_rho modes of a POD basis
    (:class:`sphrom.pod.basis.Basis`) of the kind ``basis_kind`` names (a
    model that ``needs_basis`` False ignores ``basis`` and takes its order from
    ``k_v`` or from an ``order_tolerance``).  ``options`` are the model's build
    options (``build_options``: its builder's keyword arguments, with the
    model's ``build_defaults``); any other is a ValueError naming it.
``model.run(ops, problem, *, dt, n_steps, sample_steps=None, every=1, force=None, state=None,
initial_state_scale=1.0, bound=None, progress=False, options=None, port_forces=None, area=1.0) -> ReducedResult``
    The one way to run any reduced model: ``get_model(name).run(ops, problem,
    ..., options=get_model(name).options(...))``.  The arguments every model
    shares: from t = 0 to ``n_steps * dt`` [s],
    sampled at ``sample_steps`` (default every ``every`` steps and the last);
    ``force`` f(t) [m s^-2] (default the scene's); ``state`` the initial reduced
    state z (default the operators' ``z0``); ``initial_state_scale`` multiplies
    the initial state's deviation from rest (the velocity coordinates; for a
    linear model the whole z, whose rest is z = 0), as the FMU parameter of that
    name (1 leaves the run bit for bit as without it; the runaway bound stays
    that of the unscaled state); ``bound`` the runaway bound; ``progress`` a
    progress bar where the model steps in time.  Models with ``ports`` take
    ``port_forces`` (F(t) -> (len(t), P) [N]) and ``area`` [m^2] (operators
    built with ``ports=X``); the others refuse them.  ``options``: the model's
    own options object (``model.options(...)``, default its defaults):

    * :class:`GalerkinOptions` (original, linearized): ``integrator``;
    * :class:`FrozenOptions` (frozen): ``n_freeze``, ``refresh``, ``integrator``;
    * :class:`LinearOptions` (exact, balanced): ``step`` (the communication step
      H [s], default the sample spacing) and ``hold`` (``linear`` or ``held``
      input over a step).

    Raises SimulationError on a non-finite or runaway state, naming the step
    and time; ValueError for options of another model.
``model.truncate(problem, operators, k_v, k_rho) -> operators``
    The operators of the first k_v, k_rho modes, sliced from larger ones
    (equal to ``build`` at the smaller counts, to round-off); only what a
    slice cannot give (an appended input direction, a Schur form, a
    rest-consistent b) is rebuilt.
"""

from __future__ import annotations

import dataclasses
import inspect
from dataclasses import dataclass, field
from typing import Callable

from .. import defaults
from ..errors import UserError

# basis kind -> (velocity modes, second modes, symbol of the second block, what the modes are)
BASIS_KINDS = {
    "density": ("U_v", "U_rho", "rho", "POD modes of v and ρ (Euclidean inner product, eq. 2.15)"),
    "energy": ("U_ve", "U_e", "J", "POD modes of v and of the specific volume e = ρ0/ρ - 1 in the energy inner "
                                   "products (weights ρ0 and c)"),
}
HOLDS = ("linear", "held")


@dataclass(frozen=True)
class GalerkinOptions:
    """Run options of the paper's original and density-linearised models.

    integrator : str, optional
        One of the model's ``integrators`` (default the first, explicit Euler).
    """

    integrator: str | None = None


@dataclass(frozen=True)
class FrozenOptions:
    """Run options of the frozen-coefficient model (eqs. 2.19-2.24).

    n_freeze : int
        Refresh period of the coefficients [internal steps] (eq. 2.23), >= 1.
    refresh : {"tensor", "direct"}
        The exact refresh tensor (no N) or the O(N k²) reference product.
    integrator : {"euler", "symplectic"}, optional
        Default the first.
    """

    n_freeze: int = defaults.N_FREEZE
    refresh: str = defaults.REFRESH
    integrator: str | None = None

    def __post_init__(self):
        if isinstance(self.n_freeze, bool) or int(self.n_freeze) != self.n_freeze or self.n_freeze < 1:
            raise ValueError(f"n_freeze: {self.n_freeze!r} is out of range (allowed: an integer >= 1)")


@dataclass(frozen=True)
class LinearOptions:
    """Run options of the linear models, advanced exactly in time (exact, balanced).

    step : float, optional
        The communication step H [s] (default the smallest sample spacing).
    hold : {"linear", "held"}
        The input over a step: linear between its end values, or held at its start value.
    """

    step: float | None = None
    hold: str = defaults.HOLD

    def __post_init__(self):
        if self.hold not in HOLDS:
            raise ValueError(f"hold: {self.hold!r} is out of range (allowed: {', '.join(HOLDS)})")


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
        The time integrators of the model, the default first (``exponential`` for a linear one).
    basis_kind : {"density", "energy"} or None
        The POD modes ``build`` takes (:data:`BASIS_KINDS`); None: the model
        needs no POD basis (``needs_basis`` False).
    fmu_kind : int or None
        The ``model_kind`` of the FMU's ``resources/model.bin`` the model is
        packaged as (:mod:`sphrom.fmu.resources`: 1 the frozen-coefficient
        layout K, b, D̂, p̂, T; 2 the linear layout A, B, z0 and a Schur form);
        None when it cannot be packaged as an FMU.
    builder : callable
        ``builder(problem, basis, k_v, k_rho, **options) -> operators``, called by :meth:`build`.
    solver : callable
        ``solver(ops, problem, *, <the shared arguments>, options[, port_forces, area]) -> ReducedResult``,
        called by :meth:`run` once the options are checked.
    truncate : callable
        Module docstring.
    options_type : type
        The model's run options (:class:`GalerkinOptions`, :class:`FrozenOptions`, :class:`LinearOptions`).
    build_defaults : dict
        Build options whose registry default differs from the builder's: the frozen model's
        ``b="rest"`` (b = K a^ρ_rest, rest an equilibrium: the FMU's frozen model).
    paper_build : dict
        The build options that give the paper's variant of the model (the frozen model: ``b="paper"``,
        eq. 2.22's b); {} when the registry's model is the paper's.  The density models' paper variants
        share their operators.
    fmu_input_direction : str
        How the force profile enters the model's FMU (``input_direction`` of
        ``build``): ``"needed"`` appends its residual to the velocity modes
        only when they miss more than 1 % of it (the frozen model: a small
        appended residual is a rough mode its Galerkin coupling excites),
        ``"always"`` appends it whenever it is not in their span to round-off
        (a linear model: the input is then represented exactly).
    ports : bool
        The model takes mechanical port forces as inputs and gives port velocities (``build(..., ports=X)``,
        ``run(..., port_forces=F, area=A)``; :mod:`sphrom.sph.ports`), so its FMU can have ports.
    """

    name: str
    description: str
    title: str
    linear: bool
    integrators: tuple
    basis_kind: str | None
    fmu_kind: int | None
    builder: Callable
    solver: Callable
    truncate: Callable
    options_type: type
    build_defaults: dict = field(default_factory=dict, hash=False)        # (not hashed: a model stays hashable)
    paper_build: dict = field(default_factory=dict, hash=False)
    fmu_input_direction: str = "needed"
    ports: bool = False

    # ---- properties asked by code outside the registry ---------------------------------------------------------

    @property
    def needs_basis(self):
        """The model is built on a POD basis (``basis_kind`` set); False: on the full linear SPH (balanced)."""
        return self.basis_kind is not None

    @property
    def option_names(self):
        """The names of the model's run options (the fields of ``options_type``)."""
        return tuple(f.name for f in dataclasses.fields(self.options_type))

    @property
    def uses_n_freeze(self):
        """The refresh period ``n_freeze`` (and ``refresh``) are options of the model."""
        return "n_freeze" in self.option_names

    @property
    def build_options(self):
        """The names of the model's build options (its builder's keyword arguments)."""
        return tuple(p.name for p in inspect.signature(self.builder).parameters.values()
                     if p.kind is inspect.Parameter.KEYWORD_ONLY)

    @property
    def sized_by_tolerance(self):
        """The model's order may come from ``order_tolerance`` instead of a mode count (balanced)."""
        return "order_tolerance" in self.build_options

    @property
    def second_symbol(self):
        """Symbol of the second block of coordinates: ``rho`` (density), ``J`` (specific volume), None (the
        state is one block)."""
        return BASIS_KINDS[self.basis_kind][2] if self.needs_basis else None

    def max_modes(self, n_particles):
        """The largest mode count (POD models: N) or order (r < 2N) of the model for ``n_particles``."""
        return n_particles if self.needs_basis else 2 * n_particles - 1

    def available_modes(self, basis):
        """(velocity modes, second modes) that ``basis`` holds for the model, or None when it has none of them
        (a basis made by an older sphrom); None for a model that needs no basis."""
        if not self.needs_basis:
            return None
        modes = [getattr(basis, name, None) for name in BASIS_KINDS[self.basis_kind][:2]]
        return None if any(U is None for U in modes) else tuple(U.shape[1] for U in modes)

    # ---- build, options, run ------------------------------------------------------------------------------------

    def build(self, problem, basis, k_v, k_rho, **options):
        """The model's operators (module docstring); ValueError naming an option the model does not take."""
        self._check_names(options, self.build_options, "build option")
        return self.builder(problem, basis, k_v, k_rho, **{**self.build_defaults, **options})

    def options(self, **values):
        """The model's run options object from ``values``; ValueError naming one that is not the model's."""
        self._check_names(values, self.option_names, "option")
        return self.options_type(**values)

    def select_options(self, **candidates):
        """The model's run options from those of ``candidates`` it has, the others left out on purpose: for a
        study that runs several models with common settings (``n_freeze`` for the frozen model, ``step`` for
        the linear ones ...)."""
        return self.options_type(**{k: v for k, v in candidates.items() if k in self.option_names})

    def run(self, ops, problem, *, dt, n_steps, sample_steps=None, every=1, force=None, state=None,
            initial_state_scale=1.0, bound=None, progress=False, options=None, port_forces=None, area=1.0):
        """Run the model (module docstring) -> :class:`~sphrom.rom.result.ReducedResult`."""
        if options is None:
            options = self.options_type()
        elif not isinstance(options, self.options_type):
            raise ValueError(f"options: a {type(options).__name__} is not the {self.name} model's "
                             f"({self.options_type.__name__}: {', '.join(self.option_names)})")
        shared = dict(dt=dt, n_steps=n_steps, sample_steps=sample_steps, every=every, force=force, state=state,
                      initial_state_scale=initial_state_scale, bound=bound, progress=progress, options=options)
        if self.ports:
            shared.update(port_forces=port_forces, area=area)
        elif port_forces is not None:
            raise ValueError(f"port_forces: the {self.name} model takes no port forces")
        return self.solver(ops, problem, **shared)

    def _check_names(self, given, allowed, what):
        for name in given:
            if name not in allowed:
                article = "an" if what[0] in "aeiou" else "a"
                raise ValueError(f"{name}: not {article} {what} of the {self.name} model (its {what}s: "
                                 f"{', '.join(allowed) or 'none'})")


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
