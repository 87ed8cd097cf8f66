"""Hostile output paths: nothing that is not a regular file is ever replaced.

The write to a temporary beside the output and a rename replaced whatever the path was: run as root,
``sphrom sph SCENE --out /dev/null`` turned the device node into an HDF5 file.  Now a character device, a FIFO
or /dev/stdout gets the finished bytes written into it (the node stays a node), a folder, a block device, a socket
or a trailing '/' is refused in one line before any work, and the folder is tested by creating the very
temporary the write will use (``os.access`` is true for root on /proc and /sys, and knows nothing of name
lengths).  Every refusal: exit 2, exactly one line on stderr, no traceback, nothing replaced or left behind.
"""

import os
import socket
import stat
import threading
import zipfile
from pathlib import Path

import pytest

from sphrom.cli import main
from sphrom.runio import atomic_path, check_output_path

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def one_line(capsys, *words):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    for word in words:
        assert word in err[0], err[0]
    return err[0]


def listing(folder):
    return sorted(p.name for p in Path(folder).iterdir())


class Reader(threading.Thread):
    """Reads a FIFO to its end (what a `cat fifo > file` would do)."""

    def __init__(self, path):
        super().__init__(daemon=True)
        self.path, self.data = path, b""
        self.start()

    def run(self):
        with open(self.path, "rb") as fh:
            self.data = fh.read()


def command_args(name, hostile_scene, hostile_basis, hostile_fmu, out):
    """The arguments of ``name`` on the small scene, writing ``out``."""
    args = {"sph": ["sph", str(hostile_scene)], "pod": ["pod", str(hostile_scene)],
            "rom": ["rom", str(hostile_scene), "--basis", str(hostile_basis), "--model", "frozen"],
            "reference": ["reference", str(hostile_scene), "--solver", "exact"],
            "fmu": ["fmu", str(hostile_scene), "--modes", "4", "--no-verify"],
            "cosim": ["cosim", str(hostile_fmu)]}[name]
    return args + ["--out", str(out)] + ([] if name == "cosim" else ["--quiet"])


@pytest.mark.parametrize("command", ["sph", "pod", "rom", "reference", "fmu", "cosim"])
def test_a_fifo_gets_the_output_and_stays_a_fifo(command, hostile_scene, hostile_basis, hostile_fmu, tmp_path, capsys):
    fifo = tmp_path / ("out.fmu" if command == "fmu" else "out.csv" if command == "cosim" else "out.h5")
    os.mkfifo(fifo)
    reader = Reader(fifo)
    assert main(command_args(command, hostile_scene, hostile_basis, hostile_fmu, fifo)) == 0, capsys.readouterr().err
    reader.join(60)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)                # still a FIFO
    magic = {".h5": b"\x89HDF", ".fmu": b"PK\x03\x04", ".csv": b"time,"}[fifo.suffix]
    assert reader.data.startswith(magic), reader.data[:16]
    assert listing(tmp_path) == [fifo.name]                      # no temporary left beside it


def test_a_fifo_nobody_reads_is_refused_after_a_bounded_wait(hostile_scene, tmp_path, capsys, monkeypatch):
    import sphrom.runio as runio
    monkeypatch.setattr(runio, "FIFO_WAIT_S", 0.3)
    fifo = tmp_path / "out.h5"
    os.mkfifo(fifo)
    assert main(["sph", str(hostile_scene), "--out", str(fifo), "--quiet"]) == 2
    one_line(capsys, "--out", "no process opened the FIFO", "nothing was written")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and listing(tmp_path) == ["out.h5"]


def device(tmp_path, name, minor):
    """A character device like /dev/null (1, 3) or /dev/full (1, 7): a twin in tmp_path as root (so that a
    regression cannot replace the system's own node), the system's node otherwise (which a non-root run cannot
    replace anyway)."""
    if ROOT:
        path = tmp_path / name
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        return path
    path = Path("/dev") / name
    if not path.exists():
        pytest.skip(f"no {path}")
    return path


def test_dev_null_is_written_into_and_stays_a_device(hostile_scene, tmp_path, capsys):
    null = device(tmp_path, "null", 3)
    before = os.stat(null)
    assert main(["sph", str(hostile_scene), "--out", str(null), "--quiet"]) == 0
    after = os.stat(null)
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev and after.st_ino == before.st_ino
    assert "wrote" in capsys.readouterr().out


def test_dev_full_is_one_line_and_stays_a_device(hostile_scene, tmp_path, capsys):
    full = device(tmp_path, "full", 7)
    before = os.stat(full)
    assert main(["sph", str(hostile_scene), "--out", str(full), "--quiet"]) == 2
    one_line(capsys, "--out", "cannot write into", "No space left on device")
    after = os.stat(full)
    assert stat.S_ISCHR(after.st_mode) and after.st_ino == before.st_ino


def test_a_link_to_a_file_stays_a_link(hostile_scene, tmp_path, capsys):
    target = tmp_path / "real.h5"
    target.write_bytes(b"old")
    link = tmp_path / "link.h5"
    link.symlink_to(target)
    assert main(["sph", str(hostile_scene), "--out", str(link), "--quiet"]) == 0
    assert link.is_symlink() and target.read_bytes().startswith(b"\x89HDF")
    assert listing(tmp_path) == ["link.h5", "real.h5"]


@pytest.mark.parametrize("suffix, expect", [("/", "names a folder"), ("/x.h5/", "names a folder"),
                                            ("/x.h5/.", "names a folder"), ("/x.h5/..", "names a folder")])
def test_a_trailing_slash_is_a_folder_never_a_file(hostile_scene, tmp_path, capsys, suffix, expect):
    folder = tmp_path / "d"
    folder.mkdir()
    assert main(["sph", str(hostile_scene), "--out", f"{folder}{suffix}", "--quiet"]) == 2
    one_line(capsys, "--out", expect)
    assert listing(folder) == []


def test_a_folder_a_socket_a_block_device_are_refused(hostile_scene, tmp_path, capsys):
    folder = tmp_path / "d"
    folder.mkdir()
    assert main(["sph", str(hostile_scene), "--out", str(folder), "--quiet"]) == 2
    one_line(capsys, "--out", "is a folder")
    sock_path = tmp_path / "s.h5"
    sock = socket.socket(socket.AF_UNIX)
    try:
        sock.bind(str(sock_path))
        assert main(["sph", str(hostile_scene), "--out", str(sock_path), "--quiet"]) == 2
        one_line(capsys, "--out", "is a socket")
        assert stat.S_ISSOCK(os.stat(sock_path).st_mode)
    finally:
        sock.close()
    if ROOT:
        block = tmp_path / "loop.h5"
        os.mknod(block, 0o600 | stat.S_IFBLK, os.makedev(7, 200))
        assert main(["sph", str(hostile_scene), "--out", str(block), "--quiet"]) == 2
        one_line(capsys, "--out", "is a block device")
        assert stat.S_ISBLK(os.stat(block).st_mode)


@pytest.mark.parametrize("command", ["sph", "fmu", "cosim"])
@pytest.mark.parametrize("folder", ["/proc", "/sys"])
def test_a_folder_the_system_refuses(command, folder, hostile_scene, hostile_basis, hostile_fmu, capsys):
    if not Path(folder).is_dir():
        pytest.skip(f"no {folder}")
    name = {"fmu": "x.fmu", "cosim": "x.csv"}.get(command, "x.h5")
    assert main(command_args(command, hostile_scene, hostile_basis, hostile_fmu, f"{folder}/{name}")) == 2
    one_line(capsys, "--out", f"folder '{folder}'")
    assert not Path(folder, name).exists()


def test_a_name_too_long_for_the_system(hostile_scene, tmp_path, capsys):
    for length in (300, 250):            # the name itself, or only its temporary, beyond 255 bytes
        out = tmp_path / ("a" * length + ".h5")
        assert main(["sph", str(hostile_scene), "--out", str(out), "--quiet"]) == 2
        one_line(capsys, "--out", "too long")
    assert listing(tmp_path) == []


def test_the_check_creates_the_very_temporary(tmp_path):
    """check_output_path makes and removes the temporary the write will use: a folder where files cannot be
    created fails before any work whatever os.access says; nothing is left."""
    assert check_output_path(tmp_path / "x.h5") == tmp_path / "x.h5"
    assert listing(tmp_path) == []
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / "x.h5").write_bytes(b"keep")
    os.chmod(locked, 0o500)
    try:
        if ROOT:                       # root writes anyway: the check agrees with what the write would do
            assert check_output_path(locked / "x.h5")
        else:
            from sphrom.errors import FieldError
            with pytest.raises(FieldError, match="cannot create a file in folder"):
                check_output_path(locked / "x.h5")
    finally:
        os.chmod(locked, 0o700)
    assert listing(locked) == ["x.h5"] and (locked / "x.h5").read_bytes() == b"keep"


@pytest.mark.parametrize("argv", [["bench-sph", "--n-particles", "16", "--repeats", "1"],
                                  ["bench-fmu", "--core-only", "--n-particles", "48", "--repeats", "5"],
                                  ["modes", "multimode"], ["stress", "--quick"], ["validate", "multimode"],
                                  ["bench", "--no-fmu", "--repeats", "1"]])
def test_an_output_folder_that_is_a_file(argv, tmp_path, capsys):
    """`--out EXISTING_FILE` for the commands that write a folder: FileExistsError before; now one line, before
    any work, and the file unchanged."""
    import time
    existing = tmp_path / "results"
    existing.write_bytes(b"mine")
    start = time.monotonic()
    assert main([*argv, "--out", str(existing), "--quiet"]) == 2
    one_line(capsys, "--out", "is a file", "allowed: a folder")
    assert time.monotonic() - start < 30                # refused before the benchmark
    assert existing.read_bytes() == b"mine" and listing(tmp_path) == ["results"]


def test_an_output_folder_made_for_a_run_that_failed_is_removed(hostile_scene, tmp_path, capsys):
    out = tmp_path / "new" / "deeper"
    assert main(["modes", str(hostile_scene), "--max-modes", "2", "--times", "999", "--out", str(out), "--quiet"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert listing(tmp_path) == []


def test_bench_checks_every_option_before_the_benchmark(tmp_path, capsys):
    import time
    start = time.monotonic()
    assert main(["bench", "--fmu-scene", "nosuch", "--out", str(tmp_path / "b"), "--quiet"]) == 2
    one_line(capsys, "--fmu-scene", "nosuch")
    assert main(["bench", "--no-fmu", "--report", "/proc/x.md", "--out", str(tmp_path / "b"), "--quiet"]) == 2
    one_line(capsys, "--report", "folder '/proc'")
    assert time.monotonic() - start < 30 and listing(tmp_path) == []


def test_a_sweep_refuses_outputs_it_cannot_rename_into_place(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    spec.write_text('scene = "multimode"\nt_end = 0.1\nstep = 0.01\n[grid]\namplitude = [0.01]\n')
    fifo = tmp_path / "r.h5"
    os.mkfifo(fifo)
    assert main(["sweep", str(spec), "--out", str(fifo), "--quiet"]) == 2
    one_line(capsys, "--out", "is a FIFO")
    fifo.unlink()
    (tmp_path / "r.csv").mkdir()                       # the CSV beside it
    assert main(["sweep", str(spec), "--out", str(tmp_path / "r.h5"), "--quiet"]) == 2
    one_line(capsys, "--out", "r.csv' is a folder")
    assert listing(tmp_path) == ["r.csv", "spec.toml"]


def test_atomic_path_into_a_node_leaves_no_temporary(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    reader = Reader(fifo)
    with atomic_path(fifo) as tmp:
        assert tmp.parent != tmp_path                   # a private folder, not beside the node
        tmp.write_bytes(b"payload")
        private = tmp.parent
    reader.join(10)
    assert reader.data == b"payload" and not private.exists() and listing(tmp_path) == ["f"]


def test_fmu_entries_are_readable_by_everyone(hostile_fmu):
    """zipfile's writestr stores 0600: an FMU extracted by one user was unreadable to another."""
    with zipfile.ZipFile(hostile_fmu) as zf:
        for info in zf.infolist():
            mode = info.external_attr >> 16
            want = 0o755 if info.filename.startswith("binaries/") else 0o644
            assert stat.S_IMODE(mode) == want, (info.filename, oct(mode))
