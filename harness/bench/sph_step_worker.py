"""A worker process that times full SPH steps for :mod:`sphrom.bench.sph_stencil`, in whichever checkout
``PYTHONPATH`` names.

Run as a script by its path (``python .../harness/bench/sph_step_worker.py``) so that ``import harness`` loads
the checkout on ``PYTHONPATH``: the same file times this checkout and an older one (``--before DIR``) in one run.
It uses only what both have (``loops.advance``, ``run_sph``, ``SphC``), and the fixed-offset layout where the
checkout has it (:meth:`sphrom.sph.solver.SPHProblem.loop_args`).

Protocol: one JSON object per line on stdin, one JSON answer per line on stdout.

* ``{"op": "info"}`` -> the checkout's folder, whether it has layouts.
* ``{"op": "time", "solver": "numba" | "c" | "run_sph", "layout": "auto" | "general", "scene": NAME,
  "n": N, "integrator": NAME, "steps": M}`` -> ``{"seconds": wall time of the call, "layout": the layout
  used ("stencil" | "lists"), "digest": sha256 of the final v and ρ}``.  ``steps`` steps from the scene's
  initial state at the scene's CFL number (Δt scaled as 1/N), with the scene's force values, no samples
  (restarting from the initial state every T, the scene's horizon);
  "run_sph" runs the scene as it is (its N, Δt, T; ``n`` and ``steps`` are ignored) and times the call.
"""

import hashlib
import json
import os
import sys
import time

if __name__ == "__main__" and sys.path and os.path.abspath(sys.path[0]) == os.path.dirname(os.path.abspath(__file__)):
    sys.path.pop(0)                 # this folder's modules (timing, report, ...) must not shadow anything


def _setup(cache, scene_name, n, integrator):
    """(scene, problem, dt) for N = n at the scene's CFL number, built once per key."""
    key = (scene_name, n, integrator)
    if key not in cache:
        from sphrom.scene import load_scene
        from sphrom.sph.solver import build_problem
        base = load_scene(scene_name)
        scene = base.with_sph(n_particles=n, integrator=integrator)
        dt = base.sph.dt * base.sph.n_particles / n
        cache[key] = (scene, build_problem(scene), dt)
    return cache[key]


def _loop_args(problem, layout):
    """(args, layout bit, layout name) of the compiled loops, in either checkout."""
    if hasattr(problem, "loop_args"):
        args, bit = problem.loop_args(layout)
        return args, bit, "stencil" if bit else "lists"
    nb = problem.neighbours
    args = (nb.index, nb.weight, *(problem.packed(name) for name in ("rho0", "c", "d", "profile")))
    return args, 0, "lists"


def _digest(v, rho):
    return hashlib.sha256(v.tobytes() + rho.tobytes()).hexdigest()


def time_steps(cache, req):
    """The answer to one ``time`` request (module docstring)."""
    import numpy as np
    from sphrom.sph import loops
    from sphrom.sph.solver import METHODS, force_values, run_sph, step_count
    if req["solver"] == "run_sph":
        from sphrom.scene import load_scene
        scene = load_scene(req["scene"])
        problem = cache.setdefault(("run_sph", req["scene"]), None)
        if problem is None:
            from sphrom.sph.solver import build_problem
            problem = cache[("run_sph", req["scene"])] = build_problem(scene)
        kw = {} if req["layout"] == "auto" or not hasattr(problem, "loop_args") else {"layout": req["layout"]}
        t0 = time.perf_counter()
        res = run_sph(scene, problem=problem, progress=False, sample_steps=[step_count(scene.T, scene.sph.dt)], **kw)
        seconds = time.perf_counter() - t0
        layout = _loop_args(problem, req["layout"])[2]
        return {"seconds": seconds, "layout": layout, "digest": _digest(res.v[-1], res.rho[-1])}
    scene, problem, dt = _setup(cache, req["scene"], req["n"], req["integrator"])
    steps = int(req["steps"])
    method = METHODS[req["integrator"]]
    # runs longer than the scene's horizon restart from the initial state every T (explicit Euler grows past it)
    horizon = max(1, step_count(scene.T, dt))
    g = force_values(scene, problem, 0, min(steps, horizon), dt, method)
    runs = [horizon] * (steps // horizon) + ([steps % horizon] if steps % horizon else [])
    if req["solver"] == "c":
        key = ("c", req["layout"], req["integrator"], req["n"])
        if key not in cache:
            from sphrom.fmu.make.build import ensure_binaries
            from sphrom.fmu.run.sph_c import SphC
            if "sphc" not in cache:
                cache["sphc"] = SphC(ensure_binaries().sph)
            kw = {"layout": req["layout"]} if hasattr(problem, "loop_args") else {}
            cache[key] = cache["sphc"].runner(problem, req["integrator"], **kw)
        runner = cache[key]
        seconds = 0.0
        for k in runs:
            v, rho = problem.v0.copy(), problem.rho0.copy()
            seconds += runner.advance(v, rho, k, dt, g=g[:k, 0])
        layout = "stencil" if getattr(runner, "layout_bit", 0) else "lists"
    else:
        args, bit, layout = _loop_args(problem, req["layout"])
        flags = problem.flags(bool(np.any(g != 0))) | bit
        out = np.zeros((0, problem.n))
        seconds = 0.0
        for k in runs:
            v, rho = problem.v0.copy(), problem.rho0.copy()
            t0 = time.perf_counter()
            status, _, _ = loops.advance(method, v, rho, 0, k, dt, g, *args, flags, np.zeros(0, np.int64), 0, out,
                                         out, 64, np.inf, problem.neighbours.dx)
            seconds += time.perf_counter() - t0
            if status != 0:
                raise RuntimeError(f"the SPH state failed its check (status {status})")
    return {"seconds": seconds, "layout": layout, "digest": _digest(v, rho)}


def main():
    cache = {}
    for line in sys.stdin:
        req = json.loads(line)
        try:
            if req["op"] == "info":
                import sphrom
                from sphrom.sph import solver
                ans = {"code": os.path.dirname(os.path.dirname(os.path.abspath(sphrom.__file__))),
                       "layouts": hasattr(solver.SPHProblem, "loop_args")}
            else:
                ans = time_steps(cache, req)
        except Exception as exc:          # the parent prints it and stops
            ans = {"error": f"{type(exc).__name__}: {exc}"}
        sys.stdout.write(json.dumps(ans) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
