"""Shared pieces of the ``liebridge`` command: errors, argument parsing, array input and output."""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .._validate import FloatArray

__all__ = [
    "CLIError",
    "OneLineParser",
    "array_argument",
    "check_output_path",
    "convention_arg",
    "format_matrix",
    "need_matplotlib",
    "positive_int",
    "say",
    "tangent_label",
]


class CLIError(Exception):
    """A user-facing error: printed as one line on stderr, exit status 2 (1 with ``status=1``)."""

    def __init__(self, message: str, status: int = 2) -> None:
        super().__init__(message)
        self.status = status


class OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line on stderr (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE (see 'PROG --help')`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def one_line(text: str) -> str:
    """Collapse a (possibly multi-line) message into one line."""
    return re.sub(r"\s+", " ", text).strip()


def say(*parts: Any) -> None:
    """Progress on stderr (results go to stdout), flushed at once."""
    print(*parts, file=sys.stderr, flush=True)


def option_value(text: str) -> str:
    """Read a command-line option value as the API reads string options: stripped, lower case."""
    return text.strip().lower()


def positive_int(text: str) -> int:
    """``argparse`` type: an integer ≥ 1."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {n}")
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


def array_argument(text: str, what: str) -> tuple[FloatArray, bool]:
    """Numbers from an argument: a ``.npy`` or text file, or the numbers themselves.

    Returns the array and whether it came from a file (a file keeps its shape; numbers given
    on the command line are a flat vector).
    """
    path = Path(text)
    looks_like_file = text.lower().endswith(_ARRAY_SUFFIXES) or os.sep in text
    if path.is_file():
        try:
            if text.lower().endswith(".npy"):
                arr = np.load(path, allow_pickle=False)
            else:
                delim = "," if text.lower().endswith(".csv") else None
                arr = np.loadtxt(path, delimiter=delim, comments="#", ndmin=1)
        except (OSError, ValueError) as exc:
            raise CLIError(f"{what}: cannot read {text}: {one_line(str(exc))}") from None
        if not np.issubdtype(np.asarray(arr).dtype, np.number):
            raise CLIError(f"{what}: {text} does not hold numbers (dtype {arr.dtype})")
        arr = np.asarray(arr, dtype=np.float64)
        if not np.isfinite(arr).all():
            raise CLIError(f"{what}: {text} contains NaN or Inf")
        return arr, True
    if looks_like_file or path.is_dir():
        raise CLIError(f"{what}: no such file: {text}")
    return _parse_numbers(text, what), False


def check_output_path(text: str, what: str, suffixes: tuple[str, ...] | None = None) -> Path:
    """Fail early (before a long computation) if ``text`` cannot be written."""
    path = Path(text)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise CLIError(f"{what}: directory {str(parent)!r} does not exist")
    if path.is_dir():
        raise CLIError(f"{what}: {text!r} is a directory")
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise CLIError(
            f"{what}: unsupported file type {path.suffix or '(none)'!r} "
            f"(expected one of {', '.join(suffixes)})"
        )
    return path


def need_matplotlib() -> Any:
    """Import ``matplotlib.pyplot`` with the Agg backend, or fail with the install hint."""
    try:
        import matplotlib
    except ImportError:
        raise CLIError(
            'plotting needs matplotlib, an optional extra: pip install "liebridge[plot]"'
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
