"""POD-MOR with density linearisation (eq. 2.17).

Eq. 2.19 for the velocity with the precomputed K, b, D̂, p̂, and eq. 2.20 for
the density with ρ² recomputed from the reconstruction ρ = U^ρ a^ρ at every
evaluation: O(N k) per step.  The frozen model with n_freeze = 1 is this model.

The compiled rate is :func:`sphrom.rom.galerkin._linearized_rates`, on the
Galerkin loop it shares with the original model.
"""

from functools import partial

from .galerkin import INTEGRATORS, run_galerkin
from .model import GalerkinOptions, ReducedModel
from .operators import build_paper, truncate_operators

NAME = "linearized"

MODEL = ReducedModel(
    name=NAME,
    description="POD-MOR with the density linearisation of eq. 2.17 (eqs. 2.19-2.20, ρ² at every step), O(N k)",
    title="Density-linearised POD-MOR (Fang et al., eqs. 2.17-2.20)",
    linear=False, integrators=INTEGRATORS, basis_kind="density", fmu_kind=None,
    builder=build_paper, solver=partial(run_galerkin, NAME, False), truncate=truncate_operators,
    options_type=GalerkinOptions)
