"""The README's conventions table is `liebridge conventions --format markdown`, verbatim."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from liebridge.conventions import PRESETS

README = Path(__file__).resolve().parents[1] / "README.md"
START, END = "<!-- conventions-table:start -->", "<!-- conventions-table:end -->"


def _block() -> str:
    text = README.read_text(encoding="utf-8")
    assert text.count(START) == 1 and text.count(END) == 1
    return text.split(START, 1)[1].split(END, 1)[0].strip("\n")


def test_readme_table_is_the_command_output() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "conventions", "--format", "markdown"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert _block() == out.strip("\n"), (
        "README conventions table is stale: regenerate it with "
        "`liebridge conventions --format markdown` between the markers"
    )


def test_readme_table_has_every_preset_with_its_fields() -> None:
    rows = [line for line in _block().splitlines() if line.startswith("| `")]
    assert len(rows) == len(PRESETS)
    for row, c in zip(rows, PRESETS, strict=True):
        cells = [x.strip().strip("`") for x in row.strip("|").split("|")]
        assert cells[:6] == [c.name, c.side, c.order, c.chart, c.rotation, c.quat_order]
        assert cells[6][:1] in {"V", "S", "D"}  # the evidence code leads
