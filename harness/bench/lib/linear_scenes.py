"""The scenes the linear-model measurements share (:mod:`sphrom.bench.balanced_measure`,
:mod:`sphrom.bench.linear_tradeoff`): a built-in scene, its ``@shaped`` variant, its full linear SPH."""

from __future__ import annotations

from ...rom.lti import full_linear_system
from ...scene import derive_scene, load_scene
from ...sph.solver import build_problem

SHAPED_PROFILE = "1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)"


def setup(name, n=None):
    """(scene, problem, lti) of a built-in scene, optionally with N particles.

    ``NAME@shaped``: the scene with the force profile SHAPED_PROFILE instead of
    its uniform one (a uniform profile drives only the mean velocity,
    v̇ = f - d v, which every model holding the constant mode reproduces to
    round-off, so random forces test nothing there).
    """
    name, _, variant = name.partition("@")
    scene = load_scene(name)
    if variant == "shaped":
        scene = derive_scene(scene, {"force": {"profile": SHAPED_PROFILE}})
    elif variant:
        raise ValueError(f"scene variant {variant!r} (allowed: shaped)")
    if n is not None:
        scene = derive_scene(scene, {"sph": {"n_particles": int(n)}})
    problem = build_problem(scene)
    return scene, problem, full_linear_system(problem)
