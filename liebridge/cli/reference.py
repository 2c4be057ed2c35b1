"""``docs/cli.md``: every option of every ``liebridge`` command, generated from the parsers.

``python -m liebridge.cli.reference docs/cli.md`` rewrites the page; ``tests/test_cli_reference.py``
fails when the page and the parsers disagree, so the page never goes stale. Nothing here is
written by hand except the vocabulary rules at the top.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator, Sequence

from ._common import _Missing

__all__ = ["VOCABULARY", "VOCABULARY_ROWS", "cli_reference", "deprecated_spellings", "main"]

#: The naming rules every command follows: (concept, option names, where), the page's preamble.
VOCABULARY_ROWS = (
    (
        "conventions",
        "`--from A` / `--to B` (a pair), `--convention NAME` (one)",
        "`convert-cov`, `registration info`; `optimize`, `bag export`, `traj nees`, `batch`",
    ),
    (
        "the format of what the command writes",
        "`--format`",
        "`conventions`, `traj`, `doctor`, `extrinsics convert` (text, json, ...); "
        "`bag export`, `batch convert` (file formats)",
    ),
    (
        "an input file's format",
        "`--ROLE-format`, ROLE the input it qualifies",
        "`--ref-format`/`--est-format` (REF, EST), `--src-format` (batch convert's files)",
    ),
    ("calibration systems", "`--from-system` / `--to-system`", "`extrinsics convert`"),
    (
        "ROS topics",
        "`--topic` (the one bag read), `--ROLE-topic` (one of several inputs), "
        "`--out-topic` (written)",
        "`bag`, `traj`, `batch`",
    ),
    (
        "quaternion order",
        "`--quat-order` (read), `--out-quat-order` (written)",
        "`traj`, `batch`, `doctor traj`",
    ),
    (
        "covariance files",
        "`--cov` / `--cov-glob` (read), `--out-cov` (written)",
        "`convert-cov`, `traj nees`, `batch evaluate`; `optimize`",
    ),
    (
        "output files",
        "`--out FILE` (the result), `--plot OUT.png` (a figure)",
        "every command that writes one",
    ),
)
VOCABULARY = "\n".join(
    [
        "One option name per concept, in every command:",
        "",
        "| concept | option | where |",
        "|---|---|---|",
        *(f"| {c} | {o} | {w} |" for c, o, w in VOCABULARY_ROWS),
        "",
        "So `--from`/`--to` always name conventions, and `--format` always the format of what "
        "the command writes, never an input's. Older spellings still work for one release: "
        '`--help` marks them "(deprecated: use --x)" and using one prints a one-line warning '
        "on stderr (table below).",
        "",
    ]
)


def _subparsers(parser: argparse.ArgumentParser) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            yield from action.choices.items()


def _commands(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ("liebridge",)
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every (sub)command with options of its own, depth first, in the parsers' order."""
    own = [a for a in parser._actions if not isinstance(a, argparse._SubParsersAction)]
    if any(not isinstance(a, argparse._HelpAction) for a in own):
        yield " ".join(path), parser
    for name, sub in _subparsers(parser):
        yield from _commands(sub, (*path, name))


def _cell(text: object) -> str:
    return " ".join(str(text).replace("%%", "%").split()).replace("|", "\\|")


def _argument(action: argparse.Action) -> str:
    if action.nargs == 0:
        return ""
    if action.choices is not None:
        return "{" + ",".join(str(c) for c in action.choices) + "}"
    if action.metavar is not None:
        return str(action.metavar)
    return action.dest.upper() if action.option_strings else ""


def _default(action: argparse.Action) -> str:
    d = action.default
    if action.nargs == 0 or d is None or d is argparse.SUPPRESS or callable(d):
        return ""
    if isinstance(d, _Missing):  # required in either spelling
        return ""
    return f"`{d}`" if str(d) else "`''`"


def _name(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest.upper()}` (positional)"
    return ", ".join(f"`{s}`" for s in action.option_strings)


def deprecated_spellings(parser: argparse.ArgumentParser) -> list[tuple[str, str, str]]:
    """``(command, old, new)`` for every deprecated spelling in the parser tree."""
    out = []
    for command, p in _commands(parser):
        for a in p._actions:
            new = getattr(a, "new", None)
            if isinstance(new, str) and a.option_strings:
                out.append((command, a.option_strings[0], new))
    return out


def cli_reference(parser: argparse.ArgumentParser | None = None) -> str:
    """Return ``docs/cli.md`` for ``parser`` (default: ``liebridge``'s own)."""
    if parser is None:
        from . import build_parser

        parser = build_parser()
    lines = [
        "# Command-line reference",
        "",
        "Generated from the argument parsers by `python -m liebridge.cli.reference docs/cli.md`",
        "(a test fails when this page and the parsers disagree). `liebridge COMMAND --help` says",
        "the same at the command line.",
        "",
        "## Vocabulary",
        "",
        VOCABULARY,
    ]
    old = deprecated_spellings(parser)
    if old:
        lines += ["### Deprecated spellings", "", "| command | old | use |", "|---|---|---|"]
        lines += [f"| `{c}` | `{o}` | `{n}` |" for c, o, n in old]
        lines.append("")
    for command, p in _commands(parser):
        lines += [f"## `{command}`", ""]
        if p.description:
            lines += [_cell(p.description), ""]
        lines += ["| option | argument | default | meaning |", "|---|---|---|---|"]
        for a in p._actions:
            if isinstance(a, argparse._HelpAction | argparse._SubParsersAction):
                continue
            if isinstance(a, argparse._VersionAction):
                meaning = "print the version and exit"
            else:
                meaning = a.help if a.help not in (None, argparse.SUPPRESS) else ""
            if (a.required or isinstance(a.default, _Missing)) and a.option_strings:
                meaning = f"(required) {meaning}".strip()
            lines.append(
                f"| {_name(a)} | {_cell(_argument(a))} | {_default(a)} | {_cell(meaning)} |"
            )
        lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Write the reference to the path given (default: stdout)."""
    args = list(sys.argv[1:] if argv is None else argv)
    text = cli_reference()
    if args:
        with open(args[0], "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
