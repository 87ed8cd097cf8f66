"""Independent continuum solutions of eqs. 2.2-2.4, against which the SPH and reduced models are judged.

Public names (imported from their modules on first use)::

    exact_solution, is_available, check_available, ExactUnavailable   the exact Fourier solution  (exact)
    best_reference                     the best reference of a scene without an exact one      (continuum)
    Reference                          what every reference returns                             (common)
    study                              convergence against the exact solution                   (convergence)

The three discretisations are modules with one ``solve(scene, resolution, dt,
x, t, ...)`` each: ``skfem_ref`` (scikit-fem), ``pypde_ref`` (py-pde), ``fd``
(the paper's finite differences); ``from sphrom.references import fd`` then
``fd.solve(...)``.
"""

from ..lazy import lazy_exports

EXPORTS = {
    "exact_solution": "exact", "is_available": "exact", "check_available": "exact", "ExactUnavailable": "exact",
    "best_reference": "continuum", "Reference": "common", "study": "convergence",
}
__all__ = sorted(EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)
