"""Files at the edges: reading regular files with a size cap, writing outputs atomically.

Two rules every command follows:

* **Reading** (:func:`read_regular`): only a regular file is read (a FIFO, a device such as
  ``/dev/zero``, a directory or a socket is refused before it is opened for reading, so the call
  never blocks), and the size cap applies to the read itself (a file that grows while being read
  is refused too).
* **Writing** (:func:`atomic_output`, :func:`write_text`): an output never replaces one of the
  command's inputs (compared by resolved path and by inode, so a symlink or a hard link to the
  model is caught), goes to a temporary file in the target's directory first and is renamed over
  the target only when complete. A missing directory, a directory as target, a read-only place or
  a full disk raise :class:`OutputError` (exit status 2) and leave any old file untouched.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..errors import LoopsolveError

__all__ = ["OutputError", "read_regular", "atomic_output", "write_text"]


class OutputError(LoopsolveError, OSError):
    """An output file cannot be written (exit status 2); any old file at the target is intact."""

    exit_code = 2


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ENOSPC:
        return "no space left on the device"
    if exc.errno == errno.EDQUOT:
        return "disk quota exceeded"
    if exc.errno == errno.EFBIG:
        return "file too large for this place"
    return exc.strerror or str(exc)


def read_capped(fd: int, limit: int) -> bytes | None:
    """Read an open file descriptor to its end, or ``None`` as soon as it holds more than ``limit`` bytes.

    The cap applies to the read itself (a file that grows after its ``fstat`` is still bounded).

    Examples
    --------
    >>> import os
    >>> from loopsolve.model.files import read_capped
    >>> fd = os.open(ls.models_dir() / "thesis_crank_rocker.toml", os.O_RDONLY)
    >>> read_capped(fd, 10) is None, os.close(fd)
    (True, None)
    """
    chunks, total = [], 0
    while True:
        chunk = os.read(fd, min(1 << 16, limit + 1 - total))
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)
        total += len(chunk)
        if total > limit:
            return None


def read_regular(path: str | os.PathLike, limit: int, *, what: str = "file") -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them.

    Raises :class:`FileNotFoundError`, :class:`IsADirectoryError` or :class:`ValueError` (not a
    regular file, or larger than ``limit``) with a one-line message; never blocks on a FIFO.

    Examples
    --------
    >>> from loopsolve.model.files import read_regular
    >>> len(read_regular(ls.models_dir() / "thesis_crank_rocker.toml", 1 << 20)) > 100
    True
    >>> read_regular("/dev/null", 100)
    Traceback (most recent call last):
    ...
    ValueError: /dev/null: not a regular file (a character device)
    """
    name = os.fspath(path)
    st = os.stat(name)  # follows symlinks: a link to a regular file is fine
    if stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(errno.EISDIR, "is a directory", name)
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{name}: not a regular file ({_kind(st.st_mode)})")
    if st.st_size > limit:
        raise ValueError(f"{name}: {st.st_size} bytes is too large for a {what} (limit {limit})")
    # O_NONBLOCK: should the file have been swapped for a FIFO since the stat, open does not wait
    fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{name}: not a regular file ({_kind(st.st_mode)})")
        data = read_capped(fd, limit)
        if data is None:
            raise ValueError(f"{name}: more than {limit} bytes is too large for a {what}")
        return data
    finally:
        os.close(fd)


def _kind(mode: int) -> str:
    for test, text in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symlink")):
        if test(mode):
            return text
    return "a special file"


def _same_file(a: Path, b: Path) -> bool:
    try:
        if os.path.realpath(a) == os.path.realpath(b):
            return True
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_target(path: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Refuse, before any work, an output ``path`` that is an input or cannot be a file.

    Returns the path. Raises :class:`OutputError`.
    """
    target = Path(path)
    name = os.fspath(path)
    if not name:
        raise OutputError("the output file name is empty")
    for inp in inputs:
        if inp is not None and _same_file(target, Path(inp)):
            raise OutputError(f"refusing to write the output to {name!r}: it is the input file "
                              f"{os.fspath(inp)!r}; choose another -o")
    if target.is_dir():
        raise OutputError(f"cannot write {name!r}: it is a directory")
    parent = target.parent
    if not parent.is_dir():
        raise OutputError(f"cannot write {name!r}: the directory {os.fspath(parent)!r} does not exist")
    if target.exists() and not target.is_file() and not _is_char_device(target):
        raise OutputError(f"cannot write {name!r}: it is not a regular file (use -o - for standard output)")
    return target


def _is_char_device(p: Path) -> bool:
    """A character device such as /dev/null: written in place (there is nothing to replace atomically)."""
    try:
        return stat.S_ISCHR(os.stat(p).st_mode)
    except OSError:
        return False


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Iterator[Path]:
    """Write an output through a temporary file in the target's directory, renamed on success.

    Yields the temporary path (with the target's suffix, so writers that choose the format
    by extension work). On any exception inside the block the temporary file is removed and the
    target is left as it was. ``inputs`` are files the output must not replace.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from loopsolve.model.files import atomic_output
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "table.txt"
    >>> with atomic_output(out) as tmp:
    ...     _ = tmp.write_text("theta4 = 80.72\\n", encoding="utf-8")
    >>> out.read_text(encoding="utf-8")
    'theta4 = 80.72\\n'
    """
    target = check_target(path, inputs)
    name = os.fspath(path)
    if _is_char_device(target):  # -o /dev/null: write straight to the device
        try:
            yield target
        except OutputError:
            raise
        except OSError as exc:
            raise OutputError(f"cannot write {name!r}: {_reason(exc)}") from None
        return
    try:
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name[:40]}.", suffix=".part" + target.suffix)
    except OSError as exc:
        raise OutputError(f"cannot write {name!r}: {_reason(exc)}") from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        try:
            yield tmp_path
            if tmp_path.exists():
                _fsync(tmp_path)
                mode = 0o666 & ~_umask()
                if target.exists():
                    with contextlib.suppress(OSError):
                        mode = stat.S_IMODE(os.stat(target).st_mode)
                with contextlib.suppress(OSError):
                    os.chmod(tmp_path, mode)
            os.replace(tmp_path, target)
        except OSError as exc:
            raise OutputError(f"cannot write {name!r}: {_reason(exc)}") from None
    finally:
        with contextlib.suppress(OSError):
            tmp_path.unlink()


def _fsync(p: Path) -> None:
    fd = os.open(p, os.O_RDONLY)
    try:
        os.fsync(fd)
    except OSError as exc:  # ENOSPC can surface only here on some file systems
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO):
            raise
    finally:
        os.close(fd)


def _umask() -> int:
    old = os.umask(0o022)
    os.umask(old)
    return old


def write_text(path: str | os.PathLike, text: str | Iterable[str], inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Write ``text`` (a string or an iterable of chunks, streamed) as UTF-8, atomically.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from loopsolve.model.files import write_text
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "rows.csv"
    >>> _ = write_text(out, ["a,b\\n", "1,2\\n"])
    >>> out.read_text(encoding="utf-8")
    'a,b\\n1,2\\n'
    """
    with atomic_output(path, inputs) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                if isinstance(text, str):
                    f.write(text)
                else:
                    for chunk in text:
                        f.write(chunk)
        except OSError as exc:
            raise OutputError(f"cannot write {os.fspath(path)!r}: {_reason(exc)}") from None
    return Path(path)
