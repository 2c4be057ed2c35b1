"""Sim(3) kernel in canonical form (GTSAM ``Similarity3``'s tangent): batched, float64.

Canonical conventions:

* an element is the ``(..., 4, 4)`` matrix ``X = [[sR, t], [0, 1]]`` with ``s > 0`` (Sophus
  ``Sim3::matrix()``, Umeyama, evo, COLMAP): ``act(X, p) = sRp + t``. **GTSAM's
  ``Similarity3(R, t_g, s).matrix()`` is ``[[R, t_g], [0, 1/s]]``**, the same map scaled by
  ``1/s``: its translation argument is ``t_g = t/s``. Divide GTSAM's matrix by its ``[3, 3]``
  entry to get liebridge's; the validation rejects the other form with that hint;
* a tangent is ``ξ = (ω, u, λ)``, shape ``(..., 7)`` (GTSAM's order; ``λ`` = log-scale);
* ``hat(ξ) = [[hat(ω) + λI, u], [0, 0]]`` and ``Exp(ξ) = expm(hat ξ) = [[e^λ Exp(ω), W u], [0, 1]]``
  with ``W = ∫₀¹ e^{λτ} Exp(τω) dτ`` (:func:`liebridge.lie.series.sim3_coeffs`). GTSAM's
  algebra element ``[[hat ω, u], [0, −λ]]`` differs by ``λI₄``, which commutes, so
  ``Similarity3.Expmap(ξ)`` is the same similarity (measured: equal after normalising);
* ``adjoint(X) = [[R, 0, 0], [hat(t)R, sR, −t], [0, 0, 1]]``: ``X·Exp(ξ)·X⁻¹ = Exp(Ad_X ξ)``
  (GTSAM ``Similarity3.AdjointMap``, with its ``t_g`` replaced by ``t = s·t_g``);
* ``jl(ξ) = φ(ad_ξ)``, ``jr(ξ) = φ(−ad_ξ)``, ``φ(x) = (eˣ − 1)/x``, evaluated as the top-right
  block of ``expm([[ad_ξ, I], [0, 0]])`` (scaling and squaring, accurate at every magnitude; no
  cancelling closed form); ``jl_inv``/``jr_inv`` are their inverses (``θ < 2π``).

The log is exact at θ = π (the rotation's log is :func:`liebridge.lie.so3.log`);
``s = cbrt(det(sR))``, ``λ = log s``, ``u = W⁻¹ t``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from . import _matrix_group as _mg
from . import so3
from .record import Group, Kernels, register_shipped
from .series import sim3_coeffs

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
    "vee",
]

#: Tangent dimension and matrix size.
DIM, MATRIX = 7, 4


def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    return np.einsum("...ij,...j->...i", A, x)


def _w_matrix(w: FloatArray, lam: FloatArray) -> FloatArray:
    a, b, c = sim3_coeffs(np.linalg.norm(w, axis=-1), lam)
    return so3._poly(w, b / a, c / a) * a[..., None, None]


def _assemble(A: FloatArray, t: FloatArray) -> FloatArray:
    X = np.zeros((*np.broadcast_shapes(A.shape[:-2], t.shape[:-1]), 4, 4))
    X[..., :3, :3] = A
    X[..., :3, 3] = t
    X[..., 3, 3] = 1.0
    return X


def _exp(xi: FloatArray) -> FloatArray:
    w, u, lam = xi[..., :3], xi[..., 3:6], xi[..., 6]
    W = _w_matrix(w, lam)
    return _assemble(np.exp(lam)[..., None, None] * so3._exp(w), _mv(W, u))


def _scale(X: FloatArray) -> FloatArray:
    # det(sR) = s³ under- or overflows for s below ≈ 1e-103 or above ≈ 1e102: take it of the
    # block divided by a power of two m ≥ its largest entry (exact), then s = m·cbrt(det(A/m))
    A = X[..., :3, :3]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        big = np.max(np.abs(A), axis=(-1, -2))
        m = np.ldexp(1.0, np.frexp(np.where(np.isfinite(big) & (big > 0), big, 1.0))[1])
        s = m * np.cbrt(np.linalg.det(A / m[..., None, None]))
    return np.asarray(s, dtype=np.float64)


def _log(X: FloatArray) -> FloatArray:
    s = _scale(X)
    w = so3._log(X[..., :3, :3] / s[..., None, None])
    lam = np.log(s)
    u = np.linalg.solve(_w_matrix(w, lam), X[..., :3, 3][..., None])[..., 0]
    return np.concatenate([w, u, lam[..., None]], axis=-1)


def _inverse(X: FloatArray) -> FloatArray:
    s = _scale(X)
    Ai = np.swapaxes(X[..., :3, :3], -1, -2) / (s * s)[..., None, None]  # (sR)⁻¹ = Rᵀ/s
    return _assemble(Ai, -_mv(Ai, X[..., :3, 3]))


def _adjoint(X: FloatArray) -> FloatArray:
    s = _scale(X)
    A = X[..., :3, :3]
    R = A / s[..., None, None]
    t = X[..., :3, 3]
    out = np.zeros((*X.shape[:-2], 7, 7))
    out[..., :3, :3] = R
    out[..., 3:6, :3] = so3._hat(t) @ R
    out[..., 3:6, 3:6] = A
    out[..., 3:6, 6] = -t
    out[..., 6, 6] = 1.0
    return out


def _ad(xi: FloatArray) -> FloatArray:
    """``ad_ξ = [[hat ω, 0, 0], [hat u, hat ω + λI, −u], [0, 0, 0]]``: ``ad_ξ η = [ξ, η]``."""
    W = so3._hat(xi[..., :3])
    out = np.zeros((*xi.shape[:-1], 7, 7))
    out[..., :3, :3] = W
    out[..., 3:6, :3] = so3._hat(xi[..., 3:6])
    out[..., 3:6, 3:6] = W + xi[..., 6, None, None] * np.eye(3)
    out[..., 3:6, 6] = -xi[..., 3:6]
    return out


def _phi(A: FloatArray) -> FloatArray:
    """``φ(A) = Σ Aᵏ/(k+1)!`` as the top-right block of ``expm([[A, I], [0, 0]])``."""
    from scipy.linalg import expm

    n = A.shape[-1]
    big = np.zeros((*A.shape[:-2], 2 * n, 2 * n))
    big[..., :n, :n] = A
    big[..., :n, n:] = np.eye(n)
    return np.asarray(expm(big)[..., :n, n:], dtype=np.float64)


def _jl(xi: FloatArray) -> FloatArray:
    return _phi(_ad(xi))


def _jr(xi: FloatArray) -> FloatArray:
    return _phi(-_ad(xi))


def _jl_inv(xi: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.inv(_jl(xi)), dtype=np.float64)


def _jr_inv(xi: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.inv(_jr(xi)), dtype=np.float64)


def _tangent(xi: Any, name: str = "xi") -> FloatArray:
    return validate.tangent(xi, name, 7, slice(0, 3))


@arrays.numpy_only
def hat(xi: Any) -> FloatArray:
    """``(ω, u, λ)`` → ``[[hat(ω) + λI, u], [0, 0]]``, ``(..., 4, 4)``."""
    xi = validate.vector(xi, "xi", 7)
    out = np.zeros((*xi.shape[:-1], 4, 4))
    out[..., :3, :3] = so3._hat(xi[..., :3]) + xi[..., 6, None, None] * np.eye(3)
    out[..., :3, 3] = xi[..., 3:6]
    return out


@arrays.numpy_only
def vee(X: Any) -> FloatArray:
    """Inverse of :func:`hat`: ω from the skew part, ``λ = tr/3`` of the top-left block, ``u``."""
    X = validate.square(X, "X", 4)
    lam = np.trace(X[..., :3, :3], axis1=-2, axis2=-1) / 3.0
    return np.concatenate([so3.vee(X[..., :3, :3]), X[..., :3, 3], lam[..., None]], axis=-1)


@arrays.numpy_only
def exp(xi: Any) -> FloatArray:
    """Sim(3) exponential ``(ω, u, λ)`` → ``[[e^λ Exp(ω), W u], [0, 1]]``, ``(..., 4, 4)``.

    Raises ``ValueError`` when the scale ``e^λ`` is not a normal float64 (``λ < −708``: it would
    round to a subnormal or to 0, a matrix that is no similarity), naming the batch index.
    """
    x = _tangent(xi)
    lam_min = -708.3964185322641  # log of float64's smallest normal number: e^λ stays normal
    tiny = x[..., 6] < lam_min
    if tiny.any():
        i = validate.batch_index(np.asarray(tiny))
        raise ValueError(
            f"xi: log-scale λ = {float(x[..., 6][i]):.6g} at batch index {i} is below "
            f"{lam_min:.6g}: the scale e^λ underflows float64 (no similarity has scale 0)"
        )
    return validate.finite_output(_exp(x), "sim3.exp")


@arrays.numpy_only
def log(X: Any) -> FloatArray:
    """Sim(3) logarithm → ``(ω, u, λ)``, ``‖ω‖ ∈ [0, π]``. GTSAM ``Similarity3.Logmap``."""
    return validate.finite_output(_log(validate.similarity(X, "X")), "sim3.log")


@arrays.numpy_only
def jr(xi: Any) -> FloatArray:
    """Right Jacobian ``Exp(ξ + δ) ≈ Exp(ξ)·Exp(jr δ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_jr(_tangent(xi)), "sim3.jr")


@arrays.numpy_only
def jl(xi: Any) -> FloatArray:
    """Left Jacobian ``Exp(ξ + δ) ≈ Exp(jl δ)·Exp(ξ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_jl(_tangent(xi)), "sim3.jl")


@arrays.numpy_only
def jr_inv(xi: Any) -> FloatArray:
    """Inverse right Jacobian, ``(..., 7, 7)``."""
    return validate.finite_output(_jr_inv(_tangent(xi)), "sim3.jr_inv")


@arrays.numpy_only
def jl_inv(xi: Any) -> FloatArray:
    """Inverse left Jacobian, ``(..., 7, 7)``."""
    return validate.finite_output(_jl_inv(_tangent(xi)), "sim3.jl_inv")


@arrays.numpy_only
def adjoint(X: Any) -> FloatArray:
    """``Ad_X = [[R, 0, 0], [hat(t)R, sR, −t], [0, 0, 1]]`` in ``(ω, u, λ)``, ``(..., 7, 7)``."""
    return validate.finite_output(_adjoint(validate.similarity(X, "X")), "sim3.adjoint")


@arrays.numpy_only
def inverse(X: Any) -> FloatArray:
    """``[[Rᵀ/s, −Rᵀt/s], [0, 1]]``."""
    return validate.finite_output(_inverse(validate.similarity(X, "X")), "sim3.inverse")


@arrays.numpy_only
def compose(X1: Any, X2: Any) -> FloatArray:
    """``X1·X2`` (broadcast)."""
    return _mg.compose(X1, X2, validate.similarity, ("X1", "X2"), "sim3.compose")


@arrays.numpy_only
def act(X: Any, p: Any) -> FloatArray:
    """``sRp + t`` for points ``(..., 3)`` (GTSAM ``transformFrom``)."""
    return _mg.act(X, p, validate.similarity, 3, ("X", "p"), "sim3.act")


@arrays.numpy_only
def interpolate(X0: Any, X1: Any, tau: Any) -> FloatArray:
    """Geodesic ``X0·Exp(τ·Log(X0⁻¹X1))``; ``τ`` broadcasts against the batch."""
    ops = (_log, _exp, _inverse)
    return _mg.interpolate(
        X0, X1, tau, validate.similarity, _tangent, ops, ("X0", "X1"), "sim3.interpolate"
    )


# ----------------------------------------------------------------------------- the record
GROUP = register_shipped(
    Group(
        name="sim3", dim=7, matrix=4, rot=slice(0, 3), vecs=(slice(3, 6),), cols=(3,), scale=6,
        element=validate.similarity,
        kernels=Kernels(
            exp=_exp, log=_log, inverse=_inverse, adjoint=_adjoint, jr_inv=_jr_inv,
            jl_inv=_jl_inv, jr=_jr, jl=_jl, scale=_scale,
        ),
        probe=_exp(np.array([0.4, -0.7, 0.5, 1.5, -2.0, 0.8, 0.3])), label="Sim(3)",
        tangent_doc="(ω, u, λ)",
    )
)  # fmt: skip
