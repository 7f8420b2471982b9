"""The ``windows_files`` fixture: Windows' file rules that Linux does not have, kept in this
process while a test runs, so that the code paths a lab's Windows laptop takes run here too.
Import it into a test module: ``from windows_rules import windows_files  # noqa: F401``.

* No ``fcntl`` (a Unix-only module, "Availability: Unix" in Python's documentation):
  ``cacas.store.db`` and ``cacas.store.recovery`` see ``fcntl = None``, as they do there, and
  ``recovery`` sees an ``msvcrt`` whose ``locking`` locks as Windows' does (:class:`Msvcrt`).
* A file that is open cannot be deleted, nor replaced or renamed: Python opens files on Windows
  without ``FILE_SHARE_DELETE``, so ``os.unlink`` / ``os.replace`` / ``os.rename`` of it fail with
  WinError 32, "The process cannot access the file because it is being used by another process"
  (a PermissionError). Kept for descriptors of ``os.open`` (the store's lock files); a file
  object of ``open()`` is not followed (the atomic writes close theirs before renaming), nor
  SQLite's own files.
* ``os.open`` of a folder fails (PermissionError: a folder cannot be opened as a file there), so
  the ``fsync`` of a folder and the policies folder's lock are skipped as they are on Windows.
* ``os.fsync`` of a descriptor opened read-only fails: it calls ``FlushFileBuffers``, which needs a
  handle that may write ("The file handle must have the GENERIC_WRITE access right", Microsoft's
  documentation), else EBADF.
* ``shutil.rmtree`` deletes entry by entry through paths (``_use_fd_functions`` off), as on Windows.
"""

import errno
import os
import shutil

import pytest

IN_USE = "The process cannot access the file because it is being used by another process"


class Msvcrt:
    """Windows' ``msvcrt.locking`` over Linux's ``flock``: an exclusive lock a descriptor holds until it
    unlocks or closes it, or its process ends, which another descriptor cannot take meanwhile (a
    non-blocking try fails with an OSError, as Windows' does)."""

    LK_UNLCK, LK_LOCK, LK_NBLCK, LK_RLCK, LK_NBRLCK = 0, 1, 2, 3, 4

    @staticmethod
    def locking(fd: int, mode: int, nbytes: int) -> None:
        import fcntl

        if mode == Msvcrt.LK_UNLCK:
            fcntl.flock(fd, fcntl.LOCK_UN)
            return
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (fcntl.LOCK_NB if mode in (Msvcrt.LK_NBLCK, Msvcrt.LK_NBRLCK) else 0))
        except BlockingIOError:
            raise PermissionError(errno.EACCES, "Permission denied") from None


@pytest.fixture
def windows_files(monkeypatch):
    """Windows' file rules in this process (module docstring)."""
    import tempfile

    from cacas.store import db, recovery

    monkeypatch.setattr(db, "fcntl", None)
    monkeypatch.setattr(recovery, "fcntl", None)
    monkeypatch.setattr(recovery, "msvcrt", Msvcrt, raising=False)
    monkeypatch.setattr(shutil, "_use_fd_functions", False)
    # as on Windows ("an alias for NamedTemporaryFile" on platforms that are neither POSIX nor Cygwin): Linux's
    # falls back to deleting its file while it is open
    monkeypatch.setattr(tempfile, "TemporaryFile", tempfile.NamedTemporaryFile)
    real = {name: getattr(os, name) for name in ("open", "unlink", "remove", "replace", "rename", "fsync")}
    opened: dict[int, tuple[int, int, int]] = {}  # descriptor -> (device, inode, os.open's flags)

    def live() -> dict[int, tuple[int, int, int]]:
        """The descriptors of os.open still open on the file they were opened on (one closed by a file
        object that took it over, or taken again by another file, is dropped)."""
        for fd, (dev, ino, _) in list(opened.items()):
            try:
                st = os.fstat(fd)
            except OSError:
                st = None
            if st is None or (st.st_dev, st.st_ino) != (dev, ino):
                del opened[fd]
        return opened

    def is_open(path, dir_fd=None) -> bool:
        try:
            st = os.stat(path, dir_fd=dir_fd, follow_symlinks=False)
        except OSError:
            return False
        return any((dev, ino) == (st.st_dev, st.st_ino) for dev, ino, _ in live().values())

    def open_(path, flags, mode=0o777, *, dir_fd=None):
        try:
            folder = os.path.isdir(path) if dir_fd is None else os.path.isdir(os.path.join(f"/proc/self/fd/{dir_fd}", path))
        except OSError:
            folder = False
        if folder:
            raise PermissionError(errno.EACCES, "Permission denied", os.fsdecode(path))
        fd = real["open"](path, flags, mode, dir_fd=dir_fd)
        st = os.fstat(fd)
        opened[fd] = (st.st_dev, st.st_ino, flags)
        return fd

    def refuse_if_open(name):
        def call(*paths, **kwargs):
            dir_fds = [kwargs.get("dir_fd")] if name in ("unlink", "remove") else \
                [kwargs.get("src_dir_fd"), kwargs.get("dst_dir_fd")]
            for path, dir_fd in zip(paths, dir_fds):
                if is_open(path, dir_fd):
                    raise PermissionError(errno.EACCES, IN_USE, os.fsdecode(path))
            return real[name](*paths, **kwargs)
        return call

    def fsync(fd):
        fd = fd if isinstance(fd, int) else fd.fileno()
        if fd in live() and opened[fd][2] & os.O_ACCMODE == os.O_RDONLY:
            raise OSError(errno.EBADF, "Bad file descriptor")
        return real["fsync"](fd)

    monkeypatch.setattr(os, "open", open_)
    for name in ("unlink", "remove", "replace", "rename"):
        monkeypatch.setattr(os, name, refuse_if_open(name))
    monkeypatch.setattr(os, "fsync", fsync)
    yield
