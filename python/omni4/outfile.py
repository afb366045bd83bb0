"""A file the user named (--out, a report's files), written by what is there, as the C and C++
tools do (config/include/omni4/config/outfile.h):

- nothing, or a regular file: written to PATH.tmpPID beside it, fsync'd, renamed over it, the
  directory fsync'd; a crash leaves the old or the new complete file; an existing file's
  permissions (and, where allowed, owner) are kept;
- a symbolic link: resolved, its TARGET replaced as above; the link stays;
- a character device, FIFO or socket: written in place (opened for writing, never created or
  truncated), every write and the close checked: /dev/full fails with ENOSPC;
- a directory: refused.

    with OutFile(path) as f:        # OutError("PATH: reason") on any failure
        f.write(text)               # committed when the block ends without an exception

An exception inside the block removes the temporary and leaves the target as it was."""
import errno
import os
import stat

__all__ = ["OutError", "OutFile", "check_out"]


class OutError(Exception):
    """One line naming the path: "PATH: No space left on device"."""

    def __init__(self, path, reason):
        if isinstance(reason, OSError):
            reason = reason.strerror or str(reason)
        super().__init__(f"{path}: {reason}")


def _stat(path, target):
    try:
        return os.stat(target)
    except FileNotFoundError:
        return None
    except OSError as e:
        raise OutError(path, e) from None


def check_out(path):
    """Raises OutError if path could not be written (before a long computation): a directory,
    a missing or unwritable folder. A device or FIFO passes (it is opened when written)."""
    path = os.fspath(path)
    target = os.path.realpath(path)
    st = _stat(path, target)
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise OutError(path, os.strerror(errno.EISDIR))
    if st is not None and not stat.S_ISREG(st.st_mode):
        return
    folder = os.path.dirname(target) or "."
    if not os.path.isdir(folder):
        raise OutError(path, f"folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise OutError(path, f"cannot write in {folder}: {os.strerror(errno.EACCES)}")


class _Writes:
    """The file of a with block: its writes fail as OutError; the rest is the file's."""

    def __init__(self, out):
        self._out = out

    def write(self, data):
        return self._out.write(data)

    def __getattr__(self, name):
        return getattr(self._out.file, name)


class OutFile:
    """An output being written: .file (text, or bytes with binary=True); commit() or the end of
    a with block replaces the target (or finishes writing it in place); abort() or an exception
    leaves it as it was. in_place: a device or FIFO (not seekable)."""

    def __init__(self, path, binary=False, encoding="utf-8", newline=None, new_mode=0o666):
        self.path = os.fspath(path)
        self.target = os.path.realpath(self.path)
        self.tmp = None
        self._old = _stat(self.path, self.target)
        st = self._old
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise OutError(self.path, os.strerror(errno.EISDIR))
        self.in_place = st is not None and not stat.S_ISREG(st.st_mode)
        try:
            fd = self._open_in_place() if self.in_place else self._open_temporary(new_mode)
        except OSError as e:
            raise OutError(self.path, e) from None
        mode = "wb" if binary else "w"
        self.file = os.fdopen(fd, mode, **({} if binary else
                                            {"encoding": encoding, "newline": newline}))

    def _open_in_place(self):
        return os.open(self.target, os.O_WRONLY | os.O_NOCTTY | os.O_CLOEXEC)

    def _open_temporary(self, new_mode):
        self.tmp = f"{self.target}.tmp{os.getpid()}"
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        mode = 0o600 if self._old is not None else new_mode  # the umask applies to a new file
        try:
            return os.open(self.tmp, flags, mode)
        except FileExistsError:  # left by a crash
            os.unlink(self.tmp)
            return os.open(self.tmp, flags, mode)
        except OSError:
            self.tmp = None
            raise

    def write(self, data):
        """file.write, a failure as OutError naming the path (ENOSPC on /dev/full)."""
        try:
            return self.file.write(data)
        except OSError as e:
            raise OutError(self.path, e) from None

    def _finish(self):
        f, old = self.file, self._old
        f.flush()
        fd = f.fileno()
        if self.tmp and old is not None:
            try:
                os.fchown(fd, old.st_uid, old.st_gid)
            except OSError:
                pass  # only where allowed
            os.fchmod(fd, stat.S_IMODE(old.st_mode))
        if stat.S_ISREG(os.fstat(fd).st_mode):
            os.fsync(fd)
        f.close()

    def commit(self):
        try:
            self._finish()
        except OSError as e:
            self.abort()
            raise OutError(self.path, e) from None
        if not self.tmp:
            return
        try:
            os.replace(self.tmp, self.target)
        except OSError as e:
            self.abort()
            raise OutError(self.path, f"cannot replace: {e.strerror}") from None
        self.tmp = None
        try:
            dfd = os.open(os.path.dirname(self.target) or ".", os.O_RDONLY | os.O_DIRECTORY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError as e:
            raise OutError(self.path, f"directory sync failed: {e.strerror}") from None

    def abort(self):
        try:
            self.file.close()
        except OSError:
            pass  # the error is already being reported
        if self.tmp:
            try:
                os.unlink(self.tmp)
            except OSError:
                pass
            self.tmp = None

    def __enter__(self):
        return _Writes(self)

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.commit()
        else:
            self.abort()
        return False
