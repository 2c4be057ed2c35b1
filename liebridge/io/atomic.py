"""Safe output files: one atomic-write helper for every writer, and the same-file refusal.

Every writer of liebridge (TUM, KITTI, EuRoC, g2o, bags, the command line's plots and arrays)
writes through :func:`atomic_write` (a file object) or :func:`atomic_path` (a temporary path, for
libraries that open the file themselves). What happens depends on what ``path`` is **now**:

=============================== ===========================================================
``path``                        what the writer does
=============================== ===========================================================
does not exist                  writes ``.NAME.XXXXXXXX.tmp`` beside it, renames it onto
                                ``path`` when complete (mode ``0o666`` minus the umask)
a regular file                  the same, keeping the file's permission bits; the rename
                                replaces the directory entry, so a **hard link** to the file
                                elsewhere keeps the old contents (never written through)
a symbolic link                 followed: the file it points to is replaced as above, the link
                                stays a link (a dangling link: its target is created)
a FIFO or a character device    written **through** (``/dev/null``, ``/dev/stdout``, a pipe
                                with a reader), as a shell redirection would; nothing is ever
                                renamed onto them. A FIFO without a reader is refused (opening
                                it would block forever)
a directory, a block device,    refused (``ValueError``)
a socket
an int (file descriptor)        written through and left open for the caller
=============================== ===========================================================

A failure (an exception inside the ``with`` block) removes the temporary and leaves ``path`` as
it was. :func:`refuse_same_file` refuses an output that is one of the command's inputs — by
path, by a hard link or through a symbolic link (same device and inode), or inside an input
directory (a ROS 2 bag) — before any work is done.
"""

from __future__ import annotations

import errno
import io
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO, Any, Literal, cast

__all__ = ["atomic_path", "atomic_write", "output_kind", "refuse_same_file", "same_file"]

PathLike = str | os.PathLike[str]
OutputKind = Literal["new", "regular", "through"]


def _fspath(path: Any, name: str) -> str:
    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{name}: expected a path, got {type(path).__name__}")
    text = os.fspath(path)
    if not isinstance(text, str) or not text:
        raise ValueError(f"{name}: expected a non-empty path, got {path!r}")
    return text


def output_kind(path: PathLike, name: str = "path") -> OutputKind:
    """Classify an output path: ``"new"``, ``"regular"`` (a file or a link to one), ``"through"``.

    ``"through"`` is a FIFO or a character device (written directly). Raises ``ValueError`` for a
    directory, a block device or a socket, and when the directory that would hold a new file
    does not exist.
    """
    p = _fspath(path, name)
    try:
        st = os.stat(p)  # follows symbolic links
    except FileNotFoundError:
        parent = os.path.dirname(os.path.abspath(os.path.realpath(p)))
        if not os.path.isdir(parent):
            raise ValueError(f"{name}: directory {parent!r} does not exist") from None
        return "new"
    mode = st.st_mode
    if stat.S_ISREG(mode):
        return "regular"
    if stat.S_ISFIFO(mode) or stat.S_ISCHR(mode):
        return "through"
    kind = (
        "a directory"
        if stat.S_ISDIR(mode)
        else "a block device"
        if stat.S_ISBLK(mode)
        else "a socket"
        if stat.S_ISSOCK(mode)
        else "not a regular file"
    )
    raise ValueError(f"{name}: {p!r} is {kind}; write to a file path")


def _open_through(p: str, binary: bool, name: str) -> IO[Any]:
    """Open a FIFO or character device for writing, never blocking on a FIFO without a reader."""
    try:
        fd = os.open(p, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise ValueError(f"{name}: {p!r} is a FIFO with no reader; nothing written") from None
        raise
    try:
        flags = os.get_blocking(fd)
        if not flags:
            os.set_blocking(fd, True)
    except OSError:  # pragma: no cover - a descriptor that cannot change mode: use it as it is
        pass
    if binary:
        return cast(IO[Any], _Stream(open(fd, "wb")))
    return open(fd, "w", encoding="utf-8", newline="")


class _Stream(io.BufferedIOBase):
    """A binary stream that does not claim to be a seekable OS file.

    ``numpy.save`` writes a real file object with ``ndarray.tofile``, which needs the file
    position: a FIFO has none. Through this wrapper it writes the bytes instead.
    """

    def __init__(self, raw: IO[bytes]) -> None:
        super().__init__()
        self._raw = raw

    def writable(self) -> bool:
        return True

    def write(self, b: Any) -> int:
        return self._raw.write(b)

    def flush(self) -> None:
        self._raw.flush()

    def close(self) -> None:
        if not self.closed:
            try:
                super().close()  # flushes through self.flush while the raw file is open
            finally:
                self._raw.close()


@contextmanager
def atomic_write(
    path: PathLike | int, mode: Literal["w", "wb"] = "w", *, name: str = "path"
) -> Iterator[IO[Any]]:
    """Open ``path`` for writing so that it is replaced whole or not at all.

    Parameters
    ----------
    path : str, os.PathLike or int
        See the module docstring for what each kind of path gets. An int is a file descriptor,
        written through and left open.
    mode : {"w", "wb"}
        Text (UTF-8, line ends as written) or binary.
    name : str
        The argument's name in error messages.

    Yields
    ------
    file object
        Write to it inside the ``with`` block; the rename happens when the block ends without an
        exception.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode: expected 'w' or 'wb', got {mode!r}")
    binary = mode == "wb"
    if isinstance(path, bool):
        raise TypeError(f"{name}: expected a path or a file descriptor, got {path!r}")
    if isinstance(path, int):
        if binary:
            with open(path, "wb", closefd=False) as fb:
                yield fb
        else:
            with open(path, "w", encoding="utf-8", newline="", closefd=False) as ft:
                yield ft
        return
    with atomic_path(path, name=name) as tmp:
        if tmp is None:  # a FIFO or a character device: written through
            p = _fspath(path, name)
            with _open_through(p, binary, name) as fh:
                yield fh
            return
        if binary:
            with open(tmp, "wb") as fb:
                yield fb
        else:
            with open(tmp, "w", encoding="utf-8", newline="") as ft:
                yield ft


@contextmanager
def atomic_path(
    path: PathLike, *, name: str = "path", directory: bool = False
) -> Iterator[Path | None]:
    """Yield a temporary path beside ``path``, renamed onto ``path`` when the block succeeds.

    For libraries that open the output themselves (``rosbags``' writers, ``matplotlib``'s
    ``savefig``, ``numpy.save``). Yields ``None`` when ``path`` is a FIFO or a character device:
    the caller then writes ``path`` directly (nothing may be renamed onto it; see
    :func:`atomic_write`, which does that for a file object).

    Parameters
    ----------
    path : str or os.PathLike
    name : str
        The argument's name in error messages.
    directory : bool
        The writer makes a directory (a ROS 2 bag) at the yielded path: ``path`` must not exist
        (a bag directory is never replaced).
    """
    p = _fspath(path, name)
    kind = output_kind(p, name)
    if kind == "through":
        if directory:
            raise ValueError(f"{name}: {p!r} is not a directory path (a FIFO or a device)")
        yield None
        return
    target = os.path.realpath(p)  # a symbolic link: replace the file it points to
    parent = os.path.dirname(target)
    base = os.path.basename(target)
    tmpdir = tempfile.mkdtemp(prefix=f".{base}.", suffix=".tmp", dir=parent)
    tmp = Path(tmpdir) / base
    try:
        yield tmp
        if not tmp.exists():
            raise ValueError(f"{name}: the writer produced nothing at {p!r}")
        if tmp.is_dir():
            if os.path.lexists(target):
                raise ValueError(f"{name}: {p!r} exists already; a directory is not replaced")
            os.rename(tmp, target)
            return
        if output_kind(p, name) == "regular":  # re-checked: what is there now is replaced
            with suppress(OSError):
                shutil.copymode(target, tmp)
        os.replace(tmp, target)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` are the same file (one inode: the path, a hard link or a symlink)."""
    try:
        sa, sb = os.stat(a), os.stat(b)
    except (OSError, ValueError):
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def refuse_same_file(
    output: PathLike, inputs: Iterable[PathLike | None], name: str = "output"
) -> None:
    """Raise ``ValueError`` if ``output`` is one of ``inputs`` or lies inside an input directory.

    The same file is detected by device and inode, so a hard link or a symbolic link to an input
    is caught as well as the input's own path; an output inside an input directory (a ROS 2 bag
    directory) is refused too. Inputs that do not exist, and ``None``, are skipped.
    """
    out = _fspath(output, name)
    out_real = os.path.realpath(out)
    for inp in inputs:
        if inp is None:
            continue
        i = os.fspath(inp)
        if not isinstance(i, str) or not os.path.exists(i):
            continue
        if same_file(out, i) or out_real == os.path.realpath(i):
            raise ValueError(
                f"{name} is the input file: {out!r} is {i!r} (the same file, a hard link or a "
                "symbolic link to it); write to another path"
            )
        if os.path.isdir(i):
            root = os.path.realpath(i)
            if os.path.commonpath([root, out_real]) == root:
                raise ValueError(
                    f"{name}: {out!r} lies inside the input directory {i!r}; write elsewhere"
                )
