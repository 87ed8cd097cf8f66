"""Every input at every frequency: ports under slow and constant forces and forces along non-uniform
profiles, before and after the directions of
:mod:`sphrom.rom.inputs`, for the exact, frozen and balanced models.

Cases (each against the full SPH's equations linear in J integrated exactly in time,
:func:`sphrom.rom.reference.linear_reference`, inputs held over H = 10 ms, sampled every H):

* ``ports-slow``: damped_forced (N = 100) with ports at x/L = 0.3 and 0.7, from its initial state, port forces
  2e-3 sin 1.3t and 1e-3 cos 3.1t + 5e-4 [t > 4 s], 10 s: the port velocities;
* ``port-constant``: tenmode (d = 0, N = 400) with a port at 0.5, from rest, 1e-3 N for 10 s: the port velocity;
* ``profile-constant`` / ``profile-sine``: damped_forced with the profile 1 + sin 2πx + ½ cos 6πx, from rest,
  f = 1e-2 and 1e-2 sin 7t (10 s): the velocity field;
* ``parametric-profile-constant`` / ``parametric-profile-sine`` (tenmode) and ``parametric-damped-profile-sine``
  (damped_forced): the frozen parametric model (``--vary c=c/2:2c``, and ``d=0:2d`` on a damped scene) with the
  profile 1 + sin 2πx + ½ cos 6πx, from rest, f = 1e-2 and 1e-2 sin 7t, at c = 0.6, 1 and 1.8 times the scene's
  (the worst of the three); before: the profile projected (``input_direction="project"``), after: the parametric
  FMU's rule (``moments``, :data:`sphrom.fmu.make.parametric.PARAMETRIC_INPUT_DIRECTION`); and the exact
  parametric model (its FMU's rule, the profile and its directions computed at the scene's c, d = 1);
* ``shaped-constant`` / ``shaped-sine``: tenmode with the profile exp(-((x - 0.3)/0.1)²) (trained on 1e-2 cos 2t),
  from rest, f = 1e-2 and 1e-2 sin 5t: the velocity field; ``shaped-sine-3e-3`` the sine at 3e-3 (a third of
  the strain: the frozen model's density linearisation errs in proportion to it).

The full SPH (nonlinear, the scene's dt) is a row of its own in the port cases, with the scene's own force off
as in the reference, once with the integrator a port FMU takes (symplectic Euler,
:func:`sphrom.fmu.make.options.default_integrator`) and once with the scene's (explicit Euler: ``full SPH
(euler)``). Models as the FMU builds them (k = 12, the model's ``fmu_input_direction``); ``before`` is the build
option ``input_moments=False`` (the bases main had: the port's short-time directions and the profile's own
column; the frozen model in the Euclidean projection it had, ``inner="euclid"``), the balanced model at its
default order tolerance (it has no "before": it had no ports). Errors: relative L² over all samples. The frozen model runs with the scene's dt, n_freeze = 10, the integrator its FMU
takes (with ports symplectic Euler, else the scene's) and the refresh its FMU takes (the particles where they
cost less than the tensor, :func:`sphrom.fmu.make.models.particle_sections`).

Run as::

    python -m sphrom.bench.inputs [--case NAME ...] [--out inputs.csv]

It prints a Markdown table (docs/fmu/ports.md quotes it) and writes the CSV.  About 10 min on the shared
2-core machine (the frozen model on tenmode at N = 400: 200 000 steps with k_v = 40).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from ..fmu.make.models import particle_sections
from ..fmu.make.options import default_integrator
from ..fmu.make.parametric import PARAMETRIC_INPUT_DIRECTION, parametric_model
from ..pod.pipeline import basis_for_scene
from ..rom import parametric as par
from ..rom.reference import linear_reference
from ..rom.registry import get_model
from ..scene import derive_scene, load_scene
from ..sph.solver import build_problem
from . import program_parser
from .lib.responses import held, held_response

H = 0.01
T = 10.0
K = 12


def basis_sizes(ops):
    """(k_v, k_e or k_ρ) of a POD model's operators, (r, 0) of the balanced model's."""
    return (*ops.sizes.values(), 0)[:2]


def cases():
    """{name: (scene, ports, port forces, force, from the initial state?)}."""
    damped = load_scene("damped_forced")
    profile = derive_scene(damped, {"force": {"profile": "1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)"}})
    shaped = derive_scene(load_scene("tenmode"), {"force": {"f": "1e-2*cos(2*t)",
                                                            "profile": "exp(-((x/L-0.3)/0.1)**2)"}})
    slow = lambda t: np.stack([2e-3 * np.sin(1.3 * t), 1e-3 * np.cos(3.1 * t) + 5e-4 * (t > 4)], axis=-1)  # noqa: E731
    const = lambda t: 1e-3 * np.ones((np.size(t), 1))                                                      # noqa: E731
    f_const = lambda t: 1e-2 * np.ones(np.size(t))                                                         # noqa: E731
    return {
        "ports-slow": (damped, (0.3, 0.7), slow, None, True),
        "port-constant": (load_scene("tenmode"), (0.5,), const, None, False),
        "profile-constant": (profile, (), None, f_const, False),
        "profile-sine": (profile, (), None, lambda t: 1e-2 * np.sin(7.0 * np.asarray(t)), False),
        "shaped-constant": (shaped, (), None, f_const, False),
        "shaped-sine": (shaped, (), None, lambda t: 1e-2 * np.sin(5.0 * np.asarray(t)), False),
        "shaped-sine-3e-3": (shaped, (), None, lambda t: 3e-3 * np.sin(5.0 * np.asarray(t)), False),
    }


def measure(name, scene, ports, port_forces, force, state):
    """Rows {case, model, variant, k_v, k_2, error, wall_s} of one case."""
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    _, v, vp = linear_reference(problem, ports, T, H, force=force, port_forces=port_forces, state=state)
    ref = vp if ports else v
    rows = []
    runs = [("exact", "before"), ("exact", "after"), ("frozen", "before"), ("frozen", "after"),
            ("balanced", "after")]
    for model, variant in runs:
        spec = get_model(model)
        t0 = time.perf_counter()
        port_option = {"ports": tuple(ports)} if ports else {}
        if not spec.needs_basis:                        # the balanced model: its order from its tolerance
            ops = spec.build(problem, None, None, None, **port_option)
        else:
            before = {"inner": "euclid"} if variant == "before" and "inner" in spec.build_options else {}
            ops = spec.build(problem, basis, K, K, input_direction=spec.fmu_input_direction,
                             input_moments=variant == "after", **port_option, **before)
        options = None if spec.linear else {"integrator": default_integrator(scene, ports),
                                            "refresh": "direct" if particle_sections(ops, problem) else "tensor"}
        z = held_response(spec, ops, problem, t_end=T, step=H, force=force, port_forces=port_forces if ports else None,
                          from_state=state, options=options)
        y = ops.port_velocity(z) if ports else ops.velocity(z)
        sizes = basis_sizes(ops)
        err = float(np.linalg.norm(y - ref) / np.linalg.norm(ref))
        rows.append({"case": name, "model": model, "variant": variant, "k_v": sizes[0], "k_2": sizes[1],
                     "error": err, "wall_s": time.perf_counter() - t0})
        print(f"{name} {model} {variant}: k = {sizes}, error {err:.3g}", file=sys.stderr, flush=True)
    for integrator in (default_integrator(scene, ports), scene.sph.integrator)[:2 if ports else 0]:
        # the full SPH itself (nonlinear) against the same reference: the port FMU's integrator, the scene's
        from ..sph.ports import run_sph_ports
        t0 = time.perf_counter()
        forces = held(port_forces, H)
        from ..scene import derive_scene
        from ..sph.solver import build_problem as problem_of
        quiet = derive_scene(scene, {"force": {"f": "0"}, "sph": {"integrator": integrator}})
        full = run_sph_ports(quiet, ports, forces=lambda s: forces(np.atleast_1d(s))[0], problem=problem_of(quiet),
                             state=None if state else (0.0 * problem.v0, problem.rho0.copy()),
                             every=int(round(H / scene.sph.dt)), t_end=T)
        err = float(np.linalg.norm(full.v_port[:ref.shape[0]] - ref) / np.linalg.norm(ref))
        label = "full SPH" if integrator == default_integrator(scene, ports) else f"full SPH ({integrator})"
        rows.append({"case": name, "model": label, "variant": "after", "k_v": problem.n, "k_2": problem.n,
                     "error": err, "wall_s": time.perf_counter() - t0})
        print(f"{name} {label}: error {err:.3g}", file=sys.stderr, flush=True)
        if integrator == scene.sph.integrator:
            break
    return rows


PROFILE = "1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)"


def parametric_cases():
    """{name: (scene, force)} of the parametric frozen model's profile cases."""
    f_const = lambda t: 1e-2 * np.ones(np.size(t))                                                         # noqa: E731
    f_sine = lambda t: 1e-2 * np.sin(7.0 * np.asarray(t))                                                  # noqa: E731
    tenmode = derive_scene(load_scene("tenmode"), {"force": {"profile": PROFILE}})
    damped = derive_scene(load_scene("damped_forced"), {"force": {"profile": PROFILE}})
    return {"parametric-profile-constant": (tenmode, f_const), "parametric-profile-sine": (tenmode, f_sine),
            "parametric-damped-profile-sine": (damped, f_sine)}


def measure_parametric(name, scene, force):
    """Rows of one parametric case: the frozen parametric model before ("project") and after (the FMU's rule),
    and the exact parametric model (its FMU's rule, after only): the worst relative L² error of the velocity field
    over c = 0.6, 1, 1.8 times the scene's c (at the scene's d)."""
    c0, d0 = float(build_problem(scene).c[0]), float(build_problem(scene).d[0])
    ranges = [par.Range("c", 0.5 * c0, 2.0 * c0)] + ([par.Range("d", 0.0, 2.0 * d0)] if d0 > 0 else [])
    rows = []
    for model, variant, direction in (("frozen", "before", "project"),
                                      ("frozen", "after", PARAMETRIC_INPUT_DIRECTION["frozen"]),
                                      ("exact", "after", None)):
        spec = get_model(model)
        t0 = time.perf_counter()
        affine, _, _, _ = parametric_model(scene, ranges, K, model=model, progress=False, input_direction=direction)
        worst = 0.0
        for c in (0.6 * c0, c0, 1.8 * c0):
            problem = build_problem(par.scene_at(scene, c, d0))
            _, v, _ = linear_reference(problem, (), T, H, force=force, state=False)
            ops = par.linear_at(affine, c, d0) if spec.linear else par.frozen_at(affine, c, d0)
            z = held_response(spec, ops, problem, t_end=T, step=H, force=force,
                              options=None if spec.linear else {"refresh": "tensor"})
            worst = max(worst, float(np.linalg.norm(ops.velocity(z) - v) / np.linalg.norm(v)))
        sizes = basis_sizes(affine.unit)
        rows.append({"case": name, "model": f"{model} (parametric)", "variant": variant, "k_v": sizes[0],
                     "k_2": sizes[1], "error": worst, "wall_s": time.perf_counter() - t0})
        print(f"{name} {model} (parametric) {variant}: k = {sizes}, worst error {worst:.3g}",
              file=sys.stderr, flush=True)
    return rows


def table(rows):
    """The Markdown table: one line per case and model, the error before and after (and the basis sizes)."""
    lines = ["| case | model | error before | basis before | error after | basis after |", "|---|---|---|---|---|---|"]
    keys = dict.fromkeys((r["case"], r["model"]) for r in rows)
    for case, model in keys:
        by = {r["variant"]: r for r in rows if r["case"] == case and r["model"] == model}
        b, a = by.get("before"), by["after"]
        lines.append(f"| {case} | {model} | {'-' if b is None else format(b['error'], '.2g')} | "
                     f"{'-' if b is None else (b['k_v'], b['k_2'])} | {a['error']:.2g} | {(a['k_v'], a['k_2'])} |")
    return "\n".join(lines)


def main(argv=None):
    parser = program_parser("inputs", description=__doc__.split("\n\n")[0])
    all_cases, parametric = cases(), parametric_cases()
    parser.add_argument("--case", action="append", choices=sorted([*all_cases, *parametric]),
                        help="a case (default all)")
    parser.add_argument("--out", help="CSV file to write")
    args = parser.parse_args(argv)
    rows = []
    for name in args.case or [*all_cases, *parametric]:
        rows += measure(name, *all_cases[name]) if name in all_cases else measure_parametric(name, *parametric[name])
    print(table(rows))
    if args.out:
        from .lib.tables import write_csv
        write_csv(args.out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
