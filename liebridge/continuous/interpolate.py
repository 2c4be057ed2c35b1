"""Interpolation between two poses with analytic Jacobians, in any SE(3) convention.

Two named methods, both exact at the endpoints (``T(0)`` *is* ``T₀`` and ``T(1)`` *is* ``T₁``,
bit for bit):

* ``"se3"`` — the coupled SE(3) geodesic ``T(τ) = T₀·Exp(τ·Log(T₀⁻¹T₁))`` (a screw motion;
  KISS-ICP's deskew, kontiki);
* ``"split"`` — rotation by SLERP and translation by LERP,
  ``R(τ) = R₀·Exp(τ·Log(R₀ᵀR₁))``, ``t(τ) = (1 − τ)·t₀ + τ·t₁`` (CT-ICP, basalt's split splines,
  evo). The two differ whenever the rotation turns: ``"se3"`` moves along a helix, ``"split"``
  along the chord. SLERP here takes the rotation matrices' principal logarithm, so the
  quaternion sign (``q`` and ``−q``, the "antipodal" pitfall of hand-written SLERP) cannot send
  it the long way round.

Jacobians (the CT-ICP residual's chain rule): with the convention's retraction
``X ⊕ δ`` (``convention.retract``), ``J_T_T0 = ∂ T(τ; T₀ ⊕ δ₀, T₁) ⊖ T(τ) / ∂δ₀`` — columns in
the convention's tangent at ``T₀``, rows in its tangent at ``T(τ)`` — likewise ``J_T_T1``, and
``J_T_tau = ∂ T(τ + h) ⊖ T(τ) / ∂h``. In GTSAM's right (ω, v) tangent, with ``ξ = Log(T₀⁻¹T₁)``:
``J_T_T1 = τ·Jr(τξ)·Jr(ξ)⁻¹``, ``J_T_T0 = Ad(Exp(−τξ)) − τ·Jr(τξ)·Jl(ξ)⁻¹``, ``J_T_tau = ξ``.
Tempting and false: ``J_T_T0 = (1 − τ)·I`` and ``J_T_T1 = τ·I`` — true only without motion
(``T₀ = T₁``) and, for ``"split"``, for a pure translation; for ``"se3"`` a pure translation
already couples rotation into translation (the ``Q`` block of ``Jr``).
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike
from ..conventions import unchecked as cu
from ..lie import unchecked as lu
from ._common import convention as _se3_convention
from ._common import se3_jr, se3_jr_inv, to_conv_columns

__all__ = ["METHODS", "Interpolated", "interpolate"]

#: The interpolation methods, by name.
METHODS: tuple[str, ...] = ("se3", "split")
Method = Literal["se3", "split"]
#: The coupled method: the group's own geodesic (the other, ``"split"``, is SLERP + LERP).
COUPLED: str = METHODS[0]


class Interpolated(NamedTuple):
    """``T(τ)`` and its Jacobians (``None`` when ``jacobians=False``).

    Attributes
    ----------
    T : ndarray, shape (..., 4, 4)
        The interpolated pose.
    J_T_T0, J_T_T1 : ndarray, shape (..., 6, 6)
        ``∂T(τ)/∂T₀``, ``∂T(τ)/∂T₁`` in the convention's tangents (rows at ``T(τ)``, columns at
        the endpoint).
    J_T_tau : ndarray, shape (..., 6)
        ``∂T(τ)/∂τ`` in the convention's tangent at ``T(τ)`` (per unit of τ; divide by the
        interval's length for a velocity).
    """

    T: FloatArray
    J_T_T0: FloatArray | None
    J_T_T1: FloatArray | None
    J_T_tau: FloatArray | None


def _so3_jr(w: FloatArray) -> FloatArray:
    return np.asarray(lu.so3_jl(-w), dtype=np.float64)


def interp_canonical(
    T0: FloatArray, T1: FloatArray, tau: FloatArray, method: str, jacobians: bool
) -> tuple[FloatArray, FloatArray | None, FloatArray | None, FloatArray | None]:
    """Return ``T`` and canonical (GTSAM right, (ω, v)) Jacobians of validated, broadcast inputs."""
    tt = tau[..., None]
    if method == COUPLED:
        xi = np.asarray(lu.se3_log(lu.se3_inverse(T0) @ T1), dtype=np.float64)
        E = lu.se3_exp(tt * xi)
        T = np.asarray(T0 @ E, dtype=np.float64)
    else:
        R0, R1 = T0[..., :3, :3], T1[..., :3, :3]
        w = np.asarray(lu.so3_log(np.swapaxes(R0, -1, -2) @ R1), dtype=np.float64)
        Er = lu.so3_exp(tt * w)
        R = R0 @ Er
        p = (1.0 - tt) * T0[..., :3, 3] + tt * T1[..., :3, 3]
        T = np.asarray(lu.se3_assemble(R, p), dtype=np.float64)
    T = np.where((tau == 0.0)[..., None, None], T0, T)
    T = np.where((tau == 1.0)[..., None, None], T1, T)
    if not jacobians:
        return T, None, None, None
    if method == COUPLED:
        txi = tt * xi
        Jr_t = se3_jr(txi)
        J1 = tau[..., None, None] * Jr_t @ se3_jr_inv(xi)
        J0 = lu.se3_adjoint(lu.se3_exp(-txi)) - tau[..., None, None] * Jr_t @ lu.se3_jl_inv(xi)
        Jt = np.broadcast_to(xi, (*T.shape[:-2], 6)).copy()
        return T, np.asarray(J0, dtype=np.float64), np.asarray(J1, dtype=np.float64), Jt
    shape = T.shape[:-2]
    tw = tt * w
    Jr_t = _so3_jr(tw)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    J0 = np.zeros((*shape, 6, 6))
    J1 = np.zeros((*shape, 6, 6))
    t3 = tau[..., None, None]
    J0[..., :3, :3] = np.swapaxes(lu.so3_exp(tw), -1, -2) - t3 * Jr_t @ lu.so3_jl_inv(w)
    J1[..., :3, :3] = t3 * Jr_t @ lu.so3_jr_inv(w)
    J0[..., 3:, 3:] = (1.0 - t3) * Rt @ T0[..., :3, :3]
    J1[..., 3:, 3:] = t3 * Rt @ T1[..., :3, :3]
    Jt = np.zeros((*shape, 6))
    Jt[..., :3] = w
    Jt[..., 3:] = (Rt @ (T1[..., :3, 3] - T0[..., :3, 3])[..., None])[..., 0]
    return T, J0, J1, Jt


def prepare(T0: Any, T1: Any, tau: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Validate and broadcast ``(T0, T1, tau)``; named errors."""
    A = validate.pose(T0, "T0")
    B = validate.pose(T1, "T1")
    t = validate.as_float_array(tau, "tau")
    validate.check_finite(t, "tau", core_ndim=0)
    try:
        shape = np.broadcast_shapes(A.shape[:-2], B.shape[:-2], t.shape)
    except ValueError:
        raise ValueError(
            f"T0, T1, tau: batch shapes {A.shape[:-2]}, {B.shape[:-2]} and {t.shape} "
            f"do not broadcast"
        ) from None
    A = np.broadcast_to(A, (*shape, 4, 4))
    B = np.broadcast_to(B, (*shape, 4, 4))
    t = np.broadcast_to(t, shape)
    return A, B, t


def interpolate(
    T0: Any,
    T1: Any,
    tau: Any,
    method: Method | str = "se3",
    convention: ConventionLike = "gtsam",
    jacobians: bool = True,
) -> Interpolated:
    """Pose at normalised time ``tau`` between ``T0`` (τ = 0) and ``T1`` (τ = 1), with Jacobians.

    Parameters
    ----------
    T0, T1 : array_like, shape (..., 4, 4)
        ``T_world_body`` at the two ends (or GTSAM/Sophus/... pose objects); batch shapes
        broadcast with ``tau``'s.
    tau : array_like, shape (...)
        Normalised time; values outside [0, 1] extrapolate along the same curve.
    method : {"se3", "split"}
        Coupled SE(3) geodesic or SLERP + LERP (see the module docstring).
    convention : str or Convention
        SE(3) convention of the Jacobians' rows and columns (default GTSAM: right, (ω, v)).
        Storage of the poses is always the homogeneous matrix.
    jacobians : bool
        False skips them (the fields are None).

    Returns
    -------
    Interpolated
        ``(T, J_T_T0, J_T_T1, J_T_tau)``; the poses are exact at τ = 0 and τ = 1.

    Examples
    --------
    >>> import numpy as np
    >>> from liebridge.continuous import interpolate
    >>> from liebridge.lie import se3
    >>> T1 = se3.exp([0.0, 0.0, 1.0, 1.0, 0.0, 0.0])
    >>> out = interpolate(np.eye(4), T1, [0.0, 0.5, 1.0], method="split", convention="sophus")
    >>> out.T.shape, out.J_T_T0.shape, bool((out.T[2] == T1).all())
    ((3, 4, 4), (3, 6, 6), True)
    """
    conv = _se3_convention(convention)
    meth = validate.option(method, "method", METHODS)
    A, B, t = prepare(T0, T1, tau)
    T, J0, J1, Jt = interp_canonical(A, B, t, meth, jacobians)
    if not jacobians:
        return Interpolated(T, None, None, None)
    assert J0 is not None and J1 is not None and Jt is not None
    if conv.name != "gtsam":
        J0 = to_conv_columns(J0, conv, T, A)
        J1 = to_conv_columns(J1, conv, T, B)
        Jt = np.asarray((cu.from_canonical(conv, T) @ Jt[..., None])[..., 0], dtype=np.float64)
    return Interpolated(T, J0, J1, Jt)
