"""Compare two builds of the C model core (libsphrom_core) on every message and every bit of a battery of valid and
damaged inputs: a change to fmu_src/ that claims to change nothing observable runs this once.

    python3 tests/data/compare_cores.py --make DIR                        # small model.bin of every kind (once)
    python3 tests/data/compare_cores.py --resources DIR --old OLD --new NEW

OLD and NEW are a libsphrom_core shared library or a checkout (its fmu_src/ is built into a temporary folder).
Per model.bin of DIR: the load; a run (setters with good and bad values, parameters, ports, steps with held and
linear inputs, a too-large input, outputs, output rates, checks, the envelope message, exponentials counted,
doStep's rules); its serialized state, restored and written again, and ~1000 damaged states (each field and value
slot overwritten, checksum fixed) through rom_state_check and rom_state_deserialize; ~1000 damaged resources
(truncations, flipped bytes with and without a fixed checksum, every header field set to edge values, NaN in the
body, sections dropped, repeated, transposed, with edge values, every known and unknown tag added, PARAMS
variants), each loaded and, when accepted, run briefly.  Each library runs in a process of its own and writes one
JSON line per record; the lines are compared in order (exit 1 on a difference).  It needs the harness importable
(``sphrom``: the damaged resources are cut along sphrom.fmu.layout); ``--make`` packages 16 FMUs of N = 32 scenes
(a few minutes; the SPH runs are cached).
"""

import argparse
import ctypes
import json
import random
import struct
import subprocess
import sys
import tempfile
import zipfile
import zlib
from pathlib import Path

import numpy as np

MS = 1024                                   # ROM_MESSAGE_SIZE


# ---------------------------------------------------------------------------
# resources of every kind and option
# ---------------------------------------------------------------------------

def make_resources(folder):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from conftest import small_scene
    from sphrom.fmu.make.package import package_fmu
    from sphrom.rom.parametric import parse_vary
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    forced, unforced = small_scene("damped_forced", T=0.5, n=32), small_scene("multimode", T=0.5, n=32)
    symplectic = small_scene("damped_forced", T=0.5, n=32, integrator="symplectic")
    c, d = parse_vary("c=0.05:0.2"), parse_vary("d=5:15")
    cases = {
        "frozen_forced": (forced, dict(model="frozen")),
        "frozen_unforced": (unforced, dict(model="frozen")),
        "frozen_symp": (symplectic, dict(model="frozen")),
        "exact_forced": (forced, dict(model="exact")),
        "exact_unforced": (unforced, dict(model="exact")),
        "balanced_forced": (forced, dict(model="balanced")),
        "balanced_unforced": (unforced, dict(model="balanced", bounds=False)),
        "frozen_ports": (forced, dict(model="frozen", ports=[0.3, 0.7])),
        "exact_ports": (forced, dict(model="exact", ports=[0.3, 0.7], bounds=False)),
        "exact_ports_unforced": (unforced, dict(model="exact", ports=[0.5], bounds=False)),
        "frozen_vary_c": (forced, dict(model="frozen", vary=[c])),
        "frozen_vary_d": (forced, dict(model="frozen", vary=[d])),
        "frozen_vary_cd": (forced, dict(model="frozen", vary=[c, d])),
        "exact_vary_c": (forced, dict(model="exact", vary=[c], bounds=False)),
        "exact_vary_d": (forced, dict(model="exact", vary=[d], bounds=False)),
        "exact_vary_cd": (forced, dict(model="exact", vary=[c, d], bounds=False)),
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name, (scene, options) in cases.items():
            if (folder / f"{name}.bin").exists():
                continue
            fmu = Path(tmp) / f"{name}.fmu"
            package_fmu(scene, fmu, k=6, fmi=2, progress=False, **options)
            (folder / f"{name}.bin").write_bytes(zipfile.ZipFile(fmu).read("resources/model.bin"))
            print(name, flush=True)


# ---------------------------------------------------------------------------
# one library: the records
# ---------------------------------------------------------------------------

def bind(path):
    lib = ctypes.CDLL(str(path))
    vp, sz, cp, d, u32, i64, st = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_double,
                                   ctypes.c_uint32, ctypes.c_int64, ctypes.c_int)
    pd, pu = ctypes.POINTER(d), ctypes.POINTER(u32)
    signatures = {
        "rom_model_load_memory": (st, cp, sz, ctypes.POINTER(vp), cp, sz), "rom_model_free": (None, vp),
        "rom_state_new": (vp, vp), "rom_state_free": (None, vp), "rom_state_reset": (None, vp, d),
        "rom_set_start_time": (st, vp, d, cp, sz), "rom_set_input": (st, vp, d, cp, sz),
        "rom_set_input_rate": (st, vp, d, cp, sz), "rom_set_dt": (st, vp, d, cp, sz),
        "rom_set_n_freeze": (st, vp, i64, cp, sz), "rom_set_initial_state_scale": (st, vp, d, cp, sz),
        "rom_do_step": (st, vp, d, d, cp, sz), "rom_step_exceeds": (st, vp, d), "rom_advance": (st, vp, i64, cp, sz),
        "rom_reduced_state": (sz, vp, pd, sz), "rom_expm_count": (i64, vp), "rom_model_kind": (u32, vp),
        "rom_v_probe": (d, vp, u32), "rom_rho_probe": (d, vp, u32), "rom_linear_model_name": (cp, vp),
        "rom_max_output_derivative_order": (st, vp), "rom_v_probe_rate": (st, vp, u32, pd, cp, sz),
        "rom_rho_probe_rate": (st, vp, u32, pd, cp, sz), "rom_check_outputs": (st, vp, cp, sz),
        "rom_state_serialized_size": (sz, vp),
        "rom_state_serialize": (None, vp, u32, cp), "rom_state_check": (st, vp, cp, sz, cp, sz),
        "rom_state_deserialize": (st, vp, cp, sz, pu, cp, sz), "rom_envelope_check": (st, vp, cp, sz),
        "rom_varies": (st, vp, st), "rom_set_param": (st, vp, st, d, cp, sz), "rom_get_param": (d, vp, st),
        "rom_model_assemble": (st, vp, vp, cp, sz), "rom_n_ports": (u32, vp),
        "rom_set_port_force": (st, vp, u32, d, cp, sz), "rom_set_area": (st, vp, d, cp, sz),
        "rom_set_port_rate": (st, vp, u32, d, cp, sz), "rom_v_port": (d, vp, u32), "rom_port_force": (d, vp, u32),
    }
    for name, (res, *args) in signatures.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = res, list(args)
    return lib


def fix_crc(blob):
    return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]) & 0xffffffff)


def sections_of(blob):
    """(offset of the section count, [[tag, rows, cols, data]], token) of a model.bin of the current format (the
    header, the kind's own header and body by :mod:`sphrom.fmu.layout`, as sphrom.fmu.resources.read walks them)."""
    from sphrom.fmu import layout
    header = layout.HEADER.unpack(blob)
    spec = layout.KIND_BY_NUMBER[header["model_kind"]]
    cursor, head = layout.HEADER.size, None
    if spec.head is not None:
        head = spec.head.unpack(blob, cursor)
        cursor += spec.head.size
    sizes = layout.dims(spec, header, head)
    for array in spec.body:
        if layout.present(array, header["flags"]):
            cursor += 8 * int(np.prod(layout.shape(array, sizes)))
    start = cursor
    cursor, sections = start + 4, []
    for _ in range(struct.unpack_from("<I", blob, start)[0]):
        tag, rows, cols = struct.unpack_from("<8s2I", blob, cursor)
        cursor += 16
        sections.append([tag, rows, cols, blob[cursor:cursor + 8 * rows * cols]])
        cursor += 8 * rows * cols
    return start, sections, blob[cursor:cursor + 40]


def with_sections(blob, start, sections, token):
    out = bytearray(blob[:start]) + struct.pack("<I", len(sections))
    for tag, rows, cols, data in sections:
        out += struct.pack("<8s2I", tag, rows, cols) + data
    return fix_crc(bytes(out + token + b"\0\0\0\0"))


def damaged_resources(name, blob):
    """(label, bytes) of damaged copies of one model.bin."""
    rng = random.Random(zlib.crc32(name.encode()))
    for n in (0, 5, 8, 12, 40, 71, 72, 115, 116, len(blob) // 2, len(blob) - 45, len(blob) - 4, len(blob) - 1):
        yield f"truncated to {n}", blob[:n]
    yield "8 bytes more", fix_crc(blob[:-4] + b"\0" * 8 + blob[-4:])
    for offset in list(range(72)) + [rng.randrange(72, len(blob) - 4) for _ in range(60)]:
        flipped = bytearray(blob)
        flipped[offset] ^= 0x5A
        yield f"byte {offset} flipped", bytes(flipped)
        yield f"byte {offset} flipped, checksum fixed", fix_crc(bytes(flipped))
    # model.bin format 4 (harness/fmu/layout.py): the shared header's uint32 fields from byte 8, its float64 fields
    # from 32; the frozen kind's own header at 48 (4 uint32, then dt at 64)
    frozen = struct.unpack_from("<I", blob, 12)[0] == 1
    words = [(8 + 4 * i, f) for i, f in enumerate(("version", "kind", "k_v", "k_rho", "n_probes", "flags"))]
    numbers = [(32, "bound"), (40, "L")]
    if frozen:
        words += [(48 + 4 * i, f) for i, f in enumerate(("integrator", "n_pairs", "n_freeze", "reserved"))]
        numbers += [(64, "dt")]
    for at, field in words:
        for value in (0, 1, 2, 3, 4, 8, 15, 100, 1025, 0xffffffff):
            yield f"{field} = {value}", fix_crc(blob[:at] + struct.pack("<I", value) + blob[at + 4:])
    for at, field in numbers:
        for value in (0.0, -1.0, float("nan"), float("inf"), 1e-300):
            yield f"{field} = {value}", fix_crc(blob[:at] + struct.pack("<d", value) + blob[at + 8:])
    start, sections, token = sections_of(blob)
    for offset in (72, 80, (72 + start) // 16 * 8, start - 8):
        for value in (float("nan"), 7.0):
            yield f"{value} at {offset}", fix_crc(blob[:offset] + struct.pack("<d", value) + blob[offset + 8:])
    yield "bad token", with_sections(blob, start, sections, b"x" * 40)
    for i, (tag, rows, cols, data) in enumerate(sections):
        yield f"section {i} dropped", with_sections(blob, start, sections[:i] + sections[i + 1:], token)
        yield f"section {i} twice", with_sections(blob, start, sections + [sections[i]], token)
        changed = [list(s) for s in sections]
        changed[i][1:3] = [cols, rows]
        yield f"section {i} transposed", with_sections(blob, start, changed, token)
        for at in (0, 4):
            if rows * cols <= at:
                continue
            for value in (float("inf"), -1.0, 0.0, 0.5, 2.0, 3.0, 1e9):
                changed = [list(s) for s in sections]
                changed[i][3] = data[:8 * at] + struct.pack("<d", value) + data[8 * at + 8:]
                yield f"section {i} value {at} = {value}", with_sections(blob, start, changed, token)
    kv, kr, n_probes = struct.unpack_from("<3I", blob, 16)
    tags = ("BOUNDS", "LINMODEL", "PARAMS", "KC", "BC", "DD", "A0", "AC", "AD", "PORTX", "PORTB", "PORTC", "ENVELOPE",
            "ENVRANGE", "ENVPROBE", "ENVPORT", "XYZ", "", "a b")
    shapes = ((1, 1), (2, n_probes), (2, 4), (kv, kr), (1, kv), (kv, kv), (kv + kr, kv + kr), (1, 2), (1, 8),
              (2, kv + kr))
    for tag in tags:
        for rows, cols in shapes:
            added = [tag.encode().ljust(8, b"\0"), rows, cols, struct.pack(f"<{rows * cols}d", *[0.5] * (rows * cols))]
            yield f"section {tag!r} {rows} x {cols} added", with_sections(blob, start, sections + [added], token)
    for row_c, row_d in (((1, .1, .05, .2), (0, 10, 10, 10)), ((1, .1, .05, .2), (1, 10, 5, 15)),
                         ((0, .1, .1, .1), (1, 10, 5, 15)), ((0, .1, .1, .1), (0, 10, 10, 10)),
                         ((2, .1, .05, .2), (0, 0, 0, 0)), ((1, .3, .05, .2), (0, 0, 0, 0))):
        params = [b"PARAMS\0\0", 2, 4, struct.pack("<8d", *row_c, *row_d)]
        kept = [s for s in sections if s[0].rstrip(b"\0") != b"PARAMS"]
        yield f"PARAMS {row_c} {row_d}", with_sections(blob, start, kept + [params], token)


class Recorder:
    """Runs the battery on one library, one JSON line per record on out."""

    def __init__(self, lib, out):
        self.lib, self.out, self.msg = lib, out, ctypes.create_string_buffer(MS)

    def record(self, *values):
        text = [struct.pack("<d", v).hex() if isinstance(v, float) else v for v in values]
        self.out.write(json.dumps(text) + "\n")

    def message(self):
        """The core's last message, marked as one (the count of distinct messages)."""
        return "message: " + self.msg.value.decode(errors="replace")

    def load(self, blob):
        handle = ctypes.c_void_p()
        status = self.lib.rom_model_load_memory(blob, len(blob), ctypes.byref(handle), self.msg, MS)
        return status, self.message(), handle

    def outputs(self, where, h, s, n_probes):
        lib, m = self.lib, self.msg
        values = [lib.rom_v_probe(s, j) for j in range(n_probes + 1)] + [lib.rom_rho_probe(s, j)
                                                                        for j in range(n_probes + 1)]
        ports = lib.rom_n_ports(h)
        values += [lib.rom_v_port(s, j) for j in range(ports + 1)] + [lib.rom_port_force(s, j)
                                                                     for j in range(ports + 1)]
        buffer = (ctypes.c_double * 4096)()
        values += list(buffer[:lib.rom_reduced_state(s, buffer, 4096)])
        for j in range(n_probes + 1):
            for name, f in (("v rate", lib.rom_v_probe_rate), ("rho rate", lib.rom_rho_probe_rate)):
                rate = ctypes.c_double(0.0)
                self.record(where, name, j, f(s, j, ctypes.byref(rate), m, MS), self.message(), rate.value)
        self.record(where, "check", lib.rom_check_outputs(s, m, MS), self.message())
        self.record(where, "envelope", lib.rom_envelope_check(s, m, MS) and self.message())
        self.record(where, "outputs", *[float(v) for v in values])
        self.record(where, "counts", lib.rom_expm_count(s), *[lib.rom_step_exceeds(s, h) for h in
                                                              (0.001, 1e-7, 0.01, -1.0)])

    def run(self, where, h, short):
        lib, m = self.lib, self.msg
        s = lib.rom_state_new(h)
        try:
            self.record(where, "model", lib.rom_model_kind(h), lib.rom_linear_model_name(h) and
                        lib.rom_linear_model_name(h).decode(), lib.rom_max_output_derivative_order(h),
                        lib.rom_n_ports(h), lib.rom_varies(h, 0), lib.rom_varies(h, 1))
            n_probes = 0
            while n_probes < 200 and not np.isnan(lib.rom_v_probe(s, n_probes)):
                n_probes += 1
            self.outputs(where + "/start", h, s, n_probes)
            for f, value in ((lib.rom_set_initial_state_scale, 0.5), (lib.rom_set_initial_state_scale, float("inf")),
                             (lib.rom_set_dt, -1.0), (lib.rom_set_n_freeze, 0), (lib.rom_set_n_freeze, 3),
                             (lib.rom_set_input, float("nan")), (lib.rom_set_input_rate, float("inf")),
                             (lib.rom_set_area, 0.0), (lib.rom_set_area, 2.0), (lib.rom_set_start_time, float("nan")),
                             (lib.rom_set_start_time, 0.25)):
                self.record(where, f.__name__, value if isinstance(value, float) else int(value),
                            f(s, value, m, MS), self.message())
            for which in (0, 1, 2):
                for value in (0.0, 0.1, 0.15, 10.0, 12.0, float("nan")):
                    status = lib.rom_set_param(s, which, value, m, MS)
                    self.record(where, "param", which, value, status, self.message(), lib.rom_get_param(s, which))
            self.record(where, "assemble", lib.rom_model_assemble(h, s, m, MS), self.message())
            for j in range(lib.rom_n_ports(h) + 1):
                self.record(where, "port", j, lib.rom_set_port_force(s, j, 0.3 * (j + 1), m, MS), self.message(),
                            lib.rom_set_port_rate(s, j, -0.1 * (j + 1), m, MS), self.message())
            self.outputs(where + "/set", h, s, n_probes)
            t = 0.25
            steps = [0.01, 0.003, 0.01, 0.0123, 0.002, 0.05, 0.01, 0.01]
            if not short:
                steps = steps[:6] + [0.01] * 30 + [1e-5, 0.2, 0.01]
            for i, step in enumerate(steps):
                lib.rom_set_input(s, 0.02 * np.sin(7 * t) + (5.0 if i == 6 else 0.0), m, MS)
                lib.rom_set_input_rate(s, 0.1 * np.cos(3 * t) if i % 2 else 0.0, m, MS)
                status = lib.rom_do_step(s, t, step, m, MS)
                self.record(where, "step", i, status, self.message())
                if status:
                    break
                t += step
                self.outputs(f"{where}/step {i}", h, s, n_probes)
            for label, t_comm, step in (("time mismatch", t + 1.0, 0.01), ("negative step", t, -0.01),
                                        ("huge step", t, 1e20)):
                self.record(where, label, lib.rom_do_step(s, t_comm, step, m, MS), self.message())
            self.states(where, h, s, n_probes, short)
        finally:
            lib.rom_state_free(s)

    def states(self, where, h, s, n_probes, short):
        lib, m = self.lib, self.msg
        size = lib.rom_state_serialized_size(h)
        self.record(where, "state sizes", size)
        buffer = ctypes.create_string_buffer(size)
        lib.rom_state_serialize(s, 7, buffer)
        blob = buffer.raw
        self.record(where, "state", blob.hex())
        other = lib.rom_state_new(h)
        tag = ctypes.c_uint32(0)
        try:
            status = lib.rom_state_deserialize(other, blob, size, ctypes.byref(tag), m, MS)
            self.record(where, "restored", status, self.message(), tag.value)
            self.outputs(where + "/restored", h, other, n_probes)
            again = ctypes.create_string_buffer(size)
            lib.rom_state_serialize(other, 7, again)
            self.record(where, "written again", again.raw == blob)
            self.record(where, "advance", lib.rom_advance(other, 5, m, MS), self.message(),
                        lib.rom_advance(other, -1, m, MS), self.message())
            self.outputs(where + "/advanced", h, other, n_probes)
            damaged = [("truncated", blob[:size - 8]), ("short", blob[:50]),
                       ("long", fix_crc(blob[:-4] + b"\0" * 8 + blob[-4:]))]
            values = (b"\xff\xff\xff\xff", *[struct.pack("<d", v) for v in (float("nan"), 0.0, 1e300, 0.15, -1.0)])
            for offset in list(range(0, 116, 4)) + list(range(116, size - 4, 8)):
                for value in values:
                    changed = (blob[:offset] + value + blob[offset + len(value):])[:size]
                    damaged.append((f"{value.hex()} at {offset}", fix_crc(changed)))
            for label, bad in damaged:
                self.record(where, "check", label, lib.rom_state_check(h, bad, len(bad), m, MS), self.message())
                status = lib.rom_state_deserialize(other, bad, len(bad), ctypes.byref(tag), m, MS)
                self.record(where, "restore", label, status, self.message(), tag.value)
        finally:
            lib.rom_state_free(other)

    def battery(self, resources):
        for path in sorted(Path(resources).glob("*.bin")):
            name, blob = path.stem, path.read_bytes()
            status, message, h = self.load(blob)
            self.record(name, "load", status, message)
            if status == 0:
                self.run(name, h, short=False)
                self.lib.rom_model_free(h)
            for label, bad in damaged_resources(name, blob):
                status, message, h = self.load(bad)
                self.record(name, label, status, message)
                if status == 0:
                    self.run(f"{name}/{label}", h, short=True)
                    self.lib.rom_model_free(h)


# ---------------------------------------------------------------------------
# two libraries
# ---------------------------------------------------------------------------

def library(path, folder):
    """The libsphrom_core of path: the file itself, or built from the checkout's fmu_src/ into folder."""
    path = Path(path)
    if path.is_file():
        return path
    from sphrom.fmu.make.build import configure_and_build
    configure_and_build(path / "fmu_src", folder, tests=False)
    found = sorted(folder.glob("libsphrom_core.*")) + sorted(folder.glob("sphrom_core.dll"))
    if not found:
        raise SystemExit(f"no libsphrom_core built in {folder}")
    return found[0]


def _doubles(hex_text, start=0):
    """The float64 values of a hex string from byte ``start`` on (whole values only)."""
    raw = bytes.fromhex(hex_text)[start:]
    return np.frombuffer(raw[:len(raw) // 8 * 8], dtype="<f8")


def _ulps(x, y):
    """|x - y| in units in the last place of the larger (inf where one is not finite and they differ)."""
    if x == y or (np.isnan(x) and np.isnan(y)):
        return 0.0
    if not (np.isfinite(x) and np.isfinite(y)):
        return float("inf")
    return abs(x - y) / np.spacing(max(abs(x), abs(y)))


def difference(a, b):
    """What differs between two records (lists of JSON values): each differing field, a float64 (16 hex digits) as
    its two values and their distance in ulps, a serialized state as the float64 values of its body that differ
    (their index after the header, the two values, the ulps), anything else cut to 120 characters."""
    from sphrom.fmu.layout import STATE_HEADER
    lines = [f"differs: {a[0] if a else ''}"]
    if len(a) != len(b):
        lines.append(f"  {len(a)} fields against {len(b)}")
    for i, (x, y) in enumerate(zip(a, b)):
        if x == y:
            continue
        if isinstance(x, str) and isinstance(y, str) and len(x) == len(y) == 16 and i and a[i - 1] != "state":
            try:
                u, v = float(_doubles(x)[0]), float(_doubles(y)[0])
                lines.append(f"  field {i}: {u!r} against {v!r} ({_ulps(u, v):.3g} ulps)")
                continue
            except ValueError:
                pass
        if i and a[i - 1] == "state" and isinstance(x, str) and isinstance(y, str) and len(x) == len(y):
            u, v = _doubles(x, STATE_HEADER.size), _doubles(y, STATE_HEADER.size)
            bad = [j for j in range(u.size) if not (u[j] == v[j] or (np.isnan(u[j]) and np.isnan(v[j])))]
            head = bytes.fromhex(x)[:STATE_HEADER.size] != bytes.fromhex(y)[:STATE_HEADER.size]
            worst = max((_ulps(u[j], v[j]) for j in bad), default=0.0)
            lines.append(f"  state: {len(bad)} of {u.size} float64 values differ (largest {worst:.3g} ulps)"
                         f"{'; the header differs' if head else ''}")
            lines.extend(f"    value {j}: {float(u[j])!r} against {float(v[j])!r}" for j in bad[:6])
            continue
        lines.append(f"  field {i}: {str(x)[:120]} against {str(y)[:120]}")
    return "\n".join(lines)


def compare(old, new, resources):
    with tempfile.TemporaryDirectory() as tmp:
        libs = [library(p, Path(tmp) / label) for p, label in ((old, "old"), (new, "new"))]
        command = [sys.executable, __file__, "--resources", str(resources), "--lib"]
        runs = [subprocess.Popen(command + [str(lib)], stdout=subprocess.PIPE, text=True) for lib in libs]
        records, differ, messages = 0, 0, set()
        for a, b in zip(runs[0].stdout, runs[1].stdout):
            records += 1
            messages.update(f for f in json.loads(a) if isinstance(f, str) and f.startswith("message: ") and f[9:])
            if a != b:
                differ += 1
                if differ <= 10:
                    print(difference(json.loads(a), json.loads(b)))
        rest = [run.stdout.read() for run in runs]
        codes = [run.wait() for run in runs]
    if any(codes) or rest[0] != rest[1]:
        print(f"the runs ended differently (exit {codes}, {len(rest[0])} and {len(rest[1])} characters left)")
        return 1
    print(f"{records} records ({len(messages)} distinct messages): {records - differ} equal, {differ} differ")
    return 1 if differ else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--make", metavar="DIR", help="write small model.bin files of every kind to DIR")
    parser.add_argument("--resources", metavar="DIR", help="the model.bin files")
    parser.add_argument("--old", help="libsphrom_core or a checkout")
    parser.add_argument("--new", help="libsphrom_core or a checkout")
    parser.add_argument("--lib", help=argparse.SUPPRESS)           # one library's records to stdout
    args = parser.parse_args()
    if args.make:
        make_resources(args.make)
    elif args.lib:
        Recorder(bind(args.lib), sys.stdout).battery(args.resources)
    elif args.old and args.new and args.resources:
        sys.exit(compare(args.old, args.new, args.resources))
    else:
        parser.error("give --make DIR, or --resources DIR with --old and --new")


if __name__ == "__main__":
    main()
