"""The fixed-offset layout of the SPH operator (eq. 2.9): detected where every row has its neighbours at the same
offsets, the same operator, and the same bits as the neighbour lists in every loop that takes it (numba rates,
run_sph with each integrator, run_sph_ports, the C step); the lists where the rows differ."""

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.scene import builtin_names, load_scene
from sphrom.sph import loops
from sphrom.sph.operator import build_neighbours, fixed_offsets, particle_positions
from sphrom.sph.ports import mass_spring, run_sph_ports
from sphrom.sph.solver import METHODS, build_problem, force_values, run_sph, step_count

# every field per particle (ρ0, c, d and the force profile not uniform): the loops' per-particle branches
NONUNIFORM = {"rho0": "1 + 0.3*sin(2*pi*x/L)", "c": "where(x/L <= 0.5, 0.1, 0.2)", "d": "10*(1 + x/L)",
              "profile": "1 + 0.5*cos(2*pi*x/L)"}


def lattice(n, alpha, L=1.0):
    x = particle_positions(L, n)
    return build_neighbours(x, L, alpha * L / n, np.full(n, L / n))


def same_bits(a, b):
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


# ---------------------------------------------------------------- detection and the operator itself
@pytest.mark.parametrize("name", builtin_names())
def test_every_builtin_scene_takes_the_fixed_offsets(name):
    """At the scene's own N and α, and at a small N: offsets -2, -1, 1, 2 (α = 1.04 and 1.2), weights by offset."""
    scene = load_scene(name)
    for s in (scene, scene.with_sph(n_particles=40)):
        nb = build_problem(s).neighbours
        assert nb.offsets is not None and nb.offsets.tolist() == [-2, -1, 1, 2], (name, nb.offsets)
        assert same_bits(nb.weight_by_offset, nb.weight.T)
        index, weight, bit = nb.loop_arrays()
        assert bit == loops.STENCIL and index.shape == (1, 4) and weight.shape == (4, s.sph.n_particles)
        assert nb.loop_arrays("general")[2] == 0


@pytest.mark.parametrize("n, alpha, k", [(40, 1.04, 4), (37, 1.3, 4), (600, 1.8, 6), (101, 2.6, 10)])
def test_stencil_is_the_same_operator(n, alpha, k):
    """G rebuilt from the offsets and the weights by offset is the matrix of the lists, entry for entry (the
    reduced models' operator matrices are G, unchanged)."""
    nb = lattice(n, alpha)
    assert nb.offsets is not None and nb.offsets.size == k
    rows = np.repeat(np.arange(n), k)
    cols = (np.arange(n)[:, None] + nb.offsets[None, :]) % n
    assert np.array_equal(cols, nb.index)
    import scipy.sparse as sp
    g = sp.csr_matrix((nb.weight_by_offset.T.ravel(), (rows, cols.ravel())), shape=(n, n))
    g.eliminate_zeros()
    ref = nb.matrix()
    assert (g != ref).nnz == 0 and same_bits(g.toarray(), ref.toarray())


@pytest.mark.parametrize("alpha", [1.0, 1.5, 2.0])
def test_rows_that_differ_take_the_lists(alpha):
    """2h a whole number of spacings puts the particle at the support's edge (∇W ≈ 0) into some rows only:
    the columns no longer hold one offset each, so no fixed offsets and the loops read the lists."""
    nb = lattice(400, alpha)
    assert nb.offsets is None and nb.weight_by_offset is None
    assert nb.loop_arrays()[2] == 0 and nb.loop_arrays()[0] is nb.index


def test_fixed_offsets_rejects_one_differing_row():
    n = 12
    index = (np.arange(n)[:, None] + np.array([-2, -1, 1, 2])[None, :]) % n
    assert fixed_offsets(index).tolist() == [-2, -1, 1, 2]
    index[5] = index[5][[1, 0, 2, 3]]                    # one row in another order
    assert fixed_offsets(index) is None


def test_general_path_scene_runs_the_lists_and_keeps_momentum():
    """A scene at α = 1.5 (rows differ) takes the lists and its run conserves momentum, as the lattice must."""
    scene = small_scene(T=0.4, n=40, dt=1e-3, every=100, v0="1e-3*(1 + sin(2*pi*x/L))").with_sph(alpha=1.5)
    problem = build_problem(scene)
    assert problem.neighbours.offsets is None and problem.loop_args()[1] == 0
    r = run_sph(scene, progress=False, problem=problem)
    p = r.v @ problem.mass
    assert np.max(np.abs(p - p[0])) <= 1e-14 * abs(p[0])


# ---------------------------------------------------------------- the same bits: numba
@pytest.mark.parametrize("n, alpha", [(33, 1.04), (600, 1.8)])
@pytest.mark.parametrize("uniform", [True, False])
def test_rates_same_bits(n, alpha, uniform):
    """loops.rates in both layouts on random states: K = 4 (one fused pass) and K = 6 over several blocks of
    rows; uniform fields as scalars, or every field per particle; damping and force on."""
    scene = small_scene("damped_forced", n=n, **({} if uniform else NONUNIFORM)).with_sph(alpha=alpha)
    p = build_problem(scene)
    rng = np.random.default_rng(3)
    v = rng.normal(0, 1e-3, p.n)
    rho = p.rho0 * (1 + rng.normal(0, 1e-3, p.n))
    outs = []
    for layout in ("auto", "general"):
        args, bit = p.loop_args(layout)
        dv, drho, tmp = np.empty(p.n), np.empty(p.n), np.empty(p.n)
        loops.rates(v, rho, 0.7, *args, p.flags(True) | bit, dv, drho, tmp)
        outs.append((dv, drho, bit))
    assert outs[0][2] == loops.STENCIL and outs[1][2] == 0
    assert same_bits(outs[0][0], outs[1][0]) and same_bits(outs[0][1], outs[1][1])
    assert np.all(outs[0][1] != 0)


@pytest.mark.parametrize("name", builtin_names())
@pytest.mark.parametrize("integrator", ["euler", "symplectic", "rk4"])
def test_runs_same_bits_every_builtin_scene(name, integrator):
    """Whole runs of every built-in scene (its fields, damping and force) at N = 48 for 400 steps, each
    integrator: every stored sample of the fixed-offset run equals the lists' run bit for bit."""
    base = load_scene(name)
    scene = base.with_sph(n_particles=48, integrator=integrator, every=50).with_T(400 * base.sph.dt)
    problem = build_problem(scene)
    a = run_sph(scene, problem=problem, progress=False, layout="auto")
    b = run_sph(scene, problem=problem, progress=False, layout="general")
    assert problem.neighbours.offsets is not None
    assert same_bits(a.v, b.v) and same_bits(a.rho, b.rho)
    assert not np.array_equal(a.v[-1], a.v[0]) or not np.array_equal(a.rho[-1], a.rho[0])


@pytest.mark.parametrize("integrator", ["euler", "symplectic", "rk4"])
def test_nonuniform_and_wide_stencil_runs_same_bits(integrator):
    """Every field per particle at K = 4, and α = 1.8 (K = 6, the any-K block loop) over 400 steps."""
    for scene in (small_scene("damped_forced", T=0.08, n=64, integrator=integrator, **NONUNIFORM),
                  small_scene("damped_forced", T=0.08, n=300, integrator=integrator).with_sph(alpha=1.8)):
        a = run_sph(scene, progress=False, layout="auto")
        b = run_sph(scene, progress=False, layout="general")
        assert a.problem.neighbours.offsets is not None
        assert same_bits(a.v, b.v) and same_bits(a.rho, b.rho)


@pytest.mark.parametrize("integrator", ["euler", "symplectic", "rk4"])
def test_ports_same_bits(integrator):
    """run_sph_ports with a given port force and a coupled mass-spring: the same bits in both layouts."""
    scene = small_scene("damped_forced", T=0.1, n=40, integrator=integrator)
    runs = []
    for layout in ("auto", "general"):
        runs.append(run_sph_ports(scene, [0.3, 0.7], forces=lambda t: [0.2 * np.sin(7 * t), -0.1],
                                  lumped=mass_spring(0.5, 40.0, port=1, n_ports=2, s0=1e-3), every=10,
                                  layout=layout))
    a, b = runs
    for name in ("v", "rho", "v_port", "y"):
        assert same_bits(getattr(a, name), getattr(b, name)), name


# ---------------------------------------------------------------- the same bits: the C step
@pytest.fixture(scope="module")
def sph_c():
    from sphrom.fmu.run.sph_c import SphC
    return SphC(ensure_binaries().sph)


@pytest.mark.parametrize("integrator", ["euler", "symplectic"])
@pytest.mark.parametrize("case", ["uniform", "nonuniform", "wide"])
def test_c_stencil_same_bits_as_lists_and_numba(sph_c, integrator, case):
    """fmu_src/sph.c's stencil, its lists and numba's run_sph end 1000 steps in the same bits: uniform fields,
    every field per particle, and α = 1.8 (K = 6, the any-K blocks) at N = 600."""
    if case == "wide":
        scene = small_scene("damped_forced", T=0.2, n=600, integrator=integrator).with_sph(alpha=1.8)
    else:
        scene = small_scene("damped_forced", T=0.2, n=48, integrator=integrator,
                            **(NONUNIFORM if case == "nonuniform" else {}))
    problem = build_problem(scene)
    n, dt = step_count(scene.T, scene.sph.dt), scene.sph.dt
    ref = run_sph(scene, sample_steps=[n], progress=False, problem=problem, chunk_steps=n)
    g = force_values(scene, problem, 0, n, dt, METHODS[integrator])[:, 0]
    ends = []
    for layout in ("auto", "general"):
        runner = sph_c.runner(problem, integrator, layout)
        assert runner.layout_bit == (loops.STENCIL if layout == "auto" else 0)
        v, rho = problem.v0.copy(), problem.rho0.copy()
        runner.advance(v, rho, n, dt, g=g)
        ends.append((v, rho))
    for v, rho in ends:
        assert same_bits(v, ref.v[-1]) and same_bits(rho, ref.rho[-1])
    assert not np.array_equal(ends[0][0], problem.v0)


def test_c_stencil_rejects_bad_offsets(sph_c):
    """An offset outside (-N, N) is a one-line error from the C side's check, not a read out of bounds."""
    from sphrom.fmu.run.sph_c import SphError
    problem = build_problem(small_scene(n=16))
    runner = sph_c.runner(problem, "euler")
    runner.index = np.array([[-2, -1, 1, 16]], dtype=np.int64)
    with pytest.raises(SphError, match="stencil offset 16 out of range"):
        runner.advance(problem.v0.copy(), problem.rho0.copy(), 1, 1e-4)
