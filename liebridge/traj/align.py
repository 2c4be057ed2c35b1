"""Umeyama alignment of an estimated trajectory to a reference, with its covariances.

An alignment is a similarity ``S = (s, R, t)`` acting on the estimate's world frame: a pose
``T_est = [[R_i, p_i], [0, 1]]`` becomes ``S ⊙ T_est = [[R R_i, s R p_i + t], [0, 1]]`` (evo's
``scale(s)`` then ``transform(se3(R, t))``). Its parameters minimise
``Σ_i ‖p_ref,i − (s R p_est,i + t)‖²`` over the positions only (Umeyama 1991, eq. 34–43, as in
evo 1.38 ``evo/core/geometry.py::umeyama_alignment``):

* ``"se3"``  — ``R ∈ SO(3)``, ``t``, ``s = 1`` (6 DoF);
* ``"sim3"`` — ``R``, ``t`` and the scale ``s`` (7 DoF, monocular);
* ``"4dof"`` — a rotation about the world ``z`` axis only (yaw) and ``t``, ``s = 1`` (4 DoF: the
  unobservable directions of visual-inertial odometry with gravity along ``z``; closed form
  ``θ = atan2(Σ (x × y)_z, Σ x_xy · y_xy)`` over the centred positions, as in
  rpg_trajectory_evaluation ``align_trajectory.py::get_best_yaw``);
* ``"none"`` — the identity.

**Covariances move with the poses.** Left-multiplying every pose by a rigid ``G`` leaves GTSAM's
right (body) twist unchanged, ``G·(X·Exp(ξ)) = (G X)·Exp(ξ)``; scaling the translations by ``s``
scales its ``v`` part, ``(R, s p)·Exp((ω, s v)) = scale_s(X·Exp((ω, v)))`` exactly. So an increment
``d`` in the estimate's convention at ``X`` becomes, at ``X' = S ⊙ X``,
``d' = J d`` with ``J = from_canonical(X') · diag(I₃, s I₃) · to_canonical(X)``, and
``Σ' = J Σ Jᵀ``. For right-perturbation conventions ``J`` is the identity under ``"se3"``/``"4dof"``
(tempting and false: that it is the identity for every convention — a left (world-frame)
covariance rotates with the world, ``Σ' = Ad_G Σ Ad_Gᵀ``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike, get, pose_convention
from ..conventions import unchecked as cu
from ..lie import GROUPS

__all__ = ["ALIGNMENTS", "Alignment", "AlignmentKind", "align", "umeyama"]

AlignmentKind = Literal["se3", "sim3", "4dof", "none"]
#: The alignment kinds, as the CLI's ``--align`` takes them.
ALIGNMENTS: tuple[str, ...] = ("se3", "sim3", "4dof", "none")
_MIN_POSES = 3


def _with_scale(kind: str) -> bool:
    """Whether an alignment of ``kind`` estimates a scale (the group of that name has one)."""
    return kind in GROUPS and GROUPS[kind].scale is not None


@dataclass(frozen=True)
class Alignment:
    """A similarity ``S = (scale, R, t)`` taking the estimate's world frame to the reference's.

    Attributes
    ----------
    kind : str
        ``"se3"``, ``"sim3"``, ``"4dof"`` or ``"none"``.
    R_ref_est : ndarray, shape (3, 3)
    t_ref_est : ndarray, shape (3,)
    scale : float
        1 unless ``kind == "sim3"``.
    """

    kind: str
    R_ref_est: FloatArray
    t_ref_est: FloatArray
    scale: float = 1.0

    @property
    def matrix(self) -> FloatArray:
        """The 4×4 similarity ``[[s R, t], [0, 1]]`` (evo's ``sim3(r, t, s)``)."""
        S = np.eye(4)
        S[:3, :3] = self.scale * self.R_ref_est
        S[:3, 3] = self.t_ref_est
        return S

    def apply(self, T_est: Any) -> FloatArray:
        """Poses of the estimate in the reference's world frame: ``[[R R_i, s R p_i + t], …]``.

        Parameters
        ----------
        T_est : array_like, shape (..., 4, 4)

        Raises
        ------
        ValueError
            An aligned position float64 cannot hold (``scale`` times a huge position), naming the
            first batch index and the count.
        """
        T = validate.pose(T_est, "T_est")
        out = np.array(T, dtype=np.float64, copy=True)
        out[..., :3, :3] = self.R_ref_est @ T[..., :3, :3]
        with np.errstate(over="ignore", invalid="ignore"):  # reported below, by index
            out[..., :3, 3] = (self.scale * T[..., :3, 3]) @ self.R_ref_est.T + self.t_ref_est
        bad = ~np.isfinite(out[..., :3, 3]).all(axis=-1)
        if bad.any():
            i = tuple(int(k) for k in np.argwhere(bad)[0])
            raise ValueError(
                f"T_est: the aligned position at batch index {i} overflows float64 (scale "
                f"{self.scale:.3g} times a position of {float(np.abs(T[i][:3, 3]).max()):.3g} m, "
                f"{int(bad.sum())} pose(s) in all)"
            )
        return out

    def covariance_map(self, T_est: Any, convention: ConventionLike) -> FloatArray:
        """``J`` with ``d' = J d``: an increment at ``T_est`` to one at ``apply(T_est)``.

        Both increments are in ``convention`` (see the module docstring), shape (..., 6, 6).
        """
        conv = get(convention)
        pose_convention(conv, "convention", np.eye(4))
        T = validate.pose(T_est, "T_est")
        D = np.diag([1.0, 1.0, 1.0, self.scale, self.scale, self.scale])
        with np.errstate(over="ignore", invalid="ignore"):  # reported by finite_output
            J = cu.from_canonical(conv, self.apply(T)) @ D @ cu.to_canonical(conv, T)
        return validate.finite_output(np.asarray(J, dtype=np.float64), "covariance_map")

    def transform_covariance(
        self, T_est: Any, cov_est: Any, convention: ConventionLike
    ) -> FloatArray:
        """Covariances of the aligned estimate, ``J Σ Jᵀ`` (see :meth:`covariance_map`).

        Parameters
        ----------
        T_est : array_like, shape (..., 4, 4)
            The estimate **before** alignment (where ``cov_est`` is expressed).
        cov_est : array_like, shape (..., 6, 6)
            In ``convention``'s tangent at ``T_est``.
        convention : Convention or str
            The estimator's convention.

        Returns
        -------
        ndarray, shape (..., 6, 6)
            In ``convention``'s tangent at ``apply(T_est)``.

        Raises
        ------
        ValueError
            A covariance float64 cannot hold (a left convention at translations beyond ≈ 1e150
            scales entries by their square), naming the first batch index.
        """
        cov = validate.covariance(cov_est, "cov_est", 6)
        J = self.covariance_map(T_est, convention)
        validate.batch_shape(("T_est", J.shape[:-2]), ("cov_est", cov.shape[:-2]))
        with np.errstate(over="ignore", invalid="ignore"):  # reported by finite_output
            out = J @ cov @ np.swapaxes(J, -1, -2)
            out = 0.5 * (out + np.swapaxes(out, -1, -2))
        return validate.finite_output(np.asarray(out, dtype=np.float64), "transform_covariance")


def _positions(x: Any, name: str) -> FloatArray:
    p = validate.vector(x, name, 3)
    if p.ndim != 2:
        raise ValueError(f"{name}: expected shape (N, 3), got {p.shape}")
    return p


def umeyama(p_ref: Any, p_est: Any, kind: AlignmentKind | str = "se3") -> Alignment:
    """Least-squares alignment of positions ``p_ref ≈ s R p_est + t``.

    Reference first, estimate second, like :func:`align` (``align(T_ref, T_est)``). Tempting and
    false: evo's order — ``umeyama_alignment(x, y)`` takes the estimate ``x`` first.

    Parameters
    ----------
    p_ref, p_est : array_like, shape (N, 3)
        Associated positions, N ≥ 3.
    kind : {"se3", "sim3", "4dof", "none"}

    Raises
    ------
    ValueError
        Fewer than 3 positions, different lengths, an unknown ``kind``, or positions too
        degenerate to fix the rotation (all on a line, or all equal).
    """
    if kind not in ALIGNMENTS:
        raise ValueError(f"kind: expected one of {', '.join(ALIGNMENTS)}, got {kind!r}")
    y = _positions(p_ref, "p_ref")
    x = _positions(p_est, "p_est")
    if x.shape != y.shape:
        raise ValueError(f"p_ref, p_est: different numbers of positions, {len(y)} and {len(x)}")
    if kind == "none":
        return Alignment("none", np.eye(3), np.zeros(3), 1.0)
    if len(x) < _MIN_POSES:
        raise ValueError(
            f"alignment {kind!r} needs at least {_MIN_POSES} associated poses, got {len(x)}"
        )
    # R does not change when x and y are each scaled by a positive factor, s scales by their
    # ratio and t follows: both are divided by an exact power of two near their largest
    # magnitude first, so that no square, product or sum overflows or underflows (positions of
    # 1e-300 m or 1e300 m, spreads 1e200 apart, are aligned as at unit scale)
    x, ex = _unit_scaled(x)
    y, ey = _unit_scaled(y)
    n = len(x)
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    eps = float(np.finfo(np.float64).eps)
    if kind == "4dof":
        a_c = float(np.sum(xc[:, 0] * yc[:, 0] + xc[:, 1] * yc[:, 1]))
        a_s = float(np.sum(xc[:, 0] * yc[:, 1] - xc[:, 1] * yc[:, 0]))
        # scale-free tests (the positions are at unit scale here): a horizontal spread above
        # the rounding of the centring, and |(a_c, a_s)| above the rounding of its own bound
        # ‖xc_xy‖·‖yc_xy‖ (Cauchy-Schwarz)
        sx, sy = float(np.linalg.norm(xc[:, :2])), float(np.linalg.norm(yc[:, :2]))
        floor = 64 * eps * math.sqrt(n)
        if not (sx > floor and sy > floor and np.hypot(a_c, a_s) > 8 * eps * sx * sy):
            raise ValueError(
                "alignment '4dof': the horizontal positions do not move; the yaw is undetermined"
            )
        th = np.arctan2(a_s, a_c)
        c, s = np.cos(th), np.sin(th)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return Alignment("4dof", R, _offset(my, ey, R @ mx, ex), 1.0)
    sigma_x = float(np.linalg.norm(xc) ** 2) / n
    cov_xy = (yc.T @ xc) / n
    u, d, vt = np.linalg.svd(cov_xy)
    # relative to the largest: the positions may have been rescaled above (or be in km)
    if not d[0] > 0.0 or np.count_nonzero(d > eps * d[0]) < 2:
        raise ValueError(
            f"alignment {kind!r}: the positions are degenerate (singular values of their "
            f"cross-covariance {d.tolist()}); all on one line or all equal"
        )
    # det(U)·det(V) < 0, not det(Σ) < 0 (Umeyama's rule for a full-rank Σ): on a planar
    # trajectory Σ has rank 2, its determinant is rounding noise, and the tempting rule returns
    # the reflection that fits the plane as well as the rotation does
    S = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0.0:
        S[2, 2] = -1.0
    R = u @ S @ vt
    scale = 1.0
    if _with_scale(kind):
        unit = float(np.trace(np.diag(d) @ S) / sigma_x)  # the scale between x/2^ex and y/2^ey
        try:
            scale = math.ldexp(unit, ey - ex)  # 0.0 on underflow, OverflowError on overflow
        except OverflowError:
            scale = math.inf
        if not (math.isfinite(scale) and scale > 0.0):
            raise ValueError(
                f"alignment 'sim3': the scale from the estimate to the reference is {scale!r} "
                f"in float64 (their spreads differ by a factor of about {unit:.3g}·2^{ey - ex}, "
                "beyond what float64 spans)"
            )
        # t = my − s R mx = 2^ey·(my' − unit·R mx'), mx' and my' the scaled means
        return Alignment(kind, R, _translation(my - unit * (R @ mx), ey), scale)
    return Alignment(kind, R, _offset(my, ey, R @ mx, ex), scale)


def _unit_scaled(p: FloatArray) -> tuple[FloatArray, int]:
    """``(p / 2^e, e)`` with ``2^e`` the power of two just above ``max |p|`` (e = 0 for zeros)."""
    big = float(np.abs(p).max())
    if big == 0.0:
        return p, 0
    e = math.frexp(big)[1]
    return np.ldexp(p, -e), e  # exact (2^e itself overflows for |p| near 1e308)


def _offset(my: FloatArray, ey: int, Rmx: FloatArray, ex: int) -> FloatArray:
    """``2^ey·my − 2^ex·R mx`` (a translation in the original units), no overflow on the way."""
    e = max(ex, ey)
    with np.errstate(under="ignore"):  # a term 2^-1074 below the other is exactly negligible
        t = np.ldexp(my, ey - e) - np.ldexp(Rmx, ex - e)
    return _translation(t, e)


def _translation(t: FloatArray, e: int) -> FloatArray:
    """``2^e·t`` (undoing the scaling), or a ``ValueError`` if it overflows float64."""
    with np.errstate(over="ignore"):
        out = np.asarray(np.ldexp(t, e), dtype=np.float64)
    if not np.isfinite(out).all():
        raise ValueError(
            "alignment: its translation overflows float64 (the positions and their offset are "
            "too large); the trajectories cannot be aligned in float64"
        )
    return out


def align(T_ref: Any, T_est: Any, kind: AlignmentKind | str = "se3") -> Alignment:
    """:func:`umeyama` on the positions of associated poses ``(N, 4, 4)``.

    Use ``alignment.apply(T_est)`` for the aligned poses and
    ``alignment.transform_covariance(T_est, cov, convention)`` for their covariances.
    """
    Tr = validate.pose(T_ref, "T_ref")
    Te = validate.pose(T_est, "T_est")
    if Tr.ndim != 3 or Te.ndim != 3:
        raise ValueError(f"T_ref, T_est: expected shape (N, 4, 4), got {Tr.shape}, {Te.shape}")
    return umeyama(Tr[:, :3, 3], Te[:, :3, 3], kind)
