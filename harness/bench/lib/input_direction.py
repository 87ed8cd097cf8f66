"""How the force direction enters the frozen model: projected (eq. 2.19) or appended to the basis.

The FMU takes an arbitrary f(t) along the scene's force profile (uniform: the
constant vector).  When the POD velocity modes miss part of that direction,
two choices exist: project f on the modes as the paper does (eq. 2.19; the
missed part is lost) or append the normalised residual to U_v (f enters
exactly).  This measures both on a scene, against the full SPH, so that the
FMU's rule (:data:`sphrom.rom.operators.INPUT_TOLERANCE`) rests on numbers.

Errors: relative L² (square-root form of eq. 3.4) of v and ρ − ρ0 against the
full SPH at the scene's error steps, frozen model, n_freeze = 10.
"""

from __future__ import annotations

from ...compare import error_table
from ...pod.pipeline import accel_modes, basis_for_scene, error_steps, on_steps
from ...rom.operators import INPUT_TOLERANCE, build_operators
from ...rom.registry import get_model
from ...sph.solver import step_count


def input_direction_rows(scene, k=None, n_freeze=10):
    """Rows (scene, k, input_error, choice, k_v, err_v, err_rho) for "project" and "augment".

    Parameters
    ----------
    scene : Scene
    k : int, optional
        Modes (default: the largest of the scene's acceleration-study k).
    n_freeze : int
        Refresh period of the frozen coefficients.
    """
    basis, run = basis_for_scene(scene, progress=False)
    problem = run.problem
    k = k or max(accel_modes(scene, basis))
    steps = error_steps(scene)
    t = steps * scene.sph.dt
    v_sph, rho_sph = on_steps(run, steps)
    rows = []
    for choice in ("project", "augment"):
        ops = build_operators(problem, basis.U_v[:, :k], basis.U_rho[:, :k], input_direction=choice,
                              input_tolerance=0.0 if choice == "augment" else None)
        if not ops.has_force_input:             # no force profile at all
            return []
        frozen = get_model("frozen")
        r = frozen.run(ops, problem, n_steps=step_count(scene.T, scene.sph.dt), dt=scene.sph.dt, sample_steps=steps,
                       options=frozen.options(integrator=scene.sph.integrator, n_freeze=n_freeze))
        e = error_table(r.v, r.rho, v_sph, rho_sph, t, problem.rho0)
        rows.append({"scene": scene.name, "k": k, "input_error": ops.input_error, "choice": choice,
                     "k_v": ops.sizes["velocity"],
                     "err_v": e["v"], "err_rho": e["rho_var"],
                     "fmu_rule": ("augment" if ops.input_error > INPUT_TOLERANCE else "project")})
    return rows
