"""``liebridge conventions verify``: every preset run against the user's installed libraries.

One row per (preset, library call): library, version, worst relative error against the preset,
the preset detected from the library's own update, and the verdict. Libraries that are not
installed are never imported.
"""

from __future__ import annotations

import json
import math
import sys

from ..conventions.verification import VerifyRow, verify

__all__ = ["render", "run"]

HEAD = ("preset", "library", "version", "worst_error", "detected", "verdict")


def _cell(r: VerifyRow, k: str) -> str:
    v = getattr(r, k)
    if v is None:
        return "-"
    if k == "worst_error":
        return "nan" if math.isnan(v) else f"{v:.1e}"
    return str(v)


def render(rows: list[VerifyRow], fmt: str = "table") -> str:
    """Rows as an aligned text table, a Markdown table or JSON (a list of objects)."""
    if fmt == "json":
        return json.dumps([r.as_dict() for r in rows], indent=2, ensure_ascii=False)
    cells = [list(HEAD)] + [[_cell(r, k) for k in HEAD] for r in rows]
    if fmt == "markdown":
        lines = ["| " + " | ".join(HEAD) + " |", "|" + "|".join("---" for _ in HEAD) + "|"]
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in cells[1:]]
        return "\n".join(lines)
    widths = [max(len(row[i]) for row in cells) for i in range(len(HEAD) - 1)]
    lines = []
    for row in cells:
        lines.append("  ".join([*(c.ljust(w) for c, w in zip(row, widths, strict=False)), row[-1]]))
    lines.insert(1, "  ".join(["-" * w for w in widths] + ["-------"]))
    agree = sum(r.verdict.startswith("agrees") for r in rows)
    differ = sum(r.verdict.startswith("DIFFERS") for r in rows)
    missing = sum(r.verdict.startswith("not installed") for r in rows)
    lines.append(
        f"{agree} agree, {differ} differ, {missing} not installed, "
        f"{len(rows) - agree - differ - missing} not runnable"
    )
    return "\n".join(lines)


def run(fmt: str, libraries: list[str] | None = None) -> int:
    """Measure and print (progress on stderr when it is a terminal); exit status 0."""
    tty = sys.stderr.isatty()

    def progress(what: str) -> None:
        if tty:
            print(f"\rmeasuring {what:<48}", end="", file=sys.stderr, flush=True)

    rows = verify(libraries, progress=progress)
    if tty:
        print("\r" + " " * 60 + "\r", end="", file=sys.stderr, flush=True)
    print(render(rows, fmt))
    return 0
