"""The documentation stands alone and runs.

* every page of ``docs/cookbook/`` is executed: its python code blocks in order, in one namespace,
  in a temporary directory (a page that does not run, or whose asserts fail, fails here);
* nothing shipped (package, examples, docs, CLI output) points users at documents the repository
  does not have, and every ``docs/...md`` it cites exists.

Also here (folded in from its twin file): Every Python block of docs/groups.md runs (the page's
worked examples are executed).

Also here (folded in from its twin file): Every Python block of docs/groups-in-gtsam.md runs (the
page's worked examples are executed).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
COOKBOOK = sorted(p for p in (DOCS / "cookbook").glob("*.md") if p.name != "index.md")
BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def test_the_cookbook_has_the_four_tasks() -> None:
    names = {p.stem for p in COOKBOOK}
    assert {
        "marginals-to-ros",
        "sophus-graph",
        "imu-from-gtsam-params",
        "g2o-two-semantics",
    } <= names


@pytest.mark.parametrize("page", COOKBOOK, ids=lambda p: p.stem)
def test_cookbook_page_runs(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = BLOCK.findall(page.read_text(encoding="utf-8"))
    assert blocks, f"{page.name}: no python code block"
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": f"cookbook_{page.stem}"}
    for k, code in enumerate(blocks):
        exec(compile(code, f"{page.name}[block {k}]", "exec"), namespace)


def _shipped_text() -> list[tuple[Path, str]]:
    files = [*(ROOT / "liebridge").rglob("*.py"), *(ROOT / "examples").glob("*.py")]
    files += [*DOCS.rglob("*.md"), ROOT / "mkdocs.yml", ROOT / "CHANGELOG.md"]
    return [(p, p.read_text(encoding="utf-8")) for p in files]


UNSHIPPED = re.compile(
    r"design note|shared/reference|lie-groups-design|(?<!api/)conventions\.md", re.I
)


def test_nothing_shipped_cites_unshipped_documents() -> None:
    bad = [
        f"{p.relative_to(ROOT)}:{text[: m.start()].count(chr(10)) + 1}: {m.group(0)}"
        for p, text in _shipped_text()
        for m in UNSHIPPED.finditer(text)
    ]
    assert not bad, bad


def test_cited_docs_pages_exist() -> None:
    cited = {
        (p, m.group(0))
        for p, text in _shipped_text()
        for m in re.finditer(r"docs/[\w/-]+\.md", text)
    }
    missing = [f"{p.relative_to(ROOT)} cites {c}" for p, c in cited if not (ROOT / c).is_file()]
    assert cited and not missing, missing


def test_conventions_json_cites_no_unshipped_document() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "conventions", "--format", "json"],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    ).stdout
    assert '"gtsam"' in out
    assert not UNSHIPPED.search(out)


# --------------------------------------------------------------------------- docs_groups
# Every Python block of docs/groups.md runs (the page's worked examples are executed).

GROUPS_DOC = Path(__file__).resolve().parents[1] / "docs" / "groups.md"
GROUPS_BLOCKS = re.findall(r"```python\n(.*?)```", GROUPS_DOC.read_text(encoding="utf-8"), re.S)


@pytest.mark.parametrize(
    "code", GROUPS_BLOCKS, ids=[f"block{i}" for i in range(len(GROUPS_BLOCKS))]
)
def test_groups_page_block_runs(code: str) -> None:
    exec(compile(code, str(GROUPS_DOC), "exec"), {})


# --------------------------------------------------------------------------- docs_groups_gtsam
# Every Python block of docs/groups-in-gtsam.md runs (the page's worked examples are executed).

GTSAM_GROUPS_DOC = Path(__file__).resolve().parents[1] / "docs" / "groups-in-gtsam.md"
GTSAM_GROUPS_BLOCKS = re.findall(
    r"```python\n(.*?)```", GTSAM_GROUPS_DOC.read_text(encoding="utf-8"), re.S
)


def test_the_page_has_examples() -> None:
    assert len(GTSAM_GROUPS_BLOCKS) >= 2


@pytest.mark.parametrize(
    "code", GTSAM_GROUPS_BLOCKS, ids=[f"block{i}" for i in range(len(GTSAM_GROUPS_BLOCKS))]
)
def test_groups_in_gtsam_page_block_runs(code: str) -> None:
    exec(compile(code, str(GTSAM_GROUPS_DOC), "exec"), {})
