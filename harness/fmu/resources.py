"""``resources/model.bin``: the scene's reduced model for the FMU's C core.

One binary serves every scene; the numbers of a scene live in this small,
versioned, little-endian file (the layout is documented in fmu_src/rom.h and
repeated here)::

    char[8]  magic "SPHROMRS"
    uint32   format_version (2), model_kind (1 frozen, 2 exact linear),
             integrator (0 euler, 1 symplectic; 0 for kind 2), k_v, k_rho,
             n_probes, n_pairs, flags, n_freeze_default, reserved (0)
    float64  dt [s], runaway_bound, L [m]
    kind 1 (frozen; flags bit0 damping: D present, bit1 input: p present):
    float64  a_v0[k_v], a_rho0[k_rho], K[k_v, k_rho], b[k_v], D[k_v, k_v] (bit0),
             p[k_v] (bit1), T[n_pairs, k_rho, k_v], Pv[n_probes, k_v],
             Prho[n_probes, k_rho], probe_x[n_probes]   (row-major)
    kind 2 (exact linear, k_rho = k_e, k = k_v + k_e, n_pairs = 0; flags bit0
    damping, bit1 input: B present, bit2 Schur: Q, S present):
    float64  z0[k], A[k, k], B[k] (bit1), Q[k, k], S[k, k] (bit2), Pv[n_probes, k_v],
             Pe[n_probes, 2, k_e], pw[n_probes, 2], prho0[n_probes, 2], probe_x[n_probes]
    kind 2 with flags bit3 (output rows): Pv[n_probes, k], Pe[n_probes, 2, k] are
             rows over the whole state z = (a; b) (the balanced model: k_v = k,
             k_e = 0, its state does not split)
    uint32   n_sections, then per section: char[8] tag (ASCII, NUL padded),
             uint32 rows, cols, float64 data[rows, cols]   (``sections``)
    char[40] token "{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}", NUL padded: the
             FMI guid / instantiationToken, from the first 16 bytes of the
             sha256 of every byte before the token field
    uint32   crc32 (zlib) of every byte before it

Kind 1: K, b, D, p and T are the projected operators of eqs. 2.19-2.24
(:func:`sphrom.rom.operators.build_operators`); Pv, Prho interpolate the
reconstructed fields linearly between particles at the probes
(:func:`sphrom.rom.operators.probe_rows`).  Kind 2: the exact linear model of
:mod:`sphrom.rom.exact_linear` (A, B, z0 and the real Schur form of a skew A);
the density at a probe interpolates ρ = ρ0/J linearly between the two
particles around it, J = 1 + e with e = U_e b.

Version 2 added kind 2; the kind-1 layout is that of version 1.  Version 3
added the tagged sections: optional numbers that later features store (each
tag is known to the C loader, which checks its shape and rejects unknown or
repeated tags; :data:`SECTION_TAGS` lists them here).
"""

from __future__ import annotations

import hashlib
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

MAGIC = b"SPHROMRS"
FORMAT_VERSION = 3
MODEL_FROZEN = 1
MODEL_EXACT_LINEAR = 2
INTEGRATORS = {"euler": 0, "symplectic": 1}
FLAG_DAMPING = 1
FLAG_INPUT = 2
FLAG_SCHUR = 4
FLAG_OUTPUT_ROWS = 8                       # kind 2: probe rows over the whole state z (fmu_src/rom.h)
LINEAR_EXACT_POD, LINEAR_BALANCED = 1, 2   # section LINMODEL: which linear model (messages only)
TOKEN_SIZE = 40
MAX_PROBES = 100
MAX_MODES = 1024
SECTION_TAG_SIZE = 8
MAX_SECTIONS = 32                          # fmu_src/rom.h ROM_MAX_SECTIONS
MAX_SECTION_VALUES = 1 << 26               # fmu_src/rom.h ROM_MAX_SECTION_VALUES
SECTION_TAGS: dict[str, str] = {          # tag -> what it holds (the C loader's SECTION_RULES)
    # the training envelope (harness/fmu/make/envelope.py, fmu_src/rom_envelope.c)
    "ENVELOPE": "the training envelope's scalars",
    "ENVRANGE": "the training envelope's coordinate ranges",
    "ENVPROBE": "rho0 and the training run's max |v| at the probes (training envelope)",
    "ENVPORT": "port coordinates at the end of each block (training envelope: not checked)",
    # linear models (harness/rom/balanced.py)
    "BOUNDS": "certified error bounds per probe (force, initial state)",
    "LINMODEL": "which linear model: 1 exact POD, 2 balanced",
    # parametric models (sphrom.rom.parametric)
    "PARAMS": "parametric model: c and d (varied, start, min, max)",
    "KC": "frozen model: K per unit c",
    "BC": "frozen model: b per unit c",
    "DD": "frozen model: D per unit d",
    # the frozen model's particle refresh (harness/fmu/make/models.py particle_sections)
    "PARTUR": "frozen model: U^rho at the particles (the particle refresh)",
    "PARTGUV": "frozen model: G U^v at the particles (the particle refresh)",
    "PARTIR0": "frozen model: 1/rho0 at the particles (the particle refresh)",
    "A0": "linear model: the part of A without c or d",
    "AC": "linear model: the part of A per unit c",
    "AD": "linear model: the part of A per unit d",
    # mechanical ports (sphrom.sph.ports), all three or none
    "PORTX": "port positions x/L (1 x P)",
    "PORTB": "port input rows at area 1 (P x k_v frozen, P x k linear)",
    "PORTC": "port velocity rows (P x k_v)",
    # the certified error bounds' shadow (harness/rom/bounds.py sections, fmu_src/rom_bound.c), all or none
    "SHSCAL": "error bounds: the shadow's sizes and scalars",
    "SHLAM": "error bounds: the shadow's planes",
    "SHB": "error bounds: the shadow's input columns",
    "SHC": "error bounds: the shadow's output rows",
    "SHW0": "error bounds: the shadow's initial state",
    "SHGRAM": "error bounds: the inputs' Gram matrix outside the shadow",
    "SHROW": "error bounds: per output row, its norm, input gains and initial-state envelope",
    "SHPROBE": "error bounds: the probes' weights and rho0",
    # ... a parametric FMU's shadow adds these two (with section PARAMS)
    "SHPIECE": "error bounds: the planes' pieces per unit c and per unit d",
    "SHPARAM": "error bounds: c_ref and the residual pieces' norms",
    # ... a shadow of one dense block (a damping d that is not uniform) adds these two
    "SHDENSE": "error bounds: the dense block's growth rate",
    "SHEGRAM": "error bounds: the dense block's coupling residual's Gram matrix",
}
MAX_PORTS = 4                              # fmu_src/rom.h ROM_MAX_PORTS
_HEADER = struct.Struct("<8s10I3d")
_SECTION = struct.Struct("<8s2I")
HEADER_SIZE = _HEADER.size                 # 72 bytes, magic to L (fmu_src/rom.h ROM_HEADER_SIZE)


@dataclass
class ModelData:
    """The contents of a model.bin (all arrays float64, shapes as in the file).

    Attributes
    ----------
    integrator : str
        ``euler`` or ``symplectic``.
    n_freeze : int
        Default refresh period of the frozen coefficients.
    dt : float
        Internal step [s].
    bound : float
        Runaway bound on |a| (:func:`sphrom.rom.stepping.runaway_bound`).
    L : float
        Period [m].
    a_v0, a_rho0, K, b, D, p, T, Pv, Prho, probe_x : ndarray
        D and p may be None.
    token : str
        The instantiation token (set by :func:`pack`).
    sections : dict of str to ndarray
        Tagged sections (tag -> 2-D float64 array), in file order.
    """

    integrator: str
    n_freeze: int
    dt: float
    bound: float
    L: float
    a_v0: np.ndarray
    a_rho0: np.ndarray
    K: np.ndarray
    b: np.ndarray
    D: np.ndarray | None
    p: np.ndarray | None
    T: np.ndarray | None      # None: no tensor, the particle sections PART* carry the refresh
    Pv: np.ndarray
    Prho: np.ndarray
    probe_x: np.ndarray
    token: str = ""
    sections: dict = field(default_factory=dict)
    n_freeze_errors: dict = field(default_factory=dict)   # packaging only: choose_n_freeze's measurements
    bounds = None                # the frozen model has no certified error bounds (ExactData.bounds)

    @property
    def k_v(self):
        return self.a_v0.size

    @property
    def k_rho(self):
        return self.a_rho0.size

    @property
    def n_probes(self):
        return self.probe_x.size


def model_data(ops, problem, *, dt, integrator, n_freeze, probes, bound):
    """Collect the FMU's numbers from reduced operators.

    Parameters
    ----------
    ops : ReducedOperators
        With the refresh tensor, or without it (``T`` None: the particle refresh's sections must then be added
        to the data's sections before :func:`pack`, :func:`sphrom.fmu.make.models.particle_sections`); built
        with ``input_direction="needed"`` for an input row.
    problem : SPHProblem
        The full problem (particle positions, L).
    dt : float
        Internal step [s].
    integrator : {"euler", "symplectic"}
    n_freeze : int
        Default refresh period (>= 1).
    probes : sequence of float
        Probe positions in units of L, in [0, 1].
    bound : float
        Runaway bound on |a|.
    """
    from ..rom.operators import probe_rows

    probes = np.asarray(probes, dtype=float)
    L = problem.scene.L
    return ModelData(integrator=integrator, n_freeze=int(n_freeze), dt=float(dt), bound=float(bound), L=float(L),
                     a_v0=np.asarray(ops.a_v0, float), a_rho0=np.asarray(ops.a_rho0, float),
                     K=np.asarray(ops.K, float), b=np.asarray(ops.b, float),
                     D=None if ops.D is None else np.asarray(ops.D, float),
                     p=None if ops.p is None else np.asarray(ops.p, float),
                     T=None if ops.T is None else np.asarray(ops.T, float),
                     Pv=probe_rows(ops.U_v, problem.x, L, probes), Prho=probe_rows(ops.U_rho, problem.x, L, probes),
                     probe_x=probes, sections=port_sections(ops))


def port_sections(ops):
    """The tagged sections of a model with ports (PORTX, PORTB, PORTC; module docstring), {} without."""
    if not ops.ports:
        return {}
    return {"PORTX": np.asarray(ops.ports, float)[None, :], "PORTB": np.asarray(ops.Bp, float),
            "PORTC": np.asarray(ops.Cp, float)}


def make_token(digest16: bytes) -> str:
    """``{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}`` from 16 bytes."""
    h = digest16.hex()
    return "{" + f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}" + "}"


def pack_sections(sections) -> bytes:
    """The bytes of the tagged sections: count, then (tag, rows, cols, data) each.

    Parameters
    ----------
    sections : dict of str to array_like
        Tag (1 to 8 printable ASCII characters, one of :data:`SECTION_TAGS`) ->
        values (a scalar or 1-D array is stored as one row).
    """
    if len(sections) > MAX_SECTIONS:
        raise ValueError(f"{len(sections)} sections, more than {MAX_SECTIONS}")
    out = [struct.pack("<I", len(sections))]
    for tag, values in sections.items():
        raw = tag.encode("ascii")
        if not 1 <= len(raw) <= SECTION_TAG_SIZE or not all(33 <= c <= 126 for c in raw):
            raise ValueError(f"section tag {tag!r} is not 1 to {SECTION_TAG_SIZE} printable ASCII characters")
        if tag not in SECTION_TAGS:
            raise ValueError(f"section tag {tag!r} is unknown (known: {sorted(SECTION_TAGS)})")
        a = np.atleast_2d(np.asarray(values, dtype=float))
        if a.ndim != 2 or a.size > MAX_SECTION_VALUES or not np.all(np.isfinite(a)):
            raise ValueError(f"section {tag!r}: a finite matrix of at most {MAX_SECTION_VALUES} values expected")
        out.append(_SECTION.pack(raw.ljust(SECTION_TAG_SIZE, b"\0"), a.shape[0], a.shape[1]))
        out.append(np.ascontiguousarray(a, dtype="<f8").tobytes())
    return b"".join(out)


def unpack_sections(blob: bytes, cursor: int):
    """(sections, cursor after them) read from ``blob`` at ``cursor``."""
    (n,) = struct.unpack_from("<I", blob, cursor)
    if n > MAX_SECTIONS:
        raise ValueError(f"{n} sections")
    cursor += 4
    sections = {}
    for _ in range(n):
        raw, rows, cols = _SECTION.unpack_from(blob, cursor)
        cursor += _SECTION.size
        tag = raw.rstrip(b"\0").decode("ascii")
        if tag in sections:
            raise ValueError(f"section {tag!r} appears twice")
        sections[tag] = np.frombuffer(blob, dtype="<f8", count=rows * cols, offset=cursor).reshape(rows, cols).copy()
        cursor += 8 * rows * cols
    return sections, cursor


def _finish(body: bytes, data) -> bytes:
    """Sections, token and checksum after the kind's arrays; sets ``data.token``."""
    body += pack_sections(data.sections)
    token = make_token(hashlib.sha256(body).digest()[:16])
    data.token = token
    body += token.encode("ascii").ljust(TOKEN_SIZE, b"\0")
    return body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)


def pack(data: ModelData) -> bytes:
    """The bytes of model.bin; sets ``data.token``.  ``data.T`` None: no refresh tensor (n_pairs = 0), which the
    particle refresh's sections (PARTUR, PARTGUV, PARTIR0) then replace."""
    kv, kr, npr = data.k_v, data.k_rho, data.n_probes
    if data.T is None and "PARTUR" not in data.sections:
        raise ValueError("T: a frozen model without its refresh tensor needs the particle sections PARTUR, PARTGUV, "
                         "PARTIR0")
    n_pairs = 0 if data.T is None else kr * (kr + 1) // 2
    if not (1 <= kv <= MAX_MODES and 1 <= kr <= MAX_MODES):
        raise ValueError(f"mode counts {kv}, {kr} out of range")
    if not 1 <= npr <= MAX_PROBES:
        raise ValueError(f"{npr} probes (allowed: 1 to {MAX_PROBES})")
    shapes = {"K": (kv, kr), "b": (kv,), "T": (n_pairs, kr, kv), "Pv": (npr, kv), "Prho": (npr, kr)}
    for name, shape in shapes.items():
        if name == "T" and data.T is None:
            continue
        if getattr(data, name).shape != shape:
            raise ValueError(f"{name} has shape {getattr(data, name).shape}, expected {shape}")
    flags = (FLAG_DAMPING if data.D is not None else 0) | (FLAG_INPUT if data.p is not None else 0)
    header = _HEADER.pack(MAGIC, FORMAT_VERSION, MODEL_FROZEN, INTEGRATORS[data.integrator], kv, kr, npr, n_pairs,
                          flags, int(data.n_freeze), 0, data.dt, data.bound, data.L)
    arrays = [data.a_v0, data.a_rho0, data.K, data.b]
    if data.D is not None:
        arrays.append(data.D)
    if data.p is not None:
        arrays.append(data.p)
    arrays += ([] if data.T is None else [data.T]) + [data.Pv, data.Prho, data.probe_x]
    body = header + b"".join(np.ascontiguousarray(a, dtype="<f8").tobytes() for a in arrays)
    return _finish(body, data)


def unpack(blob: bytes):
    """Read model.bin bytes back (the same checks as the C loader): ModelData or ExactData."""
    if len(blob) < _HEADER.size + TOKEN_SIZE + 4:
        raise ValueError("truncated")
    (magic, version, kind, integrator, kv, kr, npr, n_pairs, flags, n_freeze, reserved, dt, bound,
     L) = _HEADER.unpack_from(blob)
    if magic == MAGIC and version == FORMAT_VERSION and kind == MODEL_EXACT_LINEAR and reserved == 0:
        return _unpack_exact(blob)
    if magic != MAGIC or version != FORMAT_VERSION or kind != MODEL_FROZEN or reserved != 0:
        raise ValueError(f"not a version-{FORMAT_VERSION} sphrom model.bin")
    if n_pairs not in (0, kr * (kr + 1) // 2):                # 0: no tensor (the particle sections replace it)
        raise ValueError("n_pairs")
    if struct.unpack("<I", blob[-4:])[0] != zlib.crc32(blob[:-4]) & 0xFFFFFFFF:
        raise ValueError("crc mismatch")
    cursor = _HEADER.size

    def take(*shape):
        nonlocal cursor
        n = int(np.prod(shape))
        out = np.frombuffer(blob, dtype="<f8", count=n, offset=cursor).reshape(shape).astype(float)
        cursor += 8 * n
        return out

    a_v0, a_rho0, K, b = take(kv), take(kr), take(kv, kr), take(kv)
    D = take(kv, kv) if flags & FLAG_DAMPING else None
    p = take(kv) if flags & FLAG_INPUT else None
    T = take(n_pairs, kr, kv) if n_pairs else None
    Pv, Prho, probe_x = take(npr, kv), take(npr, kr), take(npr)
    sections, cursor = unpack_sections(blob, cursor)
    token = blob[cursor:cursor + TOKEN_SIZE].rstrip(b"\0").decode("ascii")
    if cursor + TOKEN_SIZE + 4 != len(blob):
        raise ValueError("size mismatch")
    name = {v: k for k, v in INTEGRATORS.items()}[integrator]
    return ModelData(integrator=name, n_freeze=n_freeze, dt=dt, bound=bound, L=L, a_v0=a_v0, a_rho0=a_rho0, K=K,
                     b=b, D=D, p=p, T=T, Pv=Pv, Prho=Prho, probe_x=probe_x, token=token, sections=sections)


@dataclass
class ExactData:
    """The contents of a kind-2 model.bin: the exact linear reduced model.

    Attributes
    ----------
    dt : float
        The scene's internal step [s] (the ``dt`` parameter; unused by the model).
    n_freeze : int
        Start value of the ``n_freeze`` parameter (unused by the model).
    bound : float
        Runaway bound on |z| (as :func:`sphrom.rom.exact_linear.run_exact`: 10⁶ max|z0|).
    L : float
    k_v : int
    z0, A : ndarray
        (k,), (k, k).
    B : ndarray or None
        (k,) input column.
    damping : bool
    Q, S : ndarray or None
        Real Schur form of a skew A (d = 0).
    Pv : ndarray (P, k_v)
    Pe : ndarray (P, 2, k_e)
    pw, prho0 : ndarray (P, 2)
    probe_x : ndarray (P,)
    token : str
    sections : dict of str to ndarray
        Tagged sections (tag -> 2-D float64 array), in file order.
    output_rows : bool
        Pv (P, k) and Pe (P, 2, k) are rows over the whole state z (flags bit3;
        the balanced model, whose state does not split: k_v = k, k_e = 0).
    bounds : dict or None
        The full report of the certified error bounds computed at packaging
        (:func:`sphrom.rom.balanced.error_bounds`: shift, factor, horizon,
        timings); only their values are stored, in section BOUNDS.
    """

    dt: float
    n_freeze: int
    bound: float
    L: float
    k_v: int
    z0: np.ndarray
    A: np.ndarray
    B: np.ndarray | None
    damping: bool
    Q: np.ndarray | None
    S: np.ndarray | None
    Pv: np.ndarray
    Pe: np.ndarray
    pw: np.ndarray
    prho0: np.ndarray
    probe_x: np.ndarray
    token: str = ""
    integrator: str = "exponential"
    sections: dict = field(default_factory=dict)
    output_rows: bool = False
    bounds: dict | None = None

    @property
    def k(self):
        return self.z0.size

    @property
    def k_rho(self):
        return self.k - self.k_v

    @property
    def n_probes(self):
        return self.probe_x.size


def probe_pairs(x, L, probes):
    """(i0, i1, w): the particles around each probe and the weight of i1 (as probe_rows)."""
    probes = np.asarray(probes, float)
    n = x.size
    dx = L / n
    s = np.mod(probes * L - x[0], L) / dx
    i0 = np.floor(s).astype(np.int64) % n
    w = s - np.floor(s)
    return i0, (i0 + 1) % n, w


def exact_data(lin, problem, *, dt, n_freeze, probes, bound=None):
    """Collect the exact model's numbers from :class:`sphrom.rom.exact_linear.LinearOperators`."""
    from ..rom.operators import probe_rows
    probes = np.asarray(probes, dtype=float)
    L = problem.scene.L
    i0, i1, w = probe_pairs(problem.x, L, probes)
    bound = 1e6 * max(float(np.max(np.abs(lin.z0))), 1e-300) if bound is None else bound
    rho0 = np.asarray(lin.rho0, float)
    return ExactData(dt=float(dt), n_freeze=int(n_freeze), bound=float(bound), L=float(L), k_v=lin.k_v,
                     z0=np.asarray(lin.z0, float), A=np.asarray(lin.A, float),
                     B=None if lin.B is None else np.asarray(lin.B, float), damping=not lin.skew,
                     Q=np.asarray(lin.schur_Q, float) if lin.skew else None,
                     S=np.asarray(lin.schur_T, float) if lin.skew else None,
                     Pv=probe_rows(lin.U_v, problem.x, L, probes),
                     Pe=np.stack([lin.U_e[i0], lin.U_e[i1]], axis=1),
                     pw=np.stack([1.0 - w, w], axis=1), prho0=np.stack([rho0[i0], rho0[i1]], axis=1),
                     probe_x=probes,
                     sections={"LINMODEL": np.array([[LINEAR_EXACT_POD]], float), **port_sections(lin)})


def balanced_data(ops, problem, *, dt, n_freeze, bound=None):
    """The numbers of a kind-2 model.bin for the balanced model (:class:`sphrom.rom.balanced_model.BalancedOperators`).

    The state x_r (r numbers) does not split: k_v = r, k_e = 0 and the probe rows
    are over the whole state (``output_rows``).  Velocity rows: Cr's probe
    velocity rows.  e rows: the reconstruction e = (V x_r)_e / √c at the probe's two
    particles, whose interpolation (weights pw) is Cr's probe-e row.  The probes
    are those the model was balanced for (``ops.lti.probes``).
    """
    lti, red = ops.lti, ops.reduced
    probes = np.asarray(lti.probes, float)
    L = problem.scene.L
    i0, i1, w = probe_pairs(problem.x, L, probes)
    n, P = lti.n, lti.n_probes
    Ve = red.V[n:] / lti.w_e[:, None]                        # e at every particle per unit x_r
    bound = 1e6 * max(float(np.max(np.abs(ops.z0))), 1e-300) if bound is None else bound
    rho0 = np.asarray(ops.rho0, float)
    return ExactData(dt=float(dt), n_freeze=int(n_freeze), bound=float(bound), L=float(L), k_v=ops.order,
                     z0=np.asarray(ops.z0, float), A=np.asarray(ops.A, float), B=np.asarray(ops.B, float),
                     damping=not ops.skew, Q=np.asarray(ops.schur_Q, float) if ops.skew else None,
                     S=np.asarray(ops.schur_T, float) if ops.skew else None,
                     Pv=np.asarray(red.Cr[:P], float), Pe=np.stack([Ve[i0], Ve[i1]], axis=1),
                     pw=np.stack([1.0 - w, w], axis=1), prho0=np.stack([rho0[i0], rho0[i1]], axis=1),
                     probe_x=probes, output_rows=True, sections={"LINMODEL": np.array([[LINEAR_BALANCED]], float),
                                                                  **port_sections(ops)})


def pack_exact(data: ExactData) -> bytes:
    """The bytes of a kind-2 model.bin; sets ``data.token``."""
    kv, k, npr = data.k_v, data.k, data.n_probes
    ke = k - kv
    rows = bool(data.output_rows)
    if not (1 <= kv <= MAX_MODES and (0 if rows else 1) <= ke <= MAX_MODES):
        raise ValueError(f"mode counts {kv}, {ke} out of range")
    if not 1 <= npr <= MAX_PROBES:
        raise ValueError(f"{npr} probes (allowed: 1 to {MAX_PROBES})")
    if data.Q is not None and data.damping:
        raise ValueError("a Schur form needs a skew operator (no damping)")
    flags = ((FLAG_DAMPING if data.damping else 0) | (FLAG_INPUT if data.B is not None else 0)
             | (FLAG_SCHUR if data.Q is not None else 0) | (FLAG_OUTPUT_ROWS if rows else 0))
    header = _HEADER.pack(MAGIC, FORMAT_VERSION, MODEL_EXACT_LINEAR, 0, kv, ke, npr, 0, flags, int(data.n_freeze), 0,
                          data.dt, data.bound, data.L)
    arrays = [data.z0, data.A] + ([data.B] if data.B is not None else [])
    arrays += [data.Q, data.S] if data.Q is not None else []
    arrays += [data.Pv, data.Pe, data.pw, data.prho0, data.probe_x]
    shapes = {"A": (k, k), "Pv": (npr, k if rows else kv), "Pe": (npr, 2, k if rows else ke), "pw": (npr, 2),
              "prho0": (npr, 2)}
    for name, shape in shapes.items():
        if getattr(data, name).shape != shape:
            raise ValueError(f"{name} has shape {getattr(data, name).shape}, expected {shape}")
    body = header + b"".join(np.ascontiguousarray(a, dtype="<f8").tobytes() for a in arrays)
    return _finish(body, data)


def _unpack_exact(blob: bytes) -> ExactData:
    (_, _, _, _, kv, ke, npr, _, flags, n_freeze, _, dt, bound, L) = _HEADER.unpack_from(blob)
    if struct.unpack("<I", blob[-4:])[0] != zlib.crc32(blob[:-4]) & 0xFFFFFFFF:
        raise ValueError("crc mismatch")
    k = kv + ke
    cursor = _HEADER.size

    def take(*shape):
        nonlocal cursor
        n = int(np.prod(shape))
        out = np.frombuffer(blob, dtype="<f8", count=n, offset=cursor).reshape(shape).astype(float)
        cursor += 8 * n
        return out

    z0, A = take(k), take(k, k)
    B = take(k) if flags & FLAG_INPUT else None
    Q, S = (take(k, k), take(k, k)) if flags & FLAG_SCHUR else (None, None)
    rows = bool(flags & FLAG_OUTPUT_ROWS)
    Pv, Pe = (take(npr, k), take(npr, 2, k)) if rows else (take(npr, kv), take(npr, 2, ke))
    pw, prho0, probe_x = take(npr, 2), take(npr, 2), take(npr)
    sections, cursor = unpack_sections(blob, cursor)
    token = blob[cursor:cursor + TOKEN_SIZE].rstrip(b"\0").decode("ascii")
    if cursor + TOKEN_SIZE + 4 != len(blob):
        raise ValueError("size mismatch")
    return ExactData(dt=dt, n_freeze=n_freeze, bound=bound, L=L, k_v=kv, z0=z0, A=A, B=B,
                     damping=bool(flags & FLAG_DAMPING), Q=Q, S=S, Pv=Pv, Pe=Pe, pw=pw, prho0=prho0,
                     probe_x=probe_x, token=token, sections=sections, output_rows=rows)
