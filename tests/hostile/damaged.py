"""Damaged copies of an sphrom FMU (issue 36, case 6), for the battery and the tests: each a file a user might be
handed, and each must be one line from ``sphrom cosim``, exit 2, with no extraction folder left behind."""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

BIN2 = "binaries/linux64/sphrom.so"


def _rebuild(src, out, change=None, drop=(), extra=(), method=zipfile.ZIP_DEFLATED):
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(out, "w", method) as zo:
        for info in zi.infolist():
            if info.filename in drop:
                continue
            data = zi.read(info.filename)
            if change and info.filename in change:
                data = change[info.filename](data)
            zo.writestr(info.filename, data)
        for name, data in extra:
            zo.writestr(name, data)
    return out


def _experiment(attribute, value):
    text = b"" if value is None else f'{attribute}="{value}"'.encode()
    return {"modelDescription.xml": lambda d: re.sub(rb'\b' + attribute.encode() + rb'="[^"]*"', text, d)}


def damaged_fmus(fmu2, folder, bomb_mib=2048):
    """{name: path} of damaged copies of the FMI 2 FMU ``fmu2`` written into ``folder``: a truncated, missing,
    garbage, empty or foreign binary, an absolute and a '..' member name, a CRC error in the binary, a
    DefaultExperiment stepSize of 0, -1 or none and a stopTime of -2, and a zip bomb (``bomb_mib`` MiB of zeros
    in about 2 MB)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = {}

    def make(name, **kw):
        out[name] = _rebuild(fmu2, folder / f"{name}.fmu", **kw)
    make("truncated binary", change={BIN2: lambda d: d[: len(d) // 2]})
    make("truncated binary, one page", change={BIN2: lambda d: d[:4096]})
    make("missing binary", drop=(BIN2,))
    make("garbage binary", change={BIN2: lambda d: bytes(range(256)) * 100})
    make("empty binary", change={BIN2: lambda d: b""})
    make("foreign binary", change={BIN2: lambda d: Path(zipfile.__file__).read_bytes() if False else _foreign(d)})
    make("absolute member", extra=[("/tmp/sphrom-hostile-absolute.txt", b"x")])
    make("dot-dot member", extra=[("../sphrom-hostile-dotdot.txt", b"x")])
    make("stepSize 0", change=_experiment("stepSize", 0))
    make("stepSize -1", change=_experiment("stepSize", -1))
    make("no stepSize", change=_experiment("stepSize", None))
    make("stopTime -2", change=_experiment("stopTime", -2))
    crc = _rebuild(fmu2, folder / "crc error.fmu", method=zipfile.ZIP_STORED)
    raw = bytearray(crc.read_bytes())
    at = raw.find(b"\x7fELF") + 5000
    raw[at] ^= 0xFF
    crc.write_bytes(bytes(raw))
    out["crc error"] = crc
    bomb = folder / "zip bomb.fmu"
    with zipfile.ZipFile(fmu2) as zi, zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zo:
        for info in zi.infolist():
            zo.writestr(info.filename, zi.read(info.filename))
        with zo.open("resources/bomb.bin", "w", force_zip64=True) as fh:
            zeros = bytes(1 << 20)
            for _ in range(bomb_mib):
                fh.write(zeros)
    out["zip bomb"] = bomb
    return out


def _foreign(binary):
    """A shared library of this machine that is no FMU (the C library's zlib, else Python's own)."""
    import sys
    for candidate in ("/usr/lib/x86_64-linux-gnu/libz.so.1", "/lib/x86_64-linux-gnu/libz.so.1",
                      str(Path(sys.executable).resolve().parent.parent / "lib" / "libpython3.so")):
        if Path(candidate).is_file():
            return Path(candidate).read_bytes()
    return binary[:64] + bytes(len(binary) - 64)
