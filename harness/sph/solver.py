"""The full SPH solver: eqs. 2.10-2.11 on fixed particles, three integrators.

    dρ_i/dt = -(ρ_i^2/ρ_i(0)) Σ_j (m_j/ρ_j(0)) v_j ∇W_ij                 (2.10)
    dv_i/dt = -(1/ρ_i(0)) Σ_j (m_j/ρ_j(0)) c_j (1 - ρ_j(0)/ρ_j) ∇W_ij
              - d_i v_i + f_i(t)                                        (2.11)

with m_j = ρ0(x_j) Δx (a = 1 m^2), so m_j/ρ_j(0) = Δx, and
f_i(t) = profile(x_i) f(t).  Time is t_n = n Δt (never accumulated).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from ..errors import SimulationError
from ..progress import progress_bar
from ..scene import Scene
from . import loops
from .operator import Neighbours, build_neighbours, particle_positions
from .timestep import GROWTH_WARN, STABILITY_BOUND, dt_limit, growth, growth_figure, omega_max, step_matrix  # noqa: F401
from .timestep import warnings as growth_warnings

METHODS = {"euler": 0, "symplectic": 1, "rk4": 2}


@dataclass(frozen=True)
class SPHProblem:
    """Everything the compiled loop needs, built once from a scene.

    Attributes
    ----------
    x : ndarray (N,)
        Particle reference positions [m].
    mass : ndarray (N,)
        m_i = ρ0(x_i) Δx [kg] (a = 1 m^2).
    rho0, c, d, profile, v0 : ndarray (N,)
        Fields at the particles.
    neighbours : Neighbours
        The gradient operator G of eq. 2.9.
    terms : dict
        Which terms exist: damping, force_profile, uniform_c, uniform_rho0,
        uniform_d, uniform_profile.
    """

    scene: Scene
    x: np.ndarray
    mass: np.ndarray
    rho0: np.ndarray
    c: np.ndarray
    d: np.ndarray
    profile: np.ndarray
    v0: np.ndarray
    neighbours: Neighbours
    terms: dict

    @property
    def n(self):
        return self.x.size

    def flags(self, force_active):
        """The flag bits of :mod:`.loops` for this problem."""
        t = self.terms
        flags = 0
        flags |= loops.DAMPING if t["damping"] else 0
        flags |= loops.FORCE if (force_active and t["force_profile"]) else 0
        flags |= loops.UNIFORM_C if t["uniform_c"] else 0
        flags |= loops.UNIFORM_RHO0 if t["uniform_rho0"] else 0
        flags |= loops.UNIFORM_D if t["uniform_d"] else 0
        flags |= loops.UNIFORM_PROFILE if t["uniform_profile"] else 0
        return flags

    def packed(self, name):
        """A field as the compiled loop takes it: length 1 when uniform."""
        arr = getattr(self, name)
        key = {"c": "uniform_c", "rho0": "uniform_rho0", "d": "uniform_d", "profile": "uniform_profile"}[name]
        return np.ascontiguousarray(arr[:1] if self.terms[key] else arr)

    def loop_args(self, layout="auto"):
        """(index, weight, rho0, c, d, profile) as :func:`.loops.rates` and :func:`.loops.advance` take them, and
        the layout's flag bit to add to :meth:`flags` (``loops.STENCIL`` for the fixed-offset layout, which
        ``layout`` "auto" takes where the neighbour lists allow it; "general": the lists).
        """
        index, weight, bit = self.neighbours.loop_arrays(layout)
        return (index, weight, *(self.packed(name) for name in ("rho0", "c", "d", "profile"))), bit


def build_problem(scene: Scene) -> SPHProblem:
    """Particles, fields and neighbour lists of ``scene``'s SPH settings."""
    n, alpha = scene.sph.n_particles, scene.sph.alpha
    x = particle_positions(scene.L, n)
    dx = scene.L / n
    rho0 = scene.field("rho0", x)
    mass = rho0 * dx
    volume = mass / rho0
    nb = build_neighbours(x, scene.L, alpha * dx, volume)
    c, d, profile = scene.field("c", x), scene.field("d", x), scene.field("profile", x)
    terms = {
        "damping": bool(np.any(d != 0)),
        "force_profile": bool(np.any(profile != 0)),
        "uniform_c": bool(np.all(c == c[0])),
        "uniform_rho0": bool(np.all(rho0 == rho0[0])),
        "uniform_d": bool(np.all(d == d[0])),
        "uniform_profile": bool(np.all(profile == profile[0])),
    }
    return SPHProblem(scene=scene, x=x, mass=mass, rho0=rho0, c=c, d=d, profile=profile,
                      v0=scene.field("v0", x), neighbours=nb, terms=terms)


def step_count(T, dt):
    """Number of steps n with n Δt = T (to 1e-9 relative), else floor(T/Δt)."""
    ratio = T / dt
    n = int(round(ratio))
    if abs(ratio - n) <= 1e-9 * max(1.0, ratio):
        return n
    return int(np.floor(ratio))


def default_sample_steps(n_steps, every, extra=()):
    """Steps 0, every, 2 every, ..., the last step, and any ``extra`` ones."""
    steps = np.arange(0, n_steps + 1, every, dtype=np.int64)
    steps = np.union1d(steps, np.asarray([n_steps], dtype=np.int64))
    if len(extra):
        extra = np.asarray(extra, dtype=np.int64)
        steps = np.union1d(steps, extra[(extra >= 0) & (extra <= n_steps)])
    return steps


def force_values(scene, problem, n0, n1, dt, method):
    """f at the stage times of steps n0..n1-1, shape (n1 - n0, 3)."""
    g = np.zeros((n1 - n0, 3))
    if not problem.terms["force_profile"]:
        return g
    tn = np.arange(n0, n1) * dt
    g[:, 0] = scene.force(tn)
    if method == METHODS["rk4"]:
        g[:, 1] = scene.force(tn + 0.5 * dt)
        g[:, 2] = scene.force(tn + dt)
    return g


@dataclass
class SPHResult:
    """Samples of a full SPH run.

    t (M,) [s], x (N,) [m], v (M, N) [m s^-1], rho (M, N) [kg m^-3],
    steps (M,) step indices, wall_time [s] of the time loop, cpu_time [s] the CPU time of this thread in it
    (:func:`time.thread_time`: what the loop cost, without the time other processes took the core).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    steps: np.ndarray
    wall_time: float
    problem: SPHProblem
    cpu_time: float = float("nan")


def run_sph(scene: Scene, *, sample_steps=None, progress=True, problem=None, chunk_steps=None,
            state=None, layout="auto"):
    """Run the full SPH model of ``scene`` from t = 0 to its T.

    Parameters
    ----------
    scene : Scene
        Scene with the SPH settings to use (see :meth:`Scene.with_sph`).
    sample_steps : array_like of int, optional
        Steps at which to store (v, ρ); default every ``scene.sph.every``
        steps and the last one.
    progress : bool
        Show a progress bar on runs longer than a couple of seconds.
    problem : SPHProblem, optional
        A prebuilt problem (saves the neighbour build in repeated runs).
    state : (v, rho), optional
        Initial state instead of (v0, ρ0).
    layout : {"auto", "general"}
        The operator's layout in the compiled loop (:meth:`SPHProblem.loop_args`); both give the same bits.

    Returns
    -------
    SPHResult

    Raises
    ------
    SimulationError
        When the state turns non-finite or ρ <= 0, or its energy exceeds
        :data:`BLOWUP_FACTOR` times the bound of :func:`energy_bound_factors`
        (a numerical blow-up); names the step and time.
    """
    problem = problem or build_problem(scene)
    dt = scene.sph.dt
    method = METHODS[scene.sph.integrator]
    n_steps = step_count(scene.T, dt)
    if sample_steps is None:
        sample_steps = default_sample_steps(n_steps, scene.sph.every)
    sample_steps = np.unique(np.asarray(sample_steps, dtype=np.int64))
    if sample_steps.size and (sample_steps[0] < 0 or sample_steps[-1] > n_steps):
        raise ValueError("sample steps outside [0, n_steps]")
    if state is None:
        v, rho = problem.v0.copy(), problem.rho0.copy()
    else:
        v, rho = np.array(state[0], dtype=float), np.array(state[1], dtype=float)
    out_v = np.empty((sample_steps.size, problem.n))
    out_rho = np.empty((sample_steps.size, problem.n))
    args, layout_bit = problem.loop_args(layout)
    if chunk_steps is None:
        # about 2e6 particle-steps per chunk: a few ms, so the bar moves smoothly
        chunk_steps = max(1, min(n_steps, int(2e6 // max(problem.n, 1))))
    check_every = 64
    dx = problem.neighbours.dx
    # blow-up bound: sqrt(E) <= e^{lam t} (sqrt(E0) + sigma * int |f| dt) for the exact dynamics
    sqrt_e0 = np.sqrt(energy(problem, v, rho)) if np.all(rho > 0) else np.inf
    sigma, lam = energy_bound_factors(problem)
    f_integral = 0.0
    # Load the compiled loop (numba's cache) before the clock starts.
    loops.advance(method, v, rho, 0, 0, dt, np.zeros((0, 3)), *args, layout_bit, sample_steps[:0], 0, out_v, out_rho,
                  1, np.inf, dx)
    ptr = 0
    wall = cpu = 0.0
    with progress_bar(total=n_steps, desc=f"sph {scene.name}", unit="step", enabled=progress) as bar:
        n0 = 0
        while n0 < n_steps:
            n1 = min(n_steps, n0 + chunk_steps)
            g = force_values(scene, problem, n0, n1, dt, method)
            flags = problem.flags(bool(np.any(g != 0))) | layout_bit
            # the bound grows with t: its value at the chunk's end holds for every step in it
            f_integral += dt * float(np.sum(np.max(np.abs(g), axis=1))) if g.size else 0.0
            bound = (np.exp(lam * n1 * dt) * (sqrt_e0 + sigma * f_integral)) ** 2
            energy_max = BLOWUP_FACTOR * bound if bound > 0 else np.inf
            t0, c0 = _time.perf_counter(), _time.thread_time()
            status, ptr, bad = loops.advance(method, v, rho, n0, n1, dt, g, *args, flags,
                                          sample_steps, ptr, out_v, out_rho, check_every, energy_max, dx)
            cpu += _time.thread_time() - c0
            wall += _time.perf_counter() - t0
            if status == 2:
                e_now = energy(problem, v, rho)
                raise SimulationError(
                    f"SPH run blew up by step {bad} (t = {bad * dt:.6g} s): its energy {e_now:.3g} J/m^2 "
                    f"exceeds {BLOWUP_FACTOR:g} x the bound {bound:.3g} J/m^2 that the scene's initial "
                    f"energy and forcing allow (integrator {scene.sph.integrator}, dt = {dt:g} s)",
                    step=bad, time=bad * dt)
            if status != 0:
                raise SimulationError(
                    f"SPH state became non-finite or non-positive density by step {bad} "
                    f"(t = {bad * dt:.6g} s, integrator {scene.sph.integrator}, dt = {dt:g} s)",
                    step=bad, time=bad * dt)
            bar.update(n1 - n0)
            n0 = n1
    return SPHResult(t=sample_steps * dt, x=problem.x, v=out_v, rho=out_rho, steps=sample_steps,
                     wall_time=wall, problem=problem, cpu_time=cpu)


def spectral_radius(problem: SPHProblem):
    """An upper bound of the fastest angular frequency ω_max [rad s^-1] (:func:`.timestep.omega_max`).

    Linearised about rest, the scheme is J̇ = G v, v̇ = ρ0^-1 G c J (J the
    specific volume): ω_max <= sqrt(max c / min ρ0) ||G||, and on a uniform
    lattice ||G|| is the maximum over wavenumbers of the stencil's symbol.
    """
    scene = problem.scene
    return omega_max(float(problem.c.max()), float(problem.rho0.min()), scene.L, problem.n, scene.sph.alpha)


def amplification(problem: SPHProblem, dt, integrator, T, samples=257):
    """The largest factor by which the scheme amplifies a mode over [0, T], and that mode's ω
    (:func:`.timestep.growth` at ω_max of :func:`spectral_radius` and the scene's smallest damping; explicit
    Euler, undamped: r = |1 + i ω Δt| = (1 + ω²Δt²)^½ per step)."""
    return growth(integrator, spectral_radius(problem), float(np.min(problem.d)), dt, T, samples)


def stability(problem: SPHProblem, dt, integrator, T):
    """The explicit stability limit and CFL numbers of a run.

    Returns a dict with ``omega_max`` [rad/s], ``dt_limit`` [s] (:func:`.timestep.dt_limit` of
    ``integrator`` with the scene's largest damping: ω_max Δt below 2 for the Euler schemes, 2√2 for RK4
    when undamped), ``cfl`` (c_s Δt / Δx with the largest sound speed of eq. 2.5 at rest),
    ``omega_dt``, ``euler_growth`` (the factor by which explicit Euler amplifies the fastest mode over T when
    d = 0; Euler has no strict stability on the imaginary axis), ``growth`` and ``growth_omega`` (the
    factor by which ``integrator`` amplifies its worst mode over T with the scene's smallest damping, and that
    mode's ω: :func:`amplification`).
    """
    w = spectral_radius(problem)
    cs = float(np.sqrt(np.max(problem.c / problem.rho0)))
    lim = dt_limit(integrator, w, float(np.max(problem.d)), float(np.min(problem.d)))
    euler = float(np.exp(min(700.0, 0.5 * (T / dt) * np.log1p((w * dt) ** 2))))
    amp, amp_w = growth(integrator, w, float(np.min(problem.d)), dt, T)
    return {"omega_max": w, "dt_limit": lim, "cfl": cs * dt / problem.neighbours.dx,
            "omega_dt": w * dt, "euler_growth": euler, "growth": amp, "growth_omega": amp_w}


def stability_warnings(problem: SPHProblem, dt, integrator, T):
    """One-line warnings (no prefix) about the time step of a run, maybe none.

    Warns when Δt exceeds the stability limit of the integrator (a scene refuses that when it is loaded;
    settings changed in code may still ask for it), and when the integrator amplifies some mode by more than
    :data:`GROWTH_WARN` over the run even below that limit (explicit Euler on an undamped scene over a long
    horizon), with the figure (:func:`.timestep.warnings`).
    """
    stab = stability(problem, dt, integrator, T)
    out = []
    if dt > stab["dt_limit"]:
        out.append(f"dt = {dt:g} s exceeds the explicit stability limit {stab['dt_limit']:.3g} s of "
                   f"'{integrator}' (CFL number c_s dt/dx = {stab['cfl']:.3g}, "
                   f"omega_max dt = {stab['omega_dt']:.3g})")
    return out + growth_warnings(integrator, dt, stab["omega_max"], float(np.min(problem.d)), T)


def energy(problem: SPHProblem, v, rho):
    """The discrete energy ½ Σ ρ0 v² Δx + ½ Σ c e² Δx [J per m²], e = ρ0/ρ − 1.

    In the specific volume J = ρ0/ρ (eq. A.9) eqs. 2.10-2.11 read ė = G v,
    ρ0 v̇ = G(c e) − ρ0 d v + ρ0 f with G skew in the volume inner product,
    so this energy is conserved by the exact (semi-discrete) SPH dynamics
    when d = f = 0, and non-increasing when d ≥ 0 and f = 0.
    """
    return strain_energy(problem, v, problem.rho0 / rho - 1.0)


def strain_energy(problem: SPHProblem, v, e):
    """The discrete energy ½ Σ ρ0 v² Δx + ½ Σ c e² Δx [J per m²] of velocities ``v`` and specific-volume
    strains ``e`` (J − 1 = ρ0/ρ − 1, or its linearisation 1 − ρ/ρ0 of eq. 2.17) at the particles."""
    dx = problem.neighbours.dx
    return 0.5 * dx * float(np.sum(problem.rho0 * v * v) + np.sum(problem.c * e * e))


# Factor between the discrete energy and the bound of the exact dynamics at
# which a run is declared blown up.  A consistent scheme run at an accurate
# step stays within a few percent of the bound's energy; 10^4 in energy is a
# factor 100 in amplitude, far beyond any discretisation error, and a mode
# that has grown that much keeps growing geometrically, so stopping there
# loses no run that could still be trusted.
BLOWUP_FACTOR = 1e4


def energy_bound_factors(problem: SPHProblem):
    """(σ, λ): √E(t) ≤ e^{λt} (√E0 + σ ∫_0^t |f| ds) for the exact SPH dynamics.

    dE/dt = −Σ ρ0 d v² Δx + f(t) Σ ρ0 profile v Δx, so with
    σ = (½ Σ ρ0 profile² Δx)^½ (Cauchy-Schwarz) and λ = max(0, −min d)
    (growth only where the scene's damping is negative) Grönwall gives the
    bound.
    """
    dx = problem.neighbours.dx
    sigma = float(np.sqrt(0.5 * dx * np.sum(problem.rho0 * problem.profile ** 2)))
    lam = max(0.0, -float(np.min(problem.d)))
    return sigma, lam
