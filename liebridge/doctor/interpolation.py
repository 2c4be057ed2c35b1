"""A user's pose interpolation: endpoints, validity, and which curve it follows."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .._validate import FloatArray
from ..lie import se3, so3
from .elements import as_element
from .jacobian import _Call
from .result import Diagnosis

__all__ = ["diagnose_interpolation"]

#: Interior parameters the curve is compared at.
TAUS = (0.25, 0.5, 0.75)


def _geodesic(T0: FloatArray, T1: FloatArray, tau: float) -> FloatArray:
    if T0.shape == (3, 3):
        return T0 @ so3.exp(tau * so3.log(T0.T @ T1))
    return T0 @ se3.exp(tau * se3.log(se3.inverse(T0) @ T1))


def _split(T0: FloatArray, T1: FloatArray, tau: float) -> FloatArray:
    out = T0.copy()
    R0, R1 = T0[:3, :3], T1[:3, :3]
    out[:3, :3] = R0 @ so3.exp(tau * so3.log(R0.T @ R1))
    if T0.shape == (4, 4):
        out[:3, 3] = (1 - tau) * T0[:3, 3] + tau * T1[:3, 3]
    return out


def diagnose_interpolation(
    interpolate: Callable[[Any, Any, float], Any],
    T0: Any,
    T1: Any,
    *,
    tol: float = 1e-9,
) -> Diagnosis:
    """Check a user's interpolation ``interpolate(T0, T1, tau)`` between two poses or rotations.

    Measured: ``T(0) = T0`` and ``T(1) = T1`` (the failure table's check; a wrong side or an
    unnormalized τ fails it), every ``T(τ)`` a valid pose (a linear blend of matrices is not),
    and which curve the interior points follow: the SE(3) geodesic
    ``T0·Exp(τ·Log(T0⁻¹·T1))`` (= ``Exp(τ·Log(T1·T0⁻¹))·T0``), or rotation and translation
    interpolated separately (SLERP and a straight line: also a valid interpolation, not the
    SE(3) geodesic). For rotations the geodesic is ``R0·Exp(τ·Log(R0ᵀ·R1))``.

    Parameters
    ----------
    interpolate : callable
        ``interpolate(T0, T1, tau)`` → pose (``(4, 4)``) or rotation (``(3, 3)``).
    T0, T1 : array_like, shape (4, 4) or (3, 3)
        The endpoints (not too close to each other: choose them ≥ 10° and 0.1 m apart).
    tol : float
        Max-abs entry difference counted as equal.

    Returns
    -------
    Diagnosis
        ``verdict`` ``"correct"`` or ``"mistake"``; ``cause`` ``"endpoint"``, ``"not_a_pose"``
        or ``"not_geodesic"``; ``evidence`` the endpoint errors and the distance of the interior
        points to each curve.
    """
    if not callable(interpolate):
        raise TypeError(f"interpolate: expected a callable, got {type(interpolate).__name__}")
    a, b = as_element(T0, "T0", so3.GROUP.name), as_element(T1, "T1", so3.GROUP.name)
    if a.record is not b.record or a.record not in (se3.GROUP, so3.GROUP):
        raise ValueError(
            f"T0, T1: expected two (4, 4) poses or two (3, 3) rotations, got {a.array.shape} and "
            f"{b.array.shape}"
        )
    call = _Call(interpolate, "interpolate")
    A, B = a.array, b.array

    def at(tau: float) -> FloatArray:
        Y = call([a.rebuild(A.copy()), b.rebuild(B.copy()), tau], f"tau = {tau:g}")
        if Y.shape != A.shape:
            raise ValueError(
                f"interpolate: returned shape {Y.shape} at tau = {tau:g}, expected {A.shape}"
            )
        return Y

    e0 = float(np.abs(at(0.0) - A).max())
    e1 = float(np.abs(at(1.0) - B).max())
    inner = {tau: at(tau) for tau in TAUS}
    ortho = max(float(np.abs(Y[:3, :3].T @ Y[:3, :3] - np.eye(3)).max()) for Y in inner.values())
    geo = max(float(np.abs(Y - _geodesic(A, B, t)).max()) for t, Y in inner.items())
    split = max(float(np.abs(Y - _split(A, B, t)).max()) for t, Y in inner.items())
    evidence = {
        "endpoint_errors": {"T(0) - T0": e0, "T(1) - T1": e1},
        "orthonormality_error": ortho,
        "distance_to_geodesic": geo,
        "distance_to_split": split,
        "taus": list(TAUS),
    }
    if e0 > tol or e1 > tol:
        return Diagnosis(
            "mistake",
            f"the interpolation misses its endpoints (|T(0) − T0| = {e0:.2g}, |T(1) − T1| = "
            f"{e1:.2g}): a side mix-up (e.g. Exp(τ·Log(T0⁻¹·T1))·T0) or τ not normalized to "
            "[0, 1]. Fix: T(τ) = T0·Exp(τ·Log(T0⁻¹·T1)), τ = (t − t0)/(t1 − t0).",
            evidence,
            "endpoint",
        )
    if ortho > 1e-6:
        return Diagnosis(
            "mistake",
            f"T(τ) is not a pose between the endpoints (|RᵀR − I| up to {ortho:.2g}): matrices "
            "blended linearly. Fix: T(τ) = T0·Exp(τ·Log(T0⁻¹·T1)).",
            evidence,
            "not_a_pose",
        )
    if geo <= tol:
        return Diagnosis(
            "correct",
            f"the geodesic T0·Exp(τ·Log(T0⁻¹·T1)) (distance {geo:.1e}); endpoints exact.",
            evidence,
        )
    if split <= tol:
        return Diagnosis(
            "correct",
            f"rotation and translation interpolated separately (SLERP and a straight line, "
            f"distance {split:.1e}); endpoints exact. A valid interpolation, though not the "
            f"SE(3) geodesic (distance {geo:.2g}): state which one your model assumes.",
            evidence,
        )
    return Diagnosis(
        "mistake",
        f"the interpolation hits its endpoints but follows neither the geodesic (distance "
        f"{geo:.2g}) nor separate SLERP + straight line ({split:.2g}).",
        evidence,
        "not_geodesic",
    )
