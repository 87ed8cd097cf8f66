"""Errors of a run against a reference, in the forms every report quotes."""

import numpy as np

from .norms import relative_l2


def error_table(v, rho, v_ref, rho_ref, t, rho0):
    """Relative L² errors (eq. 3.4) of (v, ρ) against (v_ref, ρ_ref).

    Returns a dict: ``v`` and ``rho`` (square-root form, the headline),
    ``rho_var`` (ρ measured as ρ - ρ0, the informative one), and the
    squared forms printed in the paper's eq. 3.4 (``v_sq``, ``rho_sq``).
    """
    return {
        "v": relative_l2(v, v_ref, t),
        "rho": relative_l2(rho, rho_ref, t),
        "rho_var": relative_l2(rho, rho_ref, t, baseline=rho0),
        "v_sq": relative_l2(v, v_ref, t, squared=True),
        "rho_sq": relative_l2(rho, rho_ref, t, squared=True),
    }


def format_errors(errors, label):
    return (f"{label}: v {errors['v']:.4e}   rho {errors['rho']:.4e}   rho-rho0 {errors['rho_var']:.4e}"
            f"   (squared form of eq. 3.4: v {errors['v_sq']:.4e}, rho {errors['rho_sq']:.4e})")


def exact_errors(scene, t, x, v, rho, rho0=None):
    """Errors against the exact solution, or None when the scene has none."""
    from .references.exact import exact_solution, is_available
    if not is_available(scene):
        return None
    v_ref, rho_ref = exact_solution(scene, x, t)
    if rho0 is None:
        rho0 = scene.field("rho0", x)
    return error_table(v, rho, v_ref, rho_ref, t, np.asarray(rho0))


def reference_fields(scene, x, t):
    """The reference solution (v, rho, label) at positions x and times t.

    The exact solution when the scene has one; otherwise the continuum
    reference of :mod:`sphrom.references.continuum`, or None when no
    reference can be computed.
    """
    from .references.exact import exact_solution, is_available
    if is_available(scene):
        v, rho = exact_solution(scene, x, t)
        return v, rho, "exact"
    try:
        from .references.continuum import best_reference
    except ImportError:
        return None
    return best_reference(scene, x, t)
