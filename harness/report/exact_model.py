"""The exact linear reduced model against the original POD-MOR, with the time error separated.

The original POD-MOR is integrated with the full SPH's own scheme (explicit
Euler at the scene's Δt), so its error against the full SPH is the POD error
alone.  The exact model (:mod:`sphrom.rom.exact_linear`) is exact in time, so
against the Euler SPH its error also holds the SPH's time-discretisation
error.  The semi-discrete SPH system is linear in J = ρ0/ρ, so it too can be
solved exactly in time: the exact model with every particle as a mode (bases
diag(ρ0)^-1/2 and diag(c)^-1/2).  Against that solution the exact model's
error is its POD error alone, comparable with the original's.

Errors: relative L² (square-root form of eq. 3.4) of v and ρ − ρ0 at the
scene's error steps.
"""

from __future__ import annotations

import numpy as np

from ..compare import error_table
from ..pod.pipeline import accel_modes, basis_for_scene, error_steps, on_steps
from ..rom.exact_linear import build_linear_operators, run_exact
from ..rom.registry import get_model
from ..sph.solver import step_count
from ..markdown import num, table

MAX_EXACT_IN_TIME = 500      # particles: above, the 2N x 2N exponential of the full system costs minutes


def sph_exact_in_time(problem, t, force=None):
    """(v, ρ) of the semi-discrete SPH system (eqs. 2.10-2.11) solved exactly in time at times ``t`` [s].

    Every particle is a mode: the exact linear model with bases diag(ρ0)^-1/2 (velocity, ρ0-orthonormal)
    and diag(c)^-1/2 (specific volume, c-orthonormal); the input enters linearly between sample times.
    """
    n = problem.n
    U_v = np.diag(1.0 / np.sqrt(problem.rho0))
    U_e = np.diag(1.0 / np.sqrt(problem.c))
    lin = build_linear_operators(problem, U_v, U_e, input_direction="auto")
    assert tuple(lin.sizes.values()) == (n, n)
    res = run_exact(lin, t, force=force)
    return res.v, res.rho


def compare_exact_and_original(scene, ks=None):
    """Rows per k: the original and the exact model against the Euler SPH and the exact-in-time SPH.

    Returns a list of dicts: k, orig_v, orig_rho (original vs SPH), exact_v, exact_rho (exact vs SPH),
    pure_v, pure_rho (exact vs the exact-in-time SPH), time_v, time_rho (SPH vs the exact-in-time SPH);
    the last four are NaN above :data:`MAX_EXACT_IN_TIME` particles.
    """
    basis, run = basis_for_scene(scene, progress=False)
    problem = run.problem
    steps = error_steps(scene)
    t = steps * scene.sph.dt
    v_sph, rho_sph = on_steps(run, steps)
    in_time = problem.n <= MAX_EXACT_IN_TIME
    if in_time:
        v_ex, rho_ex = sph_exact_in_time(problem, t, force=scene.force)
        time_err = error_table(v_sph, rho_sph, v_ex, rho_ex, t, problem.rho0)
    else:
        time_err = {"v": float("nan"), "rho_var": float("nan")}
    ks = ks or accel_modes(scene, basis)
    original, exact = get_model("original"), get_model("exact")
    n = step_count(scene.T, scene.sph.dt)
    rows = []
    for k in ks:
        k = min(k, *basis.max_modes)
        orig = original.run(original.build(problem, basis, k, k), problem, n_steps=n, dt=scene.sph.dt,
                            options=original.options(integrator=scene.sph.integrator), sample_steps=steps)
        e_orig = error_table(orig.v, orig.rho, v_sph, rho_sph, t, problem.rho0)
        ex = exact.run(exact.build(problem, basis, k, k), problem, n_steps=n, dt=scene.sph.dt, sample_steps=steps,
                       force=scene.force)
        e_ex = error_table(ex.v, ex.rho, v_sph, rho_sph, t, problem.rho0)
        e_pure = (error_table(ex.v, ex.rho, v_ex, rho_ex, t, problem.rho0) if in_time
                  else {"v": float("nan"), "rho_var": float("nan")})
        rows.append({"k": k, "orig_v": e_orig["v"], "orig_rho": e_orig["rho_var"], "exact_v": e_ex["v"],
                     "exact_rho": e_ex["rho_var"], "pure_v": e_pure["v"], "pure_rho": e_pure["rho_var"],
                     "time_v": time_err["v"], "time_rho": time_err["rho_var"]})
    return rows


def exact_section(scene):
    """Markdown lines and the rows of :func:`compare_exact_and_original` for a scene's report page."""
    rows = compare_exact_and_original(scene)
    lines = ["### The exact linear model (beyond the paper) against the original POD-MOR", "",
             "The original POD-MOR shares the full SPH's explicit Euler, so its error against the SPH is its POD "
             "error alone; the exact model is exact in time, so against the Euler SPH it also carries the SPH's time "
             "error. The semi-discrete SPH is linear in J = ρ0/ρ, so it can be solved exactly in time too (the exact "
             "model with every particle as a mode): against that, the exact model's error is its POD error alone. "
             "Errors of v / ρ − ρ0:", ""]
    lines += table(["k", "original vs SPH", "exact vs SPH", "exact vs SPH exact in time",
                    "SPH vs SPH exact in time (time error)", "POD error ratio exact / original (v, ρ − ρ0)"],
                   [[r["k"], f"{num(r['orig_v'])} / {num(r['orig_rho'])}", f"{num(r['exact_v'])} / {num(r['exact_rho'])}",
                     f"{num(r['pure_v'])} / {num(r['pure_rho'])}", f"{num(r['time_v'])} / {num(r['time_rho'])}",
                     f"{num(r['pure_v'] / r['orig_v'], '.2f')}, {num(r['pure_rho'] / r['orig_rho'], '.2f')}"]
                    for r in rows])
    if any(np.isnan(r["pure_v"]) for r in rows):
        lines += [f"(N > {MAX_EXACT_IN_TIME}: the exact-in-time SPH is not computed.)", ""]
    return lines, rows
