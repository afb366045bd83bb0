"""omni4.outfile, the careful writer of the Python tools (omni4-mcap, the report), per kind of
target: a file (replaced through a temporary, its permissions kept; an error inside the block
leaves it as it was), a symbolic link (kept, its target replaced), device nodes made with mknod
in the test's folder (1,7 is /dev/full's: ENOSPC as OutError naming the path, the node kept;
1,3 is /dev/null's: written in place), a FIFO (its reader gets the bytes), a directory
(refused). Needs CAP_MKNOD for the device nodes."""
import os
import stat
import threading

import pytest

from omni4.outfile import OutError, OutFile, check_out


def node(path, minor):
    os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    return path


def test_a_file_is_replaced_with_its_permissions_and_nothing_left(tmp_path):
    p = tmp_path / "out.md"
    p.write_text("old")
    os.chmod(p, 0o640)
    with OutFile(p) as f:
        f.write("new")
    assert p.read_text() == "new"
    assert stat.S_IMODE(os.stat(p).st_mode) == 0o640
    assert os.listdir(tmp_path) == ["out.md"]


def test_an_error_inside_the_block_leaves_the_file_as_it_was(tmp_path):
    p = tmp_path / "out.md"
    p.write_text("old")
    with pytest.raises(RuntimeError):
        with OutFile(p) as f:
            f.write("half")
            raise RuntimeError("the conversion failed")
    assert p.read_text() == "old" and os.listdir(tmp_path) == ["out.md"]


def test_a_link_is_kept_and_its_target_replaced(tmp_path):
    (tmp_path / "configs").mkdir()
    target = tmp_path / "configs" / "report.md"
    target.write_text("old")
    link = tmp_path / "report.md"
    os.symlink("configs/report.md", link)
    with OutFile(link) as f:
        f.write("new")
    assert os.path.islink(link) and os.readlink(link) == "configs/report.md"
    assert target.read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["configs", "report.md"]
    assert os.listdir(tmp_path / "configs") == ["report.md"]


def test_a_full_device_fails_with_one_line_and_is_kept(tmp_path):
    full = node(str(tmp_path / "full"), 7)
    with pytest.raises(OutError) as e:
        with OutFile(full, binary=True) as f:
            f.write(b"x" * 100000)
    assert str(e.value) == f"{full}: No space left on device"
    st = os.lstat(full)
    assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 7)
    assert os.listdir(tmp_path) == ["full"]


def test_a_null_device_is_written_in_place(tmp_path):
    null = node(str(tmp_path / "null"), 3)
    out = OutFile(null)
    assert out.in_place
    out.write("x" * 10000)
    out.commit()
    assert stat.S_ISCHR(os.lstat(null).st_mode) and os.listdir(tmp_path) == ["null"]


def test_a_fifo_gives_its_reader_the_bytes(tmp_path):
    fifo = str(tmp_path / "fifo")
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()), daemon=True)
    reader.start()
    with OutFile(fifo, binary=True) as f:
        f.write(b"abc" * 50000)
    reader.join(30)
    assert got == [b"abc" * 50000]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_directory_is_refused(tmp_path):
    d = tmp_path / "out"
    d.mkdir()
    with pytest.raises(OutError, match=f"^{d}: Is a directory$"):
        OutFile(d)
    with pytest.raises(OutError, match="Is a directory"):
        check_out(d)
    assert os.listdir(d) == []
