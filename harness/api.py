"""The two functions of ``import sphrom`` that take what a user has at hand (a scene's name, an FMU's path) rather than
the objects of the modules below: :func:`package_fmu` and :func:`verify_fmu`.  The other public names are the
modules' own objects (:mod:`sphrom`'s docstring).
"""

from __future__ import annotations

from pathlib import Path


def _scene(scene):
    """``scene`` as a :class:`sphrom.scene.Scene`: one already, or loaded by built-in name or TOML path."""
    from .scene import Scene, load_scene
    return scene if isinstance(scene, Scene) else load_scene(scene)


def package_fmu(scene, out, *, model="frozen", fmi=2, verify=False, progress=True, **options):
    """Package a reduced model of ``scene`` as a co-simulation FMU at ``out``: what ``sphrom fmu`` does.

    The full SPH run is computed once and cached (``$SPHROM_CACHE``), the binaries are built once per source
    tree (CMake; linux64, and win64 where MinGW-w64 is installed); the FMU is validated by fmpy and written
    atomically.

    Parameters
    ----------
    scene : str, path or Scene
        A built-in scene's name (``"tenmode"``; ``sphrom scenes`` lists them), a scene TOML file, or a scene
        from :func:`load_scene`.
    out : path
        The ``.fmu`` to write; its folder must exist.
    model : {"frozen", "exact", "balanced"}
        The reduced model: the paper's frozen-coefficient model (eqs. 2.19-2.24), the exact linear model in the
        specific volume, or the balanced truncation of the linear SPH (docs/science/models.md).
    fmi : {2, 3}
        FMI version.
    verify : bool
        Measure the FMU against the full SPH before writing it, and store the figures in its documentation
        (``sphrom fmu`` does by default; here off, as it runs the full SPH again).
    progress : bool
        Progress lines on stderr.
    **options
        The other options of :func:`sphrom.fmu.make.package.package_fmu`: ``k`` (POD modes), ``probes`` (x/L),
        ``n_freeze``, ``integrator``, ``step_size`` [s], ``tolerance``, ``ports`` (x/L), ``vary``, ...

    Returns
    -------
    sphrom.fmu.make.package.FMUSummary
        What was built: ``path``, ``k_v``, ``probes``, ``platforms``, ``verification`` (when measured), ...

    Raises
    ------
    sphrom.errors.UserError
        A scene that does not exist or does not validate, or a bad option (one line naming the field and the
        allowed range); nothing is written.
    """
    from .fmu.make.package import package_fmu as package
    return package(_scene(scene), out, model=model, fmi=fmi, verify=verify, progress=progress, **options)


def verify_fmu(fmu, scene, *, progress=True):
    """Measure the FMU at ``fmu`` against the full SPH of ``scene``, as ``sphrom fmu`` does before it writes one.

    The FMU's own probes, integrator and ports are read from it; the full SPH runs with the FMU's integrator on
    the training force and on an unseen one, and on each input channel from rest.

    Parameters
    ----------
    fmu : path
        An sphrom FMU (FMI 2 or 3).
    scene : str, path or Scene
        The scene it was packaged from (built-in name, TOML file or :func:`load_scene`'s scene).
    progress : bool
        Progress bars on stderr.

    Returns
    -------
    sphrom.fmu.check.verify.Verification
        ``training`` and ``unseen`` (each: ``err_v``, ``err_rho``, the relative L2 errors of eq. 3.4 at the probes,
        ``fmu_s``, ``sph_s`` [s], ``speedup``), ``channels`` (each input channel's error), ``sentence()``.
    """
    import zipfile

    from .fmu.make.package import verification_step
    from .fmu.kinds import unpack
    path = Path(fmu)
    with zipfile.ZipFile(path) as zf:
        data = unpack(zf.read("resources/model.bin"))
    ports = data.sections.get("PORTX")
    ports = [] if ports is None else [float(x) for x in ports.ravel()]
    return verification_step(path, _scene(scene), list(map(float, data.probe_x)), None, None, progress, None, path,
                             "", ports=ports)
