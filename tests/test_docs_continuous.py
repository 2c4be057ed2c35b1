"""docs/continuous-time.md runs: its python blocks in order, in one namespace (asserts included)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "continuous-time.md"
BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def test_continuous_time_page_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = BLOCK.findall(PAGE.read_text(encoding="utf-8"))
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "docs_continuous_time"}
    for k, code in enumerate(blocks):
        exec(compile(code, f"continuous-time.md[block {k}]", "exec"), namespace)
