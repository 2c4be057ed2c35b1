"""SO(3) kernel in canonical form: batched, float64, inputs never mutated.

Conventions (the package's canonical ones, identical to GTSAM's ``Rot3``):

* rotations are ``(..., 3, 3)`` matrices acting on column vectors;
* the tangent is the rotation vector ``ω`` (``(..., 3)``), full angle ``θ = ‖ω‖``;
* ``hat(ω) p = ω × p``;
* ``jr`` is the *right* Jacobian: ``Exp(ω + δ) ≈ Exp(ω)·Exp(jr(ω) δ)``;
  ``jl`` the *left* one: ``Exp(ω + δ) ≈ Exp(jl(ω) δ)·Exp(ω)``; ``jl(ω) = jr(−ω) = R·jr(ω)``.
  (``jr`` is GTSAM's ``Rot3.ExpmapDerivative``; ``jr_inv`` its ``LogmapDerivative``.)

Sources: Barfoot, *State Estimation for Robotics* (2nd ed.) §7.1; Solà et al. arXiv 1812.01537
App. B; GTSAM ``gtsam/geometry/SO3.cpp`` (``DexpFunctor``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _compiled
from . import _matrix_group as _mg
from .record import Group, Kernels, register_shipped
from .series import angle, jinv_coeff, one_minus_cos_over_t2, sinc, t_minus_sin_over_t3

__all__ = [
    "act",
    "adjoint",
    "compose",
    "exp",
    "hat",
    "interpolate",
    "inverse",
    "jl",
    "jl_inv",
    "jr",
    "jr_inv",
    "log",
    "project",
    "vee",
]

#: Below ``cos θ`` this value, :func:`log` reads the axis from the symmetric part of R.
_NEAR_PI_COS = -0.5


def _hat(w: FloatArray) -> FloatArray:
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    return arrays.matrix([0.0, -z, y, z, 0.0, -x, -y, x, 0.0], 3, 3)


def _poly_entries(w: FloatArray, a: FloatArray | float, b: FloatArray) -> list[Any]:
    """Return the nine entries of ``I + a·hat(w) + b·hat(w)²``, row-major, as batch-length vectors.

    ``hat(w)² = w wᵀ − ‖w‖² I``: off the diagonal ``b·w_i w_j ± a·w_k``, on it
    ``1 − b·(w_j² + w_k²)``. Each entry is a few operations on whole batch-length vectors, the
    layout numpy evaluates fastest (an ``(N, 3)`` operand would loop over its length-3 rows).
    """
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    aw0, aw1, aw2 = a * w0, a * w1, a * w2
    bw0, bw1 = b * w0, b * w1
    p01, p02, p12 = bw0 * w1, bw0 * w2, bw1 * w2
    s0, s1, s2 = w0 * w0, w1 * w1, w2 * w2
    return [
        1.0 - b * (s1 + s2), p01 - aw2, p02 + aw1,
        p01 + aw2, 1.0 - b * (s0 + s2), p12 - aw0,
        p02 - aw1, p12 + aw0, 1.0 - b * (s0 + s1),
    ]  # fmt: skip


def _poly_into(out: FloatArray, w: FloatArray, a: FloatArray | float, b: FloatArray) -> None:
    """Write ``I + a·hat(w) + b·hat(w)²`` into the numpy array ``out`` ``(..., 3, 3)``."""
    for k, e in enumerate(_poly_entries(w, a, b)):
        out[..., k // 3, k % 3] = e


def _poly(w: FloatArray, a: FloatArray | float, b: FloatArray) -> FloatArray:
    """``I + a·hat(w) + b·hat(w)²`` with scalar-per-batch coefficients ``a`` and ``b``."""
    return arrays.matrix(_poly_entries(w, a, b), 3, 3)


def _exp(w: FloatArray) -> FloatArray:
    out = _compiled.run_any_layout(_compiled.SO3_EXP, w)
    if out is not None:  # the compiled pass of the same formula, where built
        return out
    th, t2 = angle(w)
    return _poly(w, sinc(th, t2), one_minus_cos_over_t2(th, t2))


def _jr(w: FloatArray) -> FloatArray:
    th, t2 = angle(w)
    return _poly(w, -one_minus_cos_over_t2(th, t2), t_minus_sin_over_t3(th, t2))


def _jl(w: FloatArray) -> FloatArray:
    th, t2 = angle(w)
    return _poly(w, one_minus_cos_over_t2(th, t2), t_minus_sin_over_t3(th, t2))


def _jr_inv(w: FloatArray) -> FloatArray:
    th, t2 = angle(w)
    return _poly(w, 0.5, jinv_coeff(th, t2))


def _jl_inv(w: FloatArray) -> FloatArray:
    th, t2 = angle(w)
    return _poly(w, -0.5, jinv_coeff(th, t2))


def hat(w: Any) -> FloatArray:
    """Skew matrix of a 3-vector.

    Parameters
    ----------
    w : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``hat(w) @ p == cross(w, p)``.
    """
    return _hat(validate.vector(w, "w", 3))


def vee(W: Any) -> FloatArray:
    """Inverse of :func:`hat`: the 3-vector of the skew part of ``W``, shape ``(..., 3)``.

    Uses ``(W − Wᵀ)/2`` so that a slightly non-skew input gives its nearest skew matrix's vector.
    """
    W = validate.square(W, "W", 3)
    w = 0.5 * arrays.vector(
        [W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]]
    )
    return validate.finite_output(w, "so3.vee")


def exp(w: Any) -> FloatArray:
    """Exponential map (Rodrigues): rotation vector ``(..., 3)`` → rotation ``(..., 3, 3)``.

    ``Exp(ω) = I + (sin θ/θ) hat(ω) + ((1 − cos θ)/θ²) hat(ω)²``, Taylor series near 0.
    """
    out = None if arrays.is_foreign(w) else _compiled.run(_compiled.SO3_EXP, w)
    if out is not None:  # the compiled pass, where built (numpy input)
        return out
    return validate.finite_output(_exp(validate.tangent(w, "w", 3)), "so3.exp")


def _axis_near_pi(
    r: list[Any], c: FloatArray, theta: FloatArray, s: tuple[Any, Any, Any]
) -> tuple[Any, Any, Any]:
    """``θ·u`` read from the symmetric part of ``R`` (entries ``r``, row-major): for cos θ < −½.

    ``S = (R + Rᵀ)/2 − cos θ·I = (1 − cos θ) u uᵀ``: its column with the largest diagonal entry
    (the first of equal ones), the sign from ``s = sin θ·u``.
    """
    xp = arrays.namespace(*r)
    d0, d1, d2 = r[0] - c, r[4] - c, r[8] - c
    s01, s02, s12 = 0.5 * (r[1] + r[3]), 0.5 * (r[2] + r[6]), 0.5 * (r[5] + r[7])
    k0 = (d0 >= d1) & (d0 >= d2)
    k1 = ~k0 & (d1 >= d2)
    u0 = xp.where(k0, d0, xp.where(k1, s01, s02))
    u1 = xp.where(k0, s01, xp.where(k1, d1, s12))
    u2 = xp.where(k0, s02, xp.where(k1, s12, d2))
    n2 = u0 * u0 + u1 * u1 + u2 * u2
    norm = xp.sqrt(xp.where(n2 > 0.0, n2, 1.0 + 0.0 * n2))  # 0 only away from π (unselected)
    dot = u0 * s[0] + u1 * s[1] + u2 * s[2]
    scale = xp.where(dot < 0.0, -theta, theta) / norm
    return scale * u0, scale * u1, scale * u2


def _log(R: FloatArray) -> FloatArray:
    out = _compiled.run_any_layout(_compiled.SO3_LOG, R)
    if out is not None:  # the compiled pass of the same formula, where built
        return out
    # s = vee((R − Rᵀ)/2) = sin θ · u and c = (tr R − 1)/2 = cos θ, as batch-length vectors
    s0 = 0.5 * (R[..., 2, 1] - R[..., 1, 2])
    s1 = 0.5 * (R[..., 0, 2] - R[..., 2, 0])
    s2 = 0.5 * (R[..., 1, 0] - R[..., 0, 1])
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    near_pi = c < _NEAR_PI_COS
    if arrays.is_foreign(R):  # every entry through both branches, selected by where (traceable)
        xp = arrays.namespace(R)
        sn, _ = angle(xp.stack([s0, s1, s2], axis=-1))  # ‖s‖, differentiable at s = 0
        theta = xp.atan2(sn, c)
        k = 1.0 / xp.where(near_pi, 1.0 + 0.0 * theta, sinc(theta))
        entries = [R[..., i, j] for i in range(3) for j in range(3)]
        a0, a1, a2 = _axis_near_pi(entries, c, theta, (s0, s1, s2))
        return xp.stack(
            [
                xp.where(near_pi, a0, s0 * k),
                xp.where(near_pi, a1, s1 * k),
                xp.where(near_pi, a2, s2 * k),
            ],
            axis=-1,
        )
    theta = np.arctan2(np.sqrt(s0 * s0 + s1 * s1 + s2 * s2), c)
    # generic and small angles: ω = θ/sin θ · s (series through sinc)
    near_pi = np.asarray(near_pi)
    k = 1.0 / np.where(near_pi, 1.0, sinc(theta))
    w = np.empty((*R.shape[:-2], 3))
    w[..., 0], w[..., 1], w[..., 2] = s0 * k, s1 * k, s2 * k
    if near_pi.any():  # only on those entries: gathered once by index, then scattered back
        idx = np.nonzero(near_pi) if near_pi.ndim else near_pi  # (0-d: the mask itself)
        r = R[idx].reshape(-1, 9)  # rows r00 r01 r02 r10 ... r22
        a0, a1, a2 = _axis_near_pi(
            [r[:, k] for k in range(9)], c[idx], theta[idx], (s0[idx], s1[idx], s2[idx])
        )
        w[idx] = np.stack([a0, a1, a2], axis=-1)
    return w


def log(R: Any) -> FloatArray:
    """Logarithm map: rotation ``(..., 3, 3)`` → rotation vector ``(..., 3)`` with ``θ ∈ [0, π]``.

    The angle is ``atan2(‖s‖, (tr R − 1)/2)`` with ``s = vee((R − Rᵀ)/2) = sin θ·u`` (accurate at
    0 and π, unlike ``acos``). For ``cos θ < −1/2`` the axis is read from the symmetric part
    ``(R + Rᵀ)/2 − cos θ·I = (1 − cos θ) u uᵀ`` (largest diagonal column), its sign from ``s``;
    at θ = π exactly both ``±π u`` are logarithms and the one with the sign of that column is
    returned. Raises ``ValueError`` on a non-rotation (see :mod:`liebridge._validate`).
    """
    out = None if arrays.is_foreign(R) else _compiled.run(_compiled.SO3_LOG, R)
    if out is not None:
        return out
    return _log(validate.rotation(R, "R"))


def jr(w: Any) -> FloatArray:
    """Right Jacobian of SO(3): ``I − B hat(ω) + C hat(ω)²``; ``Exp(ω+δ) ≈ Exp(ω) Exp(jr δ)``."""
    return validate.finite_output(_jr(validate.tangent(w, "w", 3)), "so3.jr")


def jl(w: Any) -> FloatArray:
    """Left Jacobian of SO(3): ``I + B hat(ω) + C hat(ω)²`` ``= jr(−ω)``; also SE(3)'s ``V(ω)``."""
    return validate.finite_output(_jl(validate.tangent(w, "w", 3)), "so3.jl")


def jr_inv(w: Any) -> FloatArray:
    """Inverse right Jacobian, closed form ``I + ½ hat(ω) + D hat(ω)²``, finite up to θ = π."""
    return validate.finite_output(_jr_inv(validate.tangent(w, "w", 3)), "so3.jr_inv")


def jl_inv(w: Any) -> FloatArray:
    """Inverse left Jacobian ``I − ½ hat(ω) + D hat(ω)²`` ``= jr_inv(−ω)``; SE(3)'s ``V(ω)⁻¹``."""
    return validate.finite_output(_jl_inv(validate.tangent(w, "w", 3)), "so3.jl_inv")


def adjoint(R: Any) -> FloatArray:
    """Adjoint of SO(3), which is ``R`` itself: ``R·Exp(ω)·Rᵀ = Exp(R ω)``. Returns a copy."""
    return _adjoint_k(validate.rotation(R, "R"))


@arrays.numpy_only
def project(M: Any) -> FloatArray:
    """Closest rotation to ``M`` in Frobenius norm (SVD, ``U diag(1, 1, det(UVᵀ)) Vᵀ``).

    An explicit opt-in for inputs that drifted from orthonormality; nothing in liebridge calls it
    silently.
    """
    M = validate.square(M, "M", 3)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    d = np.where(d == 0, 1.0, d)
    D = np.broadcast_to(np.eye(3), (*M.shape[:-2], 3, 3)).copy()
    D[..., 2, 2] = d
    return np.asarray(U @ D @ Vt, dtype=np.float64)


def _inverse(R: FloatArray) -> FloatArray:
    if arrays.is_foreign(R):
        return arrays.mT(R)
    return np.array(np.swapaxes(R, -1, -2), dtype=np.float64)


def _adjoint_k(R: FloatArray) -> FloatArray:
    if arrays.is_foreign(R):
        return R * 1.0
    return np.array(R, dtype=np.float64, copy=True)


def inverse(R: Any) -> FloatArray:
    """``R⁻¹ = Rᵀ``: ``inverse(R_world_body) = R_body_world``."""
    return _inverse(validate.rotation(R, "R"))


def compose(R1: Any, R2: Any) -> FloatArray:
    """``R1·R2`` (broadcast): ``compose(R_a_b, R_b_c) = R_a_c``."""
    return _mg.compose(R1, R2, validate.rotation, ("R1", "R2"), "so3.compose")


def act(R: Any, p: Any) -> FloatArray:
    """``R p`` for points ``(..., 3)``: ``act(R_world_body, p_body) = p_world``."""
    R = validate.rotation(R, "R")
    p = validate.vector(p, "p", 3)
    validate.batch_shape(("R", R.shape[:-2]), ("p", p.shape[:-1]))
    return validate.finite_output(arrays.matvec(R, p), "so3.act")


def interpolate(R0: Any, R1: Any, tau: Any) -> FloatArray:
    """Geodesic ``R0·Exp(τ·Log(R0ᵀR1))`` (SLERP on matrices); ``τ`` broadcasts against the batch.

    ``τ = 0`` gives ``R0`` and ``τ = 1`` gives ``R1``; the arc is the principal one (angle ≤ π).
    Tempting and false: ``Exp((1 − τ)·Log(R0) + τ·Log(R1))``, which is not a geodesic.
    """
    ops = (_log, _exp, _inverse)

    def tangent(w: Any, name: str) -> FloatArray:
        return validate.tangent(w, name, 3)

    return _mg.interpolate(
        R0, R1, tau, validate.rotation, tangent, ops, ("R0", "R1"), "so3.interpolate"
    )


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="so3", dim=3, matrix=3, rot=slice(0, 3), vecs=(), cols=(), scale=None,
        element=validate.rotation,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint_k, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl,
        ),
        charts=("se3", "so3xr3_body", "so3xr3_world"),
        chart_aliases={"so3": "se3", "split_body": "so3xr3_body", "split_world": "so3xr3_world"},
        probe=_exp(np.array([0.4, -0.7, 0.5])), label="SO(3)", tangent_doc="(ω,)",
        array_api=True,
    )
)  # fmt: skip
