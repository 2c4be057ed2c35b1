"""``liebridge conventions``: the presets as a table (text, Markdown or JSON).

The README's conventions table is this module's Markdown output, verbatim (a test compares them):
one source of truth, the presets themselves.
"""

from __future__ import annotations

import argparse
import json
import re
from typing import Any

from ..conventions import PRESETS, Convention
from ._common import option_value

__all__ = ["add_parser", "evidence_summary", "render", "rows"]

COLUMNS = ("name", "side", "order", "chart", "rotation", "quat", "evidence")
EVIDENCE_CODES = {"V": "verified by running it", "S": "source", "D": "documentation"}
#: Longest evidence cell in the tables (the JSON keeps the full ``source``).
EVIDENCE_WIDTH = 76

LEGEND = (
    "side: `right` = X·Exp(d), `left` = Exp(d)·X. order: `rot_first` = (ω, v), "
    "`trans_first` = (v, ω). chart: `se3` = SE(3) exponential, `so3xr3_body`/`so3xr3_world` = "
    "rotation and translation perturbed separately, translation increment in the body "
    "(t + R·u) or world (t + u) frame. rotation: `exp` = rotation vector, `half_exp` = half "
    "angle (Ceres), `quat_vec` = quaternion vector part (g2o), `cayley` = Cayley. quat: storage "
    "order. Evidence: V = checked by running the library, S = read in its source, "
    "D = documentation; full sources and notes: `liebridge conventions --format json`."
)


def _strip_parentheticals(text: str) -> str:
    """Drop ``(...)`` asides, except versions like ``(Ceres 2.2.0)``."""

    def keep_versions(m: re.Match[str]) -> str:
        return m.group(0) if re.search(r"\d\.\d", m.group(1)) else ""

    prev = None
    while prev != text:
        prev = text
        text = re.sub(r"\s*\(([^()]*)\)", keep_versions, text)
    return text


def evidence_summary(source: str, width: int = EVIDENCE_WIDTH) -> str:
    """Abbreviate a preset's ``source``: each ``V``/``S``/``D`` claim's first item, no asides."""
    parts = []
    for segment in source.split("; "):
        code, _, text = segment.partition(" ")
        if code not in EVIDENCE_CODES or not text:
            continue  # e.g. a test file path: the JSON has it
        text = _strip_parentheticals(text).split(":")[0].split(",")[0].strip()
        parts.append(f"{code} {text}")
    out = "; ".join(parts)
    return out if len(out) <= width else out[: width - 1].rstrip() + "…"


def _row(c: Convention) -> dict[str, str]:
    return {
        "name": c.name,
        "side": c.side,
        "order": c.order,
        "chart": c.chart,
        "rotation": c.rotation,
        "quat": c.quat_order,
        "evidence": evidence_summary(c.source),
    }


def rows() -> list[dict[str, str]]:
    """One abbreviated row per preset, in registry order."""
    return [_row(c) for c in PRESETS]


def _as_dict(c: Convention) -> dict[str, Any]:
    return {
        "name": c.name,
        "side": c.side,
        "order": c.order,
        "chart": c.chart,
        "rotation": c.rotation,
        "quat_order": c.quat_order,
        "source": c.source,
        "notes": c.notes,
        "evidence": evidence_summary(c.source),
    }


def _json() -> str:
    return json.dumps([_as_dict(c) for c in PRESETS], indent=2, ensure_ascii=False)


def _markdown() -> str:
    lines = [
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "|".join("---" for _ in COLUMNS) + "|",
    ]
    for r in rows():
        cells = [f"`{r[k]}`" if k != "evidence" else r[k].replace("|", "\\|") for k in COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join([*lines, "", LEGEND])


def _text() -> str:
    table = [dict(zip(COLUMNS, COLUMNS, strict=True)), *rows()]
    widths = {k: max(len(r[k]) for r in table) for k in COLUMNS}
    lines = ["  ".join(r[k].ljust(widths[k]) for k in COLUMNS).rstrip() for r in table]
    lines.insert(1, "  ".join("-" * widths[k] for k in COLUMNS))
    return "\n".join(lines)


def render(fmt: str = "table") -> str:
    """Render the presets as ``"table"`` (aligned text), ``"markdown"`` or ``"json"``."""
    if fmt == "table":
        return _text()
    if fmt == "markdown":
        return _markdown()
    if fmt == "json":
        return _json()
    raise ValueError(f"format: expected 'table', 'markdown' or 'json', got {fmt!r}")


def _markdown_one(c: Convention) -> str:
    """One preset as markdown: its table row (the README's columns) and its full text."""
    row = next(r for r in rows() if r["name"] == c.name)
    cells = [f"`{row[k]}`" if k != "evidence" else row[k].replace("|", "\\|") for k in COLUMNS]
    text = _describe_one(c).split("\n")
    matrix = [line for line in text[5:]]
    lines = [
        f"### `{c.name}`",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "|".join("---" for _ in COLUMNS) + "|",
        "| " + " | ".join(cells) + " |",
        "",
        *(f"- **{line.partition(': ')[0]}**: {line.partition(': ')[2]}" for line in text[1:5]),
    ]
    if matrix:
        lines += ["", "```text", *matrix, "```"]
    return "\n".join(lines)


def _describe_one(c: Convention) -> str:
    import numpy as np

    from ..conventions.convert import is_exactly_linear, tangent_map
    from ..lie import se3
    from ._common import tangent_label

    X = se3.exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8]))
    M = tangent_map(X, "gtsam", c)
    lines = [
        c.describe(),
        f"tangent: {tangent_label(c)}",
        f"source: {c.source}",
        f"notes: {c.notes}",
        "from GTSAM's tangent: "
        + ("exactly linear" if is_exactly_linear("gtsam", c) else "linear to first order only")
        + (
            "; at X = Exp(0.4, -0.7, 0.5, 1.5, -2, 0.8), d = M ξ with M ="
            if not np.allclose(M, np.eye(6))
            else "; M = I (same tangent)"
        ),
    ]
    if not np.allclose(M, np.eye(6)):
        lines.append(np.array2string(M, precision=4, suppress_small=True))
    return "\n".join(lines)


def _run(args: argparse.Namespace) -> int:
    if args.name:
        from ._common import convention_arg

        conv = convention_arg(args.name, "NAME")
        if args.format == "json":
            print(json.dumps(_as_dict(conv), indent=2, ensure_ascii=False))
        elif args.format == "markdown":
            print(_markdown_one(conv))
        else:
            print(_describe_one(conv))
        return 0
    print(render(args.format))
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge conventions``."""
    p = sub.add_parser(
        "conventions",
        help="list every preset: side, order, chart, rotation coordinates, quaternion order, "
        "evidence",
        description="List every convention preset with its side, tangent order, chart, rotation "
        "coordinates, quaternion storage order and evidence (V = checked by running the "
        "library, S = its source, D = documentation). With NAME, show one preset in full.",
    )
    p.add_argument(
        "name",
        nargs="?",
        metavar="NAME",
        help="show one preset in full (--format markdown: a table row and a list; json: as JSON)",
    )
    p.add_argument(
        "--format",
        type=option_value,
        choices=("table", "markdown", "json"),
        default="table",
        help="output format (default: table; markdown is the README's table; json has the "
        "full sources and notes)",
    )
    p.set_defaults(func=_run)
