"""Snapshot strategies of sections 3.1.2-3.1.3 and 3.2.1, as step indices.

A strategy is a dict (the scene's ``[snapshots]`` table, or built from CLI
options) with exactly one of:

* ``count`` and ``window = [t0, t1]``: ``count`` times uniform in the window,
  t0 + i (t1 - t0)/count, i = 0..count-1 (the paper's "100 snapshots
  uniformly from [0, 1.6] with spacing 0.016");
* ``count``, ``window`` and ``random = SEED``: ``count`` distinct random steps in
  the window (numpy's default_rng(SEED));
* ``times``: explicit times for both fields;
* ``times_v`` and ``times_rho``: explicit times per field (e.g. v at 0, 0.4,
  0.8 and ρ also at 1.2);
* ``all = True`` (CLI ``--snapshots all``): every stored sample in the window
  (the whole run without a window).

Times are rounded to the nearest step of Δt.
"""

from __future__ import annotations

import numpy as np

from ..errors import FieldError, UserError, exact


def _to_steps(times, dt, n_steps, where):
    times = np.asarray(times, dtype=float)
    ratio = times / dt                    # compared before the cast: 1e19 s is no int64 step (numpy warned)
    bad = ~(np.rint(ratio) >= 0) | ~(np.rint(ratio) <= n_steps)
    if np.any(bad):
        raise UserError(f"{where}: time {exact(times[bad][0])} s is outside the run [0, {exact(n_steps * dt)}] s")
    return np.rint(ratio).astype(np.int64)


# The snapshot matrices of v and rho (count x N float64 each) above this are refused before they are made.
MAX_SNAPSHOT_BYTES = 4 * 2**30


def check_snapshot_memory(count, n_particles):
    """FieldError ``snapshots`` when ``count`` snapshots of N particles need more than MAX_SNAPSHOT_BYTES:
    count x N x 8 bytes for each of v and rho."""
    need = count * n_particles * 8 * 2
    if need > MAX_SNAPSHOT_BYTES:
        most = MAX_SNAPSHOT_BYTES // (n_particles * 8 * 2)
        raise FieldError("snapshots", f"{count} snapshots of {n_particles} particles need {need / 2**30:.1f} GiB "
                                      f"(allowed: at most {most} snapshots, "
                                      f"{MAX_SNAPSHOT_BYTES / 2**30:g} GiB for v and rho)")


def snapshot_steps(spec, dt, n_steps, stored_steps=None, where="snapshots", n_particles=None):
    """Step indices of the velocity and density snapshots of a strategy.

    Parameters
    ----------
    spec : dict
        The strategy (see module docstring).
    dt : float
        Time step [s].
    n_steps : int
        Steps of the run (its last step index).
    stored_steps : ndarray, optional
        The steps a run stores (for ``all``).
    n_particles : int, optional
        N: when given, a count whose snapshot matrices exceed MAX_SNAPSHOT_BYTES is refused.

    Returns
    -------
    steps_v, steps_rho : ndarray of int64
        Sorted unique step indices.
    """
    if spec.get("all"):
        t0, t1 = spec.get("window", (0.0, n_steps * dt))
        if stored_steps is None:
            raise UserError(f"{where}: 'all' needs a stored run")
        s = np.asarray(stored_steps)
        s = s[(s * dt >= t0 - 1e-9 * dt) & (s * dt <= t1 + 1e-9 * dt)]      # a billionth of a step
        return s.copy(), s.copy()
    if "times_v" in spec:
        sv = _to_steps(spec["times_v"], dt, n_steps, f"{where}.times_v")
        sr = _to_steps(spec["times_rho"], dt, n_steps, f"{where}.times_rho")
        return np.unique(sv), np.unique(sr)
    if "times" in spec:
        s = np.unique(_to_steps(spec["times"], dt, n_steps, f"{where}.times"))
        return s, s.copy()
    count = int(spec["count"])
    t0, t1 = (float(a) for a in spec["window"])
    if t1 > n_steps * dt * (1 + 1e-12):
        raise UserError(f"{where}.window: [{t0:g}, {t1:g}] exceeds the run's end {n_steps * dt:g} s")
    lo, hi = int(np.ceil(t0 / dt - 1e-9)), int(np.floor(t1 / dt + 1e-9))
    available = hi - lo + 1             # the distinct steps of the run in the window
    if count > available:               # checked before any array of `count` times is made
        raise FieldError("snapshots", f"{count} is out of range (allowed: at most {available} snapshots, "
                                      f"the steps of the full SPH run in the window [{t0:g}, {t1:g}] s "
                                      f"at dt = {dt:g} s)")
    if n_particles is not None:
        check_snapshot_memory(count, n_particles)
    if "random" in spec:
        available = np.arange(lo, hi)
        if count > available.size:
            raise UserError(f"{where}.count: {count} random snapshots do not fit in {available.size} steps of the window")
        rng = np.random.default_rng(int(spec["random"]))
        s = np.sort(rng.choice(available, size=count, replace=False))
        return s, s.copy()
    s = _to_steps(t0 + np.arange(count) * (t1 - t0) / count, dt, n_steps, f"{where}.window")
    if np.unique(s).size < s.size:
        raise UserError(f"{where}.count: {count} snapshots in [{t0:g}, {t1:g}] are closer than dt = {dt:g}")
    return s, s.copy()


def describe(spec):
    """A one-line description of a strategy, for reports."""
    if spec.get("all"):
        return "every stored sample" + (f" in [{spec['window'][0]:g}, {spec['window'][1]:g}]" if "window" in spec else "")
    if "times_v" in spec:
        return (f"v at t = {', '.join(f'{t:g}' for t in spec['times_v'])}; "
                f"rho at t = {', '.join(f'{t:g}' for t in spec['times_rho'])}")
    if "times" in spec:
        return f"t = {', '.join(f'{t:g}' for t in spec['times'])}"
    kind = f"random (seed {spec['random']})" if "random" in spec else "uniform"
    return f"{spec['count']} {kind} in [{spec['window'][0]:g}, {spec['window'][1]:g}]"
