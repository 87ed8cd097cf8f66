"""The binary contract between Python and C, written once: ``resources/model.bin`` and the serialized FMU state.

Everything both languages must agree on about the bytes lives in the tables of this module: the fixed records
(their fields, types and so byte offsets), the flags, the model kinds' numbers, each kind's own header and body
arrays (their shapes in named dimensions, the flag that makes an array present), the tagged sections (tag, what they
hold, the names of their rows and columns), the trailer (token, checksum) and the serialized state's header and
blocks.  From them come

- ``fmu_src/rom_layout.h`` (generated, committed): every size, offset, version, flag, kind and integrator number,
  section tag and named row or column as a ``#define``, and the format in words as its comment, which the C core
  reads instead of spelling the layout again (``rom.h`` includes it);
- the Python writer and reader of both kinds (:mod:`sphrom.fmu.resources`: :func:`Record.pack` /
  :func:`Record.unpack` of the records, the body arrays of :data:`BODIES` in order);
- the format pages' text (:func:`format_text`, between the markers of docs/internals/resources.md).

``python3 -m sphrom.fmu.layout --write`` regenerates the generated files; ``--check`` lists the stale ones
(``tests/test_fmu_layout.py`` fails on a stale one, naming it and the command).  A new field, flag, section or
column is one row here, then ``--write``.

Versions.  model.bin format 4 keeps the frozen kind's own numbers (integrator, n_pairs, the default n_freeze, dt)
in that kind's header at the start of its body; format 3 had them in the shared header (and every kind carried
them).  The serialized state's format 4 likewise keeps n_freeze and dt in the frozen kind's block; format 5 holds
the time since the start (the sum of the steps, exact at any start time) where format 4 held the start time t0, and
the core reads format 4 too (time - t0).  A serialized state restores only into the FMU whose token it carries, and
the token hashes the model.bin bytes, so a state of a format before 4 (written by an FMU of an older model.bin
format) can never match an FMU of this one: the C core reads model.bin format 4 and states of formats 4 and 5, and
refuses others, naming the version and saying why.
"""

from __future__ import annotations

import math
import struct
import sys
from pathlib import Path
from dataclasses import dataclass

# ---------------------------------------------------------------------------------------------------------------
# fixed records
# ---------------------------------------------------------------------------------------------------------------

TYPES = {"char8": ("8s", 8), "char40": ("40s", 40), "u32": ("I", 4), "u64": ("Q", 8), "f64": ("d", 8)}
C_TYPES = {"char8": "char[8]", "char40": "char[40]", "u32": "uint32", "u64": "uint64", "f64": "float64"}


@dataclass(frozen=True)
class Field:
    """One field of a record: name, type (:data:`TYPES`), what it holds (with its unit)."""

    name: str
    type: str
    doc: str


@dataclass(frozen=True)
class Record:
    """A fixed sequence of little-endian fields (a header)."""

    name: str
    fields: tuple

    @property
    def struct(self):
        return struct.Struct("<" + "".join(TYPES[f.type][0] for f in self.fields))

    @property
    def size(self):
        return self.struct.size

    def offset(self, name):
        """The byte offset of field ``name`` from the record's start."""
        at = 0
        for f in self.fields:
            if f.name == name:
                return at
            at += TYPES[f.type][1]
        raise KeyError(f"{self.name} has no field {name!r}")

    def pack(self, values):
        """The record's bytes from ``values`` (field name -> value; text fields as bytes or str, NUL padded)."""
        items = []
        for f in self.fields:
            v = values[f.name]
            if f.type.startswith("char"):
                v = (v.encode("ascii") if isinstance(v, str) else bytes(v)).ljust(TYPES[f.type][1], b"\0")
            items.append(v)
        return self.struct.pack(*items)

    def unpack(self, blob, at=0):
        """{field name: value} read from ``blob`` at byte ``at`` (text fields as bytes, NUL padding kept)."""
        return dict(zip((f.name for f in self.fields), self.struct.unpack_from(blob, at)))


RESOURCE_MAGIC = "SPHROMRS"
FORMAT_VERSION = 4
STATE_MAGIC = "SPHROMST"
STATE_VERSION = 5
STATE_OLDEST_VERSION = 4         # the oldest state format the core reads (format 4: t0 for elapsed)

# the shared header of model.bin (every kind)
HEADER = Record("header", (
    Field("magic", "char8", f'"{RESOURCE_MAGIC}"'),
    Field("format_version", "u32", f"{FORMAT_VERSION}"),
    Field("model_kind", "u32", "the model kind (KINDS: 1 frozen, 2 linear)"),
    Field("k_v", "u32", "velocity coordinates (linear: the first block a of z; balanced: the whole order)"),
    Field("k_rho", "u32", "density coordinates (linear: k_e, the specific-volume block b of z)"),
    Field("n_probes", "u32", "probes, 1 to MAX_PROBES"),
    Field("flags", "u32", "FLAGS (each kind reads its own)"),
    Field("runaway_bound", "f64", "|a| (frozen) or |z| (linear) above this is a runaway"),
    Field("L", "f64", "the period [m]"),
))
SECTION = Record("section", (
    Field("tag", "char8", "ASCII, NUL padded (SECTIONS)"),
    Field("rows", "u32", "rows"),
    Field("cols", "u32", "columns; then float64 data[rows][cols], finite"),
))
SECTION_COUNT = Record("sections", (Field("n_sections", "u32", "tagged sections, at most MAX_SECTIONS"),))
TRAILER = Record("trailer", (
    Field("token", "char40", '"{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}", NUL padded: the FMI guid / '
                             "instantiationToken, from the first 16 bytes of the sha256 of every byte before it"),
    Field("crc32", "u32", "zlib's CRC-32 of every byte before it"),
))
TOKEN_SIZE = TYPES["char40"][1]
SECTION_TAG_SIZE = TYPES["char8"][1]

# limits every reader applies
LIMITS = {
    "MAX_MODES": (1024, "k_v, k_rho (and k_e) at most"),
    "MAX_SHADOW_PLANES": (2500, "planes of the bounds' shadow at most (every plane of a dense decomposition)"),
    "MAX_PROBES": (100, "probes at most"),
    "MAX_SECTIONS": (32, "tagged sections of one file at most"),
    "MAX_SECTION_VALUES": (1 << 26, "rows x cols of one section at most"),
    "MAX_PORTS": (4, "mechanical ports of one FMU at most"),
}

# header flag bits: name -> (bit, what it says)
FLAGS = {
    "damping": (1, "a damping term: frozen D present; linear A not skew"),
    "input": (2, "an input: frozen row p, linear column B present"),
    "schur": (4, "linear only: the real Schur form Q, S of a skew A present (never with damping)"),
    "output_rows": (8, "linear only: the probe rows Pv, Pe act on the whole state z (the balanced model: k_e = 0)"),
    "blocks": (16, "linear only: A is block diagonal, the model in its real eigen-coordinates (1 x 1 blocks and 2 x 2 "
                   "blocks [[a, w], [-w, a]], A[i+1][i] != 0 starting one; with output_rows, never with schur)"),
}


@dataclass(frozen=True)
class Array:
    """One float64 array of a kind's body: its name, shape (dimension names, :func:`dims`), the flag that makes it
    present (None: always) and what it holds."""

    name: str
    shape: tuple
    flag: str | None
    doc: str


@dataclass(frozen=True)
class KindLayout:
    """The bytes of one model kind: its number (the header's model_kind), its own header at the start of its body
    (None: none), its body arrays in file order, the flags it reads, and its block of the serialized state."""

    name: str
    number: int
    c_name: str
    c_table: str                     # the C function that returns its table of operations (fmu_src/rom_<kind>.c)
    title: str
    head: Record | None
    body: tuple
    flags: tuple
    state_block: tuple
    notes: str = ""


FROZEN_HEAD = Record("frozen", (
    Field("integrator", "u32", "INTEGRATORS: 0 euler, 1 symplectic"),
    Field("n_pairs", "u32", "k_rho (k_rho + 1)/2, or 0 without the tensor T (the sections PART* carry the refresh)"),
    Field("n_freeze_default", "u32", "the parameter n_freeze's start value, >= 1"),
    Field("reserved", "u32", "0"),
    Field("dt", "f64", "the internal step [s], the parameter dt's start value (>= ROM_DT_MIN)"),
))
INTEGRATORS = {"euler": 0, "symplectic": 1}

KINDS = (
    KindLayout(
        "frozen", 1, "FROZEN", "rom_frozen_kind", "the frozen-coefficient model (eqs. 2.19-2.24)", FROZEN_HEAD,
        (Array("a_v0", ("k_v",), None, "the initial velocity coordinates"),
         Array("a_rho0", ("k_rho",), None, "the initial density coordinates"),
         Array("K", ("k_v", "k_rho"), None, "eq. 2.21 projected"),
         Array("b", ("k_v",), None, "eq. 2.22 projected"),
         Array("D", ("k_v", "k_v"), "damping", "eq. 2.24 projected"),
         Array("p", ("k_v",), "input", "the input row U^vT profile"),
         Array("T", ("n_pairs", "k_rho", "k_v"), None, "the refresh tensor of eq. 2.23 (none when n_pairs = 0)"),
         Array("Pv", ("n_probes", "k_v"), None, "the probes' velocity rows"),
         Array("Prho", ("n_probes", "k_rho"), None, "the probes' density rows"),
         Array("probe_x", ("n_probes",), None, "the probe positions x/L in [0, 1]")),
        ("damping", "input"),
        (("n_freeze", "1", "the parameter n_freeze (a whole number >= 1)"),
         ("dt", "1", "the parameter dt [s] (>= its floor)"),
         ("Mt", "k_v k_rho", "M(a^rho)^T, k_v rows of k_rho"),
         ("F", "k_v", "the frozen force term"))),
    KindLayout(
        "linear", 2, "EXACT_LINEAR", "rom_exact_kind", "the linear models (exact POD, balanced): dz/dt = A z + B f, exact in time",
        None,
        (Array("z0", ("k",), None, "the initial state z = (a; b), k = k_v + k_rho"),
         Array("A", ("k", "k"), None, "dz/dt = A z + B f"),
         Array("B", ("k",), "input", "the input column"),
         Array("Q", ("k", "k"), "schur", "the real Schur form A = Q S Q^T of a skew A"),
         Array("S", ("k", "k"), "schur", "its quasi-triangular factor"),
         Array("Pv", ("n_probes", "v_cols"), None, "the probes' velocity rows: over a (v_cols = k_v), or over z "
                                                    "with output_rows (v_cols = k)"),
         Array("Pe", ("n_probes", 2, "e_cols"), None, "e = J - 1 rows at the probe's two particles: over b "
                                                       "(e_cols = k_rho), or over z with output_rows"),
         Array("pw", ("n_probes", 2), None, "the interpolation weights of the two particles"),
         Array("prho0", ("n_probes", 2), None, "rho0 at the two particles [kg m^-3]"),
         Array("probe_x", ("n_probes",), None, "the probe positions x/L in [0, 1]")),
        ("damping", "input", "schur", "output_rows", "blocks"),
        (("X", "k", "the forced part of z (the whole z without the Schur form)"),),
        "rho_j = sum_m pw[j][m] prho0[j][m] / (1 + e_m); a file without output_rows is read as rows over z that are "
        "zero over the block they skip"),
)
KIND_BY_NAME = {k.name: k for k in KINDS}
KIND_BY_NUMBER = {k.number: k for k in KINDS}


def dims(kind, header, head=None):
    """{dimension name: size} of a body of ``kind`` (a KindLayout) from the shared header's fields (and the
    kind's own header ``head``)."""
    out = {"k_v": header["k_v"], "k_rho": header["k_rho"], "n_probes": header["n_probes"]}
    out["k"] = out["k_v"] + out["k_rho"]
    rows = bool(header["flags"] & FLAGS["output_rows"][0])
    out["v_cols"] = out["k"] if rows else out["k_v"]
    out["e_cols"] = out["k"] if rows else out["k_rho"]
    if head is not None:
        out.update({k: v for k, v in head.items() if isinstance(v, int)})
    return out


def present(array, flags):
    """Whether ``array`` is in a body whose header has ``flags``."""
    return array.flag is None or bool(flags & FLAGS[array.flag][0])


def shape(array, sizes):
    """The shape of ``array`` at the dimension sizes ``sizes`` (:func:`dims`)."""
    return tuple(d if isinstance(d, int) else sizes[d] for d in array.shape)


# ---------------------------------------------------------------------------------------------------------------
# tagged sections
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Range:
    """A sign or range rule on some of a section's values, which the code reading them relies on (a certified bound
    is >= 0 only if the norms it adds are): ``columns`` a named column, a tuple of them, or a span "a:b" of column
    indices where a and b are integers, "inputs" offsets (``1+inputs``: the shadow's inputs, f and each port force)
    or empty (the last column); ``low`` <= value <= ``high`` (``low_open``, ``high_open``: strictly), or exactly
    ``also`` (a sentinel value, e.g. SHROW's -1: no input gain); ``what`` the values, in messages."""

    columns: object
    what: str
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    also: float | None = None

    @property
    def allowed(self):
        """The rule in words ("> 0", "in [0, 1]", ">= 0 or -1")."""
        if math.isfinite(self.low) and math.isfinite(self.high):
            text = f"in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"
        elif math.isfinite(self.low):
            text = f"{'>' if self.low_open else '>='} {self.low:g}"
        else:
            text = f"{'<' if self.high_open else '<='} {self.high:g}"
        return text + (f" or {self.also:g}" if self.also is not None else "")


@dataclass(frozen=True)
class RowSum:
    """Each row's values in ``columns`` sum to ``total`` within ``tolerance`` (interpolation weights)."""

    columns: object
    what: str
    total: float = 1.0
    tolerance: float = 1e-12


@dataclass(frozen=True)
class Section:
    """A tagged section: what it holds, and the names of its rows or columns where they have fixed meanings
    (read and written by name, never by position), and the rules its values obey (``values``: :class:`Range`,
    :class:`RowSum`, checked when the file is read by the C core,
    fmu_src/rom_resources.c check_values, and by :func:`check_values`)."""

    what: str
    columns: tuple = ()
    rows: tuple = ()
    kind: str | None = None          # only this model kind reads it
    values: tuple = ()


SECTIONS: dict[str, Section] = {
    # the training envelope (harness/fmu/training/envelope.py, fmu_src/rom_envelope.c)
    "ENVELOPE": Section("the training envelope's scalars",
                        columns=("force_amplitude", "force_band", "max_strain", "max_probe_strain", "failure_strain",
                                 "margin", "checks", "force_mean")),
    "ENVRANGE": Section("the training envelope's coordinate ranges", rows=("min", "max")),
    "ENVPROBE": Section("rho0 and the training run's max |v| at the probes (training envelope)",
                        rows=("rho0", "v_max")),
    "ENVPORT": Section("port coordinates at the end of each block (training envelope: not checked)",
                       columns=("port_v", "port_rho")),
    # linear models (harness/rom/balanced.py)
    "BOUNDS": Section("certified error bounds per probe (force, initial state)", rows=("force", "initial_state"),
                      kind="linear", values=(Range("0:", "a certified error bound", low=0.0),)),
    "LINMODEL": Section("which linear model: 1 exact POD, 2 balanced", columns=("model",), kind="linear"),
    # parametric models (sphrom.rom.parametric)
    "PARAMS": Section("parametric model: c and d (varied, start, min, max)", rows=("c", "d"),
                      columns=("varied", "start", "min", "max")),
    "KC": Section("frozen model: K per unit c", kind="frozen"),
    "BC": Section("frozen model: b per unit c", kind="frozen"),
    "DD": Section("frozen model: D per unit d", kind="frozen"),
    # the frozen model's particle refresh (harness/fmu/kinds/frozen.py particle_sections)
    "PARTUR": Section("frozen model: U^rho at the particles (the particle refresh)", kind="frozen"),
    "PARTGUV": Section("frozen model: G U^v at the particles (the particle refresh)", kind="frozen"),
    "PARTIR0": Section("frozen model: 1/rho0 at the particles (the particle refresh)", kind="frozen",
                       values=(Range("0:", "1/rho0 [m^3 kg^-1]", low=0.0, low_open=True),)),
    "A0": Section("linear model: the part of A without c or d", kind="linear"),
    "AC": Section("linear model: the part of A per unit c", kind="linear"),
    "AD": Section("linear model: the part of A per unit d", kind="linear"),
    # mechanical ports (sphrom.sph.ports), all three or none (PORTB none with the port channel, sections PC*)
    "PORTX": Section("port positions x/L (1 x P)",
                     values=(Range("0:", "a port position x/L", low=0.0, high=1.0, high_open=True),)),
    "PORTB": Section("port input rows at area 1 (P x k_v frozen, P x k linear); absent with the port channel"),
    "PORTC": Section("port velocity rows (P x k_v; P x k over the whole state with output_rows)"),
    # the certified error bounds' shadow (harness/rom/bounds.py sections, fmu_src/rom_bound.c), all or none
    "SHSCAL": Section("error bounds: the shadow's sizes and scalars",
                      columns=("order", "planes", "inputs", "rows", "nodes", "groups", "h_tab", "q_tab", "x0_norm",
                               "e_norm", "b_norm", "tolerance", "cplanes", "growth"),
                      values=(Range("h_tab", "the free response table's node spacing [s]", low=0.0),
                              Range(("x0_norm", "e_norm", "b_norm"), "a norm", low=0.0),
                              Range("growth", "the residual drift's growth rate [s^-1] (0: none)", low=0.0),
                              Range("tolerance", "error_tolerance's default [m s^-1]", low=0.0))),
    "SHLAM": Section("error bounds: the shadow's planes"),
    "SHB": Section("error bounds: the shadow's input columns"),
    "SHC": Section("error bounds: the shadow's output rows"),
    "SHW0": Section("error bounds: the shadow's initial state"),
    "SHROW": Section("error bounds: per output row, its norm, feedthrough, gains and tail",
                     values=(Range("0:1", "the output row's norm |c_r|", low=0.0),
                             Range("1+inputs:", "a gain or a tail of the complement (-1: infinite)", low=0.0,
                                   also=-1.0))),
    "SHRATE": Section("error bounds: the complement's decay rates",
                      values=(Range("0:", "a decay rate [s^-1]", low=0.0),)),
    "SHPROBE": Section("error bounds: the probes' weights and rho0", columns=("pw0", "pw1", "rho0_0", "rho0_1"),
                       values=(Range(("pw0", "pw1"), "an interpolation weight", low=0.0, high=1.0),
                               Range(("rho0_0", "rho0_1"), "rho0 [kg m^-3]", low=0.0, low_open=True),
                               RowSum(("pw0", "pw1"), "the probe's two weights"))),
    # ... with an initial state outside the shadow, these two (the complement's free response)
    "SHTAB": Section("error bounds: the complement's free response and its slope at the table's nodes"),
    "SHTERR": Section("error bounds: the free response table's error per block of intervals",
                      values=(Range("0:", "a certified interpolation error", low=0.0),)),
    # ... and, where some of its modes are continued exactly past the table's end, this one
    "SHCONT": Section("error bounds: the complement's modes continued past the table (exponents, then amplitudes)"),
    # ... a parametric FMU's shadow adds these three (with section PARAMS)
    "SHPIECE": Section("error bounds: the planes' pieces per unit c and per unit d"),
    "SHPARAM": Section("error bounds: c_ref and the residual pieces' norms",
                       columns=("c_ref", "e_const_v", "e_const_e", "e_c_v", "e_c_e", "e_d_v", "e_d_e"),
                       values=(Range("c_ref", "the shadow's reference stiffness c_ref [kg m^-1 s^-2]", low=0.0,
                                     low_open=True),
                               Range(("e_const_v", "e_const_e", "e_c_v", "e_c_e", "e_d_v", "e_d_e"),
                                     "a residual piece's norm", low=0.0))),
    "SHCPL": Section("error bounds: the complement's planes (parametric)"),
    # the port channel (harness/rom/port_channel.py, fmu_src/rom_port.c), all or none; with it no PORTB
    "PCSCAL": Section("port channel: its sizes and scalars",
                      columns=("planes", "ports", "rows", "truncated", "dx", "growth"),
                      values=(Range("growth", "the drift's growth rate [s^-1] (0: none)", low=0.0),)),
    # (the same names as sphrom.rom.port_channel.PCSCAL_COLUMNS, which writes and reads them: tests/test_port_channel.py)
    "PCLAM": Section("port channel: each plane's 2 x 2 block [[-d, s], [-s, 0]] (planes x 4)"),
    "PCB": Section("port channel: each plane's input gains per unit F_j / area (planes x P)"),
    "PCC": Section("port channel: the output rows over the planes (3 n_probes + P rows: v probes, e at their "
                   "particles, v ports)"),
    "PCD": Section("port channel: per row the truncated planes' static correction, then their bound's gains, "
                   "then the decomposition's drift gains per unit of the integrals of |u_j|, tv_j and |w| (rows x "
                   "(4P + 1))"),
    "PCPROBE": Section("port channel: the probes' weights and rho0", columns=("pw0", "pw1", "rho0_0", "rho0_1"),
                       values=(Range(("pw0", "pw1"), "an interpolation weight", low=0.0, high=1.0),
                               Range(("rho0_0", "rho0_1"), "rho0 [kg m^-3]", low=0.0, low_open=True),
                               RowSum(("pw0", "pw1"), "the probe's two weights"))),
}
# bits of ENVELOPE's column checks: the run-time checks of the training envelope (fmu_src/rom_envelope.c)
ENVELOPE_CHECKS = {"coordinates": 1, "force": 2, "strain": 4, "failure": 8}
# LINMODEL's column model: which linear model (messages only; sphrom.fmu.kinds.linear VARIANTS)
LINEAR_MODELS = {"exact_pod": 1, "balanced": 2}


def value_columns(tag, columns, n_cols, inputs):
    """The column indices [first, end) a rule's ``columns`` cover in section ``tag`` of ``n_cols`` columns, the
    shadow having ``inputs`` inputs (1 + ports): a named column (or a tuple of them: their list), or a span."""
    if isinstance(columns, tuple):
        return [c for name in columns for c in value_columns(tag, name, n_cols, inputs)]
    if ":" not in columns:
        index = column(tag, columns) if columns in SECTIONS[tag].columns else int(columns)
        return [index] if index < n_cols else []
    first, end = (_offset(text, inputs, n_cols) for text in columns.split(":"))
    return list(range(min(first, n_cols), min(end, n_cols)))


def _offset(text, inputs, n_cols):
    """A span's end as a column index: "" the end, "3", "inputs", "1+inputs"."""
    if not text:
        return n_cols
    return sum(inputs if part == "inputs" else int(part) for part in text.split("+"))


def _span(tag, columns):
    """((c0, i0), (c1, i1)) of a rule's columns for C: first = c0 + i0 inputs, end = c1 + i1 inputs (c1 = -1: the
    last column); one pair per named column of a tuple."""
    if isinstance(columns, tuple):
        return [pair for name in columns for pair in _span(tag, name)]
    if ":" not in columns:
        index = column(tag, columns) if columns in SECTIONS[tag].columns else int(columns)
        return [((index, 0), (index + 1, 0))]

    def pair(text, end):
        if not text:
            return (-1, 0) if end else (0, 0)
        parts = text.split("+")
        return (sum(int(x) for x in parts if x != "inputs"), parts.count("inputs"))
    first, end = columns.split(":")
    return [(pair(first, False), pair(end, True))]


def check_values(sections, n_ports=0):
    """The value rules of every section of ``sections`` (tag -> 2-D array) that has them (:class:`Section`'s
    ``values``), in the C loader's order (fmu_src/rom_resources.c check_values: every range, then the row sums, each in
    the layout's order of sections): ValueError naming the section, the place, the value and the rule, in the C
    core's words.  ``n_ports``: the model's ports (the shadow's inputs are 1 + n_ports, or 1 where SHSCAL says so: a
    port channel carries the ports)."""
    import numpy as np
    inputs = 1 + int(n_ports)
    present = {tag: np.atleast_2d(np.asarray(sections[tag], dtype=float)) for tag in SECTIONS if tag in sections}
    scal = present.get("SHSCAL")
    if scal is not None and scal.shape == (1, len(SECTIONS["SHSCAL"].columns)) \
            and scal[0, column("SHSCAL", "inputs")] == 1.0:
        inputs = 1                      # the shadow's inputs: f alone (a port channel carries the ports exactly)
    for kind in (Range, RowSum):
        for tag, a in present.items():
            for rule in SECTIONS[tag].values:
                if isinstance(rule, kind):
                    _check_rule(tag, rule, a, present, inputs)


def _check_rule(tag, rule, a, present, inputs):
    where = f"resources: section '{tag}'"
    if isinstance(rule, Range):
        spans = rule.columns if isinstance(rule.columns, tuple) else (rule.columns,)   # one C rule per named column
        places = [(row, col) for span in spans for row in range(a.shape[0])
                  for col in value_columns(tag, span, a.shape[1], inputs)]
        for row, col in places:
            x = a[row, col]
            ok = ((x > rule.low if rule.low_open else x >= rule.low)
                  and (x < rule.high if rule.high_open else x <= rule.high))
            if not ok and not (rule.also is not None and x == rule.also):
                raise ValueError(f"{where} row {row + 1}, column {col + 1} holds {x:g}: {rule.what} is "
                                 f"{rule.allowed}")
    elif isinstance(rule, RowSum):
        cols = value_columns(tag, rule.columns, a.shape[1], inputs)
        for row in range(a.shape[0]):
            total = 0.0
            for col in cols:                 # in column order, as the C loader adds them
                total += float(a[row, col])
            if not abs(total - rule.total) <= rule.tolerance:
                raise ValueError(f"{where} row {row + 1}: {rule.what} sum to {total:.17g} (allowed: "
                                 f"{rule.total:g} to {rule.tolerance:g})")


def column(tag, name):
    """The index of the named column of section ``tag``."""
    return SECTIONS[tag].columns.index(name)


def row(tag, name):
    """The index of the named row of section ``tag``."""
    return SECTIONS[tag].rows.index(name)


def value(sections, tag, name, row_index=0):
    """The value of the named column of section ``tag`` (in row ``row_index``) of ``sections`` (tag -> 2-D array),
    as a float."""
    return float(sections[tag][row_index][column(tag, name)])


# ---------------------------------------------------------------------------------------------------------------
# the serialized FMU state
# ---------------------------------------------------------------------------------------------------------------

STATE_HEADER = Record("state", (
    Field("magic", "char8", f'"{STATE_MAGIC}"'),
    Field("state_version", "u32", f"{STATE_VERSION}"),
    Field("tag", "u32", "the instance's mode when the state was taken"),
    Field("k_v", "u32", "as the model's header"),
    Field("k_rho", "u32", "as the model's header"),
    Field("n_probes", "u32", "as the model's header"),
    Field("reserved", "u32", "0"),
    Field("token", "char40", "the model's token: a state restores only into the FMU that wrote it"),
    Field("n", "u64", "internal steps since reset (shortened ones too)"),
    Field("time", "f64", "the state's time [s]"),
    Field("f", "f64", "the input [m s^-2]"),
))
# the float64 values after the header, in order: (name, length in the model's sizes, what)
STATE_BLOCKS = (
    ("a_v", "k_v", "the velocity coordinates (linear: a)"),
    ("a_rho", "k_rho", "the density coordinates (linear: b)"),
    ("kind", "the kind's block", "KINDS' state_block"),
    ("elapsed", "1", "the time since the start [s]: the sum of the steps taken (the exact model's free response, "
     "the error bounds' table; format 4 held the start time t0 here, read as time - t0)"),
    ("f_rate", "1", "df/dt over a step [m s^-3] (0: held)"),
    ("bounds", "with the error bounds (sections SH*)", "the shadow w[k_s], the inputs' weighted variations V[m groups] "
     "and last values u[m], the integral of |w|, the step count, started (0 or 1), the time of the tails' decays "
     "after the table [s] (-1: none) and those decays[groups]; with SHCONT the continued modes' exp(mu (tau - "
     "t_end)) carried over the steps (Re, Im)[2 M_c], their time tau [s] (-1: none), the steps since their exact "
     "anchor, the last step's length [s], the time's rounding summed over those steps [s] (rom_bound.c)"),
    ("channel", "with the port channel (sections PC*)", "its planes p[n], q[n], the inputs' variation tv[P] and "
     "last values u[P], the step count, port_impedance [N s m^-1], a_port[P] [N], b_port[P] [N], the force held "
     "over the last step of the wave form[P] [N], da_port/dt[P] [N s^-1], the drift's integrals of |u_j|[P] "
     "[N m^-2 s], of tv_j[P] [N m^-2 s] and of |w| (rom_port.c)"),
    ("initial_state_scale", "1", "the parameter"),
    ("c", "1", "the parameter c [kg m^-1 s^-2] (0 without section PARAMS)"),
    ("d", "1", "the parameter d [s^-1] (0 without section PARAMS)"),
    ("ports", "with ports", "area [m^2], F_port[P] [N], port_driven (0 or 1), dF_port/dt[P] [N s^-1]"),
)
def resource_offset(kind, field):
    """The byte offset in model.bin of ``field`` of the own header of ``kind`` (a kind's name)."""
    return HEADER.size + KIND_BY_NAME[kind].head.offset(field)


def state_offset(blob, kind, name):
    """The byte offset in the serialized state ``blob`` of the value ``name`` of the block of ``kind`` (a kind's
    name; a value of length 1 before the block's arrays)."""
    header = STATE_HEADER.unpack(blob)
    at = STATE_HEADER.size + 8 * (header["k_v"] + header["k_rho"])
    for value, length, _ in KIND_BY_NAME[kind].state_block:
        if value == name:
            return at
        if length != "1":
            break
        at += 8
    raise KeyError(f"the {kind} kind's state block has no value {name!r} before its arrays")


STATE_TRAILER = Record("state_trailer", (Field("crc32", "u32", "zlib's CRC-32 of every byte before it"),))


# ---------------------------------------------------------------------------------------------------------------
# the format in words (rom_layout.h's comment, docs/internals/resources.md) and the C header
# ---------------------------------------------------------------------------------------------------------------

def _record_lines(record, indent="  "):
    lines = []
    for f in record.fields:
        lines.append(f"{indent}{record.offset(f.name):>4}  {C_TYPES[f.type]:<8} {f.name}: {f.doc}")
    return lines


def format_text():
    """Both formats in words (byte offsets from the record's start, types, what each field holds)."""
    lines = [f"resources/model.bin, format {FORMAT_VERSION} (little-endian)", "",
             f"header ({HEADER.size} bytes, every kind):"]
    lines += _record_lines(HEADER)
    lines += ["", "flags: " + "; ".join(f"bit {bit.bit_length() - 1} {name} ({what})"
                                        for name, (bit, what) in FLAGS.items())]
    for k in KINDS:
        lines += ["", f"kind {k.number}, {k.name}: {k.title}; reads the flags {', '.join(k.flags)}"]
        if k.head is not None:
            lines.append(f"  its header ({k.head.size} bytes, at the start of its body):")
            lines += _record_lines(k.head, "  ")
        lines.append("  its float64 arrays, row-major, in this order:")
        for a in k.body:
            when = f" (flag {a.flag})" if a.flag else ""
            lines.append(f"    {a.name}[{']['.join(str(d) for d in a.shape)}]{when}: {a.doc}")
        if k.notes:
            lines.append(f"  ({k.notes})")
    lines += ["", f"then the tagged sections: {C_TYPES[SECTION_COUNT.fields[0].type]} {SECTION_COUNT.fields[0].name}, then per "
                  "section:"]
    lines += _record_lines(SECTION)
    lines += ["  tags (the loader knows each, checks its shape and refuses unknown or repeated ones):"]
    for tag, s in SECTIONS.items():
        named = (f"; rows {', '.join(s.rows)}" if s.rows else "") + (
            f"; columns {', '.join(s.columns)}" if s.columns else "")
        lines.append(f"    {tag}: {s.what}{named}" + (f" ({s.kind} kind only)" if s.kind else "")
                     + (f"; values: {'; '.join(_rule_words(r) for r in s.values)}" if s.values else ""))
    lines += ["", "then the trailer:"]
    lines += _record_lines(TRAILER, "  ")
    lines += ["", f"The serialized FMU state, format {STATE_VERSION} (little-endian):", "",
              f"header ({STATE_HEADER.size} bytes):"]
    lines += _record_lines(STATE_HEADER)
    lines.append("then float64 values, in this order:")
    for name, length, what in STATE_BLOCKS:
        lines.append(f"    {name} [{length}]: {what}")
    for k in KINDS:
        lines.append(f"  the {k.name} kind's block: " + ", ".join(f"{n}[{length}] ({what})"
                                                                for n, length, what in k.state_block))
    lines += ["then uint32 crc32: zlib's CRC-32 of every byte before it"]
    return "\n".join(_wrap(line) for line in lines)


def _rule_words(rule):
    """A value rule in words, for the format's text."""
    if isinstance(rule, Range):
        cols = rule.columns if isinstance(rule.columns, str) else ", ".join(rule.columns)
        return f"{rule.what} (columns {cols}) {rule.allowed}"
    if isinstance(rule, RowSum):
        return f"{rule.what} sum to {rule.total:g} per row"
    return f"each row's norm at most {rule.tag}'s column {rule.column} ({rule.what})"


def _wrap(line, width=112):
    """``line`` wrapped at ``width`` characters, continuation lines indented under its text."""
    import textwrap
    indent = " " * (len(line) - len(line.lstrip()))
    return textwrap.fill(line, width, subsequent_indent=indent + "    ", break_on_hyphens=False) if line else line


def _macro(*parts):
    return "_".join(p.upper() for p in parts)


def c_header():
    """The text of fmu_src/rom_layout.h."""
    def define(name, value, comment=""):
        return f"#define {name:<36} {value}" + (f"   /* {comment} */" if comment else "")

    out = [f"/* GENERATED by `{COMMAND}` from harness/fmu/layout.py: do not edit.", " *"]
    out += [" * " + line if line else " *" for line in format_text().replace("*/", "* /").splitlines()]
    out += [" */", "#ifndef SPHROM_ROM_LAYOUT_H", "#define SPHROM_ROM_LAYOUT_H", "",
            "/* resources/model.bin */",
            define("ROM_RESOURCE_MAGIC", f'"{RESOURCE_MAGIC}"'),
            define("ROM_FORMAT_VERSION", f"{FORMAT_VERSION}u"),
            define("ROM_HEADER_SIZE", HEADER.size, "the shared header: magic to L")]
    out += [define(_macro("ROM_HEADER", f.name), HEADER.offset(f.name)) for f in HEADER.fields[1:]]
    out += [define(_macro("ROM_FLAG", name), f"{bit}u", what.split(":")[0]) for name, (bit, what) in FLAGS.items()]
    out += [define(_macro("ROM_MODEL", k.c_name), f"{k.number}u", k.name) for k in KINDS]
    for k in KINDS:
        if k.head is not None:
            out.append(define(_macro("ROM", k.name, "HEAD_SIZE"), k.head.size, f"the {k.name} kind's own header"))
            out += [define(_macro("ROM", k.name, "HEAD", f.name), k.head.offset(f.name)) for f in k.head.fields]
    out += [define(_macro("ROM_INTEGRATOR", name), f"{number}u") for name, number in INTEGRATORS.items()]
    out += [define("ROM_SECTION_HEADER_SIZE", SECTION.size, "tag, rows, cols"),
            define("ROM_SECTION_TAG_SIZE", SECTION_TAG_SIZE),
            define("ROM_TOKEN_SIZE", TOKEN_SIZE)]
    for name, (number, what) in LIMITS.items():
        out.append(define(f"ROM_{name}", f"{number}u", what))
    out += ["", "/* the tagged sections' named rows and columns (ROM_<TAG>_<COLUMN>, ROM_<TAG>_ROW_<ROW>) */"]
    for tag, s in SECTIONS.items():
        if s.columns:
            out.append(define(_macro("ROM", tag, "COLUMNS"), f"{len(s.columns)}u"))
            out += [define(_macro("ROM", tag, c), i) for i, c in enumerate(s.columns)]
        out += [define(_macro("ROM", tag, "ROW", r), i) for i, r in enumerate(s.rows)]
    out += [define(_macro("ROM_ENVELOPE_CHECK", name), f"{bit}u") for name, bit in ENVELOPE_CHECKS.items()]
    out.append(define("ROM_ENVELOPE_CHECK_ALL", f"{sum(ENVELOPE_CHECKS.values())}u"))
    out += [define(_macro("ROM_LINEAR", name), f"{number}u", "section LINMODEL") for name, number in
            LINEAR_MODELS.items()]
    out += _value_rules()
    out += [            define("ROM_N_SECTION_TAGS", f"{len(SECTIONS)}u", "rom_resources.c's SECTION_RULES has one row each"),
            "/* the model kinds' tables of operations (rom_internal.h RomKindOps; rom_resources.c's list of kinds) */",
            "#define ROM_KIND_TABLES(X) " + " ".join(f"X({k.c_table})" for k in KINDS),
            "", "/* the serialized FMU state */",
            define("ROM_STATE_MAGIC", f'"{STATE_MAGIC}"'),
            define("ROM_STATE_VERSION", f"{STATE_VERSION}u"),
            define("ROM_STATE_OLDEST_VERSION", f"{STATE_OLDEST_VERSION}u", "read too (its t0 converted)"),
            define("ROM_STATE_HEADER_SIZE", STATE_HEADER.size, "magic to f")]
    out += [define(_macro("ROM_STATE", f.name), STATE_HEADER.offset(f.name)) for f in STATE_HEADER.fields[1:]]
    out += ["", "#endif /* SPHROM_ROM_LAYOUT_H */", ""]
    return "\n".join(out)


def _c_number(x):
    return ("INFINITY" if x > 0 else "-INFINITY") if math.isinf(x) else repr(float(x))


def _value_rules():
    """rom_layout.h's tables of the sections' value rules (X-macros over SECTIONS' ``values``)."""
    ranges, sums = [], []
    for tag, s in SECTIONS.items():
        for rule in s.values:
            if isinstance(rule, Range):
                for (c0, i0), (c1, i1) in _span(tag, rule.columns):
                    ranges.append(f'X("{tag}", {c0}, {i0}, {c1}, {i1}, {_c_number(rule.low)}, '
                                  f'{_c_number(rule.high)}, {int(rule.low_open)}, {int(rule.high_open)}, '
                                  f'{int(rule.also is not None)}, {_c_number(rule.also or 0.0)}, "{rule.what}", '
                                  f'"{rule.allowed}")')
            elif isinstance(rule, RowSum):
                spans = _span(tag, rule.columns)
                first, end = spans[0][0], spans[-1][1]
                if any(b[0] != a[1] for a, b in zip(spans, spans[1:])):
                    raise ValueError(f"{tag}: a RowSum's columns must be adjacent")
                sums.append(f'X("{tag}", {first[0]}, {first[1]}, {end[0]}, {end[1]}, {_c_number(rule.total)}, '
                            f'{_c_number(rule.tolerance)}, "{rule.what}")')

    def table(name, rows):
        return [f"#define {name}(X) \\"] + [f"    {r} \\" for r in rows[:-1]] + [f"    {rows[-1]}"]
    return (["", "/* the sections' value rules (layout.py SECTIONS' values; rom_resources.c check_values): columns "
             "[first, end) as", " * c + i x inputs (the shadow's inputs: 1 + ports; end c = -1: to the last "
             "column) */",
             "/* X(tag, first c, first i, end c, end i, low, high, low open, high open, has also, also, what, "
             "allowed) */"]
            + table("ROM_RANGE_RULES", ranges)
            + ["/* X(tag, first c, first i, end c, end i, total, tolerance, what): each row's sum */"]
            + table("ROM_ROW_SUM_RULES", sums))


COMMAND = "python3 -m sphrom.fmu.layout --write"
HEADER_FILE = "fmu_src/rom_layout.h"
DOC_FILE = "docs/internals/resources.md"
DOC_BEGIN = f"<!-- begin layout: generated by `{COMMAND}` from harness/fmu/layout.py -->"
DOC_END = "<!-- end layout -->"


def doc_text(text):
    """docs/internals/resources.md's text with the format between the markers generated."""
    begin, end = text.index(DOC_BEGIN) + len(DOC_BEGIN), text.index(DOC_END)
    return text[:begin] + "\n```text\n" + format_text() + "\n```\n" + text[end:]


def generated(root=None):
    """{path relative to the checkout: its text as generated now} of every generated file."""
    from ..paths import repo_root
    root = Path(root or repo_root())
    return {HEADER_FILE: c_header(), DOC_FILE: doc_text((root / DOC_FILE).read_text(encoding="utf-8"))}


def stale(root=None):
    """The generated files whose committed text differs from the spec's."""
    from ..paths import repo_root
    from .generated import stale as stale_files
    root = Path(root or repo_root())
    return stale_files(generated(root), root)


def main(argv=None):
    from .generated import main as command_line
    return command_line(argv, prog="python3 -m sphrom.fmu.layout", source="the binary layout (harness/fmu/layout.py)",
                        command=COMMAND, generated=generated)


if __name__ == "__main__":
    sys.exit(main())
