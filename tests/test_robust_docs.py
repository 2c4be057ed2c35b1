"""The code in ``docs/bad-input.md`` runs, and its table lists every class."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

DOC = Path(__file__).parents[1] / "docs" / "bad-input.md"


def test_bad_input_doc_example_runs_and_prints_what_it_says() -> None:
    text = DOC.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        for code in blocks:
            exec(compile(code, str(DOC), "exec"), {})
    printed = out.getvalue()
    assert "cov: singular covariance at batch index (): smallest eigenvalue 0" in printed
    assert "params.lambdaInitial: expected a finite number > 0, got nan" in printed


def test_bad_input_doc_table_lists_the_13_classes_with_a_test_each() -> None:
    text = DOC.read_text(encoding="utf-8")
    rows = re.findall(r"^\| (\d+) \|", text, flags=re.M)
    assert [int(r) for r in rows] == list(range(1, 14))
    tests = (Path(__file__).parent / "test_robust_classes.py").read_text(encoding="utf-8")
    tests += (Path(__file__).parent / "test_robust_sanitizers.py").read_text(encoding="utf-8")
    for n in range(1, 14):
        assert re.search(rf"^def test_class{n}_", tests, flags=re.M), n
