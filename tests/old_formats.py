"""model.bin of format 3 (before the frozen kind's numbers left the shared header) rewritten as the current format,
for the stored references of tests/data/ that hold format 3 files: the same numbers, so an FMU packaged from the
rewritten file must give the same outputs bit for bit (only its token, a hash of the bytes, differs).

Format 3: char[8] magic, uint32 format_version, model_kind, integrator, k_v, k_rho, n_probes, n_pairs, flags,
n_freeze_default, reserved, float64 dt, runaway_bound, L (72 bytes), then the kind's arrays, sections, token and
checksum exactly as format 4 has them after its shared header (48 bytes) and the kind's own header.
"""

import struct
import zlib

FORMAT_3_HEADER = struct.Struct("<8s10I3d")


def from_format_3(blob):
    """The current format's model.bin bytes of the format 3 file ``blob`` (sphrom.fmu.layout)."""
    from sphrom.fmu import layout
    from sphrom.fmu.resources import pack, unpack
    (magic, version, kind, integrator, kv, kr, npr, n_pairs, flags, n_freeze, _, dt, bound,
     L) = FORMAT_3_HEADER.unpack_from(blob)
    if magic != b"SPHROMRS" or version != 3:
        raise ValueError(f"not a format 3 model.bin (version {version})")
    spec = layout.KIND_BY_NUMBER[kind]
    head = b"" if spec.head is None else spec.head.pack(
        {"integrator": integrator, "n_pairs": n_pairs, "n_freeze_default": n_freeze, "reserved": 0, "dt": dt})
    header = layout.HEADER.pack({"magic": b"SPHROMRS", "format_version": layout.FORMAT_VERSION, "model_kind": kind,
                                 "k_v": kv, "k_rho": kr, "n_probes": npr, "flags": flags, "runaway_bound": bound,
                                 "L": L})
    body = header + head + blob[FORMAT_3_HEADER.size:-4]
    return pack(unpack(body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)))
