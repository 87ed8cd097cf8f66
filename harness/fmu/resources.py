"""``resources/model.bin``: the scene's reduced model for the FMU's C core, written and read for every model kind.

One binary serves every scene; the numbers of a scene live in this small, versioned, little-endian file, whose
layout is written once, in :mod:`sphrom.fmu.layout` (``fmu_src/rom_layout.h`` is generated from it): the shared
header (magic, version, the model kind, sizes, flags, runaway bound, L), the kind's body (its own header, if any,
then its float64 arrays in the order of ``layout.KINDS``), the tagged sections, the token and the checksum.

This module is the one writer and reader of that file: :func:`pack` and :func:`unpack` handle the shared parts and
ask the model kind (:mod:`sphrom.fmu.kinds`, one module per kind, owning its data class) for its header fields and
arrays.  Kind 1: the frozen model's operators of eqs. 2.19-2.24 (:mod:`sphrom.fmu.kinds.frozen`); kind 2: every
linear model, the exact one of :mod:`sphrom.rom.exact_linear` and the balanced one (:mod:`sphrom.fmu.kinds.linear`).

Tagged sections are optional numbers that later features store (each tag known to the C loader, which checks its
shape and rejects unknown or repeated tags; ``layout.SECTIONS`` lists them with their named rows and columns).
"""

from __future__ import annotations

import hashlib
import struct
import zlib

import numpy as np

from ..rom.probes import probe_pairs  # noqa: F401  (the FMU's probe interpolation, its name here kept)
from . import layout

# the layout's numbers under the names the rest of sphrom has always used
MAGIC = layout.RESOURCE_MAGIC.encode("ascii")
FORMAT_VERSION = layout.FORMAT_VERSION
MODEL_FROZEN = layout.KIND_BY_NAME["frozen"].number
MODEL_EXACT_LINEAR = layout.KIND_BY_NAME["linear"].number
INTEGRATORS = dict(layout.INTEGRATORS)
FLAG_DAMPING, FLAG_INPUT, FLAG_SCHUR, FLAG_OUTPUT_ROWS, FLAG_BLOCKS = (
    layout.FLAGS[n][0] for n in ("damping", "input", "schur", "output_rows", "blocks"))
LINEAR_EXACT_POD, LINEAR_BALANCED = layout.LINEAR_MODELS["exact_pod"], layout.LINEAR_MODELS["balanced"]
TOKEN_SIZE = layout.TOKEN_SIZE
SECTION_TAG_SIZE = layout.SECTION_TAG_SIZE
MAX_PROBES, MAX_MODES, MAX_SECTIONS, MAX_SECTION_VALUES, MAX_PORTS = (
    layout.LIMITS[n][0] for n in ("MAX_PROBES", "MAX_MODES", "MAX_SECTIONS", "MAX_SECTION_VALUES", "MAX_PORTS"))
SECTION_TAGS: dict[str, str] = {tag: s.what for tag, s in layout.SECTIONS.items()}   # tag -> what it holds
HEADER_SIZE = layout.HEADER.size

# the names this module had before the kinds were one unit each, where they live now (old names kept as aliases,
# imported on first use: the kinds build on this module, which asks nothing of them)
_FROM_KINDS = {"ModelData": "kinds.frozen", "model_data": "kinds.frozen", "ExactData": "kinds.linear",
               "exact_data": "kinds.linear", "balanced_data": "kinds.linear", "pack": "kinds", "unpack": "kinds",
               "pack_exact": "kinds", "kind_of": "kinds"}


def __getattr__(name):
    if name in _FROM_KINDS:
        from importlib import import_module
        return getattr(import_module(f"{__package__}.{_FROM_KINDS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def port_sections(ops):
    """The tagged sections of a model with ports (PORTX, PORTB, PORTC; module docstring), {} without; with the port
    channel (``ops.channel``, :mod:`sphrom.rom.port_channel`) PORTX, PORTC (the model's own part of v_port) and the
    channel's sections PC*, no PORTB (the channel takes every port force)."""
    if not ops.ports:
        return {}
    if ops.channel is not None:
        from ..rom.port_channel import sections
        return {"PORTX": np.asarray(ops.ports, float)[None, :], "PORTC": np.asarray(ops.Cp, float),
                **sections(ops.channel)}
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
    out = [layout.SECTION_COUNT.pack({"n_sections": len(sections)})]
    for tag, values in sections.items():
        raw = tag.encode("ascii")
        if not 1 <= len(raw) <= SECTION_TAG_SIZE or not all(33 <= c <= 126 for c in raw):
            raise ValueError(f"section tag {tag!r} is not 1 to {SECTION_TAG_SIZE} printable ASCII characters")
        if tag not in SECTION_TAGS:
            raise ValueError(f"section tag {tag!r} is unknown (known: {sorted(SECTION_TAGS)})")
        a = np.atleast_2d(np.asarray(values, dtype=float))
        if a.ndim != 2 or a.size > MAX_SECTION_VALUES or not np.all(np.isfinite(a)):
            raise ValueError(f"section {tag!r}: a finite matrix of at most {MAX_SECTION_VALUES} values expected")
        out.append(layout.SECTION.pack({"tag": raw, "rows": a.shape[0], "cols": a.shape[1]}))
        out.append(np.ascontiguousarray(a, dtype="<f8").tobytes())
    return b"".join(out)


def unpack_sections(blob: bytes, cursor: int):
    """(sections, cursor after them) read from ``blob`` at ``cursor``."""
    n = layout.SECTION_COUNT.unpack(blob, cursor)["n_sections"]
    if n > MAX_SECTIONS:
        raise ValueError(f"{n} sections")
    cursor += layout.SECTION_COUNT.size
    sections = {}
    for _ in range(n):
        head = layout.SECTION.unpack(blob, cursor)
        rows, cols = head["rows"], head["cols"]
        cursor += layout.SECTION.size
        tag = head["tag"].rstrip(b"\0").decode("ascii")
        if tag in sections:
            raise ValueError(f"section {tag!r} appears twice")
        sections[tag] = np.frombuffer(blob, dtype="<f8", count=rows * cols, offset=cursor).reshape(rows, cols).copy()
        cursor += 8 * rows * cols
    return sections, cursor


def write(spec, header, head, arrays, sections, min_k_rho=1):
    """The bytes of model.bin of a model of kind ``spec`` (``layout.KINDS``), and its token.

    ``header``: the shared header's fields of the kind (magic, version and model_kind are added), ``head``: its own
    header or None, ``arrays``: {array name: array} checked against the kind's shapes and written in its order,
    ``sections``: the tagged sections; ``min_k_rho``: the smallest k_rho the kind's flags allow.  What a kind gives
    is :func:`sphrom.fmu.kinds.pack`'s (each kind's ``file_fields``)."""
    header = {"magic": MAGIC, "format_version": FORMAT_VERSION, "model_kind": spec.number, **header}
    kv, kr, npr = header["k_v"], header["k_rho"], header["n_probes"]
    if not (1 <= kv <= MAX_MODES and min_k_rho <= kr <= MAX_MODES):
        raise ValueError(f"mode counts {kv}, {kr} out of range")
    if not 1 <= npr <= MAX_PROBES:
        raise ValueError(f"{npr} probes (allowed: 1 to {MAX_PROBES})")
    sizes = layout.dims(spec, header, head)
    body = [layout.HEADER.pack(header)] + ([spec.head.pack(head)] if spec.head is not None else [])
    for array in spec.body:
        value = arrays.get(array.name)
        if not layout.present(array, header["flags"]):
            continue
        shape = layout.shape(array, sizes)
        if value is None and 0 in shape:
            continue
        if value is None or np.shape(value) != shape:
            raise ValueError(f"{array.name} has shape {None if value is None else np.shape(value)}, expected {shape}")
        body.append(np.ascontiguousarray(value, dtype="<f8").tobytes())
    body.append(pack_sections(sections))
    blob = b"".join(body)
    token = make_token(hashlib.sha256(blob).digest()[:16])
    blob += token.encode("ascii").ljust(TOKEN_SIZE, b"\0")
    return blob + struct.pack("<I", zlib.crc32(blob) & 0xFFFFFFFF), token


def read(blob: bytes):
    """Read model.bin bytes (the checks of the C loader that concern the layout): (spec, header, head, arrays,
    token, sections), ``spec`` the kind's ``layout.KINDS`` row; :func:`sphrom.fmu.kinds.unpack` makes the kind's
    data class of them."""
    if len(blob) < HEADER_SIZE + TOKEN_SIZE + 4:
        raise ValueError("truncated")
    header = layout.HEADER.unpack(blob)
    if header["magic"] != MAGIC or header["format_version"] != FORMAT_VERSION:
        raise ValueError(f"not a format-{FORMAT_VERSION} sphrom model.bin")
    if header["model_kind"] not in layout.KIND_BY_NUMBER:
        raise ValueError(f"model kind {header['model_kind']} (known: {sorted(layout.KIND_BY_NUMBER)})")
    if struct.unpack("<I", blob[-4:])[0] != zlib.crc32(blob[:-4]) & 0xFFFFFFFF:
        raise ValueError("crc mismatch")
    spec = layout.KIND_BY_NUMBER[header["model_kind"]]
    cursor = HEADER_SIZE
    head = None
    if spec.head is not None:
        head = spec.head.unpack(blob, cursor)
        cursor += spec.head.size
    sizes = layout.dims(spec, header, head)
    arrays = {}
    for array in spec.body:
        if not layout.present(array, header["flags"]):
            continue
        shape = layout.shape(array, sizes)
        n = int(np.prod(shape))
        arrays[array.name] = np.frombuffer(blob, dtype="<f8", count=n, offset=cursor).reshape(shape).astype(float)
        cursor += 8 * n
    sections, cursor = unpack_sections(blob, cursor)
    layout.check_values(sections, _ports(sections))          # the sections' sign and range rules, as the C loader
    token = blob[cursor:cursor + TOKEN_SIZE].rstrip(b"\0").decode("ascii")
    if cursor + TOKEN_SIZE + 4 != len(blob):
        raise ValueError("size mismatch")
    return spec, header, head, arrays, token, sections


def _ports(sections):
    """The ports a file's sections describe (section PORTX's columns; 0 without it)."""
    x = sections.get("PORTX")
    return 0 if x is None else int(np.shape(x)[-1])
