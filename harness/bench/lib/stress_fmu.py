"""The FMU in the stability stress maps (``sphrom stress``): does it report an error where it blows up?

For each stress setting the FMU (FMI 2, through fmpy and :class:`sphrom.fmu.run.driver.FMU`) runs the same
reduced model as the Python rows of :mod:`sphrom.bench.lib.stress` (the frozen FMU with its own b, about the
projected rest density, where the Python rows run the paper's: :func:`sphrom.bench.lib.stress.fmu_operators`): the
scene's x1 basis and operators,
the initial velocity coordinates scaled by the amplitude (the FMU's ``initial_state_scale``, so one FMU per
scene and model serves every amplitude), the internal step ``dt`` (the FMU's ``dt``
parameter; the exact model ignores it), n_freeze = 10, the force held over each communication step.
Communication points are the stress run's sample steps, so the FMU's internal grid is the Python one.

Each run ends as in :func:`sphrom.bench.lib.stress.run_one` (stable, growing, unphysical, blow-up), with
two more fields: ``fmu_error``, the FMU's logged error message when a call returned an error status
(its blow-up time is read from that message), and ``silent_nan``, the number of communication points
at which an output was non-finite without an error status: the contract is that this is always 0.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ... import defaults
from ...fmu.make.archive import write_fmu
from ...fmu.make.build import ensure_binaries
from ...fmu.make.describe import model_description
from ...fmu.make.models import operator_resource
from ...fmu.run.driver import FMU
from ...rom.registry import get_model
from ...sph.diagnostics import energy
from ...sph.solver import step_count
from .fmu import benched_fmu_models
from .stress import classify_energy, fmu_operators

N_FREEZE = defaults.N_FREEZE
_TIME = re.compile(r"t = ([-+0-9.eE]+) s")


def _outcome(e, rho_bad_time=None):
    outcome, growth, drift = classify_energy(e)
    if rho_bad_time is not None:
        outcome = "unphysical"
    return {"outcome": outcome, "blowup_time": rho_bad_time, "energy_growth": growth, "energy_drift": drift,
            "energy_end": float(e[-1])}


class FMUStress:
    """FMUs made from a stress context's operators, one per (scene, model), in a private folder.

    Call :meth:`close` (or use as a context manager) to remove the folder.
    """

    def __init__(self):
        self.folder = Path(tempfile.mkdtemp(prefix="sphrom-stress-"))
        self._made = {}

    def close(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def fmu(self, ctx, model):
        """(extracted folder, fields(z) -> (v, ρ), k) of the FMU for ``ctx`` (the amplitude is set at run time)."""
        key = (ctx.scene.name, id(ctx), model)
        if key in self._made:
            return self._made[key]
        from fmpy import extract


        scene, problem = ctx.scene, ctx.problem
        ops = fmu_operators(ctx, model)             # the FMU's model: the frozen one with b about rest
        data, blob = operator_resource(get_model(model).fmu_kind, ops, problem, dt=scene.sph.dt, n_freeze=N_FREEZE)
        fields = ops.fields
        description = model_description(2, token=data.token, scene=scene, data=data, k_requested=ctx.k,
                                         step_size=0.01, stop_time=scene.T, input_error=ops.input_error, model=model)
        path = self.folder / f"{len(self._made)}.fmu"
        write_fmu(path, fmi=2, blob=blob, description=description, binary=ensure_binaries().fmi2)
        unzipped = extract(str(path), unzipdir=str(self.folder / f"{len(self._made)}"))
        self._made[key] = (unzipped, fields, data.k_v + data.k_rho)
        return self._made[key]

    def run(self, ctx, model, dt, amplitude=1.0, T=None, force=None, n_samples=200):
        """One stress run of the FMU; the dict of :func:`sphrom.bench.lib.stress.run_one` plus fmu_error, silent_nan."""
        from fmpy.fmi1 import FMICallException


        scene, problem = ctx.scene, ctx.problem
        T = T or scene.T
        force = force or scene.force
        n = max(1, step_count(T, dt))
        steps = np.unique(np.linspace(0, n, min(n, n_samples) + 1).astype(np.int64))
        folder, fields, k = self.fmu(ctx, model)
        energies, rho_bad, silent_nan = [], None, 0
        times = steps * dt
        f = np.array([float(np.asarray(force(np.array([float(x)])))[0]) for x in times])
        linear = get_model(model).linear          # a linear FMU has no dt, no n_freeze
        with FMU(folder, name="stress") as s:

            def observe(i, t):
                nonlocal rho_bad
                v, rho = fields(s.reduced_state(k))
                energies.append(float(energy(problem, v, rho)[0]))
                if rho_bad is None and np.any(~(rho > 0)):
                    rho_bad = float(steps[i] * dt)
            try:
                s.initialize(dt=None if linear else dt, n_freeze=None if linear else N_FREEZE,
                             initial_state_scale=amplitude)
                observe(0, times[0])
                y = s.simulate(times, {"f": f}, steps=np.diff(steps) * dt, on_step=observe, stop_on_error=True)
                silent_nan += int(np.sum(~np.all(np.isfinite(y), axis=1)))
                failed = len(y) < len(times)
            except FMICallException:
                failed = True
            if failed:
                message = "; ".join(s.errors()) or "error status"
                found = [float(m) for m in _TIME.findall(message)]
                return {"outcome": "blow-up", "blowup_time": found[0] if found else float("nan"),
                        "energy_growth": np.inf, "energy_drift": np.inf, "energy_end": np.inf,
                        "fmu_error": message, "silent_nan": silent_nan}
        e = np.asarray(energies)
        if not np.all(np.isfinite(e)):
            return {"outcome": "blow-up", "blowup_time": float("nan"), "energy_growth": np.inf,
                    "energy_drift": np.inf, "energy_end": np.inf, "fmu_error": "", "silent_nan": silent_nan + 1}
        return {**_outcome(e, rho_bad), "fmu_error": "", "silent_nan": silent_nan}


def stress_runners(stress: FMUStress):
    """The ``extra`` methods of :mod:`sphrom.bench.lib.stress`: name -> runner(ctx, dt, amplitude, T=None, force=None)."""
    def runner(model):
        def go(ctx, dt, amplitude=1.0, T=None, force=None):
            return stress.run(ctx, model, dt, amplitude, T=T, force=force)
        return go
    return {f"FMU {model}": runner(model) for model in benched_fmu_models()}   # on the scene's POD basis
