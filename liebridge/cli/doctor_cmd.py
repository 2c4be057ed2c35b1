"""``liebridge doctor jacobian MODULE:FUNCTION`` and ``liebridge doctor traj FILE``.

``jacobian`` imports the user's module (a dotted name importable from the current directory, or
a path to a ``.py`` file) and reads from it:

- ``FUNCTION``: the function ``f(X)`` (or ``f(X1, X2, ...)``);
- ``FUNCTION_jacobian`` (else ``jacobian``): its analytic Jacobian, a function of the same
  arguments or an array;
- ``FUNCTION_point`` (else ``point``): where to check it, one input or a tuple of inputs
  (default: a generic pose, for a function of one pose);
- ``solver_convention`` (optional): the solver's convention, overridden by ``--solver``.

It prints :func:`liebridge.doctor.diagnose_jacobian`'s diagnosis and the errors per candidate.
``traj`` reads a TUM file (``timestamp tx ty tz q q q q``; quaternion order declared by
``--quat-order``, else by a header naming ``qw`` first, else TUM's ``xyzw``) and prints
:func:`liebridge.doctor.scan_trajectory`'s findings. Exit status: 0 nothing wrong found, 1 a
problem found, 2 a usage error (one line on stderr).
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from ..doctor import Diagnosis, diagnose_jacobian, scan_trajectory
from ..lie import quaternion, se3, so3
from ._common import (
    CLIError,
    check_output_path,
    convention_arg,
    deprecated_alias,
    need_matplotlib,
    one_line,
    option_value,
    say,
)

__all__ = ["add_parser"]

#: Where a function of one pose is checked when the module names no point.
DEFAULT_POINT = se3.exp(np.array([0.3, -0.2, 0.1, 1.0, 2.0, 3.0]))


def _load_module(spec: str) -> ModuleType:
    if spec.endswith(".py") or "/" in spec or "\\" in spec:
        path = Path(spec)
        if not path.is_file():
            raise CLIError(f"MODULE: no such file: {spec}")
        name = "liebridge_doctor_user_" + re.sub(r"\W", "_", path.stem)
        mspec = importlib.util.spec_from_file_location(name, path)
        if mspec is None or mspec.loader is None:
            raise CLIError(f"MODULE: cannot load {spec}")
        module = importlib.util.module_from_spec(mspec)
        sys.modules[name] = module
        try:
            mspec.loader.exec_module(module)
        except Exception as exc:
            raise CLIError(f"MODULE: importing {spec} raised {type(exc).__name__}: {exc}") from None
        return module
    if "" not in sys.path and str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        return importlib.import_module(spec)
    except Exception as exc:
        raise CLIError(f"MODULE: importing {spec!r} raised {type(exc).__name__}: {exc}") from None


def _attr(module: ModuleType, names: list[str], what: str, required: bool = True) -> Any:
    for n in names:
        if hasattr(module, n):
            return getattr(module, n)
    if required:
        raise CLIError(
            f"{module.__name__} has no {what} (looked for {', '.join(names)}); see "
            "'liebridge doctor jacobian --help'"
        )
    return None


def _print(d: Diagnosis, fmt: str, table: list[str]) -> int:
    if fmt == "json":
        print(d.to_json())
    else:
        print(str(d))
        if table:
            print()
            print("\n".join(table))
    return 0 if d.ok else 1


def _run_jacobian(args: argparse.Namespace) -> int:
    target = args.target
    if ":" not in target.replace(":\\", ""):
        raise CLIError(f"TARGET: expected MODULE:FUNCTION, got {target!r}")
    mod_spec, _, fname = target.rpartition(":")
    if not mod_spec or not fname:
        raise CLIError(f"TARGET: expected MODULE:FUNCTION, got {target!r}")
    module = _load_module(mod_spec)
    f = _attr(module, [fname], f"function {fname!r}")
    J = _attr(module, [f"{fname}_jacobian", "jacobian"], "Jacobian")
    X = _attr(module, [f"{fname}_point", "point"], "point", required=False)
    if X is None:
        X = DEFAULT_POINT
    solver = args.solver or _attr(module, ["solver_convention"], "solver", required=False)
    if solver is not None and args.solver:
        solver = convention_arg(args.solver, "--solver")
    try:
        d = diagnose_jacobian(f, J, X, solver_convention=solver)
    except (ValueError, TypeError) as exc:
        raise CLIError(one_line(str(exc))) from None
    table = ["evidence (max relative error per probe point):"]
    for c in d.evidence.get("candidates", [])[:5]:
        errs = "  ".join(f"{k}: {v:.1e}" for k, v in c["errors"].items())
        table.append(f"  {c['error']:.1e}  {c['cause']:<20} {c['explanation']}")
        table.append(f"           {errs}")
    return _print(d, args.format, table)


def _declared_order(path: Path, option: str | None) -> str:
    if option:
        return option
    with path.open("r", encoding="utf-8", errors="replace") as fh:
        for line in fh:
            s = line.strip()
            if not s:
                continue
            if s.startswith("#"):
                words = s.lstrip("#").split()
                if "qw" in words and "qx" in words:
                    return "wxyz" if words.index("qw") < words.index("qx") else "xyzw"
                continue
            break
    return "xyzw"


def _read_rows(path: Path) -> np.ndarray:
    rows: list[list[float]] = []
    width = None
    with path.open("r", encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.split("#", 1)[0].strip()
            if not s:
                continue
            fields = s.replace(",", " ").split()
            try:
                vals = [float(v) for v in fields]
            except ValueError:
                raise CLIError(f"{path}:{lineno}: not a number in {s[:60]!r}") from None
            if width is None:
                width = len(vals)
                if width not in (8, 5):
                    raise CLIError(
                        f"{path}:{lineno}: expected 8 fields (timestamp tx ty tz q q q q) or 5 "
                        f"(timestamp q q q q), got {width}"
                    )
            elif len(vals) != width:
                raise CLIError(f"{path}:{lineno}: expected {width} fields, got {len(vals)}")
            rows.append(vals)
    if len(rows) < 2:
        raise CLIError(f"{path}: need at least 2 data lines, got {len(rows)}")
    return np.asarray(rows, dtype=np.float64)


def _plot_traj(
    out: Path, name: str, stamps: np.ndarray, q: np.ndarray, order: str, d: Diagnosis
) -> None:
    """‖Log(R_0ᵀR)‖ and the step angle along the sequence, with the findings marked."""
    plt = need_matplotlib()
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    R = quaternion.to_matrix(qn, order=order)  # type: ignore[arg-type]
    w = so3.log(np.einsum("ji,njk->nik", R[0], R))
    step = np.degrees(np.linalg.norm(so3.log(np.einsum("nji,njk->nik", R[:-1], R[1:])), axis=-1))
    dots = np.einsum("ni,ni->n", qn[:-1], qn[1:])
    fig, ax = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    ax[0].plot(stamps, np.linalg.norm(w, axis=-1), "k-", lw=1, label="‖Log(R_0ᵀR)‖")
    ax[0].plot(stamps, w, lw=0.8, alpha=0.7)
    ax[0].axhline(np.pi, ls="--", c="gray", lw=0.8)
    ax[0].set(ylabel="rad", title=f"{name}: verdict {d.verdict} (quaternions read {order})")
    ax[1].plot(stamps[1:], step, "C0-", lw=1)
    ax[1].set(ylabel="rotation step (deg)")
    ax[2].plot(stamps[1:], dots, "C2-", lw=1)
    ax[2].axhline(0.0, ls="--", c="gray", lw=0.8)
    ax[2].set(ylabel="dot(q_k, q_k+1)", xlabel="time (s)")
    colors = {"alarm": "red", "warning": "orange", "info": "0.6"}
    for f in d.evidence["findings"]:
        for k in f.get("indices", [f["index"]] if "index" in f else [])[:20]:
            k = min(int(k), len(stamps) - 1)
            for a in ax:
                a.axvline(stamps[k], color=colors[f["severity"]], lw=0.8, alpha=0.6)
    ax[0].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    say(f"wrote {out}")


def _run_traj(args: argparse.Namespace) -> int:
    path = Path(args.file)
    if not path.is_file():
        raise CLIError(f"FILE: no such file: {args.file}")
    plot = check_output_path(args.plot, "--plot", (".png", ".pdf", ".svg")) if args.plot else None
    data = _read_rows(path)
    order = _declared_order(path, args.order)
    try:
        d = scan_trajectory(data[:, 0], data[:, 1:], quat_order=order)
    except (ValueError, TypeError) as exc:
        raise CLIError(f"{path}: {one_line(str(exc))}") from None
    status = _print(d, args.format, [])
    if plot is not None:
        measured = (d.evidence.get("quat_order") or {}).get("order")
        use = measured if measured in ("xyzw", "wxyz") else order
        _plot_traj(plot, path.name, data[:, 0], data[:, -4:], use, d)
    return status


def add_parser(sub: Any) -> None:
    """Register ``liebridge doctor``."""
    p = sub.add_parser(
        "doctor",
        help="diagnose your own Jacobian (which convention or known mistake) or trajectory",
        description="The convention doctor. 'jacobian MODULE:FUNCTION' compares your analytic "
        "Jacobian with finite differences through every convention and the catalogue of known "
        "mistakes; 'traj FILE' scans a TUM file for branch-cut crossings, quaternion sign "
        "flips, bad rotations, time problems and the quaternion storage order. Exit status 0: "
        "nothing wrong found, 1: a problem found, 2: usage error.",
    )
    dsub = p.add_subparsers(dest="doctor_command", metavar="{jacobian,traj}")
    dsub.required = True
    j = dsub.add_parser(
        "jacobian",
        help="which convention, or which known mistake, your Jacobian matches",
        description="Import MODULE (dotted name or path to a .py file) and diagnose FUNCTION's "
        "Jacobian. The module defines FUNCTION (f), FUNCTION_jacobian or jacobian (a function "
        "of the same arguments, or an array), optionally FUNCTION_point or point (the input, "
        "or a tuple of inputs; default a generic 4×4 pose) and solver_convention.",
    )
    j.add_argument("target", metavar="MODULE:FUNCTION")
    j.add_argument("--solver", help="your solver's convention (a preset name, e.g. gtsam)")
    j.add_argument("--format", type=option_value, choices=("text", "json"), default="text")
    j.set_defaults(func=_run_jacobian)
    t = dsub.add_parser(
        "traj",
        help="scan a TUM trajectory file",
        description="Scan FILE (TUM: timestamp tx ty tz q q q q, or timestamp q q q q) for "
        "duplicate/backward stamps, time gaps, non-unit quaternions, pose jumps, rotation-log "
        "branch-cut crossings near π, quaternion sign flips (and the SLERP spin they would "
        "cause) and the quaternion storage order (measured; declared by --quat-order, else by a "
        "header naming qw first, else xyzw as TUM).",
    )
    t.add_argument("file", metavar="FILE")
    order = t.add_argument(
        "--quat-order",
        dest="order",
        type=option_value,
        choices=("xyzw", "wxyz"),
        help="declared quaternion order",
    )
    deprecated_alias(t, order, "--order")
    t.add_argument("--format", type=option_value, choices=("text", "json"), default="text")
    t.add_argument(
        "--plot",
        metavar="OUT",
        help="write ‖Log(R_0ᵀR)‖, the rotation steps and dot(q_k, q_k+1) along the sequence with "
        "the findings marked (.png/.pdf/.svg; needs matplotlib)",
    )
    t.set_defaults(func=_run_traj)
