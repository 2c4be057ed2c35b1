"""Which convention, or which known mistake, a user's Jacobian matches."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..check import numerical_jacobian
from ..conventions import (
    Convention,
    ConventionLike,
    detect_convention,
    get,
    single_group,
    tangent_map,
)
from ..lie import se2, se3, so3
from .elements import (
    CANONICAL_NAME,
    VECTOR,
    ConventionClass,
    as_element,
    conventions_classes,
    has_blocks,
    kind_of_output,
    record,
    rotation_index,
    with_angle,
)
from .result import Diagnosis

__all__ = ["ANGLES_DEG", "diagnose_jacobian"]

#: Rotation angles (degrees) the Jacobian is also checked at, where small-angle formulas fail.
ANGLES_DEG = (0.0, 90.0, 170.0, 179.0)


class _Call:
    """Call the user's function (or Jacobian) and turn every failure into one clear error."""

    def __init__(self, fn: Callable[..., Any], name: str) -> None:
        self.fn, self.name = fn, name

    def __call__(self, args: Sequence[Any], where: str) -> FloatArray:
        try:
            out = self.fn(*args)
        except Exception as exc:  # the user's code: any failure is reported, never re-raised raw
            raise ValueError(f"{self.name}: raised {type(exc).__name__} at {where}: {exc}") from exc
        if isinstance(out, (tuple, list)):  # a Jacobian given per input
            blocks = [np.atleast_2d(np.asarray(_matrix(b), dtype=np.float64)) for b in out]
            try:
                arr = np.hstack(blocks)
            except ValueError as exc:
                raise ValueError(
                    f"{self.name}: returned blocks of shapes {[b.shape for b in blocks]} at "
                    f"{where}; they must have the same number of rows"
                ) from exc
        else:
            arr = np.asarray(_matrix(out), dtype=np.float64)
        if not np.isfinite(arr).all():
            bad = int(np.size(arr) - np.isfinite(arr).sum())
            raise ValueError(f"{self.name}: returned {bad} NaN/Inf entries at {where}")
        return arr


def _matrix(x: Any) -> Any:
    return x.matrix() if hasattr(x, "matrix") else x


@dataclass
class _Hyp:
    """One explanation: a convention class pair, possibly with a known mistake applied."""

    cause: str  # "" for a plain convention
    words: str
    inc: ConventionClass | None
    outc: ConventionClass | None
    mats: list[FloatArray]  # the Jacobian this explanation predicts, per point
    errors: list[float] | None = None

    @property
    def error(self) -> float:
        return max(self.errors) if self.errors else math.inf


def _rel_err(J: FloatArray, H: FloatArray) -> float:
    if J.shape != H.shape:
        return math.inf
    return float(np.abs(J - H).max() / max(1.0, float(np.abs(H).max())))


def _blockdiag(blocks: Sequence[FloatArray]) -> FloatArray:
    n = sum(b.shape[0] for b in blocks)
    m = sum(b.shape[1] for b in blocks)
    out = np.zeros((n, m))
    i = j = 0
    for b in blocks:
        out[i : i + b.shape[0], j : j + b.shape[1]] = b
        i, j = i + b.shape[0], j + b.shape[1]
    return out


def _twin(conv: Convention) -> Convention:
    """Return the same convention perturbed on the other side."""
    side = "left" if conv.side == "right" else "right"
    return Convention(
        conv.name + "/twin",
        side,  # type: ignore[arg-type]
        conv.order,
        conv.chart,
        conv.rotation,
        conv.quat_order,
        group=conv.group,
        embed=conv.embed,
    )


def _jr_mistakes(y: FloatArray) -> list[tuple[str, str, FloatArray]]:
    """``(cause, words, M)``: ``M·J`` is a Jacobian that left out the ``J⁻¹`` of a log output."""
    out: list[tuple[str, str, FloatArray]] = []
    n = y.shape[-1]
    if n == 3:
        out += [
            ("jr_inv_omitted", "Jr⁻¹(r) of the SO(3) log omitted", so3.jr(y)),
            ("jl_inv_omitted", "Jl⁻¹(r) of the SO(3) log omitted", so3.jl(y)),
        ]
        for order, perm in (("(x, y, θ)", [0, 1, 2]), ("(θ, x, y)", [1, 2, 0])):
            P = np.eye(3)[perm]
            out.append(
                (
                    "jr_inv_omitted",
                    f"Jr⁻¹(r) of the SE(2) log omitted, r in {order}",
                    P.T @ se2.jr(P @ y) @ P,
                )
            )
    elif n == 6:
        for order, perm in (("(ω, v)", [0, 1, 2, 3, 4, 5]), ("(v, ω)", [3, 4, 5, 0, 1, 2])):
            P = np.eye(6)[perm]
            yr = P @ y
            out += [
                (
                    "jr_inv_omitted",
                    f"Jr⁻¹(r) of the SE(3) log omitted, r in {order}",
                    P.T @ se3.jr(yr) @ P,
                ),
                (
                    "jl_inv_omitted",
                    f"Jl⁻¹(r) of the SE(3) log omitted, r in {order}",
                    P.T @ se3.jl(yr) @ P,
                ),
            ]
    return out


def _fix_words(found: Convention, want: Convention, kind: str, where: str) -> list[str]:
    """Say what turns a Jacobian in ``found``'s tangent into one in ``want``'s."""
    words: list[str] = []
    A = "Ad_X" if where == "input" else "Ad_Y"
    blocks = has_blocks(kind)  # a rotation's tangent has no order and no chart
    if not blocks:
        A = "R" if where == "input" else "R_Y"
    if found.side != want.side:
        if where == "input":
            op = f"{A}⁻¹" if found.side == "right" else A
            words.append(f"multiply by {op} on the right (J_{want.side} = J_{found.side}·{op})")
        else:
            op = A if found.side == "right" else f"{A}⁻¹"
            words.append(f"multiply by {op} on the left (J_{want.side} = {op}·J_{found.side})")
    if blocks and found.order != want.order:
        what = "column" if where == "input" else "row"
        words.append(f"swap the rotation and translation {what} blocks")
    if found.rotation_scale != want.rotation_scale:
        k = (
            want.rotation_scale / found.rotation_scale
            if where == "input"
            else (found.rotation_scale / want.rotation_scale)
        )
        what = "columns" if where == "input" else "rows"
        words.append(f"scale the rotation {what} by {k:g} (the half-angle factor)")
    if blocks and found.chart != want.chart and not words:
        words.append("convert the translation part between body- and world-frame increments")
    return words


def _cause_of(found: Convention, want: Convention, kind: str) -> str:
    parts = []
    blocks = has_blocks(kind)
    if found.side != want.side:
        parts.append("right_vs_left")
    if blocks and found.order != want.order:
        parts.append("order")
    if found.rotation_scale != want.rotation_scale:
        parts.append("half_angle")
    if blocks and found.chart != want.chart:
        parts.append("chart")
    if found.stores != want.stores:  # e.g. a solver on world→camera poses (dpvo)
        parts.append("stored_inverse")
    return "+".join(parts) or "convention"


def _the(words: str) -> str:
    return words if words.startswith("the ") else f"the Jacobian for {words}"


def _solver_words(solver: Convention, evidence: dict[str, Any]) -> str:
    if evidence.get("solver_measured"):
        return f"your solver's retraction (measured: like {solver.name!r})"
    return f"your solver ({solver.name})"


def _name(conv: Convention) -> str:
    return repr(conv.name) if "/" not in conv.name else f"Convention({conv.describe()!r})"


def diagnose_jacobian(
    f: Callable[..., Any],
    J: Any,
    X: Any,
    *,
    solver_convention: ConventionLike | Callable[[Any, Any], Any] | None = None,
    group: str | None = None,
    tol: float = 1e-6,
    eps: float = 1e-6,
) -> Diagnosis:
    """Say which convention — or which known mistake — the Jacobian ``J`` of ``f`` matches.

    ``J`` is compared with central finite differences of ``f`` through every candidate
    convention's retraction (each registered preset and every side × order × chart × rotation
    coordinates combination, grouped into classes with the same first-order map), read back
    through every candidate convention of the output when ``f`` returns a pose or rotation, and
    with the catalogue of known mistakes applied to each: skew matrix of the old sign (rotation
    columns or rows negated), ``Ad_X`` used for ``Ad_X⁻¹`` in a side conversion, the adjoint
    applied on the wrong side, ``Jr⁻¹``/``Jl⁻¹`` of a log output omitted, the transpose, and
    ``J = I`` in place of a bias Jacobian. Swapped blocks and the half-angle factor are the
    order and rotation-scale classes themselves. Where ``J`` is a function it is also checked
    with every rotation input turned to 0°, 90°, 170° and 179° about its own axis, and a
    Jacobian that holds only near zero is reported as such.

    Parameters
    ----------
    f : callable
        ``f(X)`` or ``f(X1, X2, ...)``: the user's function of poses ``(4, 4)``, rotations
        ``(3, 3)``, SE(2) poses ``(3, 3)`` or vectors ``(n,)`` (a bias); GTSAM ``Pose3``,
        ``Rot3`` and ``Pose2`` are accepted and handed back as such. It returns a pose, a
        rotation, or a vector (a residual).
    J : callable or array_like
        The analytic Jacobian: a function of the same arguments as ``f``, or its value at ``X``;
        shape ``(m, n)`` with ``n`` the summed tangent lengths of the inputs (or a tuple of one
        block per input).
    X : element or tuple of elements
        Where to check: one input, or a tuple of inputs (then ``f(*X)``).
    solver_convention : Convention, str or callable, optional
        The retraction the user's solver uses, when known: the verdict is then ``"correct"``
        only for that convention's Jacobian, and a mismatch gets its fix. A callable is the
        solver's own ``retract(X, d)``; its convention is measured with
        :func:`liebridge.detect_convention` (on the inputs' group, or the output's for a
        function of vectors).
    group : {"so3", "se2"}, optional
        How to read ``(3, 3)`` inputs when both readings hold (the identity).
    tol : float
        Relative error (max-abs over the largest entry, at least 1) below which a candidate
        explains ``J``.
    eps : float
        Finite-difference step.

    Returns
    -------
    Diagnosis
        ``verdict`` ``"correct"``, ``"convention_mismatch"``, ``"mistake"``,
        ``"small_angle_only"`` or ``"unexplained"``; ``cause`` names the best explanation;
        ``evidence`` holds the errors of the best candidates per probe point.

    Raises
    ------
    ValueError
        When ``f`` or ``J`` raises, returns NaN/Inf, or has the wrong shape.
    TypeError
        When ``f`` is not callable.
    """
    if not callable(f):
        raise TypeError(f"f: expected a callable, got {type(f).__name__}")
    measured = callable(solver_convention) and not isinstance(solver_convention, Convention)
    solver = (
        single_group(get(solver_convention), "solver_convention")  # type: ignore[arg-type]
        if solver_convention is not None and not measured
        else None
    )
    if group is None and solver is not None and solver.record is se2.GROUP:
        group = se2.GROUP.name
    xs = X if isinstance(X, (tuple, list)) else (X,)
    if not xs:
        raise ValueError("X: give at least one input")
    els = [as_element(x, f"X[{k}]" if len(xs) > 1 else "X", group) for k, x in enumerate(xs)]
    kinds = {e.kind for e in els} - {VECTOR}
    recs = {record(k) for k in kinds}
    if len(kinds) > 1 and recs != {se3.GROUP, so3.GROUP}:  # a rotation takes SE(3)'s conventions
        raise ValueError(f"X: inputs of kinds {sorted(kinds)} cannot share one convention")
    in_kind = se3.GROUP.name if se3.GROUP in recs else (kinds.pop() if kinds else VECTOR)
    f_call = _Call(f, "f")
    j_call = _Call(J, "J") if callable(J) else None
    if j_call is None and isinstance(J, (tuple, list)) and all(np.ndim(b) == 2 for b in J):
        J = np.hstack([np.asarray(b, dtype=np.float64) for b in J])  # one block per input

    # probe points: X itself, then (J a function) every rotation input at the table's angles
    point_names = ["X"]
    points = [[e.array for e in els]]
    if j_call is not None and in_kind != VECTOR:
        for deg in ANGLES_DEG:
            point_names.append(f"{deg:g}°")
            points.append([with_angle(e, math.radians(deg)) for e in els])

    def args(p: Sequence[FloatArray]) -> list[Any]:
        return [e.rebuild(a) for e, a in zip(els, p, strict=True)]

    ys = [
        f_call(args(p), f"the probe point {nm}") for p, nm in zip(points, point_names, strict=True)
    ]
    out_kind = kind_of_output(ys[0], [e.kind for e in els])
    for y, nm in zip(ys, point_names, strict=True):
        if y.shape != ys[0].shape:
            raise ValueError(f"f: returned shape {y.shape} at {nm} but {ys[0].shape} at X")
    out_rec = record(out_kind)
    m = out_rec.dim if out_rec is not None else int(ys[0].size)
    if measured:  # the solver's own retraction: measure its convention
        on = in_kind if in_kind != VECTOR else out_kind
        if on == VECTOR:
            raise ValueError("solver_convention: a retraction needs a pose or rotation to act on")
        try:
            solver = detect_convention(solver_convention, group=on)  # type: ignore[arg-type]
        except ValueError as exc:
            raise ValueError(f"solver_convention: {exc}") from exc
    dims = [
        solver.dim()
        if (solver is not None and solver.embed is not None and e.record is solver.record)
        else e.dim
        for e in els
    ]
    n = sum(dims)
    J0 = j_call(args(points[0]), "the probe point X") if j_call is not None else None
    j_cols = (J0 if J0 is not None else np.asarray(J)).shape[-1:]
    if j_cols == (sum(e.dim for e in els),):  # the group's own tangent (not the embedding)
        dims, n = [e.dim for e in els], sum(e.dim for e in els)
    if j_call is not None:
        Js = [
            j_call(args(p), f"the probe point {nm}")
            for p, nm in zip(points, point_names, strict=True)
        ]
    else:
        Js = [validate.as_float_array(J, "J")]
        validate.check_finite(Js[0], "J")
    for Jp, nm in zip(Js, point_names, strict=True):
        Jp2 = Jp.reshape(m, -1) if Jp.ndim < 2 and Jp.size == m * n else Jp
        if Jp2.shape != (m, n):
            raise ValueError(
                f"J: expected shape ({m}, {n}) (output tangent {m} × summed input tangents {n}) "
                f"at {nm}, got {Jp.shape}"
            )
    Js = [Jp.reshape(m, n) for Jp in Js]

    # convention classes of the inputs and of the output
    extra = [solver] if solver is not None else []
    group_idx = [k for k, e in enumerate(els) if e.kind != VECTOR]
    in_classes: list[ConventionClass | None] = [None]
    if in_kind != VECTOR:
        key_pts = [p[k] for p in points for k in group_idx]  # every group input, every point
        planar = record(in_kind) is se2.GROUP
        ext = [c for c in extra if (c.record is se2.GROUP) == planar]
        in_classes = list(conventions_classes(in_kind, key_pts, ext))
    out_classes: list[ConventionClass | None] = [None]
    if out_kind != VECTOR:
        ext = [c for c in extra if (c.record is se2.GROUP) == (out_rec is se2.GROUP)]
        out_classes = list(conventions_classes(out_kind, ys, ext))
    canon_out = CANONICAL_NAME.get(out_rec) if out_rec is not None else None

    def fd(cls: ConventionClass | None, pi: int) -> FloatArray:
        cols = []
        p = points[pi]
        for k, e in enumerate(els):

            def fk(a: Any, k: int = k) -> FloatArray:
                q = list(p)
                q[k] = a
                return f_call(args(q), f"a finite-difference step at {point_names[pi]}")

            conv = cls.rep if (cls is not None and e.kind != VECTOR) else None
            cols.append(
                numerical_jacobian(
                    fk,
                    p[k],
                    in_convention=conv,
                    out_convention=canon_out,
                    out_local="euclidean" if canon_out is None else None,
                    eps=eps,
                ).reshape(m, -1)
            )
        return np.hstack(cols)

    fds = {id(c): [fd(c, pi) for pi in range(len(points))] for c in in_classes}

    def row_map(oc: ConventionClass | None, pi: int) -> FloatArray:
        if oc is None or canon_out is None:
            return np.eye(m)
        return np.asarray(tangent_map(ys[pi], canon_out, oc.rep), dtype=np.float64)

    def col_block(conv: Convention, pi: int, inverse: bool) -> FloatArray:
        """Block-diagonal T(X; twin→conv) (or its inverse) over the inputs."""
        blocks = []
        for e, a in zip(els, points[pi], strict=True):
            if e.kind == VECTOR:
                blocks.append(np.eye(e.dim))
            else:
                tw = _twin(conv)
                src, dst = (conv, tw) if inverse else (tw, conv)
                blocks.append(np.asarray(tangent_map(a, src, dst), dtype=np.float64))
        return _blockdiag(blocks)

    hyps: list[_Hyp] = []
    npts = len(points)
    for ic in in_classes:
        for oc in out_classes:
            base = [row_map(oc, pi) @ fds[id(ic)][pi] for pi in range(npts)]
            if base[0].shape != (m, n):  # an embedded tangent of another size
                continue
            words = ic.label if ic is not None else "Euclidean input"
            if oc is not None and ic is not None and oc.label == ic.label:
                words = f"{words}, input and output"
            elif oc is not None:
                words = f"input: {words}; output: {oc.label}"
            hyps.append(_Hyp("", words, ic, oc, base))
            # skew matrix of the old sign: rotation coordinates negated
            if ic is not None:
                D = np.ones(n)
                off = 0
                for e, dk in zip(els, dims, strict=True):
                    if e.kind != VECTOR:
                        for r in rotation_index(ic.rep, e.kind):
                            D[off + r] = -1.0
                    off += dk
                if (D < 0).any():
                    hyps.append(
                        _Hyp(
                            "skew_sign",
                            f"{words}, with the rotation columns of the "
                            "sign-flipped skew matrix (hat(ω)·p = −ω×p)",
                            ic,
                            oc,
                            [b * D for b in base],
                        )
                    )
            if oc is not None:
                E = np.ones(m)
                E[rotation_index(oc.rep, out_kind)] = -1.0
                if (E < 0).any():
                    hyps.append(
                        _Hyp(
                            "skew_sign",
                            f"{words}, with the rotation rows of the sign-flipped skew matrix",
                            ic,
                            oc,
                            [E[:, None] * b for b in base],
                        )
                    )
            # Ad_X for Ad_X⁻¹ / the adjoint on the wrong side (input)
            if ic is not None:
                tw = _twin(ic.rep).side
                Ms = [col_block(ic.rep, pi, inverse=False) for pi in range(npts)]
                Mi = [col_block(ic.rep, pi, inverse=True) for pi in range(npts)]
                hyps.append(
                    _Hyp(
                        "inverse_adjoint",
                        f"the {tw}-perturbation Jacobian converted to "
                        f"{ic.rep.side} perturbations with Ad_X where Ad_X⁻¹ belongs "
                        f"(target: {words})",
                        ic,
                        oc,
                        [b @ M @ M for b, M in zip(base, Ms, strict=True)],
                    )
                )
                if m == n:
                    hyps.append(
                        _Hyp(
                            "adjoint_wrong_side",
                            f"the {tw}-perturbation Jacobian with the "
                            f"side-changing adjoint multiplied on the left instead of the right "
                            f"(target: {words})",
                            ic,
                            oc,
                            [Mv @ b @ M for b, M, Mv in zip(base, Ms, Mi, strict=True)],
                        )
                    )
            if oc is not None:
                tw_o = _twin(oc.rep)
                Ns = [np.asarray(tangent_map(y, oc.rep, tw_o), dtype=np.float64) for y in ys]
                hyps.append(
                    _Hyp(
                        "inverse_adjoint",
                        f"the {tw_o.side}-perturbation output rows converted "
                        f"to {oc.rep.side} with the inverse adjoint (target: {words})",
                        ic,
                        oc,
                        [N @ N @ b for b, N in zip(base, Ns, strict=True)],
                    )
                )
            # a log output's Jr⁻¹ / Jl⁻¹ left out
            if out_kind == VECTOR:
                per_pt = [_jr_mistakes(y.reshape(-1)) for y in ys]
                for j, (cause, w, _) in enumerate(per_pt[0]):
                    hyps.append(
                        _Hyp(
                            cause,
                            f"{words}, {w}",
                            ic,
                            oc,
                            [pp[j][2] @ b for pp, b in zip(per_pt, base, strict=True)],
                        )
                    )
            # the transpose
            if m == n:
                hyps.append(
                    _Hyp("transpose", f"the transpose of {words}", ic, oc, [b.T for b in base])
                )
    for h in hyps:
        h.errors = [_rel_err(Jp, H) for Jp, H in zip(Js, h.mats, strict=True)]

    solver_in = solver_out = None
    if solver is not None:
        for ic in in_classes:
            if ic is not None and solver in ic.members:
                solver_in = ic
        for oc in out_classes:
            if oc is not None and solver in oc.members:
                solver_out = oc

    def distance(cls: ConventionClass | None) -> int:
        """How many fields separate a class from the solver's (ties go to the closest)."""
        if cls is None or solver is None:
            return 0
        a = cls.rep
        return sum(
            (
                a.side != solver.side,
                a.order != solver.order,
                a.chart != solver.chart,
                a.rotation_scale != solver.rotation_scale,
            )
        )

    def rank(h: _Hyp) -> tuple[float, int, int, int, int]:
        good = h.error <= tol
        return (
            0.0 if good else h.error,
            0 if h.cause == "" else 1,
            0 if (h.inc is solver_in and h.outc is solver_out) else 1,
            distance(h.inc) + distance(h.outc),
            0
            if (
                h.inc is None
                or h.outc is None
                or h.inc.rep == h.outc.rep
                or set(h.inc.presets()) & set(h.outc.presets())
            )
            else 1,
        )

    hyps.sort(key=rank)
    best = hyps[0]
    evidence: dict[str, Any] = {
        "points": point_names,
        "input_kind": in_kind,
        "output_kind": out_kind,
        "solver_convention": solver.name if solver is not None else None,
        "solver_measured": bool(measured),
        "candidates": [
            {
                "explanation": h.words,
                "cause": h.cause or "convention",
                "error": h.error,
                "errors": dict(zip(point_names, h.errors or [], strict=True)),
            }
            for h in hyps[:8]
        ],
    }
    err = f"error {best.error:.1e}"
    if best.error <= tol:
        evidence["best"] = evidence["candidates"][0]
        if best.cause == "":
            return _convention_verdict(
                best, solver, solver_in, solver_out, in_kind, out_kind, err, evidence
            )
        fix = {
            "skew_sign": "use hat(ω) with hat(ω)·p = ω×p (hat(e1)·e2 = e3) and rederive",
            "inverse_adjoint": "use Ad_X⁻¹ where Ad_X stands (J_left = J_right·Ad_X⁻¹)",
            "adjoint_wrong_side": "the adjoint multiplies the Jacobian on the right, "
            "J_left = J_right·Ad_X⁻¹",
            "jr_inv_omitted": "multiply by Jr⁻¹(r) on the left",
            "jl_inv_omitted": "multiply by Jl⁻¹(r) on the left",
            "transpose": "transpose it",
        }[best.cause]
        return Diagnosis(
            "mistake",
            f"your Jacobian is {_the(best.words)} ({err}). Fix: {fix}.",
            evidence,
            best.cause,
        )
    # J = I where a bias (or other) Jacobian belongs
    if m == n and all(np.abs(Jp - np.eye(n)).max() < tol for Jp in Js):
        plain = next(h for h in hyps if h.cause == "")
        evidence["best"] = evidence["candidates"][0]
        return Diagnosis(
            "mistake",
            f"your Jacobian is the identity, but f's measured Jacobian is not (closest: "
            f"{_the(plain.words)}, {err}): a J = I substitution (e.g. Exp(δb) in place of "
            "Exp(J_b·δb) in an IMU bias correction). Fix: use the accumulated Jacobian "
            "(ΔR's J_b = −Σ ΔR_{k+1,j}ᵀ·Jr(ω_k dt)·dt).",
            evidence,
            "identity_substitution",
        )
    if len(point_names) > 1:
        i0 = point_names.index("0°")
        near = sorted(
            hyps,
            key=lambda h: (
                (h.errors or [math.inf] * npts)[i0] > tol,
                h.cause != "",
                rank(h)[2:],
                (h.errors or [math.inf] * npts)[i0],
            ),
        )[0]
        if (near.errors or [math.inf] * npts)[i0] <= tol:
            per = ", ".join(
                f"{nm}: {e:.1e}" for nm, e in zip(point_names, near.errors or [], strict=True)
            )
            evidence["best"] = {
                "explanation": near.words,
                "cause": "small_angle_only",
                "errors": dict(zip(point_names, near.errors or [], strict=True)),
            }
            return Diagnosis(
                "small_angle_only",
                f"your Jacobian matches {_the(near.words)} at zero rotation but not at large "
                f"angles "
                f"({per}): a small-angle formula (or Euler angles) used outside its domain.",
                evidence,
                "small_angle_only",
            )
    evidence["best"] = evidence["candidates"][0]
    return Diagnosis(
        "unexplained",
        f"no convention or known mistake reproduces your Jacobian; the closest is "
        f"{_the(best.words)} ({err}). Check it entry by entry against "
        "liebridge.check.numerical_jacobian through your solver's retraction.",
        evidence,
        "unexplained",
    )


def _convention_verdict(
    best: _Hyp,
    solver: Convention | None,
    solver_in: ConventionClass | None,
    solver_out: ConventionClass | None,
    in_kind: str,
    out_kind: str,
    err: str,
    evidence: dict[str, Any],
) -> Diagnosis:
    sides = {c.side for c in (best.inc.members if best.inc is not None else [])}
    if len(sides) > 1:  # a degenerate point: left and right Jacobians coincide there
        evidence["note"] = (
            "left and right perturbations give the same Jacobian at this X: check at a generic "
            "pose (or pass J as a function, which adds the probe angles)"
        )
    if solver is None:
        return Diagnosis(
            "correct",
            f"your Jacobian is {_the(best.words)} ({err}); it is right for a solver that "
            "retracts that way (pass solver_convention= to check against yours)"
            + (f"; {evidence['note']}." if "note" in evidence else "."),
            evidence,
        )
    bad_in = best.inc is not None and best.inc is not solver_in
    bad_out = best.outc is not None and solver_out is not None and best.outc is not solver_out
    if not bad_in and not bad_out:
        return Diagnosis(
            "correct",
            f"your Jacobian is {_the(best.words)} ({err}), which is what "
            f"{_solver_words(solver, evidence)} needs"
            + (f" ({evidence['note']})." if "note" in evidence else "."),
            evidence,
        )
    fixes: list[str] = []
    causes: list[str] = []
    if bad_in and best.inc is not None:
        found = best.inc.rep
        fixes += _fix_words(found, solver, in_kind, "input")
        fixes.append(f"in general J_solver = J·lb.tangent_map(X, {_name(solver)}, {_name(found)})")
        causes.append(_cause_of(found, solver, in_kind))
    if bad_out and best.outc is not None:
        found = best.outc.rep
        fixes += _fix_words(found, solver, out_kind, "output")
        fixes.append(
            f"for the rows, J_solver = lb.tangent_map(Y, {_name(found)}, {_name(solver)})·J"
        )
        causes.append(_cause_of(found, solver, out_kind))
    side = {"right": "on the right (X·Exp(δ))", "left": "on the left (Exp(δ)·X)"}[solver.side]
    return Diagnosis(
        "convention_mismatch",
        f"your Jacobian is {_the(best.words)} ({err}); {_solver_words(solver, evidence)} "
        f"retracts {side}: " + "; ".join(fixes) + ".",
        evidence,
        "+".join(dict.fromkeys("+".join(causes).split("+"))),
    )
