"""What the port benchmarks share (:mod:`sphrom.bench.port_coupling`, :mod:`sphrom.bench.port_envelope`,
:mod:`sphrom.bench.port_rates`): the ports, the open-loop port forces, the lumped mass-spring, the error."""

import functools

import numpy as np

PORTS = (0.3, 0.7)
MASS, STIFFNESS, S0 = 0.05, 5.0, 1e-3         # kg, N/m, m


def open_loop_forces(t):
    """F_1, F_2 [N] at times t: (len(t), 2)."""
    t = np.atleast_1d(np.asarray(t, float))
    return 1e-3 * np.stack([np.sin(5 * t + 0.3), np.cos(2 * t) ** 2], axis=-1)


def mass_spring_step(y, v_port, h, damping=0.0, *, mass=MASS, stiffness=STIFFNESS):
    """The mass-spring (s, w) advanced exactly over h [s] with the port velocity held: s'' = -ω² s, w = s' + v_port.

    ``damping`` [N s m^-1]: a dashpot beside the spring (a mass-spring-damper): m s'' = -K s - damping s'; the force
    on the port is then K s + damping s' (:func:`coupling_force`).  ``mass`` [kg], ``stiffness`` [N m^-1]: m and K
    (default the unit bar's :data:`MASS`, :data:`STIFFNESS`)."""
    s, w = y
    if damping == 0.0:
        omega = np.sqrt(stiffness / mass)
        c, sn = np.cos(omega * h), np.sin(omega * h)
        s_new = s * c + (w - v_port) / omega * sn
        ds = -s * omega * sn + (w - v_port) * c
        return np.array([s_new, ds + v_port])
    s_new, ds = _lumped_flow(h, damping, mass, stiffness) @ np.array([s, w - v_port])
    return np.array([s_new, ds + v_port])


def coupling_force(y, v_port, damping=0.0, *, stiffness=STIFFNESS):
    """The force [N] the lumped mass-spring(-damper) in state y = (s, w) puts on the port moving at v_port."""
    return stiffness * y[0] + damping * (y[1] - v_port)


@functools.lru_cache(maxsize=8)
def _lumped_flow(h, damping, mass=MASS, stiffness=STIFFNESS):
    """e^{A h} of (s, s')' = [[0, 1], [-K/m, -damping/m]] (s, s'), read-only (one per step length, dashpot, mass
    and spring: a loop's every step uses the same)."""
    import scipy.linalg as sla
    E = sla.expm(np.array([[0.0, 1.0], [-stiffness / mass, -damping / mass]]) * h)
    E.setflags(write=False)
    return E


def loop_map(problem, port, h, damping=0.0, *, mass=MASS, stiffness=STIFFNESS):
    """The sampled loop of the port benchmarks with the full SPH in the FMU's place, as one linear map Z.

    The loop: the lumped mass-spring (with a dashpot of ``damping`` [N s m^-1] beside the spring) on the port at
    x/L = ``port``, its force at the start of each communication step (:func:`coupling_force`) held over it as the
    port force (per unit area), the port velocity read at the step's start held in the mass-spring's step
    (:func:`mass_spring_step`); the bar is the full SPH of eqs. 2.10-2.11 linear in J in energy coordinates x
    (:func:`sphrom.rom.lti.full_linear_system`), advanced exactly over each step.  Then (x, s, w) at the next step
    = Z (x, s, w).

    Parameters
    ----------
    problem : SPHProblem
    port : float
        The coupled port's position x/L.
    h : float
        Communication step [s].
    damping, mass, stiffness : float
        The lumped element's dashpot [N s m^-1], mass [kg] and spring [N m^-1] (default the unit bar's).

    Returns
    -------
    Z : ndarray (2N + 2, 2N + 2)
    """
    from ...rom.bounds import input_columns, output_rows
    from ...rom.exact_linear import propagators
    from ...rom.lti import full_linear_system
    A = full_linear_system(problem, [0.5]).A.toarray()
    n2 = A.shape[0]
    b = input_columns(problem, (port,))[:, 1]                   # per F/area [N m^-2]
    c = output_rows(problem, [0.5], (port,))[0][-1]            # v_port [m s^-1]
    Phi, g, _ = propagators(A, b, h)                           # e^{Ah}, ∫ e^{As} ds b (the force held)
    R = _lumped_flow(h, damping, mass, stiffness)              # (s, w - v_port) over the step, v_port = c x held
    Z = np.zeros((n2 + 2, n2 + 2))
    # F = K s + damping (w - c x), held: x+ = Phi x + g F
    Z[:n2, :n2] = Phi - damping * np.outer(g, c)
    Z[:n2, n2], Z[:n2, n2 + 1] = g * stiffness, g * damping
    # s+ = R00 s + R01 (w - c x);  w+ = R10 s + R11 (w - c x) + c x
    Z[n2, :n2], Z[n2, n2], Z[n2, n2 + 1] = -R[0, 1] * c, R[0, 0], R[0, 1]
    Z[n2 + 1, :n2], Z[n2 + 1, n2], Z[n2 + 1, n2 + 1] = (1.0 - R[1, 1]) * c, R[1, 0], R[1, 1]
    return Z


def loop_radius(problem, port, h, damping=0.0, *, dense_limit=2500, mass=MASS, stiffness=STIFFNESS):
    """The spectral radius of :func:`loop_map` (``damping``, ``mass``, ``stiffness``: the lumped element): above 1 the
    sampled loop runs away at step ``h`` [s] whatever model stands in for the bar (the held force feeds the bar
    energy faster than its damping takes it); at most 1 (the rigid motion's 1) it does not.  None above
    ``dense_limit`` particles (the map is dense)."""
    if problem.rho0.size > dense_limit:
        return None
    return float(np.abs(np.linalg.eigvals(loop_map(problem, port, h, damping, mass=mass, stiffness=stiffness))).max())


def rel(a, b):
    """Relative L² error of a against b."""
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def lumped_energy(y):
    """½ m w² + ½ k s² [J] of the lumped mass-spring in state y = (s, w)."""
    return 0.5 * MASS * y[1] ** 2 + 0.5 * STIFFNESS * y[0] ** 2


def damped_loop(bar_velocity, bar_step, n_steps, watch, h, damping):
    """Port 1 tied to the lumped mass-spring(-damper) over ``n_steps`` of ``h`` [s], the spring (and dashpot)
    force held over each step, the port velocity held in the mass-spring's exact step: (v_port_1 at each point
    reached, ``watch(y)`` there, the stop message or None).  ``bar_velocity()`` -> v_port_1 [m s^-1],
    ``bar_step(F)`` advances the bar over a step with F [N] on port 1."""
    y, vp, v, seen = np.array([S0, 0.0]), 0.0, [], []
    for j in range(n_steps + 1):
        if j:
            y = mass_spring_step(y, vp, h, damping)
        vp = float(bar_velocity())
        v.append(vp)
        seen.append(watch(y))
        if j == n_steps:
            break
        try:
            bar_step(coupling_force(y, vp, damping))
        except Exception as exc:                 # the FMU's or the SPH's own stop: recorded, not raised
            return np.array(v), seen, f"t = {(j + 1) * h:.2f} s: {exc}"
    return np.array(v), seen, None


def frozen_fields(ops, problem):
    """z -> (energy [J m^-2], min ρ/ρ0) of the fields of a frozen state z = [a^v, a^ρ] (the operators' protocol
    ``fields``): E = ½ Σ (ρ0 v² + c e²) Δx, e = ρ0/ρ - 1."""
    def fields(z):
        v, rho = (x[0] for x in ops.fields(z))
        e = problem.rho0 / rho - 1.0
        energy = 0.5 * float(np.sum(problem.rho0 * v ** 2 + problem.c * e ** 2)) * problem.neighbours.dx
        return energy, float(np.min(rho / problem.rho0))
    return fields
