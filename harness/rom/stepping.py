"""The Python driver of the time-stepped reduced models: sampling, force tables, chunks, progress, failures.

A model's ``run`` wraps its compiled loop as ``advance(n0, n1, g, ptr) ->
(status, ptr, step)`` and hands it to :func:`drive`, which runs it in chunks
from step 0 to ``n_steps``, times the loop alone and turns a bad status
(:mod:`.loops`) into a SimulationError naming the step and time.

Numerical blow-ups of the explicit integrators, as for the full SPH
(:mod:`sphrom.sph.solver`): before a run, :func:`reduced_stability_warnings`
estimates the factor by which the integrator amplifies the fastest reduced
mode over the run, from the eigenvalues of the reduced operator linearised
about rest (explicit Euler, undamped: |1 + iωΔt|^n); during a run,
:func:`energy_guard` stops it (SimulationError, exit status 3 on the command
line) when the energy of the reconstructed fields exceeds
:data:`~sphrom.sph.solver.BLOWUP_FACTOR` times the bound that the scene's
initial energy and forcing allow (:func:`~sphrom.sph.solver.energy_bound_factors`),
even while the state is finite.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import SimulationError
from ..progress import progress_bar
from ..sph.ports import port_accelerations
from ..sph.solver import BLOWUP_FACTOR, GROWTH_WARN, energy_bound_factors, growth_figure, step_count, strain_energy
from .operators import density_matrix

METHODS = {"euler": 0, "symplectic": 1, "rk4": 2}
RUNAWAY_FACTOR = 1e6
CHUNK_WORK = 5e7          # multiply-adds per chunk of steps
GUARD_CHECKS = 100        # a guarded run is checked at least this many times (chunks of at most n_steps / 100)


def runaway_bound(ops):
    """|a| above this is a runaway: 10⁶ x the largest initial reduced coordinate."""
    return RUNAWAY_FACTOR * max(np.max(np.abs(ops.a_v0)), np.max(np.abs(ops.a_rho0)), 1e-300)


def initial_scale(value):
    """``initial_state_scale`` as a float; ValueError naming it unless it is a finite real number."""
    scale = float(value)
    if not np.isfinite(scale):
        raise ValueError(f"initial_state_scale = {value!r} is out of range (allowed: a finite real number; 1 the "
                         "scene's initial state, 0 at rest)")
    return scale


def start_arrays(ops, state, n_samples, initial_state_scale=1.0):
    """(a_v, a_rho, out_z): the initial reduced coordinates as fresh arrays (``state`` the whole initial state
    z = [a_v, a_rho], default the operators' projections of v0, ρ0) and the samples' states, (n_samples, k).

    ``initial_state_scale`` multiplies the velocity coordinates only (the density coordinates are those of
    ρ0, the rest state), as the FMU's parameter of that name; 1 leaves them bit for bit.  The loops write the
    samples into the two blocks of ``out_z`` (:func:`sample_blocks`)."""
    z = None if state is None else ops.as_state(state)
    a_v0, a_rho0 = (ops.a_v0, ops.a_rho0) if z is None else (z[:ops.k_v], z[ops.k_v:])
    av = initial_scale(initial_state_scale) * np.array(a_v0, dtype=float)
    ar = np.array(a_rho0, dtype=float)
    return av, ar, np.empty((n_samples, ops.order))


def sample_blocks(out_z, k_v):
    """(out_av, out_ar): the velocity and second blocks of the sample states ``out_z`` (views the loops write)."""
    return out_z[:, :k_v], out_z[:, k_v:]


def sample_grid(n_steps, sample_steps=None, every=1):
    """The sorted, unique sample steps: ``sample_steps``, or every ``every`` steps and the last."""
    if sample_steps is None:
        sample_steps = np.union1d(np.arange(0, n_steps + 1, every), [n_steps])
    return np.unique(np.asarray(sample_steps, dtype=np.int64))


def method_code(integrator, allowed, what):
    """The loops' code of ``integrator``; ValueError when ``allowed`` does not hold it."""
    if integrator not in allowed:
        raise ValueError(f"{what} are defined for {' and '.join(allowed)} only (not {integrator!r})")
    return METHODS[integrator]


def force_table(force, active, method, n0, n1, dt):
    """f at the stage times of steps n0..n1-1, shape (n1 - n0, 3): t_n, t_n + dt/2, t_n + dt (RK4 only).

    Zeros when the input is not ``active``.
    """
    g = np.zeros((n1 - n0, 3))
    if active:
        tn = np.arange(n0, n1) * dt
        g[:, 0] = force(tn)
        if method == 2:
            g[:, 1] = force(tn + 0.5 * dt)
            g[:, 2] = force(tn + dt)
    return g


def drive(name, advance, forces, *, n_steps, dt, cost, bound, progress=False, guard=None):
    """Run ``advance`` over steps 0..n_steps in chunks of about :data:`CHUNK_WORK` / ``cost`` steps.

    Parameters
    ----------
    name : str
        The model, for the progress bar and the failure message.
    advance : callable
        ``advance(n0, n1, g, ptr) -> (status, ptr, step)``: the compiled loop
        from step n0 to n1 with the force table ``g`` (:func:`force_table`).
    forces : callable
        ``forces(n0, n1) -> g``.
    cost : float
        Multiply-adds per step.
    bound : float
        The runaway bound (for the message).
    guard : callable, optional
        ``guard(n1, g)`` after each chunk (:func:`energy_guard`): raises
        SimulationError on a blow-up; chunks are then at most
        ``n_steps / GUARD_CHECKS`` steps, so a run is stopped early.

    Returns
    -------
    float
        Wall time of the loop alone [s].
    """
    chunk = max(1, min(n_steps, int(CHUNK_WORK // max(cost, 1))))
    if guard is not None:
        chunk = max(1, min(chunk, -(-n_steps // GUARD_CHECKS)))
    advance(0, 0, np.zeros((0, 3)), 0)          # load the compiled loop before the clock starts
    ptr, wall, n0 = 0, 0.0, 0
    with progress_bar(total=n_steps, desc=f"rom {name}", unit="step", enabled=progress) as bar:
        while n0 < n_steps:
            n1 = min(n_steps, n0 + chunk)
            g = forces(n0, n1)
            t0 = time.perf_counter()
            status, ptr, bad = advance(n0, n1, g, ptr)
            wall += time.perf_counter() - t0
            if status != 0:
                what = "non-finite" if status == 1 else f"runaway (|a| > {bound:.3g})"
                raise SimulationError(f"{name} reduced state became {what} by step {bad} (t = {bad * dt:.6g} s)",
                                      step=bad, time=bad * dt)
            if guard is not None:
                guard(n1, g)
            bar.update(n1 - n0)
            n0 = n1
    return wall


def reduced_energy(ops, problem, a_v, a_rho):
    """The energy [J per m²] of the fields a reduced state reconstructs (:func:`~sphrom.sph.solver.strain_energy`).

    ``ops.velocity`` gives v, ``ops.strain`` the specific-volume strain e
    (the density models: its linearisation 1 − ρ/ρ0, eq. 2.17, finite for
    any reconstructed ρ; the exact model: U_e b).
    """
    return strain_energy(problem, ops.velocity(np.asarray(a_v, float)), ops.strain(np.asarray(a_rho, float)))


def energy_guard(ops, problem, a_v, a_rho, *, dt, name, integrator, port_work=None):
    """The blow-up check of a time-stepped reduced run: ``guard(n1, g)`` for :func:`drive`.

    ``a_v``, ``a_rho`` are the run's state arrays (read, never written,
    after each chunk); ``g`` the chunk's force table (:func:`force_table`).
    As for the full SPH (:func:`sphrom.sph.solver.run_sph`): with (σ, λ) of
    :func:`~sphrom.sph.solver.energy_bound_factors`, the exact dynamics
    keep √E(t) ≤ e^{λt} (√E0 + σ ∫|f| dt); the guard raises SimulationError
    naming the step and time when the reconstructed energy
    (:func:`reduced_energy`) exceeds :data:`~sphrom.sph.solver.BLOWUP_FACTOR`
    times that bound (a factor 100 in amplitude) at the end of a chunk.  ``port_work(n0, n1)``: the ports'
    share of σ ∫|f| dt over steps n0..n1 (:func:`port_work`), for a run with port forces.
    """
    sqrt_e0 = float(np.sqrt(reduced_energy(ops, problem, a_v, a_rho)))
    sigma, lam = energy_bound_factors(problem)
    f_integral = [0.0]
    last = [0]

    def guard(n1, g):
        if g.size:
            f_integral[0] += dt * float(np.sum(np.max(np.abs(g), axis=1)))
        if port_work is not None:
            f_integral[0] += port_work(last[0], n1) / max(sigma, 1e-300)
        last[0] = n1
        bound = (np.exp(lam * n1 * dt) * (sqrt_e0 + sigma * f_integral[0])) ** 2
        if not bound > 0:
            return
        e_now = reduced_energy(ops, problem, a_v, a_rho)
        if not e_now <= BLOWUP_FACTOR * bound:        # NaN fails it too
            raise SimulationError(
                f"{name} reduced run blew up by step {n1} (t = {n1 * dt:.6g} s): the energy of its fields "
                f"{e_now:.3g} J/m^2 exceeds {BLOWUP_FACTOR:g} x the bound {bound:.3g} J/m^2 that the scene's "
                f"initial energy and forcing allow (integrator {integrator}, dt = {dt:g} s)", step=n1, time=n1 * dt)

    return guard


def port_work(problem, ports, port_forces, dt, area=1.0):
    """``work(n0, n1)`` = Σ_j σ_j ∫|F_j/A| dt over steps n0..n1 (rectangle rule at the step times), σ_j =
    (½ Σ ρ0 b_j² Δx)^½ with b_j = W(x - x_j, h)/ρ0 the port's acceleration per N (as σ of
    :func:`~sphrom.sph.solver.energy_bound_factors` for the profile): the ports' term of the energy bound."""
    b = port_accelerations(problem, ports)
    sig = np.sqrt(0.5 * problem.neighbours.dx * np.sum(problem.rho0[None, :] * b * b, axis=1))

    def work(n0, n1):
        if n1 <= n0:
            return 0.0
        F = np.asarray(port_forces(np.arange(n0, n1) * dt), float).reshape(n1 - n0, sig.size)
        return dt * float(np.sum(np.abs(F) @ sig)) / area

    return work


def linearized_jacobian(ops):
    """J = [[−D̂, −K], [−M0, 0]] over (a^v, a^ρ): eqs. 2.19-2.20 linearised about rest, M0 = M(a^ρ(0)) (eq. 2.23).

    At a^v = 0 the term (∂M/∂a^ρ) a^v vanishes, so this is the Jacobian of the
    frozen, density-linearised and (to first order in the strain) original
    models alike.
    """
    kv, kr = ops.k_v, ops.k_rho
    D = np.zeros((kv, kv)) if ops.D is None else ops.D
    return np.block([[-D, -ops.K], [-density_matrix(ops, ops.a_rho0), np.zeros((kr, kr))]])


def reduced_step_matrix(J, k_v, dt, integrator):
    """One step of ``integrator`` on ż = J z, z = (a^v, a^ρ), as the reduced loops take it.

    "euler": I + Δt J; "symplectic": a^ρ first, then a^v with the new a^ρ
    (:mod:`.frozen`, :mod:`.galerkin`); "rk4": the degree-4 Taylor polynomial of e^{Δt J}.
    """
    k = J.shape[0]
    eye = np.eye(k)
    if integrator == "euler":
        return eye + dt * J
    if integrator == "symplectic":
        rho_rows = np.hstack([dt * J[k_v:, :k_v], np.eye(k - k_v) + dt * J[k_v:, k_v:]])
        v_rows = np.hstack([np.eye(k_v) + dt * J[:k_v, :k_v], np.zeros((k_v, k - k_v))]) + dt * J[:k_v, k_v:] @ rho_rows
        return np.vstack([v_rows, rho_rows])
    hj = dt * J
    out, term = eye.copy(), eye
    for order in range(1, 5):
        term = term @ hj / order
        out = out + term
    return out


def reduced_amplification(ops, dt, integrator, T):
    """(growth, ω): the largest factor by which ``integrator`` amplifies a reduced mode over [0, T], and its ω.

    The spectral radius r of :func:`reduced_step_matrix` on
    :func:`linearized_jacobian` to the power of the run's steps n (capped at
    exp(700), as :func:`sphrom.sph.solver.amplification`); ω [rad s^-1] is
    the angle of that eigenvalue per step.  Explicit Euler on an undamped mode
    of frequency ω: r = |1 + iωΔt|.
    """
    n = step_count(T, dt)
    mu = np.linalg.eigvals(reduced_step_matrix(linearized_jacobian(ops), ops.k_v, dt, integrator))
    i = int(np.argmax(np.abs(mu)))
    r = float(np.abs(mu[i]))
    log_growth = n * np.log(r) if r > 0 else -np.inf
    return float(np.exp(min(700.0, log_growth))), float(abs(np.angle(mu[i])) / dt)


def reduced_stability_warnings(model, ops, dt, integrator, T):
    """One-line warnings (no prefix) about the time step of a reduced run of ``model``, maybe none.

    Warns with the figure when ``integrator`` amplifies the fastest reduced
    mode by more than :data:`~sphrom.sph.solver.GROWTH_WARN` over the run
    (:func:`reduced_amplification`).  Linear models are advanced exactly in
    time (no integrator): none.
    """
    if model.linear or integrator not in METHODS:
        return []
    growth, w = reduced_amplification(ops, dt, integrator, T)
    if growth <= GROWTH_WARN:
        return []
    others = [m for m in model.integrators if m != integrator]
    n = step_count(T, dt)
    return [f"'{integrator}' amplifies the {model.name} model's fastest reduced mode (omega = {w:.4g} rad/s, "
            f"omega dt = {w * dt:.3g}, linearised about rest) by a factor {growth_figure(growth)} over the run "
            f"({n} steps to T = {T:g} s); rounding errors in that mode grow with it: use fewer modes, a shorter T"
            + (f" or --integrator {'/'.join(others)}" if others else "")]
