"""Every install line the project shows works from a checkout: liebridge is not on the index.

Docs, README, examples, benchmarks, messages and docstrings say ``pip install ".[plot]"`` (in the
checkout), never ``pip install liebridge`` or ``pip install "liebridge[plot]"``: those ask the
package index for a package liebridge does not publish (and would fetch someone else's).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NAME = "lie" + "bridge"  # spelled in two parts, so this file's own examples are not hits

#: An installer; the words after it, up to the end of the command, are its arguments.
INSTALLER = re.compile(r"(?:\bpip3?|\bpipx|\buv\s+pip|\bconda|\bmamba)\s+install\b|\buv\s+add\b")
END_OF_COMMAND = re.compile(r"\n|&&|\|\||;|#|`|\)")
#: The bare name, optionally with extras or a version: an index request. A path
#: (``./liebridge``, ``/path/to/liebridge[dask]``), ``.`` or another name is not.
REQUIREMENT = re.compile(rf"{NAME}(?:\[[^\]]*\])?(?:[=<>~!]=?\S*)?")
SKIP_DIRS = {".git", ".venv", "venv", "build", "dist", "site", "node_modules", "__pycache__"}
SUFFIXES = {".md", ".py", ".toml", ".yml", ".yaml", ".txt", ".cfg", ".rst", ".sh", ".ini", ""}


def index_installs(text: str) -> list[tuple[int, str]]:
    """Return ``(offset, command)`` of each install in ``text`` asking the index for liebridge."""
    hits = []
    for m in INSTALLER.finditer(text):
        rest = text[m.end() :]
        end = END_OF_COMMAND.search(rest)
        args = rest[: end.start() if end else len(rest)]
        for word in args.split():
            if REQUIREMENT.fullmatch(word.strip("\"'.,:")):
                hits.append((m.start(), f"{m.group(0)}{args}".strip()))
                break
    return hits


def _shipped_text_files() -> list[Path]:
    out = []
    for p in sorted(ROOT.rglob("*")):
        rel = p.relative_to(ROOT)
        if any(part in SKIP_DIRS or part.endswith(".egg-info") for part in rel.parts[:-1]):
            continue
        if not p.is_file() or p.suffix not in SUFFIXES or p.name == Path(__file__).name:
            continue
        if p.suffix == "" and not (p.parent.name == ".ci" or p.name in {"Makefile"}):
            continue
        out.append(p)
    return out


@pytest.mark.parametrize(
    "line",
    [
        f"python -m pip install {NAME}",
        f"pip install {NAME}        # numpy, scipy, gtsam",
        f'pip install "{NAME}[plot]"',
        f"pip install '{NAME}[ros,calib]' to read bags",
        f"pip install -U {NAME}==0.1.0",
        f"pip3 install --upgrade {NAME}",
        f"uv pip install {NAME}[plot]",
        f"pipx install {NAME}",
        f"uv add {NAME}",
        f"conda install -c conda-forge {NAME}",
        f"`pip install {NAME}`",
    ],
)
def test_the_check_catches_an_index_install_line(line: str) -> None:
    assert index_installs(line), line


@pytest.mark.parametrize(
    "line",
    [
        'python -m pip install ".[plot]"',
        "python -m pip install . && liebridge optimize",
        f'pip install "/path/to/{NAME}[dask]"',
        f"pip install ./{NAME}",
        f"pip install -e /src/{NAME}",
        f"pip install {NAME}-plugins",
        f"pip install rosbags  # {NAME}.ros reads bags without ROS",
        f"pip show {NAME}",
    ],
)
def test_the_check_passes_a_checkout_install_line(line: str) -> None:
    assert not index_installs(line), line


def test_no_shipped_text_asks_the_package_index_for_liebridge() -> None:
    """README, docs, examples, benchmarks, messages and docstrings install from the checkout."""
    files = _shipped_text_files()
    assert any(p.name == "README.md" for p in files) and any(p.suffix == ".py" for p in files)
    bad = []
    for p in files:
        text = p.read_text(encoding="utf-8", errors="replace")
        for at, hit in index_installs(text):
            line = text[:at].count("\n") + 1
            bad.append(f"{p.relative_to(ROOT)}:{line}: {hit}")
    assert not bad, "install from the checkout (pip install '.[extra]'):\n" + "\n".join(bad)
