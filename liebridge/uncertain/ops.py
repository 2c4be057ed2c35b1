"""Operations on uncertain poses: compose, inverse, relative, change of frame, action on a point.

Every operation is an exact group operation on the means and a propagation of the covariance.

``method="linear"``: first-order (Jacobian) propagation. Written in GTSAM's tangent (right
perturbation ``X·Exp(ξ)``, ``ξ = (ω, v)``, ``Ad_X = [[R, 0], [hat(t)R, R]]``), where

* ``compose``  ``C = A·B``:      ``ξ_C = Ad_{B⁻¹} ξ_A + ξ_B``
* ``inverse``  ``C = A⁻¹``:      ``ξ_C = −Ad_A ξ_A``
* ``relative`` ``C = A⁻¹·B``:    ``ξ_C = −Ad_{B⁻¹A} ξ_A + ξ_B``
* ``transform`` ``F·A`` (left):  ``ξ_C = ξ_A``;  ``A·F`` (right): ``ξ_C = Ad_{F⁻¹} ξ_A``
* ``act``      ``q = R p + t``:  ``δq = [−R hat(p), R] ξ_A + R δp``

(for rotations ``Ad_R = R`` and ``δq = −R hat(p) ω + R δp``). These are GTSAM's own Jacobians
(``Pose3::compose``/``inverse``/``between``/``transformFrom`` with their ``H`` arguments, GTSAM 4.3
``gtsam/geometry/Pose3.cpp``; checked against the wheel in the tests). In a convention ``c`` each
Jacobian becomes ``J_c = M_{g→c}(C) · J_g · M_{c→g}(X)`` with the closed-form maps of
:func:`~liebridge.conventions.tangent_map`, and ``Σ_C = J Σ_joint Jᵀ`` where ``Σ_joint`` is the
joint covariance of the inputs, ``[[Σ_A, cross], [crossᵀ, Σ_B]]`` (``cross = E[δA δBᵀ]``,
zero for independent inputs).

On torch tensors and JAX arrays ``method="linear"`` runs the same Jacobians with the
array-generic tangent maps, built without in-place writes: the result keeps the caller's array
type, device, dtype and autograd graph (numpy keeps its own code). ``method="unscented"`` runs
on them too, with the same rule and the same square root (the eigendecomposition of
:func:`~liebridge.conventions.cubature.sqrt_psd`, in the array's own ``eigh``): the sigma points
are pushed through the conventions' ``retract``/``local`` on the device, the weights are arrays
of the caller's type, the chunks are concatenated (no in-place write); differentiable with
respect to the means and the covariances (the latter where the joint covariance has distinct
eigenvalues, where its eigenvectors are differentiable). No random numbers are drawn: the
cubature is deterministic (the Monte Carlo references are :mod:`liebridge.check`'s).

``method="unscented"``: the joint covariance is factored, ``S Sᵀ = Σ_joint``, and the points of
Stroud's fifth-degree Gaussian cubature (rule En^r² 5-2, ``2N² + 1`` points for ``N`` input
dimensions, exact for polynomials of degree ≤ 5; the same rule as
:func:`liebridge.conventions.convert_covariance`'s ``method="unscented"``) are pushed through the
exact operation on samples ``c.retract(X, δ)`` and read back with ``c.local(C̄, ·)`` at the
operation's value on the means ``C̄``. The covariance is taken about the cubature mean of those
tangents (the mean shift, second order, is not applied to the pose).

False (the public bugs these functions exist to avoid): the inverse's covariance is
``Ad_A Σ Ad_Aᵀ`` in every convention (it is in right-perturbation tangents; in left ones, e.g.
Barfoot's, it is ``Ad_{A⁻¹} Σ Ad_{A⁻¹}ᵀ``); a composition of correlated poses is the sum of the
two propagated covariances (the cross term ``J_A cross J_Bᵀ + (·)ᵀ`` is missing); a pose moved to
another frame keeps its covariance (ROS 2's tf2_geometry_msgs copied a ``PoseWithCovariance``'s
covariance unrotated, ros2/geometry2 issue #372; right only when the new parent frame has the old
one's orientation).
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable
from typing import Any, Literal, TypeVar, cast

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from ..conventions import CANONICAL, Convention
from ..conventions.cubature import cubature_rule_5, sqrt_psd
from ..lie import unchecked as U
from .pose import (
    UncertainPoint,
    UncertainPose,
    _map,
    _matrix_of,
    element_input,
    moved,
    same_dtype,
    trusted,
)

__all__ = ["act", "compose", "inverse", "relative", "sigma_points", "transform"]

Method = Literal["linear", "unscented"]


# --------------------------------------------------------------------------- group helpers
def _ad(X: FloatArray) -> FloatArray:
    """``Ad_X`` in GTSAM's ``(ω, v)`` (a rotation's adjoint is itself)."""
    return U.se3_adjoint(X) if X.shape[-1] == 4 else X


def _inv(X: FloatArray) -> FloatArray:
    return U.se3_inverse(X) if X.shape[-1] == 4 else arrays.mT(X)


def _cat(parts: list[Any], axis: int = -1) -> Any:
    """Concatenate in the parts' own namespace (numpy's ``concatenate``, else ``concat``)."""
    if not arrays.any_foreign(*parts):
        return np.concatenate(parts, axis=axis)
    return arrays.concat(parts, axis)


def _f64(X: Any) -> Any:
    """Return a numpy result as float64, a torch/JAX result as it is (type, dtype, graph)."""
    return X if arrays.is_foreign(X) else np.asarray(X, dtype=np.float64)


def _align(A: UncertainPose, B: UncertainPose, nb: str) -> tuple[UncertainPose, UncertainPose]:
    """Move a numpy operand to the other's torch/JAX type (dtype and device); dtypes must agree."""
    if arrays.is_foreign(A.T) and not arrays.is_foreign(B.T):
        B = moved(B, A.T)
    elif arrays.is_foreign(B.T) and not arrays.is_foreign(A.T):
        A = moved(A, B.T)
    same_dtype(A.T, B.T, f"{nb}.T", "A.T")
    return A, B


def _to_g(X: FloatArray, c: Convention) -> Any:
    """``M`` with ``ξ_gtsam = M δ_c`` at ``X`` (torch/JAX in GTSAM's own tangent: ``None``, I)."""
    if arrays.is_foreign(X) and c.fields == CANONICAL.fields:
        return None
    return _map(X, c, CANONICAL)


def _from_g(X: FloatArray, c: Convention) -> Any:
    """``M`` with ``δ_c = M ξ_gtsam`` at ``X`` (torch/JAX in GTSAM's own tangent: ``None``, I)."""
    if arrays.is_foreign(X) and c.fields == CANONICAL.fields:
        return None
    return _map(X, CANONICAL, c)


def _mul(*Ms: Any) -> Any:
    """Return the product of ``Ms``, ``None`` standing for the identity (``None`` if all are)."""
    out = None
    for M in Ms:
        if M is not None:
            out = M if out is None else out @ M
    return out


def _full(M: Any, ref: Any, n: int) -> Any:
    """Return ``M``, or for ``None`` the ``n × n`` identity over ``ref``'s batch (an array)."""
    return arrays.eye(n, ref, tuple(ref.shape[:-2])) if M is None else M


def _sw(J: Any, S: Any) -> Any:
    """Return ``J S Jᵀ`` (``S`` for ``J = None``)."""
    return S if J is None else J @ S @ arrays.mT(J)


def _result(TC: Any, cov: Any, c: Convention) -> UncertainPose:
    """Return the operation's result; torch/JAX results are valid by construction."""
    TC, cov = validate.finite_output(TC, "T"), validate.finite_output(cov, "cov")
    if arrays.is_foreign(TC):
        return trusted(TC, cov, c)
    return UncertainPose(TC, cov, c)


def _kind(A: UncertainPose) -> str:
    return "rotation" if A.is_rotation else "pose"


def _check_uncertain(A: Any, name: str) -> UncertainPose:
    if not isinstance(A, UncertainPose):
        raise TypeError(f"{name}: expected an UncertainPose, got {type(A).__name__}")
    return A


def _check_pair(A: Any, B: Any, na: str = "A", nb: str = "B") -> tuple[int, ...]:
    """Check: same group, same convention (by its retraction fields), broadcastable batch shapes."""
    A = _check_uncertain(A, na)
    B = _check_uncertain(B, nb)
    if A.is_rotation != B.is_rotation:
        raise ValueError(f"{nb}: a {_kind(B)}, but {na} is a {_kind(A)}")
    if A.convention.fields != B.convention.fields:
        raise ValueError(
            f"{nb}: convention {B.convention.name!r} {B.convention.fields} differs from {na}'s "
            f"{A.convention.name!r} {A.convention.fields}; convert one first, e.g. "
            f"{nb}.to({na}.convention)"
        )
    try:
        return validate.batch_shape((na, A.batch_shape), (nb, B.batch_shape))
    except ValueError as exc:
        raise ValueError(f"{na}, {nb}: {exc}") from None


def _joint(
    A: UncertainPose, B: UncertainPose, cross: Any, shape: tuple[int, ...]
) -> tuple[FloatArray, tuple[int, ...]]:
    """``[[Σ_A, cross], [crossᵀ, Σ_B]]`` validated positive semi-definite."""
    n = A.dim
    if arrays.is_foreign(A.T):
        return _joint_generic(A, B, cross, shape)
    if cross is not None:
        X = validate.as_float_array(cross, "cross")
        if X.ndim < 2 or X.shape[-2:] != (n, n):
            raise ValueError(f"cross: expected shape (..., {n}, {n}), got {X.shape}")
        validate.check_finite(X, "cross", core_ndim=2)
        shape = validate.batch_shape(("A and B", shape), ("cross", X.shape[:-2]))
    J = np.zeros((*shape, 2 * n, 2 * n))
    J[..., :n, :n] = A.cov
    J[..., n:, n:] = B.cov
    if cross is None:
        return J, shape
    J[..., :n, n:] = X
    J[..., n:, :n] = np.swapaxes(X, -1, -2)
    validate.covariance(J, "cross (the joint covariance [[A.cov, cross], [crossᵀ, B.cov]])", 2 * n)
    return J, shape


def _joint_generic(
    A: UncertainPose, B: UncertainPose, cross: Any, shape: tuple[int, ...]
) -> tuple[Any, tuple[int, ...]]:
    """Return :func:`_joint` on torch/JAX arrays: blocks, no in-place write.

    ``None`` for independent inputs (the operations then sum two sandwiches instead).
    """
    n = A.dim
    if cross is None:  # not needed: independent inputs take two n×n sandwiches
        return None, shape
    (X,) = arrays.common(A.T, cross)[1:]
    X = validate.square(X, "cross", n)
    same_dtype(A.T, X, "cross", "A.T")
    shape = validate.batch_shape(("A and B", shape), ("cross", tuple(X.shape[:-2])))
    J = arrays.blocks([[A.cov, X], [arrays.mT(X), B.cov]])
    validate.covariance(J, "cross (the joint covariance [[A.cov, cross], [crossᵀ, B.cov]])", 2 * n)
    return J, shape


def _joint_full(A: UncertainPose, B: UncertainPose, joint: Any, shape: tuple[int, ...]) -> Any:
    """Return the joint covariance over the batch ``shape``, or its diagonal blocks.

    :func:`_joint` returns ``None`` for independent torch/JAX inputs (the linear path sums two
    sandwiches); the cubature then takes the blocks ``(Σ_A, Σ_B)`` of ``[[Σ_A, 0], [0, Σ_B]]``
    and factors each (:func:`_unscented_generic`).
    """
    if joint is None:
        return (_bshape(A.cov, shape), _bshape(B.cov, shape))
    return _bshape(joint, shape)


def _sym(S: FloatArray) -> FloatArray:
    return _f64(0.5 * (S + arrays.mT(S)))


def _sandwich(J: FloatArray, S: FloatArray) -> FloatArray:
    return _sym(J @ S @ arrays.mT(J))


sigma_points = cubature_rule_5
_sqrt_psd = sqrt_psd


#: Bytes of sigma-point arrays in flight per pass of the unscented transform: a batch is cut into
#: chunks so that memory stays ≈ this whatever the batch (1e5 compositions needed ≈ 20 GB at once).
UNSCENTED_BYTES = 2**26


def _unscented(joint: FloatArray, f: Callable[..., FloatArray], *inputs: FloatArray) -> FloatArray:
    """Covariance of ``f(δ, *inputs)``, ``δ ~ N(0, joint)`` by the fifth-degree cubature.

    ``f`` maps ``(b, K, N)`` perturbations and the ``inputs`` (each ``(b, …)``, the batch of
    ``joint`` flattened to ``b``) to ``(b, K, m)`` outputs. The batch is processed in chunks of
    about :data:`UNSCENTED_BYTES` of sigma points (≈ 1 kB per point and element in flight).
    A torch/JAX ``joint`` takes :func:`_unscented_generic` (the same formula).
    """
    if isinstance(joint, tuple) or arrays.is_foreign(joint):
        return _unscented_generic(joint, f, *inputs)
    shape = joint.shape[:-2]
    N = joint.shape[-1]
    pts, w = sigma_points(N)
    total = math.prod(shape)
    chunk = max(1, UNSCENTED_BYTES // (pts.shape[0] * 1024))
    flat_joint = joint.reshape((total, N, N))
    flat = [
        np.reshape(np.broadcast_to(a, (*shape, *a.shape[len(shape) :])), (total, -1))
        for a in inputs
    ]
    out: FloatArray | None = None
    for lo in range(0, max(total, 1), chunk):
        hi = min(lo + chunk, total)
        d = np.einsum("...ij,kj->...ki", _sqrt_psd(flat_joint[lo:hi]), pts)
        parts = (
            a[lo:hi].reshape((hi - lo, *b.shape[len(shape) :]))
            for a, b in zip(flat, inputs, strict=True)
        )
        try:
            y = f(d, *parts)
        except ValueError as exc:  # the index inside the chunk → the caller's batch index
            raise ValueError(_rebase(str(exc), lo, shape)) from None
        dy = y - np.einsum("k,...ki->...i", w, y)[..., None, :]
        part = np.einsum("k,...ki,...kj->...ij", w, dy, dy)
        if out is None:
            out = np.empty((total, *part.shape[1:]))
        out[lo:hi] = part
    assert out is not None
    return _sym(out.reshape((*shape, *out.shape[1:])))


def _unscented_generic(joint: Any, f: Callable[..., Any], *inputs: Any) -> Any:
    """:func:`_unscented` on torch/JAX arrays: one expression, the caller's type and device.

    The same rule, square root and weighted moments as the numpy code, written with the array
    API: the points and weights are moved to ``joint``'s type, dtype and device
    (``arrays.like``), ``δ = P Sᵀ`` and the moments are matrix products (numpy's ``einsum``s),
    and the chunks are concatenated instead of written into a preallocated output, so autograd
    and tracing see one expression.

    ``joint`` may be a tuple of the diagonal blocks of a block-diagonal joint covariance
    (independent inputs): each block is factored on its own and ``S`` is their block diagonal.
    numpy's ``eigh`` of the whole joint returns the same eigenvectors, in another column order
    (and the rule is symmetric under permutations and sign changes of the coordinates), so the
    result is the same; the gradient then needs distinct eigenvalues within each block only
    (an isotropic covariance that does not require grad, or an exact point's zero covariance,
    does not make the other input's gradient NaN).
    """
    if isinstance(joint, tuple):
        ref = joint[0]
        roots = [_sqrt_psd(b) for b in joint]
        dims = [int(b.shape[-1]) for b in joint]
        S = arrays.blocks(
            [
                [r if i == k else arrays.zeros((dims[i], dims[k]), ref) for k in range(len(dims))]
                for i, r in enumerate(roots)
            ]
        )
    else:
        ref, S = joint, None
    xp = arrays.namespace(ref)
    shape = tuple(ref.shape[:-2])
    N = int(S.shape[-1]) if S is not None else int(joint.shape[-1])
    pts_np, w_np = sigma_points(N)
    pts, w = arrays.like(pts_np, ref), arrays.like(w_np, ref)
    total = math.prod(shape)
    chunk = max(1, UNSCENTED_BYTES // (pts_np.shape[0] * 1024))
    flat_S = None if S is None else xp.reshape(S, (total, N, N))
    flat_joint: Any = xp.reshape(joint, (total, N, N)) if S is None else None
    flat = [
        xp.reshape(
            xp.broadcast_to(a, (*shape, *a.shape[len(shape) :])),
            (total, *a.shape[len(shape) :]),
        )
        for a in inputs
    ]
    parts_out = []
    for lo in range(0, max(total, 1), chunk):
        hi = min(lo + chunk, total)
        root = _sqrt_psd(flat_joint[lo:hi]) if flat_S is None else flat_S[lo:hi]
        d = pts @ arrays.mT(root)  # (b, K, N): d_k = S p_k
        try:
            y = f(d, *(a[lo:hi] for a in flat))
        except ValueError as exc:  # the index inside the chunk → the caller's batch index
            raise ValueError(_rebase(str(exc), lo, shape)) from None
        dy = y - (w @ y)[..., None, :]  # about the cubature mean
        parts_out.append(arrays.mT(dy) @ (w[:, None] * dy))
    out = parts_out[0] if len(parts_out) == 1 else arrays.concat(parts_out, 0)
    return _sym(xp.reshape(out, (*shape, *out.shape[1:])))


def _rebase(msg: str, offset: int, shape: tuple[int, ...]) -> str:
    """``… batch index (j, k) …`` of a chunk's cubature points → the caller's ``(*i, k)``."""
    m = re.search(r"batch index \((\d+), (\d+)\)", msg)
    if m is None:
        return msg
    where = tuple(int(i) for i in np.unravel_index(offset + int(m.group(1)), shape or (1,)))
    i = (*where[: len(shape)], int(m.group(2)))
    return msg[: m.start()] + f"batch index {i}" + msg[m.end() :]


_F = TypeVar("_F", bound=Callable[..., Any])


def _finite_result(op: str) -> Callable[[_F], _F]:
    """Run an operation without numpy's overflow warnings; name it in an overflow's error.

    Finite input can overflow (translations of 1e200 squared in a covariance): the result is
    checked (``validate.finite_output``) and the error says which operation overflowed, not
    that "cov contains NaN or Inf" as if the caller's covariance did.
    """

    def wrap(f: _F) -> _F:
        @functools.wraps(f)
        def run(*args: Any, **kwargs: Any) -> Any:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                try:
                    return f(*args, **kwargs)
                except ValueError as exc:
                    if "the result overflows float64" in str(exc):
                        raise ValueError(f"{op}: {exc}") from None
                    raise

        return cast(_F, run)

    return wrap


def _check_method(method: str) -> None:
    if method not in ("linear", "unscented"):
        raise ValueError(f"method: expected 'linear' or 'unscented', got {method!r}")


def _sample(c: Convention, T: FloatArray, d: FloatArray, name: str = "A.cov") -> FloatArray:
    """``c.retract(T, d)`` for cubature points ``d`` (..., K, n) at means ``T`` (..., 4, 4)."""
    try:
        return c.retract(T[..., None, :, :], d)
    except ValueError as exc:
        raise ValueError(
            f"{name}: a cubature point of this covariance leaves the {c.name!r} chart's domain "
            f"({exc}); use method='linear' or a smaller covariance"
        ) from None


def _read(c: Convention, C: FloatArray, Y: FloatArray) -> FloatArray:
    """``c.local(C̄, Y)`` for samples ``Y`` (..., K, 4, 4) about the mean ``C̄`` (..., 4, 4)."""
    Cb = arrays.namespace(C).broadcast_to(C[..., None, :, :], tuple(Y.shape))
    return c.local(Cb, Y)


def _bshape(X: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    return arrays.namespace(X).broadcast_to(X, (*shape, *X.shape[-2:]))


# --------------------------------------------------------------------------- operations
@_finite_result("compose")
def compose(
    A: UncertainPose, B: UncertainPose, cross: Any = None, method: Method = "linear"
) -> UncertainPose:
    """Uncertain composition ``C = A·B`` (e.g. ``T_world_cam = T_world_body · T_body_cam``).

    Linear: in GTSAM's tangent ``ξ_C = Ad_{B⁻¹} ξ_A + ξ_B``, so
    ``Σ_C = J_A Σ_A J_Aᵀ + J_B Σ_B J_Bᵀ + J_A X J_Bᵀ + J_B Xᵀ J_Aᵀ`` with, in the convention,
    ``J_A = M_{g→c}(C) Ad_{B⁻¹} M_{c→g}(A)``, ``J_B = M_{g→c}(C) M_{c→g}(B)`` (GTSAM
    ``Pose3::compose``'s ``H1 = Ad_{B⁻¹}``, ``H2 = I``).

    Parameters
    ----------
    A, B : UncertainPose
        Same group and convention (compared by its retraction fields); batch shapes broadcast.
    cross : array_like, shape (..., n, n), optional
        ``E[δA δBᵀ]`` in the convention's tangents (A's error in rows, B's in columns), e.g. the
        off-diagonal block of a GTSAM joint marginal converted with
        :func:`liebridge.gtsam.uncertain.joint_marginal`. ``None``: independent. The joint
        covariance must be positive semi-definite.
    method : {"linear", "unscented"}

    Returns
    -------
    UncertainPose
        ``T = A.T @ B.T`` in ``A.convention``.
    """
    shape = _check_pair(A, B)
    _check_method(method)
    A, B = _align(A, B, "B")
    joint, shape = _joint(A, B, cross, shape)
    c = A.convention
    TA, TB = _bshape(A.T, shape), _bshape(B.T, shape)
    TC = _f64(TA @ TB)
    n = A.dim
    if method == "linear":
        Mo = _from_g(TC, c)
        JA, JB = _mul(Mo, _ad(_inv(TB)), _to_g(TA, c)), _mul(Mo, _to_g(TB, c))
        if cross is None and arrays.is_foreign(TC):  # independent: two n×n sandwiches
            cov = _sym(_sw(JA, _bshape(A.cov, shape)) + _sw(JB, _bshape(B.cov, shape)))
        else:
            cov = _sandwich(_cat([_full(JA, TC, n), _full(JB, TC, n)]), joint)
    else:
        cov = _unscented(
            _joint_full(A, B, joint, shape),
            lambda d, TA, TB, TC: _read(
                c, TC, _sample(c, TA, d[..., :n]) @ _sample(c, TB, d[..., n:], "B.cov")
            ),
            TA,
            TB,
            TC,
        )
    return _result(TC, cov, c)


@_finite_result("inverse")
def inverse(A: UncertainPose, method: Method = "linear") -> UncertainPose:
    """Uncertain inverse ``C = A⁻¹`` (``T_body_world`` from ``T_world_body``).

    Linear: ``ξ_C = −Ad_A ξ_A`` in GTSAM's tangent (``Pose3::inverse``'s ``H = −Ad_A``), so
    ``Σ_C = J Σ_A Jᵀ``, ``J = −M_{g→c}(A⁻¹) Ad_A M_{c→g}(A)``. Right-perturbation conventions
    get ``Ad_A Σ Ad_Aᵀ``; left ones (Barfoot, pytransform3d's global) get
    ``Ad_{A⁻¹} Σ Ad_{A⁻¹}ᵀ``; ROS's get a rotation of the blocks. False: ``Ad_A`` (or ``Ad_{A⁻¹}``)
    in every convention. In an SE(3)-exponential chart the inverse is exactly linear
    (``(A·Exp(ξ))⁻¹ = A⁻¹·Exp(−Ad_A ξ)``): ``method="unscented"`` gains nothing there.
    """
    A = _check_uncertain(A, "A")
    _check_method(method)
    c, TA = A.convention, A.T
    TC = _inv(TA)
    TC = TC if arrays.is_foreign(TC) else TC.copy()
    if method == "linear":
        J = _mul(_from_g(TC, c), _ad(TA), _to_g(TA, c))  # the sign cancels in J Σ Jᵀ
        cov = _sym(_sw(J, A.cov))
    else:
        cov = _unscented(A.cov, lambda d, TA, TC: _read(c, TC, _inv(_sample(c, TA, d))), TA, TC)
    return _result(TC, cov, c)


@_finite_result("relative")
def relative(
    A: UncertainPose, B: UncertainPose, cross: Any = None, method: Method = "linear"
) -> UncertainPose:
    """Uncertain relative pose ``C = A⁻¹·B`` (``T_a_b`` from ``T_w_a``, ``T_w_b``; GTSAM's between).

    Linear: ``ξ_C = −Ad_{B⁻¹A} ξ_A + ξ_B`` in GTSAM's tangent (``Pose3::between``'s
    ``H1 = −Ad_{C⁻¹}``, ``H2 = I``), then converted as in :func:`compose`. With a GTSAM joint
    marginal pass its off-diagonal block as ``cross`` (``E[δA δBᵀ]``): for two poses estimated
    from the same graph it is usually large, and dropping it overstates the relative uncertainty
    (the poses' common error cancels in ``A⁻¹B``).
    """
    shape = _check_pair(A, B)
    _check_method(method)
    A, B = _align(A, B, "B")
    joint, shape = _joint(A, B, cross, shape)
    c = A.convention
    TA, TB = _bshape(A.T, shape), _bshape(B.T, shape)
    TC = _f64(_inv(TA) @ TB)
    n = A.dim
    if method == "linear":
        Mo = _from_g(TC, c)
        JA = -_mul(Mo, _ad(_inv(TC)), _to_g(TA, c))
        JB = _mul(Mo, _to_g(TB, c))
        if cross is None and arrays.is_foreign(TC):  # independent: two n×n sandwiches
            cov = _sym(_sw(JA, _bshape(A.cov, shape)) + _sw(JB, _bshape(B.cov, shape)))
        else:
            cov = _sandwich(_cat([JA, _full(JB, TC, n)]), joint)
    else:
        cov = _unscented(
            _joint_full(A, B, joint, shape),
            lambda d, TA, TB, TC: _read(
                c, TC, _inv(_sample(c, TA, d[..., :n])) @ _sample(c, TB, d[..., n:], "B.cov")
            ),
            TA,
            TB,
            TC,
        )
    return _result(TC, cov, c)


@_finite_result("transform")
def transform(
    A: UncertainPose,
    T_fixed: Any,
    side: Literal["left", "right"] = "left",
    method: Method = "linear",
    *,
    cross: Any = None,
) -> UncertainPose:
    """Change the parent frame (``side="left"``: ``F·A``) or the body frame (``"right"``: ``A·F``).

    ``T_fixed`` is a known transform (an array ``(..., 4, 4)``/``(..., 3, 3)`` or a GTSAM object
    with ``.matrix()``): ``side="left"`` re-expresses ``T_old_body`` as
    ``T_new_body = T_new_old · T_old_body``; ``side="right"`` moves the body frame,
    ``T_parent_sensor = T_parent_body · T_body_sensor`` (a calibrated extrinsic).

    Linear, GTSAM's tangent: left ``ξ_C = ξ_A`` (a right perturbation does not see the parent
    frame), right ``ξ_C = Ad_{F⁻¹} ξ_A``; in a left or world-frame convention (ROS, Barfoot) the
    left change rotates the covariance (``[[R_F, 0], [0, R_F]]`` for ROS, ``Ad_F`` for Barfoot).
    False: the covariance unchanged by a change of parent frame (ROS 2 tf2_geometry_msgs'
    ``doTransform`` for ``PoseWithCovarianceStamped`` copied it: ros2/geometry2 issue #372,
    fixed in C++ by PR #430 with ``transformCovariance``; the Python twin was issue #431).

    An uncertain extrinsic: pass an :class:`UncertainPose` as ``T_fixed``; the result is
    :func:`compose` (``F·A`` or ``A·F``) with ``cross = E[δA δFᵀ]`` (default independent).
    """
    A = _check_uncertain(A, "A")
    if side not in ("left", "right"):
        raise ValueError(f"side: expected 'left' (F·A) or 'right' (A·F), got {side!r}")
    _check_method(method)
    if isinstance(T_fixed, UncertainPose):
        _check_pair(A, T_fixed, "A", "T_fixed")
        if side == "left":
            if cross is None:
                X = None
            elif arrays.is_foreign(cross):
                X = arrays.mT(validate.square(cross, "cross", A.dim))
            else:
                X = np.swapaxes(validate.as_float_array(cross, "cross"), -1, -2)
            return compose(T_fixed, A, X, method)
        return compose(A, T_fixed, cross, method)
    if cross is not None:
        raise ValueError("cross: only meaningful with an uncertain T_fixed (an UncertainPose)")
    TF = _matrix_of(T_fixed)
    if arrays.is_foreign(TF) and not arrays.is_foreign(A.T):
        A = moved(A, TF)
    F = element_input(arrays.common(A.T, TF)[1], "T_fixed")
    same_dtype(A.T, F, "T_fixed", "A.T")
    if tuple(F.shape[-2:]) != tuple(A.T.shape[-2:]):
        raise ValueError(
            f"T_fixed: a {tuple(F.shape[-2:])} matrix, but A holds {tuple(A.T.shape[-2:])}"
        )
    shape = validate.batch_shape(("A", A.batch_shape), ("T_fixed", tuple(F.shape[:-2])))
    c = A.convention
    TA, F = _bshape(A.T, shape), _bshape(F, shape)
    TC = _f64(F @ TA if side == "left" else TA @ F)
    cov_A = _bshape(A.cov, shape)
    if method == "linear":
        Jg = _to_g(TA, c) if side == "left" else _mul(_ad(_inv(F)), _to_g(TA, c))
        cov = _sym(_sw(_mul(_from_g(TC, c), Jg), cov_A))
    elif side == "left":
        cov = _unscented(
            cov_A,
            lambda d, F, TA, TC: _read(c, TC, F[..., None, :, :] @ _sample(c, TA, d)),
            F,
            TA,
            TC,
        )
    else:
        cov = _unscented(
            cov_A,
            lambda d, F, TA, TC: _read(c, TC, _sample(c, TA, d) @ F[..., None, :, :]),
            F,
            TA,
            TC,
        )
    return _result(TC, cov, c)


@_finite_result("act")
def act(A: UncertainPose, p: Any, cov_p: Any = None, method: Method = "linear") -> UncertainPoint:
    """Map an uncertain point through an uncertain pose: ``q = T·p`` (``R p + t``; ``R p``).

    ``p``, ``cov_p`` are in A's body frame (``p_body``), the result in A's parent frame
    (``p_parent``); ``p`` and ``A`` are independent. Linear, GTSAM's tangent:
    ``δq = [−R hat(p), R] ξ_A + R δp`` (``Pose3::transformFrom``'s ``H1``, ``H2 = R``), so
    ``Σ_q = J_A Σ_A J_Aᵀ + R Σ_p Rᵀ`` with ``J_A = [−R hat(p), R] M_{c→g}(A)``.
    The position of the pose itself is ``act(A, zeros(3))``: its covariance in the parent frame.

    Parameters
    ----------
    A : UncertainPose
    p : array_like, shape (..., 3)
    cov_p : array_like, shape (..., 3, 3), optional
        Default: an exact point.
    method : {"linear", "unscented"}

    Returns
    -------
    UncertainPoint
    """
    A = _check_uncertain(A, "A")
    _check_method(method)
    ref = next((x for x in (p, cov_p) if arrays.is_foreign(x)), None)
    if ref is not None and not arrays.is_foreign(A.T):
        A = moved(A, ref)
    _, p, cov_p = arrays.common(A.T, p, cov_p)
    pa = validate.vector(p, "p", 3)
    same_dtype(A.T, pa, "p", "A.T")
    if cov_p is None:
        Cp = arrays.zeros((3, 3), A.T) if arrays.is_foreign(A.T) else np.zeros((3, 3))
    else:
        Cp = validate.covariance(cov_p, "cov_p", 3)
        same_dtype(A.T, Cp, "cov_p", "A.T")
    shape = validate.batch_shape(
        ("A", A.batch_shape), ("p", tuple(pa.shape[:-1])), ("cov_p", tuple(Cp.shape[:-2]))
    )
    c, n = A.convention, A.dim
    TA = _bshape(A.T, shape)
    pa = arrays.namespace(pa).broadcast_to(pa, (*shape, 3))
    R = TA[..., :3, :3]
    q = arrays.matvec(R, pa)
    if n == 6:
        q = q + TA[..., :3, 3]
    if arrays.is_foreign(TA):
        Z = arrays.zeros((n, 3), TA)
        joint = arrays.blocks([[A.cov, Z], [arrays.mT(Z), Cp]])
    else:
        joint = np.zeros((*shape, n + 3, n + 3))
        joint[..., :n, :n] = A.cov
        joint[..., n:, n:] = Cp
    if method == "linear":
        Jg = -R @ U.so3_hat(pa)
        if n == 6:
            Jg = _cat([Jg, R])
        J = _cat([_mul(Jg, _to_g(TA, c)), R])
        cov = _sandwich(J, joint)
    else:

        def f(d: FloatArray, TA: FloatArray, pa: FloatArray) -> FloatArray:
            X = _sample(c, TA, d[..., :n])
            pk = pa[..., None, :] + d[..., n:]
            if arrays.is_foreign(X):
                out = arrays.matvec(X[..., :3, :3], pk)
            else:
                out = np.einsum("...ij,...j->...i", X[..., :3, :3], pk)
            return out + X[..., :3, 3] if n == 6 else out

        if arrays.is_foreign(TA):  # independent: the blocks, factored one by one
            joint = (_bshape(A.cov, shape), _bshape(Cp, shape))
        cov = _unscented(joint, f, TA, pa)
    return UncertainPoint(validate.finite_output(q, "p"), validate.finite_output(cov, "cov"))
