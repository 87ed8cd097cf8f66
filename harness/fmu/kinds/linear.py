"""Model kind 2 of ``resources/model.bin``: every linear model (the exact POD model, the balanced model), advanced
over each communication step exactly by the matrix exponential (fmu_src/rom_exact.c).

The kind's data (:class:`ExactData`), its part of the file (no header of its own; its arrays,
:data:`sphrom.fmu.layout.KINDS`), its packaging step (no build options: no internal step, so no ``n_freeze`` and
no ``dt``), the registry models it holds (:data:`VARIANTS`: section LINMODEL says which), its words and the output
rates the C core gives (:func:`linear_output_rates`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ...progress import progress_bar
from ...rom import parametric as par
from ...rom.exact_linear import linear_runaway_bound, state_rate
from ...rom.modal import real_blocks
from ...rom.operators import probe_rows
from ...rom.port_channel import attach, model_ports
from ...rom.registry import get_model
from ...sph.solver import build_problem
from ..resources import (FLAG_BLOCKS, FLAG_DAMPING, FLAG_INPUT, FLAG_OUTPUT_ROWS, FLAG_SCHUR, LINEAR_BALANCED,
                         LINEAR_EXACT_POD, port_sections, probe_pairs)
from ..training.steps import model_basis, packaging_truth, shadow_step, training_basis, training_envelope
from . import ModelWords, pack

NUMBER = 2
BUILD_OPTIONS = ()
INTERNAL_STEP = False
INITIAL_STATE = "z0"             # what initial_state_scale multiplies (rom.h rom_set_initial_state_scale)
OUTPUT_DERIVATIVE_ORDER = 1      # dy/dt = C (A z + B f) exactly (rom.h rom_max_output_derivative_order)
# the registry models of this kind: name -> the value of section LINMODEL that names it in model.bin
VARIANTS = {"exact": LINEAR_EXACT_POD, "balanced": LINEAR_BALANCED}
MODELS = {
    "exact": ModelWords(
        ports=("Each port's directions are in the basis: the rigid motion and the static deflection under a constant "
               "force exactly, the in-band response (rational moments) and the modes a step makes ring, until the "
               "basis misses at most 0.5 % of the port's step response over the scene's T; what it approximates is "
               "the ringing of the modes left out (larger in a shorter run: the rigid drift grows, the ringing "
               "does not)."),
        what=("POD-Galerkin of the full SPH written in the specific volume, where it is exactly linear (eq. A.9): "
              "no linearisation, exact in time (matrix exponential); each input's directions (rigid motion, static "
              "deflection, in-band moments, the modes a step rings) in the basis"),
        limits="linear in the specific volume only; error = the POD span's",
        when="a component in a system simulation: no internal step, input derivatives integrated exactly"),
    "balanced": ModelWords(
        ports=("The port forces are inputs and the port velocities outputs of the balanced system: what it "
               "approximates is the Hankel-singular-value tail its order tolerance drops."),
        what="balanced truncation of the full linear SPH (2N states) for the FMU's probes; no POD basis",
        limits=("its default order serves a component at rest, not the training run's initial state "
                "(see the training column)"),
        when="forced response from rest at the smallest order; give `--modes` for an initial state"),
}


@dataclass
class ExactData:
    """The contents of a kind-2 model.bin: a linear reduced model (exact POD or balanced).

    Attributes
    ----------
    bound : float
        Runaway bound on |z| (as :func:`sphrom.rom.exact_linear.run_exact`: 10⁶ max|z0|).
    L : float
    k_v : int
    z0, A : ndarray
        (k,), (k, k).
    B : ndarray or None
        (k,) input column.
    damping : bool
    Q, S : ndarray or None
        Real Schur form of a skew A (d = 0).
    Pv : ndarray (P, k_v)
    Pe : ndarray (P, 2, k_e)
    pw, prho0 : ndarray (P, 2)
    probe_x : ndarray (P,)
    token : str
    sections : dict of str to ndarray
        Tagged sections (tag -> 2-D float64 array), in file order.
    output_rows : bool
        Pv (P, k) and Pe (P, 2, k) are rows over the whole state z (flags bit3;
        the balanced model, whose state does not split: k_v = k, k_e = 0).
    bounds : dict or None
        The full report of the certified error bounds computed at packaging
        (:func:`sphrom.rom.balanced.error_bounds`: shift, factor, horizon,
        timings); only their values are stored, in section BOUNDS.
    """

    bound: float
    L: float
    k_v: int
    z0: np.ndarray
    A: np.ndarray
    B: np.ndarray | None
    damping: bool
    Q: np.ndarray | None
    S: np.ndarray | None
    Pv: np.ndarray
    Pe: np.ndarray
    pw: np.ndarray
    prho0: np.ndarray
    probe_x: np.ndarray
    token: str = ""
    integrator: str = "exponential"
    sections: dict = field(default_factory=dict)
    output_rows: bool = False
    bounds: dict | None = None
    blocks: bool = False             # A block diagonal: the model in its real eigen-coordinates (flags bit4)
    block_condition: float = float("nan")   # packaging only: κ(V) of the transform (to_blocks), kept or not
    KIND: ClassVar[int] = 2      # resources/model.bin's model_kind (sphrom.fmu.layout.KINDS)
    INTERNAL_STEP: ClassVar[bool] = INTERNAL_STEP     # the kind's (sphrom.fmu.variables.facts reads it)

    @property
    def k(self):
        return self.z0.size

    @property
    def k_rho(self):
        return self.k - self.k_v

    @property
    def n_probes(self):
        return self.probe_x.size


Data = ExactData


def exact_data(lin, problem, *, probes, bound=None):
    """Collect the exact model's numbers from :class:`sphrom.rom.exact_linear.LinearOperators`."""
    probes = np.asarray(probes, dtype=float)
    L = problem.scene.L
    i0, i1, w = probe_pairs(problem.x, L, probes)
    bound = 1e6 * max(float(np.max(np.abs(lin.z0))), 1e-300) if bound is None else bound
    rho0 = np.asarray(lin.rho0, float)
    return ExactData(bound=float(bound), L=float(L), k_v=lin.k_v,
                     z0=np.asarray(lin.z0, float), A=np.asarray(lin.A, float),
                     B=None if lin.B is None else np.asarray(lin.B, float), damping=not lin.skew,
                     Q=np.asarray(lin.schur_Q, float) if lin.skew else None,
                     S=np.asarray(lin.schur_T, float) if lin.skew else None,
                     Pv=probe_rows(lin.U_v, problem.x, L, probes),
                     Pe=np.stack([lin.U_e[i0], lin.U_e[i1]], axis=1),
                     pw=np.stack([1.0 - w, w], axis=1), prho0=np.stack([rho0[i0], rho0[i1]], axis=1),
                     probe_x=probes,
                     sections={"LINMODEL": np.array([[LINEAR_EXACT_POD]], float), **port_sections(lin)})


def balanced_data(ops, problem, *, bound=None):
    """The numbers of a kind-2 model.bin for the balanced model (:class:`sphrom.rom.balanced_model.BalancedOperators`).

    The state x_r (r numbers) does not split: k_v = r, k_e = 0 and the probe rows
    are over the whole state (``output_rows``).  Velocity rows: Cr's probe
    velocity rows.  e rows: the reconstruction e = (V x_r)_e / √c at the probe's two
    particles, whose interpolation (weights pw) is Cr's probe-e row.  The probes
    are those the model was balanced for (``ops.lti.probes``).
    """
    lti, red = ops.lti, ops.reduced
    probes = np.asarray(lti.probes, float)
    L = problem.scene.L
    i0, i1, w = probe_pairs(problem.x, L, probes)
    n, P = lti.n, lti.n_probes
    Ve = red.V[n:] / lti.w_e[:, None]                        # e at every particle per unit x_r
    bound = 1e6 * max(float(np.max(np.abs(ops.z0))), 1e-300) if bound is None else bound
    rho0 = np.asarray(ops.rho0, float)
    return ExactData(bound=float(bound), L=float(L), k_v=ops.order,
                     z0=np.asarray(ops.z0, float), A=np.asarray(ops.A, float), B=np.asarray(ops.B, float),
                     damping=not ops.skew, Q=np.asarray(ops.schur_Q, float) if ops.skew else None,
                     S=np.asarray(ops.schur_T, float) if ops.skew else None,
                     Pv=np.asarray(red.Cr[:P], float), Pe=np.stack([Ve[i0], Ve[i1]], axis=1),
                     pw=np.stack([1.0 - w, w], axis=1), prho0=np.stack([rho0[i0], rho0[i1]], axis=1),
                     probe_x=probes, output_rows=True, sections={"LINMODEL": np.array([[LINEAR_BALANCED]], float),
                                                                  **port_sections(ops)})


def to_blocks(data):
    """``data`` in the model's real eigen-coordinates y = V⁻¹ z (:func:`sphrom.rom.modal.real_blocks`): A block
    diagonal (1 x 1 and 2 x 2 blocks, flags bit4), stepped block by block by the C core at O(k (2 + 2 inputs)) per
    step instead of O(k²); B, z0 and the port input rows times V⁻¹, every output row (the probes' v and e, the ports'
    v) times V over the whole state (output rows; k_v, k_e keep sizing the state's two blocks), the runaway bound
    times ‖V⁻¹‖.  Where the transform is not well
    conditioned (κ(V) above :data:`sphrom.rom.modal.BLOCK_CONDITION`, or its residual above round-off: a damped A
    near a defective one) ``data`` is kept dense; ``block_condition`` says κ(V) either way.  A parametric model (A
    assembled from pieces at run time) stays dense."""
    import dataclasses

    if data.blocks or "A0" in data.sections:
        return data
    rb = real_blocks(data.A, skew=not data.damping)
    if not rb.usable:
        return dataclasses.replace(data, block_condition=rb.condition)
    k, kv = data.k, data.k_v
    V, W = rb.V, rb.V_inv
    P = data.n_probes
    Pv = data.Pv if data.output_rows else np.hstack([data.Pv, np.zeros((P, k - kv))])
    Pe = data.Pe if data.output_rows else np.concatenate([np.zeros((P, 2, kv)), data.Pe], axis=2)
    sections = dict(data.sections)
    if "PORTC" in sections:                          # rows over a (k_v), or over z already (output rows)
        Cp = np.asarray(sections["PORTC"], float)
        sections["PORTC"] = np.hstack([Cp, np.zeros((Cp.shape[0], k - Cp.shape[1]))]) @ V
    if "PORTB" in sections:                          # input columns over z, stored as rows
        sections["PORTB"] = (W @ np.asarray(sections["PORTB"], float).T).T
    return dataclasses.replace(data, bound=float(data.bound * np.linalg.norm(W, 2)), z0=W @ data.z0, A=rb.L,
                               B=None if data.B is None else W @ data.B, Q=None, S=None, Pv=Pv @ V,
                               Pe=np.einsum("psk,kj->psj", Pe, V), output_rows=True, blocks=True,
                               block_condition=rb.condition, sections=sections)


def from_operators(ops, problem, *, probes, bound=None):
    """:func:`exact_data` of operators built elsewhere (a benchmark's own); the runaway bound 10⁶ max|z0| unless
    given."""
    return exact_data(ops, problem, probes=probes, bound=bound)


def parametric(affine, c, d, problem, *, probes):
    """(data, operators, the affine pieces' sections A0, AC, AD) of a parametric linear model at (c, d)
    (:func:`sphrom.fmu.make.parametric.parametric_resource`; the C core assembles A = A_0 + c A_c + d A_d)."""
    lin = par.linear_at(affine, c, d)
    return exact_data(lin, problem, probes=probes), lin, {"A0": affine.A0, "AC": affine.Ac, "AD": affine.Ad}

def example(rng):
    """A small linear model with random numbers in the layout's shapes (k_v = 3, k_e = 2, two probes, damping,
    an input), for tests of the file and the core: its numbers are not a physical model's."""
    kv, ke, npr = 3, 2, 2
    k = kv + ke
    return ExactData(bound=1e6, L=0.5, k_v=kv, z0=0.01 * rng.normal(size=k), A=-np.eye(k) + 0.1 * rng.normal(size=(k, k)),
                     B=rng.normal(size=k), damping=True, Q=None, S=None, Pv=rng.normal(size=(npr, kv)),
                     Pe=0.01 * rng.normal(size=(npr, 2, ke)), pw=np.full((npr, 2), 0.5), prho0=np.ones((npr, 2)),
                     probe_x=np.array([0.25, 0.5]))

# ---------------------------------------------------------------------------------------------------------------
# its part of model.bin (sphrom.fmu.kinds pack, unpack; the shared pieces sphrom.fmu.resources write, read)
# ---------------------------------------------------------------------------------------------------------------

def min_k_rho(flags):
    """The smallest k_e of a linear model's header: 0 with output rows over z (a state that does not split)."""
    return 0 if flags & FLAG_OUTPUT_ROWS else 1


def file_fields(data):
    """(shared header fields, None: no header of its own, {array name: array}) of ``data`` for
    :func:`sphrom.fmu.resources.pack`."""
    if data.Q is not None and data.damping:
        raise ValueError("a Schur form needs a skew operator (no damping)")
    if data.blocks and (data.Q is not None or not data.output_rows):
        raise ValueError("blocks: the block-diagonal form has output rows over z and no Schur form")
    rows = bool(data.output_rows)
    flags = ((FLAG_DAMPING if data.damping else 0) | (FLAG_INPUT if data.B is not None else 0)
             | (FLAG_SCHUR if data.Q is not None else 0) | (FLAG_OUTPUT_ROWS if rows else 0)
             | (FLAG_BLOCKS if data.blocks else 0))
    header = {"k_v": data.k_v, "k_rho": data.k - data.k_v, "n_probes": data.n_probes, "flags": flags,
              "runaway_bound": data.bound, "L": data.L}
    arrays = {name: getattr(data, name) for name in ("z0", "A", "B", "Q", "S", "Pv", "Pe", "pw", "prho0", "probe_x")}
    return header, None, arrays


def from_file(header, head, arrays, token, sections):
    """The :class:`ExactData` of a linear model.bin's fields (:func:`sphrom.fmu.resources.unpack`)."""
    flags = header["flags"]
    return ExactData(bound=header["runaway_bound"], L=header["L"], k_v=header["k_v"], z0=arrays["z0"], A=arrays["A"],
                     B=arrays.get("B"), damping=bool(flags & FLAG_DAMPING), Q=arrays.get("Q"), S=arrays.get("S"),
                     Pv=arrays["Pv"], Pe=arrays["Pe"], pw=arrays["pw"], prho0=arrays["prho0"],
                     probe_x=arrays["probe_x"], token=token, sections=sections,
                     output_rows=bool(flags & FLAG_OUTPUT_ROWS), blocks=bool(flags & FLAG_BLOCKS))


# ---------------------------------------------------------------------------------------------------------------
# packaging
# ---------------------------------------------------------------------------------------------------------------

def resource(scene, model, k, n_freeze, probes, integrator, progress, problem, order_tolerance=None,
             bounds=True, ports=(), build_options=None, extra_steps=(), error_bounds=True):
    """The packaging step of kind 2 (``sphrom.fmu.make.package.model_step``): the exact POD model (on its basis, with its training envelope) or the balanced model (no basis);
    both with the certified error bounds against the full linear SPH at the FMU's probes (the operators'
    ``error_bounds``; section BOUNDS: force, initial state), unless ``bounds`` is False (benchmarks that time
    the stepping only: the bounds take seconds to minutes at N = 400).  ``n_freeze`` and ``integrator`` are not
    this kind's options (a linear model has no internal step): the caller's values are ignored."""

    build_options = dict(build_options or {})
    # the model in its real eigen-coordinates (to_blocks): O(k) per step instead of O(k²), the dense form
    # kept where the transform is ill-conditioned; build option blocks=False keeps it dense (the form of before)
    blocks = bool(build_options.pop("blocks", True))
    if get_model(model).needs_basis:
        basis, run, problem = training_basis(scene, progress, problem, extra_steps)
        truth = packaging_truth(problem, ports, build_options, error_bounds)   # the channel's and the shadow's
        data, ops, problem, _ = exact_model(scene, k, probes, progress=progress,
                                            problem=problem,
                                            model=model, ports=ports, build_options=build_options,
                                            made=(basis, run), truth=truth)
        data.sections.update(training_envelope(scene, ops, problem, probes, True, progress, run=run).sections())
    else:
        problem = problem or build_problem(scene)
        truth = packaging_truth(problem, ports, build_options, error_bounds)
        data, ops, problem = balanced_model(scene, k, probes,
                                            order_tolerance=order_tolerance,
                                            problem=problem, model=model, build_options=build_options, ports=ports,
                                            truth=truth)
    if error_bounds:
        shadow_step(data, ops, problem, probes, truth=truth)
    if blocks:
        data = to_blocks(data)          # its real eigen-coordinates where well conditioned (the dense form kept else)
    if not bounds:
        return data, ops, pack(data)
    data.bounds = linear_bounds(ops, problem, probes, progress=progress)
    data.sections["BOUNDS"] = np.vstack([data.bounds["force_error_bound"], data.bounds["initial_state_error_bound"]])
    return data, ops, pack(data)


def parameter_starts(data):
    """None of the kind's own FMU parameters: a linear model has no n_freeze and no dt."""
    return {}


def exact_model(scene, k, probes, progress=True, problem=None, model="exact", ports=(),
                build_options=None, made=None, truth=None):
    """The FMU's numbers for a model of resource kind 2 on a POD basis (the exact model):
    (ExactData, lin, problem, basis).

    The model's bases (the exact model: the energy-weighted ``Basis.U_ve``, ``U_e``), the operators with the
    model's ``fmu_input_direction`` (the exact model: ``"always"``, the force profile is always in its
    velocity basis, so the input f is represented exactly) and ``build_options``.  ``truth``: the packaging's
    truth's matrix for the port channel (:func:`sphrom.fmu.training.steps.packaging_truth`; None: built there).
    """

    spec = get_model(model)
    basis, problem = model_basis(scene, spec, k, progress=progress, problem=problem, made=made)
    own_ports, options, channel = model_ports(problem, ports, build_options)
    lin = spec.build(problem, basis, k, k, input_direction=spec.fmu_input_direction,
                     **({"ports": own_ports} if own_ports else {}), **options)
    if channel:                     # the portless model and the port channel, which takes every port force
        lin = attach(lin, problem, ports, probes, truth=truth)
    data = exact_data(lin, problem, probes=probes, bound=linear_bound(lin, scene))
    return data, lin, problem, basis


def balanced_model(scene, k, probes, order_tolerance=None, problem=None, model="balanced",
                   build_options=None, ports=(), truth=None):
    """The FMU's numbers for a linear model without a POD basis (balanced): (ExactData, ops, problem).

    The full linear SPH of the scene with the FMU's probes as outputs, balanced
    and truncated at order ``k`` (or the order ``order_tolerance`` gives; the default
    tolerance when both are None); :func:`sphrom.fmu.resources.balanced_data`.  ``truth``: the packaging's
    truth's matrix for the port channel (:func:`sphrom.fmu.training.steps.packaging_truth`; None: built there).
    """

    problem = problem or build_problem(scene)
    own_ports, options, channel = model_ports(problem, ports, build_options)
    if channel:                     # balanced for the port velocities as outputs; the channel takes the port forces
        options["port_outputs"] = tuple(ports)
    try:
        ops = get_model(model).build(problem, None, k, k, order_tolerance=None if k is not None else order_tolerance,
                                     probes=probes, **({"ports": own_ports} if own_ports else {}),
                                     **options)
    except ValueError as exc:
        field_name, _, detail = str(exc).partition(": ")
        from ...errors import FieldError
        raise FieldError("k" if field_name == "order" else field_name, detail) from None
    if channel:
        ops = attach(ops, problem, ports, probes, truth=truth)
    return balanced_data(ops, problem), ops, problem


def linear_bounds(ops, problem, probes, progress=True):
    """The certified error bounds of a linear reduced model at the velocity probes (the operators'
    ``error_bounds``, :func:`sphrom.rom.balanced.error_bounds`), with a progress bar over the probes."""
    with progress_bar(len(probes), "error bounds", unit="probe", enabled=progress) as bar:
        return ops.error_bounds(problem, probes, progress=bar)


def linear_bound(lin, scene, samples=4097):
    """The linear FMU's runaway bound on |z|: 10⁶ (|z0| + |B| ∫_0^T |f| dt) with the scene's force over its T
    (:func:`sphrom.rom.exact_linear.linear_runaway_bound`; trapezoidal rule on ``samples`` points).

    10⁶ |z0| alone is 0 for a scene at rest, and such an FMU stopped as a runaway at its first forced step.
    """
    t = np.linspace(0.0, float(scene.T), samples)
    f = np.abs(np.asarray(scene.force(t), float)) if lin.B is not None else np.zeros(samples)
    return linear_runaway_bound(lin, float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t))))

def model_name(data):
    """The registered reduced model a linear model.bin holds: section LINMODEL's (the exact model without it)."""
    linmodel = data.sections.get("LINMODEL")
    number = LINEAR_EXACT_POD if linmodel is None else int(linmodel[0, 0])
    return next(name for name, value in VARIANTS.items() if value == number)


def integrator(data):
    """None: a linear model has no time integrator of its own (exact in time)."""
    return None


# ---------------------------------------------------------------------------------------------------------------
# its words (modelDescription, documentation/index.html)
# ---------------------------------------------------------------------------------------------------------------

def stepping(data):
    """modelDescription's words on the time stepping."""
    return ("advanced over each communication step by the matrix exponential (input held, or linear "
            "with fmi2SetRealInputDerivatives in FMI 2): no internal step, so no parameters dt and n_freeze")


def model_rows(data):
    """The documentation page's rows (quantity, HTML value) on the time stepping."""
    return [("time stepping", "the matrix exponential over each communication step (exact in time; no "
                              "internal step, so no parameters dt and n_freeze)")]


def usage(data):
    """The documentation page's sentence on how the FMU steps (HTML)."""
    return "It is exact in time over any communication step h &gt; 0 (the matrix exponential; no internal step)."


# ---------------------------------------------------------------------------------------------------------------
# the output rates the C core gives (fmi2GetRealOutputDerivatives)
# ---------------------------------------------------------------------------------------------------------------

def linear_output_rates(data, z, f=0.0):
    """First time derivatives of the probe outputs of a linear model (an ExactData) in state ``z`` (k,) with the
    input ``f`` [m s^-2] now, as fmu_src/rom_exact.c gives them (fmi2GetRealOutputDerivatives).

    dz/dt = A z + B f; dv_j/dt = Pv[j] . (dz/dt)_a; ρ_j = Σ_m w_m ρ0_m / J_m with J_m = 1 + Pe[j][m] . b, so
    dρ_j/dt = -Σ_m w_m ρ0_m (Pe[j][m] . (db/dt)) / J_m² (with output rows, over the whole z instead of a, b).  Returns (dv/dt [m s^-2], dρ/dt [kg m^-3 s^-1]).
    """
    z = np.asarray(z, float)
    zdot = state_rate(data.A, data.B, z, f)
    kv = 0 if data.output_rows else data.k_v       # rows over the whole z (output rows: the block form, balanced)
    dv = data.Pv @ (zdot if data.output_rows else zdot[:kv])
    J = 1.0 + np.einsum("psk,k->ps", data.Pe, z[kv:])
    dJ = np.einsum("psk,k->ps", data.Pe, zdot[kv:])
    drho = -np.sum(data.pw * data.prho0 * dJ / (J * J), axis=1)
    return dv, drho
