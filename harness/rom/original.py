"""The original POD-MOR: Galerkin projection (eq. 2.16, Φ = U) of the full SPH
right-hand side (eqs. 2.10-2.11), evaluated at the reconstructed state
v = U^v a^v, ρ = U^ρ a^ρ: O(N k) per step, exact for k = N.

The compiled rate is :func:`sphrom.rom.galerkin._original_rates`, on the
Galerkin loop it shares with the density-linearised model.
"""

from functools import partial

from .galerkin import INTEGRATORS, run_galerkin
from .model import GalerkinOptions, ReducedModel
from .operators import build_paper, truncate_operators

NAME = "original"

MODEL = ReducedModel(
    name=NAME,
    description="the paper's original POD-MOR (eq. 2.16): the full SPH right-hand side projected, O(N k) per step",
    title="Original POD-MOR (Fang et al., eq. 2.16)",
    linear=False, integrators=INTEGRATORS, basis_kind="density", fmu_kind=None,
    builder=build_paper, solver=partial(run_galerkin, NAME, True), truncate=truncate_operators,
    options_type=GalerkinOptions)
