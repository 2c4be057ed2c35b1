"""One CLI vocabulary: ``docs/cli.md`` matches the parsers, old spellings work and say so."""

from __future__ import annotations

import argparse
from pathlib import Path

import gtsam
import numpy as np
import pytest

from liebridge.cli import build_parser, main
from liebridge.cli.reference import cli_reference, deprecated_spellings

ROOT = Path(__file__).resolve().parents[1]
POSE3 = gtsam.findExampleDataFile("pose3example.txt")
#: The commands whose ``--from``/``--to`` exist: each names a convention there.
CONVENTION_PAIRS = {"liebridge convert-cov", "liebridge registration info"}


def _options(parser: argparse.ArgumentParser, path: str = "liebridge"):
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sub in a.choices.items():
                yield from _options(sub, f"{path} {name}")
        else:
            yield path, parser, a


def test_docs_cli_md_is_what_the_parsers_say() -> None:
    page = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    assert page == cli_reference(), (
        "docs/cli.md is stale: run `python -m liebridge.cli.reference docs/cli.md`"
    )
    assert "cli.md" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")


def test_docs_cli_md_lists_every_option_of_every_command() -> None:
    page = cli_reference()
    for command, _, action in _options(build_parser()):
        if isinstance(action, argparse._HelpAction):
            continue
        assert f"## `{command}`" in page, command
        for s in action.option_strings:
            assert f"`{s}`" in page, (command, s)


def test_from_and_to_are_conventions_wherever_they_are_not_deprecated() -> None:
    seen = set()
    for command, _, action in _options(build_parser()):
        names = set(action.option_strings) & {"--from", "--to"}
        if names and not hasattr(action, "new"):
            seen.add(command)
    assert seen == CONVENTION_PAIRS


@pytest.mark.parametrize(
    "argv",
    [
        [
            "convert-cov",
            "--from",
            "gtsam",
            "--to",
            "barfot",
            "--pose",
            "0 0 0 0 0 0 1",
            "--cov",
            "1 1 1 1 1 1",
        ],
        ["registration", "info", "result.npz", "--to", "barfot"],
    ],
    ids=["convert-cov", "registration-info"],
)
def test_to_names_a_convention(argv, capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    if argv[0] == "registration":
        np.savez(tmp_path / "result.npz", T=np.eye(4), H=np.eye(6), library="small_gicp")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "did you mean 'barfoot'" in err, err


def test_every_deprecated_spelling_is_marked_and_stores_into_its_new_option() -> None:
    parser = build_parser()
    old = deprecated_spellings(parser)
    assert len(old) >= 7
    for command, _, action in _options(parser):
        new = getattr(action, "new", None)
        if new is None:
            continue
        assert action.help == f"(deprecated: use {new})", (command, action.option_strings)
        siblings = {s: a for _, p, a in _options(parser) if _ == command for s in a.option_strings}
        target = siblings[new]
        assert target.dest == action.dest and target.choices == action.choices, (command, new)


def test_a_deprecated_spelling_warns_once_and_works(tmp_path, capsys) -> None:
    new, old = tmp_path / "new.npy", tmp_path / "old.npy"
    assert main(["optimize", POSE3, "--out-cov", str(new)]) == 0
    assert "deprecated" not in capsys.readouterr().err
    assert main(["optimize", POSE3, "--marginals", str(old)]) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if "deprecated" in line]
    assert warnings == [
        "liebridge optimize: warning: --marginals is deprecated (use --out-cov); "
        "it will be removed in the next release"
    ]
    np.testing.assert_allclose(np.load(old), np.load(new), rtol=1e-12, atol=0)


def test_a_required_option_may_be_given_in_either_spelling(capsys, tmp_path) -> None:
    f = tmp_path / "camchain-imucam.yaml"
    f.write_text("cam0:\n  T_cam_imu: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n")
    assert main(["extrinsics", "convert", str(f), "--to-system", "okvis"]) == 0
    assert main(["extrinsics", "convert", str(f), "--to", "okvis"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["extrinsics", "convert", str(f)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "required: --to-system" in err


def test_help_marks_the_old_spelling(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["bag", "export", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "--to {tum,g2o,npz} (deprecated: use --format)" in out
