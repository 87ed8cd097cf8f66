"""The generated user scenes of the error-bound benches (``--corpus N`` of :mod:`sphrom.bench.error_bounds` and
:mod:`sphrom.bench.error_bounds_ports`): one corpus, one selection, so that the two benches measure the same scenes."""

from __future__ import annotations

import numpy as np

# the menu of the generated user scenes (fields as expressions of x, L, t, T)
CORPUS_MENU = {
    "d": ("0", "1", "2 + 1.5*sin(2*pi*x/L)", "4 + 3*sin(2*pi*x/L + 1)", "6*exp(-((x/L - 0.5)/0.2)**2) + 0.5"),
    "c": ("0.1", "0.1*(1 + 0.4*sin(2*pi*x/L))"),
    "rho0": ("1", "1 + 0.3*cos(2*pi*x/L)"),
    "profile": ("1", "cos(8*pi*x/L)", "1 + 0.5*cos(2*pi*x/L)", "exp(-((x/L - 0.3)/0.08)**2)"),
    "v0": ("4e-3*sin(2*pi*x/L)", "4e-3*(x/L)*(1 - x/L)*sum(sin(2*pi*l*x/L + l**2) for l in range(1, 6))",
           "2e-3*exp(-((x/L - 0.5)/0.1)**2)"),
    "f": ("0", "2e-3*sin(3*t)", "1e-3"),
}


def user_scenes(count, seed=33):
    """``count`` generated user scenes (seeded): fields drawn from :data:`CORPUS_MENU` over the scene
    mild_damped_forced's settings, N in {64, 96, 128}, T in {2, 3} s; every other one with a damping that varies
    along the bar.  (A stand-in for the project's generator of user scenes.)"""
    from ...scene import derive_scene, load_scene
    rng = np.random.default_rng(seed)
    base = load_scene("mild_damped_forced")
    out = []
    for i in range(count):
        pick = {k: v[int(rng.integers(len(v)))] for k, v in CORPUS_MENU.items()}
        if i % 2 == 0:                                   # every other scene: a damping that varies
            pick["d"] = CORPUS_MENU["d"][2 + int(rng.integers(3))]
        n = int(rng.choice([64, 96, 128]))
        T = float(rng.choice([2.0, 3.0]))
        changes = {"name": f"user_{i + 1}", "title": f"generated user scene {i + 1}", "domain": {"T": T},
                   "fields": {k: pick[k] for k in ("rho0", "v0", "c", "d")},
                   "force": {"f": pick["f"], "profile": pick["profile"]},
                   "sph": {"n_particles": n, "dt": 2e-4 * 64 / n, "every": max(1, int(round(0.01 / (2e-4 * 64 / n))))},
                   "snapshots": {"count": 20, "window": [0.0, 0.8 * T]}}
        out.append(derive_scene(base, changes))
    return out


SI_MIN_PARTICLES = 101      # si_scenes: the SI corpus's scenes above the unit corpus's N (64-128 above: port FMUs of
#                             at most 96 particles keep every plane, a weak test of the sizing)
SI_SCAN = 1000              # ... looked for among its first this many indices


def si_scenes(count, seed=0, min_particles=SI_MIN_PARTICLES):
    """The first ``count`` scenes of the SI corpus of ``seed`` (:mod:`sphrom.bench.lib.corpus`, the user scenes of
    ``sphrom bench scenes``: unit, rubber and steel bars of any magnitudes) with at least ``min_particles`` particles,
    in the corpus's order, each named as there (user<seed>_<index>)."""
    from ...scene import parse_scene
    from .corpus import user_scene
    out = []
    for index in range(SI_SCAN):
        if len(out) >= count:
            break
        name, text, facts = user_scene(seed, index)
        if facts["n"] >= min_particles:
            out.append(parse_scene(text, f"{name}.toml", name=name))
    return out
