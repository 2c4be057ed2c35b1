"""Uncertain poses and points: a batch of group elements with covariances, tied to a convention.

An :class:`UncertainPose` ``(T, Σ, c)`` stands for the random pose ``c.retract(T, δ)`` with
``δ ~ N(0, Σ)`` in the convention ``c``'s tangent (its side, order, chart and rotation
coordinates). The same random pose in another convention ``d`` is ``(T, M Σ Mᵀ, d)`` with
``M = tangent_map(T, c, d)`` to first order (exact when ``is_exactly_linear(c, d)``); that is
:meth:`UncertainPose.to`. False: ``(T, Σ, d)`` — the same matrix handed to another library —
describes the same uncertainty (it does not, unless the two conventions' tangents coincide at
``T``).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import (
    Convention,
    ConventionLike,
    convert_covariance,
    get,
    group_input,
    pose_convention,
    unchecked,
)

__all__ = ["UncertainPoint", "UncertainPose"]


def _frozen(a: Any) -> FloatArray:
    """Return a read-only float64 copy (immutable objects; the caller's array is untouched).

    A torch/JAX array stays one (its type, device, dtype and autograd graph): a new array
    (``a * 1.0``: never an alias of the caller's tensor, no host round trip); it cannot be made
    read-only, but nothing in liebridge writes into it.
    """
    if arrays.is_foreign(a):
        return a * 1.0
    out = np.array(a, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


def _broadcast(a: Any, shape: tuple[int, ...]) -> Any:
    """Return ``a`` broadcast to ``shape`` in its own namespace."""
    return arrays.namespace(a).broadcast_to(a, shape)


def _rot(c: Convention) -> slice:
    return slice(0, 3) if c.order == "rot_first" else slice(3, 6)


def _map(X: FloatArray, src: Convention, dst: Convention) -> FloatArray:
    """``unchecked.tangent_map(X, src, dst)`` (poses, or rotations as their SO(3) part)."""
    return unchecked.tangent_map(X, src, dst)


def trusted(T: Any, cov: Any, convention: Convention) -> UncertainPose:
    """Return an :class:`UncertainPose` of torch/JAX arrays an operation computed (unchecked).

    The operations' results are valid by construction (group products, ``J Σ Jᵀ``, checked
    finite); validating them again would cost an eigen-decomposition per batch element.
    """
    out = object.__new__(UncertainPose)
    object.__setattr__(out, "T", T)
    object.__setattr__(out, "cov", cov)
    object.__setattr__(out, "convention", convention)
    return out


def moved(A: UncertainPose, ref: Any) -> UncertainPose:
    """Return a numpy :class:`UncertainPose` as one of ``ref``'s array type, device and dtype."""
    T = arrays.like(np.array(A.T), ref)  # a writable copy: torch warns on read-only numpy
    return UncertainPose(T, arrays.like(np.array(A.cov), ref), A.convention)


def element_input(X: Any, name: str) -> Any:
    """Validate a pose ``(..., 4, 4)`` or a rotation ``(..., 3, 3)`` of any array type.

    numpy input goes through :func:`~liebridge.conventions.group_input`; a torch/JAX array is
    checked in its own namespace (:func:`liebridge._validate.pose`/``rotation``: the same error
    wording, a host copy only to word it) and returned as it is, graph included.
    """
    if not arrays.is_foreign(X):
        return group_input(X, name)
    shape = tuple(X.shape[-2:]) if X.ndim >= 2 else tuple(X.shape)
    if shape == (4, 4):
        return validate.pose(X, name)
    if shape == (3, 3):
        return validate.rotation(X, name)
    raise ValueError(
        f"{name}: expected a pose (..., 4, 4) or a rotation (..., 3, 3), got {tuple(X.shape)}"
    )


def same_dtype(ref: Any, x: Any, name: str, ref_name: str) -> None:
    """Raise ``TypeError`` when two torch/JAX arrays of one operation have different dtypes."""
    if arrays.is_foreign(ref) and arrays.is_foreign(x) and x.dtype != ref.dtype:
        raise TypeError(
            f"{name}: dtype {x.dtype} differs from {ref_name}'s {ref.dtype}; convert one first "
            "(liebridge does not promote float32 tensors silently)"
        )


def _matrix_of(T: Any) -> Any:
    """``T.matrix()`` for GTSAM-like objects (``Pose3``, ``Rot3``), else ``T`` itself."""
    m = getattr(T, "matrix", None)
    return m() if callable(m) else T


class UncertainPose:
    """A batch of poses (or rotations) with covariances in one convention's tangent.

    The random pose is ``convention.retract(T, δ)``, ``δ ~ N(0, cov)``: for GTSAM
    (``right, rot_first, se3``) ``T·Exp(δ)`` with ``δ = (ω, v)``; for ROS
    (``left, trans_first, so3xr3_world``) rotation ``Exp(r)·R`` and position ``t + u`` with
    ``δ = (u, r)`` in the parent frame.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4) or (..., 3, 3)
        Mean poses ``T_parent_body`` (or rotations); anything with a ``.matrix()`` method
        (``gtsam.Pose3``, ``gtsam.Rot3``) is read through it.
    cov : array_like, shape (..., 6, 6) or (..., 3, 3)
        Symmetric positive semi-definite covariances in ``convention``'s tangent (its order:
        ``(ω, v)`` for ``rot_first``, ``(v, ω)`` for ``trans_first``); broadcast against ``T``.
    convention : Convention or str
        A :class:`~liebridge.conventions.Convention` or a preset name (``"gtsam"``, ``"ros"``, ...).

    Attributes
    ----------
    T, cov : ndarray, or the caller's torch/JAX array type
        Read-only copies, broadcast to one batch shape. torch tensors and JAX arrays stay
        arrays of their library, device and dtype (float32 or float64, the same for both; a
        numpy argument beside a tensor is moved to it), with their autograd graph: new arrays,
        never aliases of the caller's, but not read-only (docs/tensors.md).
    convention : Convention

    Notes
    -----
    Immutable: the arrays are read-only copies. Indexing (``A[i]``) selects batch elements.
    """

    __slots__ = ("T", "convention", "cov")
    T: FloatArray
    cov: FloatArray
    convention: Convention

    def __init__(self, T: Any, cov: Any, convention: ConventionLike) -> None:
        conv = get(convention)
        pose_convention(conv, "convention")  # before T is read as a 3×3 rotation
        T, cov = arrays.common(_matrix_of(T), cov)
        Ta = element_input(T, "T")
        pose_convention(conv, "convention", Ta)
        n = 3 if Ta.shape[-1] == 3 else 6
        C = validate.covariance(cov, "cov", n)
        same_dtype(Ta, C, "cov", "T")
        shape = validate.batch_shape(("T", tuple(Ta.shape[:-2])), ("cov", tuple(C.shape[:-2])))
        object.__setattr__(self, "T", _frozen(_broadcast(Ta, (*shape, *Ta.shape[-2:]))))
        object.__setattr__(self, "cov", _frozen(_broadcast(C, (*shape, n, n))))
        object.__setattr__(self, "convention", conv)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"UncertainPose is immutable (cannot set {name!r})")

    # ------------------------------------------------------------------ descriptors
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """The leading (batch) dimensions."""
        return tuple(self.T.shape[:-2])

    @property
    def dim(self) -> int:
        """Tangent dimension: 6 for poses, 3 for rotations."""
        return 3 if self.T.shape[-1] == 3 else 6

    @property
    def is_rotation(self) -> bool:
        """Whether the elements are rotations ``(3, 3)`` rather than poses ``(4, 4)``."""
        return self.T.shape[-1] == 3

    def __len__(self) -> int:
        if not self.batch_shape:
            raise TypeError("len() of an unbatched UncertainPose")
        return self.batch_shape[0]

    def __getitem__(self, index: Any) -> UncertainPose:
        idx = index if isinstance(index, tuple) else (index,)
        if any(i is Ellipsis for i in idx):
            raise IndexError("UncertainPose: index the batch dimensions without '...'")
        if len(idx) > len(self.batch_shape):
            raise IndexError(
                f"UncertainPose: {len(idx)} indices for batch shape {self.batch_shape}"
            )
        return UncertainPose(self.T[idx], self.cov[idx], self.convention)

    def __repr__(self) -> str:
        kind = "rotation" if self.is_rotation else "pose"
        return (
            f"UncertainPose({kind}, batch_shape={self.batch_shape}, "
            f"convention={self.convention.name!r})"
        )

    # ------------------------------------------------------------------ conversions
    def to(
        self, convention: ConventionLike, *, method: Literal["linear", "unscented"] = "linear"
    ) -> UncertainPose:
        """Describe the same random pose in another convention's tangent.

        ``cov_dst = M cov Mᵀ``, ``M = tangent_map(T, self.convention, convention)``
        (``method="linear"``, exact when :func:`~liebridge.conventions.is_exactly_linear`), or
        the unscented transform of :func:`~liebridge.conventions.convert_covariance` (numpy,
        torch and JAX). ``T`` is unchanged (the mean shift of a nonlinear change of chart is
        second order and dropped).
        """
        dst = pose_convention(get(convention), "convention", self.T)
        cov = convert_covariance(self.cov, self.T, self.convention, dst, method=method)
        return UncertainPose(self.T, cov, dst)

    @classmethod
    def from_gtsam(cls, pose: Any, cov: Any, convention: ConventionLike = "gtsam") -> UncertainPose:
        """From a GTSAM pose (``gtsam.Pose3``/``Rot3`` or its matrix) and a GTSAM covariance.

        ``cov`` is in GTSAM's tangent (``X·Exp(ξ)``, ``ξ = (ω, v)``), e.g.
        ``gtsam.Marginals.marginalCovariance(key)``; the result is expressed in ``convention``.
        No GTSAM import: the pose is read with ``.matrix()`` (duck typing). For the joint
        marginal of two keys see :func:`liebridge.gtsam.uncertain.joint_marginal`.
        """
        return cls(pose, cov, "gtsam").to(convention)

    def gtsam_cov(self) -> FloatArray:
        """Return the covariance in GTSAM's tangent (for ``noiseModel.Gaussian.Covariance``)."""
        return self.to("gtsam").cov


class UncertainPoint:
    """A batch of 3-D points with covariances (the result of :func:`~liebridge.uncertain.act`).

    Parameters
    ----------
    p : array_like, shape (..., 3)
        Mean points, in the frame named by the operation that produced them.
    cov : array_like, shape (..., 3, 3)
        Their covariances (symmetric positive semi-definite), broadcast against ``p``.
    """

    __slots__ = ("cov", "p")
    p: FloatArray
    cov: FloatArray

    def __init__(self, p: Any, cov: Any) -> None:
        p, cov = arrays.common(p, cov)
        pa = validate.vector(p, "p", 3)
        C = validate.covariance(cov, "cov", 3)
        same_dtype(pa, C, "cov", "p")
        shape = validate.batch_shape(("p", tuple(pa.shape[:-1])), ("cov", tuple(C.shape[:-2])))
        object.__setattr__(self, "p", _frozen(_broadcast(pa, (*shape, 3))))
        object.__setattr__(self, "cov", _frozen(_broadcast(C, (*shape, 3, 3))))

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"UncertainPoint is immutable (cannot set {name!r})")

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """The leading (batch) dimensions."""
        return tuple(self.p.shape[:-1])

    def __repr__(self) -> str:
        return f"UncertainPoint(batch_shape={self.batch_shape})"
