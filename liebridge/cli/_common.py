"""Shared pieces of the ``liebridge`` command: errors, argument parsing, array input and output."""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .._validate import FloatArray
from ..io.atomic import atomic_write, output_kind, refuse_same_file

__all__ = [
    "CLIError",
    "OneLineParser",
    "array_argument",
    "check_output_path",
    "convention_arg",
    "deprecated_alias",
    "format_matrix",
    "need_matplotlib",
    "positive_int",
    "save_figure",
    "save_npy",
    "say",
    "tangent_label",
]


class CLIError(Exception):
    """A user-facing error: printed as one line on stderr, exit status 2 (1 with ``status=1``)."""

    def __init__(self, message: str, status: int = 2) -> None:
        super().__init__(message)
        self.status = status


class OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line on stderr (exit status 2).

    It also enforces the options made required "in either spelling" by
    :func:`deprecated_alias` (argparse alone would demand the new spelling): such an option's
    default is a :class:`_Missing` marker, and a namespace still holding one is an error.
    """

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE (see 'PROG --help')`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")

    def parse_known_args(  # type: ignore[override]
        self, args: Any = None, namespace: Any = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """Parse, then require each option made required in either spelling."""
        ns, rest = super().parse_known_args(args, namespace)
        missing = [v for v in vars(ns).values() if isinstance(v, _Missing)]
        if missing:
            prog = missing[0].prog
            names = ", ".join(m.option for m in missing)
            self.exit(
                2,
                f"{prog}: error: the following arguments are required: {names} "
                f"(see '{prog} --help')\n",
            )
        return ns, rest


class _Missing:
    """The default of an option required in either of its spellings (see :class:`OneLineParser`)."""

    def __init__(self, option: str, prog: str) -> None:
        self.option, self.prog = option, prog

    def __repr__(self) -> str:
        return f"<{self.option} missing>"


class _DeprecatedAlias(argparse.Action):
    """An old spelling of an option: stores into the new option's ``dest``, with a warning."""

    def __init__(self, option_strings: list[str], dest: str, new: str = "", **kw: Any) -> None:
        self.new = new
        super().__init__(option_strings, dest, **kw)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        print(
            f"{parser.prog}: warning: {option_string} is deprecated (use {self.new}); "
            "it will be removed in the next release",
            file=sys.stderr,
        )
        setattr(namespace, self.dest, values)


def deprecated_alias(parser: argparse.ArgumentParser, new: argparse.Action, old: str) -> None:
    """Keep ``old`` working, for one release, as a deprecated spelling of the option ``new``.

    ``new`` is what ``parser.add_argument`` returned for the new spelling (a ``store`` option);
    ``old`` stores into the same ``dest`` with the same ``type``, ``choices`` and ``metavar``,
    is listed in ``--help`` as "(deprecated: use NEW)" and prints a one-line warning on stderr
    when used. A required ``new`` becomes "required in either spelling".
    """
    name = new.option_strings[-1]
    if new.required:
        new.required = False
        new.default = _Missing(name, parser.prog)
    kw: dict[str, Any] = {"choices": new.choices, "metavar": new.metavar}
    if new.type is not None:
        kw["type"] = new.type
    parser.add_argument(
        old,
        action=_DeprecatedAlias,
        new=name,
        dest=new.dest,
        default=argparse.SUPPRESS,
        help=f"(deprecated: use {name})",
        **kw,
    )


def one_line(text: str) -> str:
    """Collapse a (possibly multi-line) message into one line."""
    return re.sub(r"\s+", " ", text).strip()


def say(*parts: Any) -> None:
    """Progress on stderr (results go to stdout), flushed at once."""
    print(*parts, file=sys.stderr, flush=True)


#: Largest integer :func:`positive_int` accepts (what every binding's ``int`` holds).
MAX_INT = 2**31 - 1


def option_value(text: str) -> str:
    """Read a command-line option value as the API reads string options: stripped, lower case."""
    return text.strip().lower()


def positive_int(text: str) -> int:
    """``argparse`` type: an integer in ``[1, MAX_INT]``."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {n}")
    if n > MAX_INT:
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise argparse.ArgumentTypeError(f"expected a positive integer ≤ {MAX_INT}, got {shown}")
    return n


_NUMBER_SEPARATORS = re.compile(r"[\s,;\[\]()]+")


def _parse_numbers(text: str, what: str) -> FloatArray:
    out = []
    for tok in _NUMBER_SEPARATORS.split(text.strip()):
        if not tok:
            continue
        try:
            out.append(float(tok))
        except ValueError:
            raise CLIError(f"{what}: not a number: {tok!r}") from None
    if not out:
        raise CLIError(f"{what}: no numbers given")
    arr = np.asarray(out, dtype=np.float64)
    if not np.isfinite(arr).all():
        raise CLIError(f"{what}: contains NaN or Inf")
    return arr


_ARRAY_SUFFIXES = (".npy", ".txt", ".csv", ".dat")


def _is(path: Path, test: str) -> bool:
    """``path.is_file()`` / ``is_dir()`` that answers False for names the OS cannot hold.

    A command's own full-precision output pasted back is longer than 255 characters: the OS
    refuses it as a file name (``ENAMETOOLONG``), so it is numbers.
    """
    try:
        return bool(getattr(path, test)())
    except (OSError, ValueError):  # name too long, or an embedded NUL
        return False


def _load_npy(path: Path, text: str, what: str) -> Any:
    """``np.load`` after checking the header: real numbers, and no more data than the file holds.

    A header may promise any shape; ``np.load`` would try to allocate it.
    """
    with open(path, "rb") as fh:
        try:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        except (ValueError, SyntaxError, TypeError) as exc:
            raise CLIError(f"{what}: cannot read {text}: {one_line(str(exc))}") from None
        start = fh.tell()
    if dtype.kind == "c":
        raise CLIError(f"{what}: {text} holds complex numbers ({dtype}); expected real numbers")
    if dtype.kind not in "biuf":
        raise CLIError(f"{what}: {text} does not hold numbers (dtype {dtype})")
    need = int(np.prod(shape, dtype=object)) * dtype.itemsize
    have = path.stat().st_size - start
    if need > have:
        raise CLIError(
            f"{what}: {text}: its header promises shape {shape} ({need} bytes) but the file holds "
            f"{have} bytes of data"
        )
    return np.load(path, allow_pickle=False)


def check_connected(ids: list[int], edges: list[list[int]], gauge: list[int]) -> None:
    """Refuse a pose graph with a vertex that no path of edges ties to a gauge vertex.

    Such a vertex's pose and marginal are undetermined; GTSAM would fail deep inside (3-D) or
    return the initial value unchanged (2-D), so the command says which vertices, first.
    """
    neighbours: dict[int, list[int]] = {k: [] for k in ids}
    for i, j in edges:
        neighbours[i].append(j)
        neighbours[j].append(i)
    seen = set(gauge)
    stack = list(seen)
    while stack:
        for m in neighbours[stack.pop()]:
            if m not in seen:
                seen.add(m)
                stack.append(m)
    loose = [k for k in ids if k not in seen]
    if loose:
        shown = ", ".join(str(k) for k in loose[:5]) + (", ..." if len(loose) > 5 else "")
        raise CLIError(
            f"the graph is not connected: {len(loose)} vertices ({shown}) have no path of edges "
            f"to the gauge vertex {', '.join(str(k) for k in gauge)}; their poses and "
            "marginals are undetermined (add edges, or FIX one vertex of each part)"
        )


def npy_argument(text: str, what: str) -> FloatArray:
    """One real, finite array from a ``.npy`` file, its header checked before anything is read.

    Complex, non-numeric, pickled or truncated files, and headers promising more data than the
    file holds, are refused with a one-line error naming ``what`` and the file.
    """
    path = Path(text)
    if not _is(path, "is_file"):
        raise CLIError(f"{what}: no such file: {text}")
    try:
        arr = _load_npy(path, text, what)
    except (OSError, ValueError, EOFError, MemoryError) as exc:
        raise CLIError(f"{what}: cannot read {text} as .npy: {one_line(str(exc))}") from None
    arr = np.asarray(arr, dtype=np.float64)
    if not np.isfinite(arr).all():
        raise CLIError(f"{what}: {text} contains NaN or Inf")
    return arr


def array_argument(text: str, what: str) -> tuple[FloatArray, bool]:
    """Numbers from an argument: a ``.npy`` or text file, or the numbers themselves.

    Returns the array and whether it came from a file (a file keeps its shape; numbers given
    on the command line are a flat vector).
    """
    path = Path(text)
    looks_like_file = text.lower().endswith(_ARRAY_SUFFIXES) or os.sep in text
    if _is(path, "is_file"):
        try:
            if text.lower().endswith(".npy"):
                arr = _load_npy(path, text, what)
            else:
                delim = "," if text.lower().endswith(".csv") else None
                arr = np.loadtxt(path, delimiter=delim, comments="#", ndmin=1)
        except (OSError, ValueError, MemoryError) as exc:
            raise CLIError(f"{what}: cannot read {text}: {one_line(str(exc))}") from None
        if np.asarray(arr).dtype.kind == "c":
            raise CLIError(f"{what}: {text} holds complex numbers; expected real numbers")
        if not np.issubdtype(np.asarray(arr).dtype, np.number):
            raise CLIError(f"{what}: {text} does not hold numbers (dtype {arr.dtype})")
        arr = np.asarray(arr, dtype=np.float64)
        if not np.isfinite(arr).all():
            raise CLIError(f"{what}: {text} contains NaN or Inf")
        return arr, True
    if looks_like_file or _is(path, "is_dir"):
        raise CLIError(f"{what}: no such file: {text}")
    return _parse_numbers(text, what), False


def check_output_path(
    text: str,
    what: str,
    suffixes: tuple[str, ...] | None = None,
    *,
    inputs: Iterable[str | os.PathLike[str] | None] = (),
) -> Path:
    """Fail early (before a long computation) if ``text`` cannot or must not be written.

    Refused: a missing directory, a directory, a block device or socket, an unsupported suffix,
    no write permission, and an output that is one of ``inputs`` (the
    same file by path, hard link or symbolic link, or a path inside an input directory).
    """
    path = Path(text)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        if path.is_dir():
            raise CLIError(f"{what}: {text!r} is a directory")
        raise CLIError(
            f"{what}: unsupported file type {path.suffix or '(none)'!r} "
            f"(expected one of {', '.join(suffixes)})"
        )
    try:
        kind = output_kind(path, what)
        refuse_same_file(path, inputs, what)
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    if kind == "through":  # a device or a FIFO: opening could block; ask instead
        if not os.access(path, os.W_OK):
            raise CLIError(f"{what}: cannot write {text!r}: permission denied")
        return path
    # really try (permissions, read-only file systems, /proc): append mode changes nothing
    existed = kind == "regular"
    try:
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise CLIError(f"{what}: cannot write {text!r}: {exc.strerror or exc}") from None
    if not existed:
        path.unlink(missing_ok=True)
    return path


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 110) -> None:
    """``fig.savefig`` through the one atomic-write helper (format from the suffix)."""
    fmt = Path(path).suffix.lower().lstrip(".") or "png"
    try:
        with atomic_write(path, "wb", name="--plot") as fh:
            fig.savefig(fh, format=fmt, dpi=dpi)
    except ValueError as exc:
        raise CLIError(str(exc)) from None


def save_npy(path: str | os.PathLike[str], array: Any, what: str) -> None:
    """``numpy.save`` through the one atomic-write helper."""
    try:
        with atomic_write(path, "wb", name=what) as fh:
            np.save(fh, array)
    except ValueError as exc:
        raise CLIError(str(exc)) from None


def need_matplotlib() -> Any:
    """Import ``matplotlib.pyplot`` with the Agg backend, or fail with the install hint."""
    try:
        import matplotlib
    except ImportError:
        raise CLIError(
            'plotting needs matplotlib, an optional extra: pip install ".[plot]" from the checkout'
        ) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def convention_arg(name: str, option: str) -> Any:
    """``liebridge.conventions.get(name)``, its error naming the command-line option."""
    from ..conventions import get

    try:
        return get(name)
    except ValueError as exc:
        raise CLIError(option + str(exc).removeprefix("convention")) from None


def tangent_label(conv: Any) -> str:
    """E.g. ``(v, ω), right X·Exp(d), se3``: what a 6-vector in ``conv`` means."""
    order = "(ω, v)" if conv.order == "rot_first" else "(v, ω)"
    side = "right X·Exp(d)" if conv.side == "right" else "left Exp(d)·X"
    return f"{order}, {side}, chart {conv.chart}, rotation {conv.rotation}"


def format_matrix(A: FloatArray, indent: str = "") -> str:
    """Rows of full-precision numbers (``repr``: reads back to the same double), aligned."""
    cells = [[repr(float(x)) for x in row] for row in np.atleast_2d(A)]
    width = max(len(c) for row in cells for c in row)
    return "\n".join(indent + " ".join(c.rjust(width) for c in row) for row in cells)
