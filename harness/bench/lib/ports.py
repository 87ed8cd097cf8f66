"""What the port benchmarks share (:mod:`sphrom.bench.port_coupling`, :mod:`sphrom.bench.port_envelope`,
:mod:`sphrom.bench.port_rates`): the ports, the open-loop port forces, the lumped mass-spring, the error."""

import numpy as np

PORTS = (0.3, 0.7)
MASS, STIFFNESS, S0 = 0.05, 5.0, 1e-3         # kg, N/m, m


def open_loop_forces(t):
    """F_1, F_2 [N] at times t: (len(t), 2)."""
    t = np.atleast_1d(np.asarray(t, float))
    return 1e-3 * np.stack([np.sin(5 * t + 0.3), np.cos(2 * t) ** 2], axis=-1)


def mass_spring_step(y, v_port, h):
    """The mass-spring (s, w) advanced exactly over h [s] with the port velocity held: s'' = -ω² s, w = s' + v_port."""
    omega = np.sqrt(STIFFNESS / MASS)
    s, w = y
    c, sn = np.cos(omega * h), np.sin(omega * h)
    s_new = s * c + (w - v_port) / omega * sn
    ds = -s * omega * sn + (w - v_port) * c
    return np.array([s_new, ds + v_port])


def rel(a, b):
    """Relative L² error of a against b."""
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))
