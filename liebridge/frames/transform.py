"""A rigid transform that carries its frames: ``T_target_source`` as data.

A :class:`Transform` holds ``T`` (``(..., 4, 4)``) together with the names of the two frames it
relates. ``T_target_source`` maps coordinates of a point in ``source_frame`` to its coordinates in
``target_frame``: ``p_target = R p_source + t``; equivalently it is the pose of ``source_frame``
expressed in ``target_frame``. Kalibr's ``T_cam_imu`` is ``Transform(T, "cam0", "imu0")``.

Composition checks the names: ``T_a_b ∘ T_b_c = T_a_c``, and composing ``T_a_b`` with
``T_c_d`` (``b ≠ c``) raises naming both frames. Tempting and false: ``T_a_b ∘ T_c_b`` "because
both mention b" — one of them must be inverted first.

Covariance (optional) is that of a perturbation of ``T`` in ``convention``'s tangent (default
GTSAM's: ``T_true = T·Exp(ξ)``, ``ξ = (ω, v)``, i.e. in ``source_frame``). :meth:`inverse` and
:meth:`compose` propagate it to first order, computing in the canonical chart
(``Σ_inv = Ad_T Σ Ad_Tᵀ``; ``Σ_ac = Ad_{T_bc⁻¹} Σ_ab Ad_{T_bc⁻¹}ᵀ + Σ_bc`` for independent
inputs) and returning it in the first operand's convention. Tempting and false:
``Σ_inv = Σ`` (true only for a left-perturbation covariance read as a right one, never both).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import (
    CANONICAL,
    Convention,
    ConventionLike,
    convert_covariance,
    get,
    pose_convention,
    single_group,
)
from ..lie import unchecked as U

__all__ = ["FrameMismatchError", "Transform", "frame_name"]

#: Largest rotation tolerance ``max|RᵀR − I|`` a :class:`Transform` accepts (beyond it a matrix
#: is not a rotation in any useful sense; project it with :func:`liebridge.lie.so3.project`).
MAX_TOL = 1e-2

_FRAME = re.compile(r"^[^\s]+$")


class FrameMismatchError(ValueError):
    """Two transforms whose frames do not chain (the message names both frames)."""


def frame_name(name: Any, what: str) -> str:
    """Validate a frame name: a non-empty string without whitespace (ROS ``frame_id`` style)."""
    if not isinstance(name, str):
        raise TypeError(f"{what}: expected a frame name (str), got {type(name).__name__}")
    if not _FRAME.match(name):
        raise ValueError(f"{what}: frame name must be non-empty without whitespace, got {name!r}")
    return name


def _readonly(a: FloatArray) -> FloatArray:
    a = np.array(a, dtype=np.float64)  # a private copy: the caller's array is never aliased
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Transform:
    """``T_target_source``: a rigid transform (or a batch of them) with named frames.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        ``[[R, t], [0, 1]]`` with ``p_target = R p_source + t``: the pose of ``source_frame`` in
        ``target_frame``. Validated (rotation within ``tol``, bottom row ``[0, 0, 0, 1]``) and
        stored as a read-only copy.
    target_frame, source_frame : str
        Frame names (no whitespace). The name in words: ``T_{target}_{source}``.
    cov : array_like, shape (..., 6, 6), optional
        Covariance of a perturbation of ``T`` in ``convention``'s tangent.
    convention : Convention or str
        Tangent convention of ``cov`` (default: canonical GTSAM, right ``T·Exp(ξ)``, ``(ω, v)``).
    tol : float
        Rotation tolerance ``max|RᵀR − I|`` (default :data:`liebridge._validate.ROTATION_TOL`),
        in ``(0, MAX_TOL]`` (:data:`MAX_TOL` = 1e-2).

    Examples
    --------
    >>> import numpy as np
    >>> T_cam_imu = Transform(np.eye(4), "cam0", "imu0")
    >>> T_cam_imu.name
    'T_cam0_imu0'
    >>> T_cam_imu.inverse().name
    'T_imu0_cam0'
    """

    T: FloatArray
    target_frame: str
    source_frame: str
    cov: FloatArray | None = None
    convention: Convention = field(default=CANONICAL)
    tol: float = field(default=validate.ROTATION_TOL, repr=False)

    def __post_init__(self) -> None:
        frame_name(self.target_frame, "target_frame")
        frame_name(self.source_frame, "source_frame")
        tol = self.tol
        if isinstance(tol, bool) or not isinstance(tol, int | float | np.floating | np.integer):
            raise TypeError(f"tol: expected a number, got {type(tol).__name__}")
        if not 0.0 < float(tol) <= MAX_TOL:  # NaN fails too
            raise ValueError(
                f"tol ({self.name}): expected a rotation tolerance in (0, {MAX_TOL:g}], got {tol!r}"
            )
        T = validate.pose(self.T, f"T ({self.name})", float(tol))
        object.__setattr__(self, "T", _readonly(T))
        conv = get(self.convention)
        pose_convention(conv, f"convention ({self.name})", T)
        object.__setattr__(self, "convention", conv)
        if self.cov is not None:
            cov = validate.covariance(self.cov, f"cov ({self.name})", 6)
            if cov.shape[:-2] != T.shape[:-2]:
                shape = validate.batch_shape(("cov", cov.shape[:-2]), ("T", T.shape[:-2]))
                if shape != T.shape[:-2]:
                    raise ValueError(
                        f"cov ({self.name}): batch shape {cov.shape[:-2]} has more covariances "
                        f"than T's batch shape {T.shape[:-2]} has poses"
                    )
                cov = np.broadcast_to(cov, (*T.shape[:-2], 6, 6))
            object.__setattr__(self, "cov", _readonly(cov))

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """``"T_{target}_{source}"``."""
        return f"T_{self.target_frame}_{self.source_frame}"

    @property
    def R(self) -> FloatArray:
        """Rotation block ``(..., 3, 3)``: directions in ``source_frame`` to ``target_frame``."""
        return self.T[..., :3, :3]

    @property
    def t(self) -> FloatArray:
        """Translation ``(..., 3)``: the origin of ``source_frame`` in ``target_frame``."""
        return self.T[..., :3, 3]

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch shape of ``T``."""
        return tuple(self.T.shape[:-2])

    def describe(self) -> str:
        """One line: the name and its direction in words."""
        return (
            f"{self.name}: maps {self.source_frame} coordinates to {self.target_frame} "
            f"coordinates (p_{self.target_frame} = R p_{self.source_frame} + t); the pose of "
            f"{self.source_frame} in {self.target_frame}"
        )

    def __repr__(self) -> str:
        cov = "" if self.cov is None else f", cov in {self.convention.name!r}"
        shape = f", batch {self.batch_shape}" if self.batch_shape else ""
        return f"Transform({self.name}{shape}{cov})"

    # ------------------------------------------------------------------ operations
    def canonical_cov(self) -> FloatArray | None:
        """Return the covariance in the canonical (GTSAM) tangent, or None."""
        if self.cov is None:
            return None
        if self.convention.fields == CANONICAL.fields:
            return self.cov
        return convert_covariance(self.cov, self.T, self.convention, CANONICAL)

    def with_convention(self, convention: ConventionLike) -> Transform:
        """Return this transform with its covariance re-expressed in ``convention`` (1st order)."""
        conv = single_group(get(convention))
        cov = None
        if self.cov is not None:
            cov = convert_covariance(self.cov, self.T, self.convention, conv)
        return Transform(self.T, self.target_frame, self.source_frame, cov, conv, self.tol)

    def inverse(self) -> Transform:
        """``T_source_target = T⁻¹``; covariance ``Ad_T Σ Ad_Tᵀ`` (canonical), in this convention.

        ``(T·Exp(ξ))⁻¹ = T⁻¹·Exp(−Ad_T ξ)``.
        """
        Ti = U.se3_inverse(self.T)
        cov = self.canonical_cov()
        out_cov = None
        if cov is not None:
            A = U.se3_adjoint(self.T)
            out_cov = _sym(A @ cov @ np.swapaxes(A, -1, -2))
        out = Transform(Ti, self.source_frame, self.target_frame, out_cov, CANONICAL, self.tol)
        return out if out_cov is None else out.with_convention(self.convention)

    def compose(self, other: Transform) -> Transform:
        """``T_a_b ∘ T_b_c = T_a_c`` (this is ``T_a_b``); raises if the frames do not chain.

        Covariances of the two operands are taken as independent (a missing one as zero);
        ``T_ab Exp(ξ1) T_bc Exp(ξ2) ≈ T_ac Exp(Ad_{T_bc⁻¹} ξ1 + ξ2)``. The result's covariance
        is in this transform's convention.

        Raises
        ------
        FrameMismatchError
            If ``self.source_frame != other.target_frame``, naming both frames.
        """
        if not isinstance(other, Transform):
            raise TypeError(f"compose: expected a Transform, got {type(other).__name__}")
        if self.source_frame != other.target_frame:
            raise FrameMismatchError(
                f"cannot compose {self.name} with {other.name}: source frame "
                f"{self.source_frame!r} of the first is not target frame {other.target_frame!r} "
                f"of the second (T_a_b ∘ T_b_c needs the inner frames to match; invert one?)"
            )
        validate.batch_shape((self.name, self.batch_shape), (other.name, other.batch_shape))
        T = validate.finite_output(np.asarray(self.T @ other.T, dtype=np.float64), "compose")
        c1, c2 = self.canonical_cov(), other.canonical_cov()
        cov = None
        if c1 is not None or c2 is not None:
            shape = np.broadcast_shapes(self.batch_shape, other.batch_shape)
            cov = np.zeros((*shape, 6, 6))
            if c1 is not None:
                A = U.se3_adjoint(U.se3_inverse(other.T))
                cov = cov + A @ c1 @ np.swapaxes(A, -1, -2)
            if c2 is not None:
                cov = cov + c2
            cov = _sym(cov)
        conv = self.convention if self.cov is not None else other.convention
        out = Transform(T, self.target_frame, other.source_frame, cov, CANONICAL, self.tol)
        return out if cov is None else out.with_convention(conv)

    def __matmul__(self, other: Transform) -> Transform:
        """``T_a_b @ T_b_c`` is :meth:`compose`."""
        return self.compose(other)

    def apply(self, p_source: Any) -> FloatArray:
        """Map points ``(..., 3)`` from ``source_frame`` to ``target_frame``: ``R p + t``."""
        p = validate.vector(p_source, f"p_{self.source_frame}", 3)
        validate.batch_shape((self.name, self.batch_shape), ("p", p.shape[:-1]))
        out = np.einsum("...ij,...j->...i", self.R, p) + self.t
        return validate.finite_output(np.asarray(out, dtype=np.float64), "apply")

    def rename(self, target_frame: str | None = None, source_frame: str | None = None) -> Transform:
        """Return the same numbers under other frame names (e.g. a system's own names)."""
        return Transform(
            self.T,
            self.target_frame if target_frame is None else target_frame,
            self.source_frame if source_frame is None else source_frame,
            self.cov,
            self.convention,
            self.tol,
        )

    def __getitem__(self, index: Any) -> Transform:
        """Index the batch: ``tf[3]`` is the fourth transform, frames and convention kept."""
        if not self.batch_shape:
            raise IndexError(f"{self.name} is a single transform, not a batch")
        cov = None if self.cov is None else self.cov[index]
        return Transform(
            self.T[index], self.target_frame, self.source_frame, cov, self.convention, self.tol
        )


def _sym(A: FloatArray) -> FloatArray:
    return np.asarray(0.5 * (A + np.swapaxes(A, -1, -2)), dtype=np.float64)
