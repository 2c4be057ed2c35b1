"""The README's quick start runs, and its two commands are what .ci/run executes."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_quick_start_runs():
    block = README.split("## Quick start", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    namespace: dict = {}
    exec(compile(block, "README quick start", "exec"), namespace)
    assert namespace["cov_barfoot"].shape == (6, 6)
    assert repr(namespace["g"]).startswith("ConventionGraph('sophus'")


def test_the_two_commands_are_the_ones_ci_runs():
    venv, *commands = re.findall(r"```bash\n(.+?)\n```", README)[:3]
    assert venv == "python3 -m venv .venv && . .venv/bin/activate"  # what .ci/run does too
    assert "python3 -m venv" in (ROOT / ".ci" / "run").read_text()
    assert commands[0] == "python -m pip install . && liebridge optimize"
    install, test = commands[1].split(" && ")
    ci = (ROOT / ".ci" / "run").read_text()
    assert install in ci and test in ci
