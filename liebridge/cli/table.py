"""``liebridge conventions``: the presets as a table (text, Markdown or JSON).

The README's conventions table is this module's Markdown output, verbatim (a test compares them):
one source of truth, the presets themselves.
"""

from __future__ import annotations

import argparse
import json
import re
from typing import Any

from ..conventions import (
    ALL_PRESETS,
    GROUP_NAMES,
    PRESETS,
    STATE_PRESETS,
    Bundle,
    Chart,
    Convention,
    NavChart,
)
from ..conventions.convention import DEFAULT_GROUP
from ..lie import group as lie_group
from ._common import option_value

__all__ = ["add_parser", "evidence_summary", "render", "rows"]

COLUMNS = ("name", "side", "order", "chart", "rotation", "quat", "evidence")
EVIDENCE_CODES = {
    "V": "verified by running it",
    "S": "source",
    "D": "documentation",
    "N": "why it is not run here",
}
#: Longest evidence cell in the tables (the JSON keeps the full ``source``).
EVIDENCE_WIDTH = 76

LEGEND = (
    "side: `right` = X·Exp(d), `left` = Exp(d)·X. order: `rot_first` = (ω, v), "
    "`trans_first` = (v, ω). chart: `se3` = SE(3) exponential, `so3xr3_body`/`so3xr3_world` = "
    "rotation and translation perturbed separately, translation increment in the body "
    "(t + R·u) or world (t + u) frame. rotation: `exp` = rotation vector, `half_exp` = half "
    "angle (Ceres), `quat_vec` = quaternion vector part (g2o), `cayley` = Cayley. quat: storage "
    "order. Evidence: V = checked by running the library (the version measured; "
    "`liebridge conventions verify` re-measures your installed versions), S = read in its "
    "source, D = documentation, N = why no library runs it here; full sources and notes: "
    "`liebridge conventions --format json`."
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
        if code == "N":  # the reason, whole (no file to shorten)
            parts.append(f"N {_strip_parentheticals(text).strip()}")
            continue
        text = _strip_parentheticals(text).split(":")[0].split(",")[0].strip()
        parts.append(f"{code} {text}")
    out = "; ".join(parts)
    return out if len(out) <= width else out[: width - 1].rstrip() + "…"


def _row(c: Chart) -> dict[str, str]:
    """Return a preset's row (a navigation chart: its pose convention's fields, ``+v_<frame>``)."""
    if isinstance(c, NavChart):
        p = c.pose
        chart = f"{p.chart}+v_{c.velocity}"
        p_fields = (p.side, p.order, chart, p.rotation, p.quat_order)
    else:
        assert isinstance(c, Convention)
        p_fields = (c.side, c.order, c.chart, c.rotation, c.quat_order)
    side, order, chart, rotation, quat = p_fields
    return {
        "name": c.name,
        "side": side,
        "order": order,
        "chart": chart,
        "rotation": rotation,
        "quat": quat,
        "evidence": evidence_summary(c.source),
    }


#: Section titles of ``--group all``, in this order (SE(3) first: its presets also take SO(3)).
GROUP_LEGEND = (
    "Tangent orders per group: SE(2) `rot_first` = (ω, x, y), `trans_first` = (x, y, ω) "
    "(GTSAM's); Sim(3) `rot_first` = (ω, u, λ) (GTSAM's), `trans_first` = (u, ω, λ), log-scale "
    "last; SE₂(3) `rot_first` = (ω, p, v) (GTSAM's), `trans_first` = (p, v, ω). chart: the "
    "group's name = its exponential; `split_body`/`split_world` = blocks perturbed separately, "
    "vector increments in the body (t + A·u) or world (t + u) frame. `ros_pose2` embeds "
    "(x, y, yaw) at entries (0, 1, 5) of ROS's 6-vector."
)


def _presets(group: str | None) -> tuple[Convention, ...]:
    if group is None:
        return PRESETS
    if group == "all":
        return ALL_PRESETS
    return tuple(c for c in ALL_PRESETS if c.group == group)


def rows(group: str | None = None) -> list[dict[str, str]]:
    """One abbreviated row per preset, in registry order (SE(3)'s by default; ``"all"``)."""
    return [_row(c) for c in _presets(group)]


def _as_dict(c: Chart) -> dict[str, Any]:
    if isinstance(c, Bundle):  # a whole state: its blocks and tangent order, not one chart
        return {
            "group": c.group,
            "name": c.name,
            "blocks": {
                n: (b.describe() if isinstance(b, Convention) else b.group) for n, b in c.blocks
            },
            "tangent_order": list(c.perm) if c.perm is not None else list(range(c.dim())),
            "source": c.source,
            "notes": c.notes,
            "evidence": evidence_summary(c.source),
        }
    out: dict[str, Any] = {} if c.group == DEFAULT_GROUP else {"group": c.group}
    if isinstance(c, NavChart):
        out |= {"pose": c.pose.describe(), "velocity": c.velocity}
    row = _row(c)
    if isinstance(c, Convention) and c.stores != "pose":
        out["stores"] = c.stores  # the library holds the inverse of liebridge's element
    return out | {
        "name": c.name,
        "side": row["side"],
        "order": row["order"],
        "chart": row["chart"],
        "rotation": row["rotation"],
        "quat_order": row["quat"],
        "source": c.source,
        "notes": c.notes,
        "evidence": evidence_summary(c.source),
    }


def _json(group: str | None = None) -> str:
    return json.dumps([_as_dict(c) for c in _presets(group)], indent=2, ensure_ascii=False)


def _markdown_rows(group: str | None) -> list[str]:
    lines = [
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "|".join("---" for _ in COLUMNS) + "|",
    ]
    for r in rows(group):
        cells = [f"`{r[k]}`" if k != "evidence" else r[k].replace("|", "\\|") for k in COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _group_title(group: str) -> str:
    """Return a group's table heading from its record (``"SE₂(3) (extended pose / ...)"``)."""
    rec = lie_group(group)
    return f"{rec.label} ({rec.note})" if rec.note else rec.label


def _markdown(group: str | None = None) -> str:
    if group != "all":
        legend = LEGEND if group in (None, DEFAULT_GROUP) else GROUP_LEGEND
        return "\n".join([*_markdown_rows(group), "", legend])
    out: list[str] = []
    for g in dict.fromkeys(c.group for c in ALL_PRESETS):  # in registry order
        out += [f"#### {_group_title(g)}", "", *_markdown_rows(g), ""]
    return "\n".join([*out, LEGEND, "", GROUP_LEGEND, "", _states_line()])


def _states_line() -> str:
    """List the whole-state presets (bundles of several blocks; ``mola``: an SE₂(3) chart)."""
    names = ", ".join(f"{c.name} ({c.dim()})" for c in STATE_PRESETS)
    return f"Whole IMU states (`liebridge conventions NAME`: blocks, order, sources): {names}."


def _text_rows(group: str | None) -> list[str]:
    table = [dict(zip(COLUMNS, COLUMNS, strict=True)), *rows(group)]
    widths = {k: max(len(r[k]) for r in table) for k in COLUMNS}
    lines = ["  ".join(r[k].ljust(widths[k]) for k in COLUMNS).rstrip() for r in table]
    lines.insert(1, "  ".join("-" * widths[k] for k in COLUMNS))
    return lines


def _text(group: str | None = None) -> str:
    if group != "all":
        return "\n".join(_text_rows(group))
    out: list[str] = []
    for g in dict.fromkeys(c.group for c in ALL_PRESETS):  # in registry order
        out += [_group_title(g), *_text_rows(g), ""]
    return "\n".join([*out, _states_line()]).rstrip()


def render(fmt: str = "table", group: str | None = None) -> str:
    """Render the presets as ``"table"`` (aligned text), ``"markdown"`` or ``"json"``.

    ``group``: ``None`` (the SE(3)/SO(3) presets, as before groups existed), one of
    ``so2, se2, so3, se3, sim3, se23``, or ``"all"`` (every preset, one section per group).
    """
    if group is not None and group != "all" and group not in GROUP_NAMES:
        raise ValueError(f"group: expected one of {GROUP_NAMES} or 'all', got {group!r}")
    if fmt == "table":
        return _text(group)
    if fmt == "markdown":
        return _markdown(group)
    if fmt == "json":
        return _json(group)
    raise ValueError(f"format: expected 'table', 'markdown' or 'json', got {fmt!r}")


def _markdown_one(c: Chart) -> str:
    """One preset as markdown: its table row (the README's columns) and its full text."""
    if isinstance(c, Bundle):  # whole states have no row in the one-chart table
        return "\n".join([f"### `{c.name}`", "", "```text", _describe_one(c), "```"])
    row = _row(c)  # any registered preset (rows() lists the SE(3) ones only)
    cells = [f"`{row[k]}`" if k != "evidence" else row[k].replace("|", "\\|") for k in COLUMNS]
    text = _describe_one(c).split("\n")
    # the header lines ("key: value") end where the printed matrix starts
    k = next((i for i, line in enumerate(text) if line.lstrip().startswith("[[")), len(text))
    matrix = text[k:]
    lines = [
        f"### `{c.name}`",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "|".join("---" for _ in COLUMNS) + "|",
        "| " + " | ".join(cells) + " |",
        "",
        *(f"- **{line.partition(': ')[0]}**: {line.partition(': ')[2]}" for line in text[1:k]),
    ]
    if matrix:
        lines += ["", "```text", *matrix, "```"]
    return "\n".join(lines)


def _describe_one(c: Chart) -> str:
    import numpy as np

    from ..conventions.convert import is_exactly_linear, tangent_map
    from ..lie import se3
    from ._common import tangent_label

    if isinstance(c, Bundle):
        return _describe_state(c)
    if c.group != DEFAULT_GROUP:
        return _describe_group(c)
    assert isinstance(c, Convention)
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


def _describe_state(c: Bundle) -> str:
    """Describe a whole-state preset: blocks, map from ``gtsam_combined`` at a generic state."""
    import numpy as np

    from ..conventions.convert import is_exactly_linear, tangent_map
    from ..lie import se23

    lines = [c.describe(), f"source: {c.source}", f"notes: {c.notes}"]
    if c.group == "bundle[se23,r3,r3]" and c.dim() == 15:
        X = c.assemble(
            nav=se23.exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8, -0.6, 1.1, 0.7])),
            b_a=np.array([0.1, -0.2, 0.05]),
            b_g=np.array([0.01, 0.0, -0.02]),
        )
        M = tangent_map(X, "gtsam_combined", c)
        lines += [
            "from gtsam_combined's tangent: "
            + (
                "exactly linear"
                if is_exactly_linear("gtsam_combined", c)
                else "linear to first order only"
            )
            + "; at a generic state, d = M ξ with M =",
            np.array2string(M, precision=3, suppress_small=True, max_line_width=200),
        ]
    return "\n".join(lines)


def _describe_group(c: Chart) -> str:
    import numpy as np

    from ..conventions.convert import is_exactly_linear, tangent_map
    from ..gtsam.build import gtsam_convention_of

    probe = c.record.probe  # the group's generic element
    ref = gtsam_convention_of(c.group).name
    M = tangent_map(probe, ref, c)
    lines = [
        c.describe(),
        f"source: {c.source}",
        f"notes: {c.notes}",
        f"from {ref}'s tangent: "
        + ("exactly linear" if is_exactly_linear(ref, c) else "linear to first order only")
        + "; at a generic element, d = M ξ with M =",
        np.array2string(M, precision=4, suppress_small=True),
    ]
    return "\n".join(lines)


def _run(args: argparse.Namespace) -> int:
    if args.name == "verify":  # not a preset name: measure the installed libraries
        from . import verify_cmd

        return verify_cmd.run(args.format)
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
    print(render(args.format, args.group))
    return 0


def add_parser(sub: Any) -> None:
    """Register ``liebridge conventions``."""
    p = sub.add_parser(
        "conventions",
        help="list every preset: side, order, chart, rotation coordinates, quaternion order, "
        "evidence",
        description="List every convention preset with its side, tangent order, chart, rotation "
        "coordinates, quaternion storage order and evidence (V = checked by running the "
        "library, S = its source, D = documentation). With NAME, show one preset in full. "
        "'liebridge conventions verify' runs every installed library's own update against its "
        "presets and prints one row per preset (never importing what is not installed).",
    )
    p.add_argument(
        "name",
        nargs="?",
        metavar="NAME",
        help="show one preset in full (--format markdown: a table row and a list; json: as JSON); "
        "'verify': run every installed library against its presets (library, version, worst "
        "error, detected preset, verdict)",
    )
    p.add_argument(
        "--format",
        type=option_value,
        choices=("table", "markdown", "json"),
        default="table",
        help="output format (default: table; markdown is the README's table; json has the "
        "full sources and notes)",
    )
    p.add_argument(
        "--group",
        choices=(*GROUP_NAMES, "all"),
        default=None,
        help="list the presets of one group (so2, se2, so3, se3, sim3, se23), or 'all' with one "
        "section per group (default: the SE(3) presets)",
    )
    p.set_defaults(func=_run)
