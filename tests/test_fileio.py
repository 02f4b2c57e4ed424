"""core.fileio: a write never destroys what the path points at.

Regular files are replaced atomically; symbolic links are written through to their target;
devices, FIFOs and /dev/stdout are written in place; folders, sockets and paths under a file
are refused with one line; missing parent folders are created.
"""

from __future__ import annotations

import io
import os
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from special_files import FifoReader, as_unprivileged, char_device, needs_root

from core.fileio import OutputError, OutputPathError, atomic_write, atomic_write_text, check_output, check_output_folder, make_folder

ROOT = Path(__file__).resolve().parent.parent


def test_regular_file_replaced_atomically(tmp_path):
    p = tmp_path / "plan.json"
    p.write_text("old")
    inode = p.stat().st_ino
    atomic_write_text(p, "new")
    assert p.read_text() == "new" and p.stat().st_ino != inode  # a new file was renamed in
    assert sorted(x.name for x in tmp_path.iterdir()) == ["plan.json"]  # no temporary left


def test_symlink_stays_a_link_and_its_target_gets_the_content(tmp_path):
    real = tmp_path / "real" / "script.sgt"
    real.parent.mkdir()
    real.write_text("old")
    link = tmp_path / "link.sgt"
    link.symlink_to(Path("real") / "script.sgt")  # relative, as users make them
    chain = tmp_path / "chain.sgt"
    chain.symlink_to(link)
    atomic_write_text(chain, "new")
    assert chain.is_symlink() and link.is_symlink()
    assert real.read_text() == "new" and not real.is_symlink()
    assert sorted(x.name for x in real.parent.iterdir()) == ["script.sgt"]


def test_dangling_symlink_creates_its_target(tmp_path):
    link = tmp_path / "out.json"
    link.symlink_to(tmp_path / "made" / "there.json")
    atomic_write(link, b"{}")
    assert link.is_symlink() and (tmp_path / "made" / "there.json").read_bytes() == b"{}"


def test_fifo_is_written_in_place(tmp_path):
    reader = FifoReader(tmp_path / "pipe.json")
    atomic_write_text(reader.path, '{"a": 1}')
    assert reader.close() == b'{"a": 1}'
    assert stat.S_ISFIFO(os.lstat(reader.path).st_mode)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["pipe.json"]


@needs_root
def test_char_device_is_written_in_place_never_replaced(tmp_path):
    dev = char_device(tmp_path / "null.json")
    check_output(dev)
    atomic_write(dev, b"data")
    assert stat.S_ISCHR(os.lstat(dev).st_mode) and os.lstat(dev).st_rdev == os.stat("/dev/null").st_rdev
    link = tmp_path / "to-dev.json"
    link.symlink_to(dev)
    atomic_write(link, b"data")
    assert link.is_symlink() and stat.S_ISCHR(os.lstat(dev).st_mode)


@needs_root
def test_a_full_device_reports_the_full_disk_in_one_line(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    dev = char_device(tmp_path / "full.json", like="/dev/full")
    with pytest.raises(OutputError) as e:
        atomic_write(dev, b"x" * 10000)
    assert "No space left" in str(e.value) and "\n" not in str(e.value)
    assert stat.S_ISCHR(os.lstat(dev).st_mode)


def test_stdout_link_redirected_to_a_file_is_written_like_a_shell_does(tmp_path):
    """A link like /dev/stdout -> /proc/self/fd/1 -> the file: written in place, not renamed over.

    The link is made in the test's folder: a regression must not replace the machine's /dev/stdout."""
    stdout = tmp_path / "stdout"
    stdout.symlink_to("/proc/self/fd/1")
    out = tmp_path / "out.txt"
    code = f"from core.fileio import atomic_write_text; atomic_write_text({str(stdout)!r}, 'hello\\n')"
    with open(out, "wb") as f:
        inode = os.fstat(f.fileno()).st_ino
        subprocess.run([sys.executable, "-c", code], cwd=ROOT, stdout=f, check=True)
    assert out.read_text() == "hello\n" and out.stat().st_ino == inode
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert r.stdout == "hello\n"  # a pipe
    assert stdout.is_symlink() and sorted(p.name for p in tmp_path.iterdir()) == ["out.txt", "stdout"]


@pytest.mark.parametrize("make, kind", [
    (lambda p: p.mkdir(), OutputPathError),
    (lambda p: socket.socket(socket.AF_UNIX).bind(str(p)), OutputPathError),
])
def test_folders_and_sockets_are_refused(tmp_path, make, kind):
    p = tmp_path / "thing.json"
    make(p)
    for fn in (check_output, lambda x: atomic_write(x, b"x")):
        with pytest.raises(kind) as e:
            fn(p)
        assert str(p) in str(e.value) and "\n" not in str(e.value)
    assert not stat.S_ISREG(os.lstat(p).st_mode)


def test_a_path_under_a_file_is_refused_and_nothing_is_created(tmp_path):
    f = tmp_path / "script.sgt"
    f.write_text("x")
    for bad in (f / "plan.json", f / "deeper" / "plan.json"):
        with pytest.raises(OutputPathError, match="is a file, not a folder"):
            check_output(bad)
        with pytest.raises(OutputPathError):
            atomic_write(bad, b"x")
    with pytest.raises(OutputPathError):
        check_output_folder(f)
    with pytest.raises(OutputPathError):
        make_folder(f / "sub")
    assert f.read_text() == "x"


def test_missing_parents_are_created_when_written_not_when_checked(tmp_path):
    out = tmp_path / "a" / "b" / "plan.json"
    check_output(out)
    check_output_folder(tmp_path / "c" / "d")
    assert sorted(x.name for x in tmp_path.iterdir()) == []
    atomic_write(out, b"{}")
    assert out.read_bytes() == b"{}"


def refused(fn, *args) -> str:
    try:
        fn(*args)
    except OutputError as e:
        assert "\n" not in str(e), str(e)
        return str(e)
    raise AssertionError(f"not refused: {fn.__name__}{args}")


def test_read_only_files_and_folders_are_refused_in_one_line(shared_dir):
    keep = shared_dir / "keep.json"
    keep.write_text("mine")
    keep.chmod(0o444)
    locked = shared_dir / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    lines = as_unprivileged(lambda: [
        refused(atomic_write, keep, b"x"),
        refused(check_output, keep),
        refused(atomic_write, locked / "x.json", b"x"),
        refused(check_output, locked / "x.json"),
        refused(check_output_folder, locked / "sub"),
        refused(make_folder, locked / "sub"),
        refused(atomic_write, locked / "deeper" / "x.json", b"x"),
    ])
    assert "read-only" in lines[0] and "read-only" in lines[1]
    assert all("ermission denied" in line for line in lines[2:]), lines
    assert keep.read_text() == "mine" and sorted(p.name for p in locked.iterdir()) == []


def test_kernel_files_are_written_in_place_and_fail_in_one_line():
    """/proc files are not renamed over (as root, writing /proc/version fails with EIO)."""
    if not os.path.exists("/proc/version"):
        pytest.skip("no /proc here")
    with pytest.raises(OutputError) as e:
        atomic_write("/proc/version", b"x")
    assert "/proc/version" in str(e.value) and "\n" not in str(e.value)


def test_odd_names_are_one_line_errors():
    with pytest.raises(OutputPathError, match="empty"):
        check_output("")
    with pytest.raises(OutputPathError, match="NUL"):
        atomic_write("a\0b.json", b"x")


def test_a_stream_is_written_and_flushed():
    buf = io.BytesIO()
    atomic_write(buf, b"abc")
    assert buf.getvalue() == b"abc"


def test_the_editor_saves_a_symlinked_script_through_the_link(tmp_path):
    """ctrl+s used to replace a symlinked script with a regular file and leave its target old."""
    from sgt_tui.editor.files import ScriptFile

    real = tmp_path / "scripts" / "lobby.sgt"
    real.parent.mkdir()
    real.write_text("guide: hello\n")
    link = tmp_path / "lobby.sgt"
    link.symlink_to("scripts/lobby.sgt")
    f = ScriptFile.open(link)
    f.document.set_text("guide: hello again\n")
    f.save()
    assert link.is_symlink() and real.read_text() == "guide: hello again\n"
    assert not f.changed_on_disk()
