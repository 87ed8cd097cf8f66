"""sphrom: reduced-order models of a Lagrangian SPH mass-spring-damper bar, packaged as FMI 2.0 / 3.0
co-simulation FMUs.

The package follows the paper (Fang, Song, Fraser, Huang, "POD-based model-order reduction of SPH for a 1D
mass-spring-damper system"); equation numbers in comments refer to it.  The command line is ``sphrom`` (or
``python -m sphrom``); in Python::

    import sphrom

    scene = sphrom.load_scene("tenmode")                     # a built-in scene, or a TOML file
    summary = sphrom.package_fmu(scene, "tenmode.fmu", model="exact")
    with sphrom.FMU("tenmode.fmu") as fmu:                    # drive it step by step
        fmu.initialize(initial_state_scale=1.0)
        y = fmu.run([0.01] * 100, [0.0] * 100)                # rows t = 0, 0.01, ..., 1; columns fmu.model_outputs
    result = sphrom.run_cosim("tenmode.fmu", force="1e-3*sin(2*pi*t)")   # or a whole run, as sphrom cosim
    measured = sphrom.verify_fmu("tenmode.fmu", scene)        # against the full SPH, as sphrom fmu does

Public names (imported from their modules on first use, so ``import sphrom`` imports nothing heavy)::

    load_scene     a scene by built-in name or TOML path                     (scene)
    package_fmu    scene -> validated .fmu, as sphrom fmu                    (api)
    FMU            one FMU instance driven from Python                       (fmu.run.driver)
    run_cosim      a whole co-simulation with a force input, as sphrom cosim (fmu.run.cosim)
    verify_fmu     an FMU measured against the full SPH                       (api)
    __version__    the package's version (pyproject.toml reads it from here)

The page docs/user/api.md is generated from their docstrings (``python3 -m sphrom.api_page --write``).  The
subpackages hold the rest: :mod:`sphrom.sph` (the full SPH), :mod:`sphrom.pod`, :mod:`sphrom.rom`,
:mod:`sphrom.fmu`, :mod:`sphrom.references`.
"""

from .lazy import lazy_exports

__version__ = "0.1.0"

EXPORTS = {"load_scene": "scene", "package_fmu": "api", "FMU": "fmu.run.driver", "run_cosim": "fmu.run.cosim",
           "verify_fmu": "api"}
__all__ = ["__version__", *EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)


def _take_signals_when_run():
    """When this package is the program (``python -m sphrom``, the ``sphrom`` script), SIGINT and SIGTERM end
    it with the command line's one line ("sphrom: interrupted (SIGINT); no output written", exit 128 + the
    signal) until :func:`sphrom.cli.main` installs its own handler: without this, a signal while Python
    imports the command line was a KeyboardInterrupt traceback (SIGINT) or a silent death (SIGTERM).
    Imported as a library, nothing changes."""
    import os
    import signal
    import sys
    argv = getattr(sys, "orig_argv", [])
    if argv[1:3] != ["-m", "sphrom"] and not (len(argv) > 1 and os.path.basename(argv[1]) == "sphrom"):
        return

    def leave(signum, frame):
        os.write(2, f"sphrom: interrupted ({signal.Signals(signum).name}); no output written\n".encode())
        os._exit(128 + signum)
    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, leave)


_take_signals_when_run()
