"""The floor plan holds: imports go one way, no package reaches into another's underscore names.

Every ``import`` in ``liebridge/`` counts — at module level, inside functions and under
``TYPE_CHECKING`` alike. A package may import its own modules, packages on a lower floor, and
nothing else; packages on the same floor do not import each other (except on the top floor,
where the command line and the façades of old import paths live). ``docs/design.md`` draws the
same picture.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "liebridge"

#: Floors, lowest first. A unit is the first component below ``liebridge`` ("__init__" for the
#: package's own ``__init__.py``).
FLOORS: list[set[str]] = [
    {"arrays"},
    {"_validate"},
    {"lie"},
    {"conventions"},
    {"uncertain"},
    {"check", "io"},
    {"frames", "traj", "continuous", "doctor", "registration"},
    {"gtsam", "ceres"},
    {"imu"},
    {"ros"},
    {"batch"},
    {"cli", "adapters", "factors", "interop", "__init__"},
]
RANK = {unit: k for k, floor in enumerate(FLOORS) for unit in floor}
TOP = len(FLOORS) - 1


def _unit(module: str) -> str:
    parts = module.split(".")
    assert parts[0] == "liebridge", module
    if len(parts) == 1:
        return "__init__"
    return parts[1].removesuffix(".py")


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _resolve(node: ast.ImportFrom, here: str, is_package: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = here.split(".") if is_package else here.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(path: Path) -> list[tuple[int, str, str | None]]:
    """``(line, imported module, imported name or None)`` for every liebridge import in a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    here = _module_name(path)
    is_package = path.name == "__init__.py"
    out: list[tuple[int, str, str | None]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [
                (node.lineno, a.name, None) for a in node.names if a.name.startswith("liebridge")
            ]
        elif isinstance(node, ast.ImportFrom):
            mod = _resolve(node, here, is_package)
            if mod == "liebridge" or mod.startswith("liebridge."):
                out += [(node.lineno, mod, a.name) for a in node.names]
    return out


def _sources() -> list[Path]:
    return sorted(p for p in ROOT.rglob("*.py") if "__pycache__" not in p.parts)


def _target(mod: str, name: str | None) -> str:
    """The module an import really loads (``from liebridge import io`` loads ``liebridge.io``)."""
    if name is None:
        return mod
    sub = ROOT.parent.joinpath(*mod.split("."), name)
    if sub.is_dir() or sub.with_suffix(".py").exists():  # a module imported from its package
        return f"{mod}.{name}"
    return mod


def test_every_unit_has_a_floor():
    units = {_unit(_module_name(p)) for p in _sources()}
    assert units <= set(RANK), f"add {sorted(units - set(RANK))} to FLOORS (and docs/design.md)"


def test_imports_only_go_down():
    bad = []
    for path in _sources():
        src = _unit(_module_name(path))
        for line, mod, name in _imports(path):
            dst = _unit(_target(mod, name))
            if dst == src:
                continue
            if RANK[dst] > RANK[src] or (RANK[dst] == RANK[src] and RANK[src] != TOP):
                bad.append(f"{path.relative_to(ROOT.parent)}:{line}: {src} imports {dst}")
    assert not bad, "imports against the floor plan:\n" + "\n".join(bad)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__") and name != "_validate"


def test_no_package_uses_another_packages_underscore_names():
    bad = []
    for path in _sources():
        src = _unit(_module_name(path))
        tree = ast.parse(path.read_text(encoding="utf-8"))
        aliases: dict[str, str] = {}  # local name -> unit of a liebridge module bound to it
        for line, mod, name in _imports(path):
            dst_mod = _target(mod, name)
            dst = _unit(dst_mod)
            if dst == src:
                continue
            parts = dst_mod.split(".")[1:] + ([name] if name and dst_mod == mod else [])
            if any(_private(p) for p in parts):
                bad.append(f"{path.relative_to(ROOT.parent)}:{line}: {'.'.join(parts)}")
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom | ast.Import):
                for a in node.names:
                    local = a.asname or a.name.split(".")[0]
                    mods = [m for _, m, n in _imports(path) if (n or m.split(".")[-1]) == a.name]
                    if mods and _unit(_target(mods[0], a.name)) != src:
                        aliases[local] = _unit(_target(mods[0], a.name))
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in aliases
                and _private(node.attr)
            ):
                bad.append(
                    f"{path.relative_to(ROOT.parent)}:{node.lineno}: {node.value.id}.{node.attr}"
                )
    assert not bad, "underscore names used across packages:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "source, expect",
    [
        ("from ..gtsam import glue\n", "io imports gtsam"),
        ("def f():\n    from ..cli import main\n", "io imports cli"),
        (
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..check import x\n",
            "io imports check",
        ),
    ],
)
def test_the_layer_check_finds_upward_imports(tmp_path, monkeypatch, source, expect):
    """The check itself can fail: an upward import planted in a copy of ``io`` is reported."""
    fake_root = tmp_path / "liebridge"
    (fake_root / "io").mkdir(parents=True)
    (fake_root / "io" / "__init__.py").write_text("")
    (fake_root / "io" / "planted.py").write_text(source)
    for unit in ("gtsam", "cli", "check"):
        (fake_root / unit).mkdir()
        (fake_root / unit / "__init__.py").write_text("")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", fake_root)
    with pytest.raises(AssertionError, match=expect):
        test_imports_only_go_down()


def test_the_underscore_check_finds_reach_ins(tmp_path, monkeypatch):
    fake_root = tmp_path / "liebridge"
    for unit in ("lie", "conventions"):
        (fake_root / unit).mkdir(parents=True)
        (fake_root / unit / "__init__.py").write_text("")
    (fake_root / "lie" / "se3.py").write_text("def _exp(x):\n    return x\n")
    (fake_root / "conventions" / "planted.py").write_text(
        "from ..lie import se3\n\ny = se3._exp(1)\n"
    )
    monkeypatch.setattr(sys.modules[__name__], "ROOT", fake_root)
    with pytest.raises(AssertionError, match=r"se3\._exp"):
        test_no_package_uses_another_packages_underscore_names()


# --------------------------------------------------------------------------- one group record
#: Where a group's facts are declared (and so may name groups): the groups' own modules.
RECORD_HOMES = ("lie/",)


def _group_name_comparisons(tree: ast.AST, names: set[str]) -> list[tuple[int, str]]:
    """Find ``==``/``!=``/``in``/``not in`` whose operands hold a group name as a literal."""

    def literals(node: ast.AST) -> list[str]:
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return [node.value]
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            return [v for e in node.elts for v in literals(e)]
        return []

    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Compare):
            continue
        if not all(isinstance(op, ast.Eq | ast.NotEq | ast.In | ast.NotIn) for op in node.ops):
            continue
        hits = [v for side in (node.left, *node.comparators) for v in literals(side) if v in names]
        if hits:
            found.append((node.lineno, hits[0]))
    return found


def test_no_string_comparison_against_a_group_name_outside_the_records() -> None:
    """A group's facts live in its record: nothing else branches on ``group == "se3"``."""
    from liebridge import lie

    names = set(lie.GROUPS)
    offenders = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith(RECORD_HOMES):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        offenders += [
            f"{rel}:{line}: {name!r}" for line, name in _group_name_comparisons(tree, names)
        ]
    assert not offenders, "compare against the group record instead:\n" + "\n".join(offenders)


def test_the_comparison_finder_finds_what_it_looks_for() -> None:
    src = 'a = g == "se3"\nb = "sim3" != g\nc = g in ("so3", "x")\nd = g == "sphere"\ne = x < "se3"'
    hits = _group_name_comparisons(ast.parse(src), {"se3", "so3", "sim3"})
    assert [h[0] for h in hits] == [1, 2, 3]
