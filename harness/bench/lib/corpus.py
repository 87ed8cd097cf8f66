"""A corpus of plausible user scenes: bars a user could write from docs/user/scenes.md, deterministic from a seed.

Each scene is TOML text as a user writes it (no snapshots, modes or paper; the automatic choices of the loader do
the rest), drawn by :func:`user_scene` from ``numpy.random.default_rng([seed, index])``:

- magnitudes (``kind``): ``unit`` (the paper's scaling: L = 1 m, rho0 ~ 1, c ~ 0.1-1), ``rubber`` (rho0 ~ 1100
  kg m^-3, c ~ 1e6-1e7 Pa, L ~ 0.2-2 m) or ``steel`` (rho0 = 7850 kg m^-3, c = 2.1e11 Pa, L ~ 0.2-2 m: periods of a
  fraction of a millisecond);
- modulus: uniform, two materials (a jump in c and rho0 at a random point, c up to 20x apart) or graded (c varying
  smoothly by up to 20x);
- density: uniform, non-uniform (a smooth variation of up to 50 %) or that of the two materials;
- damping: none, uniform, graded (linear along the bar) or local (a Gaussian patch), at damping ratios of 0.2 % to
  20 % of the lowest mode (d = 2 zeta omega_1);
- the motion: an initial velocity of sine modes (strains of 1e-4 to 1e-3 of the sound speed), a force along a
  uniform or a local (Gaussian) profile (a sine near the band or two tones), or both;
- N log-uniform in [n_min, n_max], T 1 to 4 times the wave's time once around the bar T';
- the step: ``dt`` at 0.2 of the integrator's stability limit (omega_max dt = 0.4 for the Euler schemes), or left
  out; ``integrator`` left out, or symplectic, or rk4, or euler (euler only with dt left out, named with a CFL-sized
  step it amplifies every undamped mode, which every command says before the run; and only at N <=
  :data:`EULER_MAX_N`).

:func:`corpus` gives ``count`` of them.  The texts depend only on the seed and the index (numpy's PCG64), so a corpus
is the same on every machine.
"""

from __future__ import annotations

import math

import numpy as np

KINDS = ("unit", "rubber", "steel")
DT_FRACTION = 0.2          # the given dt as a fraction of the integrator's stability limit
# Euler is named only on bars of at most this many particles: without dt the loader keeps its growth over [0, T]
# below 2 (sphrom.sph.timestep.EULER_AUTO_GROWTH), which takes T omega_max^2 / (2 ln 2) steps, growing as N^2
EULER_MAX_N = 150


def _g(x):
    """A number as it goes into an expression: 4 significant digits."""
    return f"{x:.4g}"


def user_scene(seed, index, n_min=64, n_max=2000):
    """(name, TOML text, facts) of scene ``index`` of the corpus of ``seed`` (module docstring); ``facts`` is a dict
    of what was drawn (kind, modulus, density, damping, force, motion, N, dt given, integrator)."""
    from ...sph.timestep import dt_limit, omega_max
    rng = np.random.default_rng([int(seed), int(index)])
    kind = KINDS[int(rng.integers(len(KINDS)))]
    if kind == "unit":
        L, rho, c = 1.0, float(rng.uniform(0.5, 2.0)), float(rng.uniform(0.05, 1.0))
    elif kind == "rubber":
        L, rho, c = float(rng.uniform(0.2, 2.0)), float(rng.uniform(900, 1300)), float(10 ** rng.uniform(6, 7))
    else:
        L, rho, c = float(rng.uniform(0.2, 2.0)), 7850.0, 2.1e11
    n = int(round(math.exp(rng.uniform(math.log(n_min), math.log(n_max)))))
    ratio = float(rng.uniform(2.0, 20.0))
    modulus = ("uniform", "two materials", "graded")[int(rng.integers(3))]
    x0 = float(rng.uniform(0.3, 0.7))
    if modulus == "uniform":
        c_expr = _g(c)
    elif modulus == "two materials":
        c_expr = f"where(x < {_g(x0)}*L, {_g(c)}, {_g(c / ratio)})"
    else:
        c_expr = f"{_g(c)}*(1 + {_g(ratio - 1)}*(0.5 + 0.5*sin(2*pi*x/L + {_g(rng.uniform(0, 2 * math.pi))})))/{_g(ratio)}"
    density = ("uniform", "non-uniform") [int(rng.integers(2))] if modulus != "two materials" else "two materials"
    if density == "uniform":
        rho_expr = _g(rho)
    elif density == "non-uniform":
        rho_expr = f"{_g(rho)}*(1 + {_g(rng.uniform(0.1, 0.5))}*cos(2*pi*x/L + {_g(rng.uniform(0, 2 * math.pi))}))"
    else:
        rho_expr = f"where(x < {_g(x0)}*L, {_g(rho)}, {_g(rho * rng.uniform(0.3, 1.0))})"
    # the bar's time scales: the wave's time once around it and its lowest angular frequency (uniform estimate)
    speed = math.sqrt(c / rho)
    period = L / speed * (1.0 if modulus == "uniform" else math.sqrt(ratio) * 0.6)
    w1 = 2 * math.pi / period
    zeta = float(10 ** rng.uniform(math.log10(0.002), math.log10(0.2)))
    d = 2 * zeta * w1
    damping = ("none", "uniform", "graded", "local")[int(rng.integers(4))]
    d_expr = {"none": "0", "uniform": _g(d), "graded": f"{_g(2 * d)}*x/L",
              "local": f"{_g(4 * d)}*exp(-((x - {_g(rng.uniform(0.2, 0.8))}*L)/(0.1*L))**2)"}[damping]
    v_scale = float(10 ** rng.uniform(-4, -3)) * speed          # a strain of 1e-4 to 1e-3
    motion = ("initial velocity", "force", "both")[int(rng.integers(3))]
    lines = [f"# a user's bar, corpus seed {seed} #{index}: {kind}, {modulus} modulus, {density} density, "
             f"{damping} damping, {motion}", "[domain]", f"L = {L!r}"]
    T = float(rng.uniform(1.0, 4.0)) * period
    lines += [f"T = {float(_g(T))!r}", "", "[fields]", f'rho0 = "{rho_expr}"', f'c = "{c_expr}"', f'd = "{d_expr}"']
    if motion in ("initial velocity", "both"):
        modes = [1 + int(m) for m in rng.choice(4, size=int(rng.integers(1, 4)), replace=False)]
        terms = " + ".join(f"{_g(rng.uniform(0.3, 1.0) / m)}*sin(2*pi*{m}*x/L + {_g(rng.uniform(0, 6.28))})"
                           for m in sorted(modes))
        lines.append(f'v0 = "{_g(v_scale)}*({terms})"')
    force = "none"
    if motion in ("force", "both"):
        local = bool(rng.integers(2))
        nu = float(rng.uniform(0.3, 3.0)) * w1 / (2 * math.pi)
        amp = v_scale * 2 * math.pi * nu
        if rng.integers(2):
            f_expr = f"{_g(amp)}*sin(2*pi*{_g(nu)}*t)"
        else:
            f_expr = f"{_g(amp)}*(sin(2*pi*{_g(nu)}*t) + 0.5*cos(2*pi*{_g(2.3 * nu)}*t))"
        lines += ["", "[force]", f'f = "{f_expr}"']
        if local:
            lines.append(f'profile = "exp(-((x - {_g(rng.uniform(0.2, 0.8))}*L)/({_g(rng.uniform(0.03, 0.15))}*L))**2)"')
        force = ("local" if local else "uniform") + " profile"
    lines += ["", "[sph]", f"n_particles = {n}"]
    integrator = (None, "symplectic", "rk4", "euler")[int(rng.integers(4))]
    if integrator == "euler" and n > EULER_MAX_N:
        integrator = None
    give_dt = integrator != "euler" and bool(rng.integers(2))
    if integrator is not None:
        lines.append(f'integrator = "{integrator}"')
    if give_dt:
        # omega_max of the fields' extremes, as the loader bounds it (sphrom.sph.timestep.omega_max)
        from ...expr import compile_expr
        from ...sph.operator import particle_positions
        x = particle_positions(L, n)
        c_max = float(np.max(np.broadcast_to(compile_expr(c_expr, ("x", "L", "T"), "c")(x=x, L=L, T=T), x.shape)))
        rho_min = float(np.min(np.broadcast_to(compile_expr(rho_expr, ("x", "L", "T"), "rho0")(x=x, L=L, T=T),
                                               x.shape)))
        d_max = float(np.max(np.broadcast_to(compile_expr(d_expr, ("x", "L", "T"), "d")(x=x, L=L, T=T), x.shape)))
        w = omega_max(c_max, rho_min, L, n, 1.04)
        lines.append(f"dt = {float(_g(DT_FRACTION * dt_limit(integrator or 'symplectic', w, d_max))):.4g}")
    name = f"user{seed}_{index:02d}"
    facts = {"name": name, "kind": kind, "modulus": modulus, "density": density, "damping": damping,
             "motion": motion, "force": force, "n": n, "dt_given": give_dt, "integrator": integrator or "(default)"}
    return name, "\n".join(lines) + "\n", facts


def corpus(seed=0, count=16, n_min=64, n_max=2000):
    """[(name, TOML text, facts)] of ``count`` scenes of the corpus of ``seed``."""
    return [user_scene(seed, i, n_min, n_max) for i in range(count)]
