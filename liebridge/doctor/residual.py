"""A relative-pose residual on a one-edge graph with a known 1 m and 10° error."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..check import numerical_jacobian
from ..conventions import ConventionLike, get
from ..lie import GROUPS, Group, se2, se3
from .jacobian import _Call
from .result import Diagnosis

__all__ = ["diagnose_residual"]

#: The edge's error: 1 m along the body x axis and 10° about the body z axis.
EDGE_METERS = 1.0
EDGE_DEGREES = 10.0


#: The groups the one-edge graph is built for.
EDGE_GROUPS: tuple[Group, ...] = (se3.GROUP, se2.GROUP)


def _edge(rec: Group) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(T_i, Z, G)``: a generic anchor pose, the measurement, a generic frame change."""
    th = math.radians(EDGE_DEGREES)
    if rec is se2.GROUP:
        Ti = se2.exp([1.5, -2.0, 0.8])
        Z = np.array(
            [
                [math.cos(th), -math.sin(th), EDGE_METERS],
                [math.sin(th), math.cos(th), 0.0],
                [0.0, 0.0, 1.0],
            ]
        )
        return Ti, Z, se2.exp([-3.0, 0.7, 2.1])
    Ti = se3.exp([0.2, -0.3, 0.5, 1.0, -2.0, 0.5])
    c, s = math.cos(th), math.sin(th)
    Z = np.array(
        [[c, -s, 0.0, EDGE_METERS], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    )
    return Ti, Z, se3.exp([1.1, -0.4, 2.0, 3.0, -1.0, 2.5])


def _inv(T: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.inv(T), dtype=np.float64)


def _distance(A: FloatArray, B: FloatArray) -> tuple[float, float]:
    """Rotation angle (deg) and translation distance (m) between two poses."""
    n = A.shape[0] - 1
    Rr = A[:n, :n].T @ B[:n, :n]
    if n == 2:
        ang = abs(math.atan2(Rr[1, 0], Rr[0, 0]))
    else:
        ang = math.acos(max(-1.0, min(1.0, (np.trace(Rr) - 1.0) / 2.0)))
    return math.degrees(ang), float(np.linalg.norm(B[:n, n] - A[:n, n]))


def diagnose_residual(
    residual: Callable[[Any, Any, Any], Any],
    *,
    jacobian: Callable[[Any, Any, Any], Any] | None = None,
    convention: ConventionLike = "gtsam",
    group: str = "se3",
    tol: float = 1e-8,
) -> Diagnosis:
    """Run the one-edge-graph diagnostic on a user's relative-pose residual.

    The graph: pose ``T_i`` fixed (a generic pose), pose ``T_j`` free, one edge with measurement
    ``Z`` = 1 m along the body x axis and 10° about the body z axis, and ``T_j`` starting at
    ``T_i`` (so the error is exactly 1 m and 10°). Measured:

    - **zero at the measurement**: is ``residual(T_i, T_i·Z, Z) = 0`` (a body-frame relative
      residual, ``T_i⁻¹T_j = Z``), or ``residual(T_i, Z·T_i, Z) = 0`` (a world-frame one,
      ``T_j·T_i⁻¹ = Z``)? If instead it vanishes at ``T_i·Z⁻¹`` (or ``Z⁻¹·T_i``), the residual
      is *inverted*: a loop closure moves the graph the opposite way.
    - **invariance** under a global frame change ``T ↦ G·T`` (left) and under ``T ↦ T·G``
      (right): a body-frame residual must be left-invariant (the note's code-review item), a
      world-frame one right-invariant.
    - **the first Gauss–Newton step** on ``T_j`` through ``convention``'s retraction, with the
      user's ``jacobian`` if given (else central differences through the same retraction): does
      it reduce the error, and in which direction does ``T_j`` move (cosine with the true
      direction)?

    Parameters
    ----------
    residual : callable
        ``residual(T_i, T_j, Z)`` → vector; poses are ``(4, 4)`` (``(3, 3)`` for
        ``group="se2"``).
    jacobian : callable, optional
        ``jacobian(T_i, T_j, Z)`` → ``∂r/∂δ_j`` in ``convention``'s tangent of ``T_j``.
    convention : Convention or str
        The solver's retraction (default GTSAM's, ``T·Exp(δ)``, δ = (ω, v)).
    group : {"se3", "se2"}
    tol : float
        Residual norm counted as zero, and invariance tolerance (relative).

    Returns
    -------
    Diagnosis
        ``verdict`` ``"correct"`` or ``"mistake"``; ``cause`` one of ``"inverted_residual"``,
        ``"not_zero_at_measurement"``, ``"not_frame_invariant"``, ``"step_wrong_direction"``,
        ``"step_does_not_reduce"``; ``evidence`` the residual norms, invariance errors and the
        step (error before/after, direction cosine).

    Raises
    ------
    ValueError
        When ``residual`` or ``jacobian`` raises, returns NaN/Inf or changes shape.
    """
    if not callable(residual):
        raise TypeError(f"residual: expected a callable, got {type(residual).__name__}")
    rec = GROUPS.get(group) if isinstance(group, str) else None
    if rec is None or rec not in EDGE_GROUPS:
        raise ValueError(f"group: expected 'se3' or 'se2', got {group!r}")
    conv = get(convention)
    r_call = _Call(residual, "residual")
    Ti, Z, G = _edge(rec)
    Zi = _inv(Z)

    def r(A: FloatArray, B: FloatArray, where: str) -> FloatArray:
        return r_call([A.copy(), B.copy(), Z.copy()], where).reshape(-1)

    at = {
        "T_i·Z (body-frame measurement)": Ti @ Z,
        "Z·T_i (world-frame measurement)": Z @ Ti,
        "T_i·Z⁻¹ (inverted)": Ti @ Zi,
        "Z⁻¹·T_i (inverted, world frame)": Zi @ Ti,
    }
    norms = {k: float(np.linalg.norm(r(Ti, B, f"T_j = {k}"))) for k, B in at.items()}
    r0 = r(Ti, Ti, "T_j = T_i (the start)")
    scale = max(1.0, float(np.linalg.norm(r0)))
    zero = {k: v <= tol * scale for k, v in norms.items()}
    keys = list(at)
    form = "body" if zero[keys[0]] else ("world" if zero[keys[1]] else None)
    inverted = not form and (zero[keys[2]] or zero[keys[3]])
    target = at[keys[1]] if form == "world" else at[keys[0]]

    # frame invariance at a generic T_j
    Tj = (
        Ti
        @ Z
        @ (
            se2.exp([0.3, -0.2, 0.25])
            if rec is se2.GROUP
            else se3.exp([0.1, 0.2, -0.1, 0.3, -0.2, 0.4])
        )
    )
    base = r(Ti, Tj, "a generic T_j")
    bscale = max(1.0, float(np.linalg.norm(base)))
    left = float(np.abs(r(G @ Ti, G @ Tj, "G·T_i, G·T_j") - base).max()) / bscale
    right = float(np.abs(r(Ti @ G, Tj @ G, "T_i·G, T_j·G") - base).max()) / bscale

    # the first Gauss–Newton step from T_j = T_i
    Tj0 = Ti.copy()
    if jacobian is not None:
        J = _Call(jacobian, "jacobian")([Ti.copy(), Tj0.copy(), Z.copy()], "T_j = T_i")
    else:
        J = numerical_jacobian(
            lambda B: r(Ti, np.asarray(B), "a finite-difference step"),
            Tj0,
            in_convention=conv,
            out_local="euclidean",
        )
    dim = conv.dim(Tj0)
    if J.shape != (r0.size, dim):
        raise ValueError(f"jacobian: expected shape ({r0.size}, {dim}), got {J.shape}")
    delta = -np.linalg.lstsq(J, r0, rcond=None)[0]
    Tj1 = conv.retract(Tj0, delta)
    before = _distance(target, Tj0)
    after = _distance(target, Tj1)
    n = Ti.shape[0] - 1
    moved = Tj1[:n, n] - Tj0[:n, n]
    want = target[:n, n] - Tj0[:n, n]
    cosine = float(moved @ want / max(1e-300, np.linalg.norm(moved) * np.linalg.norm(want)))
    ratio = (after[0] / before[0] + after[1] / before[1]) / 2.0

    evidence: dict[str, Any] = {
        "edge": f"{EDGE_METERS:g} m along body x, {EDGE_DEGREES:g}° about body z",
        "convention": conv.name,
        "residual_norm_at": norms,
        "form": form or ("inverted" if inverted else "none"),
        "left_invariance_error": left,
        "right_invariance_error": right,
        "step": {
            "error_before_deg_m": before,
            "error_after_deg_m": after,
            "error_ratio": ratio,
            "direction_cosine": cosine,
            "jacobian": "user" if jacobian is not None else "finite differences",
        },
    }
    step_words = (
        f"first Gauss–Newton step: error {before[1]:.3g} m/{before[0]:.3g}° → "
        f"{after[1]:.3g} m/{after[0]:.3g}°, T_j moves with cosine {cosine:+.2f} to the true "
        "direction"
    )
    if inverted:
        return Diagnosis(
            "mistake",
            "the residual is inverted: it vanishes at T_j = "
            + (keys[2].split(" ")[0] if zero[keys[2]] else keys[3].split(" ")[0])
            + " instead of T_i·Z, so a loop closure moves the graph the opposite way ("
            + step_words
            + "). Fix: r = Log(Z⁻¹·T_i⁻¹·T_j) (right) or Log(T_j·T_i⁻¹·Z⁻¹) (left).",
            evidence,
            "inverted_residual",
        )
    if form is None:
        return Diagnosis(
            "mistake",
            "the residual is not zero at the measurement (‖r‖ at T_i·Z: "
            f"{norms[keys[0]]:.3g}, at Z·T_i: {norms[keys[1]]:.3g}): it does not measure "
            "T_i⁻¹·T_j against Z.",
            evidence,
            "not_zero_at_measurement",
        )
    inv_err, which = (left, "global (left, G·T)") if form == "body" else (right, "right (T·G)")
    if inv_err > 1e-6:
        return Diagnosis(
            "mistake",
            f"the residual is zero at the measurement but not invariant under a {which} frame "
            f"change (relative change {inv_err:.2g}): part of it is expressed in the world "
            "frame (e.g. t_j − t_i − R_i·z without R_iᵀ), so its weights depend on where the "
            "world frame is.",
            evidence,
            "not_frame_invariant",
        )
    if cosine < 0.5:
        return Diagnosis(
            "mistake",
            f"the {step_words}: the step goes the wrong way. The residual is right; its "
            "Jacobian is not the one of the solver's retraction (run diagnose_jacobian).",
            evidence,
            "step_wrong_direction",
        )
    if ratio > 0.5:
        return Diagnosis(
            "mistake",
            f"the {step_words}: the step barely reduces the error (its Jacobian is not the "
            "residual's through the solver's retraction: run diagnose_jacobian).",
            evidence,
            "step_does_not_reduce",
        )
    kind = (
        "a body-frame relative residual (zero at T_i·Z, invariant under G·T)"
        if form == "body"
        else "a world-frame relative residual (zero at Z·T_i, invariant under T·G)"
    )
    return Diagnosis("correct", f"{kind}; {step_words}.", evidence)
