"""Every Python block of docs/navigation-states.md runs (the page's worked examples)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[1] / "docs" / "navigation-states.md"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def test_the_page_has_examples() -> None:
    assert len(BLOCKS) == 3


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_docs_block_runs(code: str) -> None:
    exec(compile(code, str(DOC), "exec"), {})


def test_the_table_lists_every_state_preset() -> None:
    from liebridge.conventions import STATE_PRESETS

    text = DOC.read_text(encoding="utf-8")
    for c in STATE_PRESETS:
        assert f"| `{c.name}`" in text, c.name
