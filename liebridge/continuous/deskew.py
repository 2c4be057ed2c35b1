"""Deskew (motion compensation) of a LiDAR scan, each library's convention a named model.

A scan's points are measured in the sensor frame *at their own capture time*. Deskewing moves
each point ``p`` captured at normalised time ``α`` into the sensor frame at one reference time
``α_ref``: ``p' = T(α_ref)⁻¹·T(α)·p``, with ``T(α)`` the sensor pose ``T_world_sensor``
interpolated between ``T_begin`` (α = 0) and ``T_end`` (α = 1).

Models (what each library does, read in its source and, for KISS-ICP, run):

``"kiss_icp"``
    SE(3) geodesic, ``α = (t − t_min)/(t_max − t_min)`` over the scan's own stamps, reference at
    the scan **end**: ``p' = Exp((α − 1)·Log(ΔT))·p`` with ``ΔT = T_begin⁻¹·T_end``. KISS-ICP
    passes the *previous* scan's relative motion as ``ΔT`` (constant velocity); give that pair of
    poses here (only ``ΔT`` matters: ``deskew(points, stamps, np.eye(4), delta, "kiss_icp")``
    is KISS-ICP's ``Preprocess(points, stamps, delta)``). Source: PRBonn/kiss-icp@4bd9a10
    cpp/kiss_icp/core/Preprocessing.cpp:55-84; run: equal to the ``kiss-icp`` 1.3 package's own
    preprocessor in the tests.
``"ct_icp"``
    Split: SLERP of the rotations and LERP of the translations between the frame's
    ``begin_pose`` and ``end_pose``, α normalised per scan, reference at the scan **end** (CT-ICP's
    ``DistortFrame`` "put all raw_points in the coordinate frame of the pose at the end of the
    acquisition"). Source-read (not run: ct_icp does not install from a package index):
    jedeschaud/ct_icp@d467813 src/ct_icp/ct_icp.cpp:199-212 (``DistortFrame``),
    src/SlamCore/types.cxx:24-30 (``ContinousTransform``: SLERP + LERP), include/SlamCore/types.h:
    210-218 (α = (t − t_begin)/(t_end − t_begin) with the two poses' stamps). Eigen's ``slerp``
    takes the short way, as the principal logarithm here does.
``"generic"``
    Your choice: ``method="se3"`` or ``"split"``, ``reference="begin"``, ``"mid"``, ``"end"`` or a
    time (in the stamps' unit), ``t_begin``/``t_end`` the times of the two poses (default: the
    scan's own first and last stamps).

Time: float stamps are seconds, integer stamps nanoseconds (:attr:`Deskewed.time_unit` says which
was read); a reference time or ``t_begin``/``t_end`` in the other unit is an error, never a
guess. Stamps need not be sorted.

Jacobians (``jacobians=True``): ``J_p_T_begin[i] = ∂p'_i/∂δ`` for ``T_begin ⊕ δ`` in the
convention's retraction (columns in its tangent at ``T_begin``), likewise ``J_p_T_end`` — the
chain rule of a CT-ICP residual. Tempting and false: the Jacobian of a point with respect to the
end pose is ``α`` times that of a rigid transform (it is for a pure translation only).
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import ConventionLike
from ..lie import unchecked as lu
from ..lie.series import one_minus_cos_over_t2, sinc, t_minus_sin_over_t3
from ._common import convention as _se3_convention
from ._common import hat3, same_unit, time_array, to_conv_columns
from .interpolate import COUPLED, METHODS, interp_canonical

__all__ = ["DESKEW_MODELS", "REFERENCES", "Deskewed", "deskew"]

#: The deskew models, by name.
DESKEW_MODELS: tuple[str, ...] = ("kiss_icp", "ct_icp", "generic")
#: Named reference times and their normalised α.
REFERENCES: dict[str, float] = {"begin": 0.0, "mid": 0.5, "end": 1.0}
Model = Literal["kiss_icp", "ct_icp", "generic"]


class Deskewed(NamedTuple):
    """A deskewed scan.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        Points in the sensor frame at the reference time.
    J_p_T_begin, J_p_T_end : ndarray, shape (N, 3, 6) or None
        ``∂p'/∂T_begin``, ``∂p'/∂T_end`` in the convention's tangent (None unless requested).
    alpha : ndarray, shape (N,)
        Each point's normalised time.
    alpha_ref : float
        The reference time, normalised.
    time_unit : str
        ``"s"`` (float stamps were read as seconds) or ``"ns"`` (integer nanoseconds).
    """

    points: FloatArray
    J_p_T_begin: FloatArray | None
    J_p_T_end: FloatArray | None
    alpha: FloatArray
    alpha_ref: float
    time_unit: str


_MODEL_DEFAULTS: dict[str, tuple[str, str]] = {
    "kiss_icp": ("se3", "end"),
    "ct_icp": ("split", "end"),
}


def _alpha(stamps: Any, t_begin: Any, t_end: Any, reference: Any) -> tuple[FloatArray, float, str]:
    st, unit = time_array(stamps, "stamps")
    if st.ndim != 1 or st.size == 0:
        raise ValueError(f"stamps: expected shape (N,) with N ≥ 1, got {st.shape}")
    ends = []
    for val, name, default in (
        (t_begin, "t_begin", st.min()),
        (t_end, "t_end", st.max()),
    ):
        if val is None:
            ends.append(default)
            continue
        v, u = time_array(val, name)
        same_unit(unit, "stamps", u, name)
        if v.ndim != 0:
            raise ValueError(f"{name}: expected one time, got shape {v.shape}")
        ends.append(v[()])
    t0, t1 = ends
    span = t1 - t0
    if span <= 0:
        what = "t_max == t_min" if t_begin is None and t_end is None else "t_end ≤ t_begin"
        raise ValueError(
            f"stamps: cannot normalise time in this scan ({what}: begin {t0.item()!r}, "
            f"end {t1.item()!r} "
            f"{unit}, {st.size} stamps); a deskew needs a scan that lasts"
        )
    if unit == "ns":
        alpha = (st - t0).astype(np.float64) / float(span)
    else:
        alpha = (st - t0) / span
    if isinstance(reference, str):
        a_ref = REFERENCES[validate.option(reference, "reference", tuple(REFERENCES))]
    else:
        r, ru = time_array(reference, "reference")
        same_unit(unit, "stamps", ru, "reference")
        if r.ndim != 0:
            raise ValueError(f"reference: expected one time, got shape {r.shape}")
        a_ref = float(r[()] - t0) / float(span)
    return np.asarray(alpha, dtype=np.float64), a_ref, unit


def deskew(
    points: Any,
    stamps: Any,
    T_begin: Any,
    T_end: Any,
    model: Model | str = "generic",
    *,
    reference: str | float | int | None = None,
    method: str | None = None,
    t_begin: Any = None,
    t_end: Any = None,
    convention: ConventionLike = "gtsam",
    jacobians: bool = False,
) -> Deskewed:
    """Move a scan's points into the sensor frame at the reference time.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Each point in the sensor frame at its own capture time.
    stamps : array_like, shape (N,)
        Capture times: float seconds or integer nanoseconds (any order).
    T_begin, T_end : array_like, shape (4, 4)
        ``T_world_sensor`` at α = 0 and α = 1 (for ``"kiss_icp"``: the pair whose relative
        motion ``T_begin⁻¹·T_end`` is the constant-velocity guess).
    model : {"kiss_icp", "ct_icp", "generic"}
        See the module docstring; the first two fix ``method`` and ``reference``.
    reference : {"begin", "mid", "end"} or time, optional
        ``"generic"`` only (default ``"end"``); a time is in the stamps' unit.
    method : {"se3", "split"}, optional
        ``"generic"`` only (default ``"se3"``).
    t_begin, t_end : time, optional
        ``"generic"`` only: the times of ``T_begin`` and ``T_end`` (default: the stamps' min, max).
    convention : str or Convention
        SE(3) convention of the Jacobians' columns.
    jacobians : bool
        Also return ``∂p'/∂T_begin`` and ``∂p'/∂T_end``.

    Returns
    -------
    Deskewed

    Examples
    --------
    >>> import numpy as np
    >>> from liebridge.continuous import deskew
    >>> from liebridge.lie import se3
    >>> T_end = se3.exp([0.0, 0.0, 0.1, 1.0, 0.0, 0.0])
    >>> out = deskew([[5.0, 0, 0], [5.0, 0, 0]], [0, 100_000_000], np.eye(4), T_end, "kiss_icp")
    >>> out.time_unit, out.alpha.tolist()
    ('ns', [0.0, 1.0])
    """
    model = validate.option(model, "model", DESKEW_MODELS)
    if model in _MODEL_DEFAULTS:
        for val, name in ((reference, "reference"), (method, "method")):
            if val is not None:
                raise ValueError(
                    f"{name}: model {model!r} fixes it ({_MODEL_DEFAULTS[model]}); "
                    f"use model='generic' to choose"
                )
        for val, name in ((t_begin, "t_begin"), (t_end, "t_end")):
            if val is not None:
                raise ValueError(f"{name}: model {model!r} normalises time by the scan's stamps")
        meth, ref_name = _MODEL_DEFAULTS[model]
        ref: str | float | int = ref_name
    else:
        meth = "se3" if method is None else validate.option(method, "method", METHODS)
        ref = "end" if reference is None else reference
    conv = _se3_convention(convention)
    P = validate.as_float_array(points, "points")
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"points: expected shape (N, 3), got {P.shape}")
    validate.check_finite(P, "points", core_ndim=1)
    n = P.shape[0]
    st = np.asarray(stamps)
    if st.shape != (n,):
        raise ValueError(f"stamps: expected shape ({n},) to match points, got {st.shape}")
    A = validate.pose(T_begin, "T_begin")
    B = validate.pose(T_end, "T_end")
    for X, name in ((A, "T_begin"), (B, "T_end")):
        if X.shape != (4, 4):
            raise ValueError(f"{name}: expected one pose, shape (4, 4), got {X.shape}")
    alpha, a_ref, unit = _alpha(stamps, t_begin, t_end, ref)

    if meth == COUPLED and not jacobians:
        # Exp(c·ξ)·p for one twist ξ = (ω, v) and per-point scalars c, without 4×4 matrices:
        # R p = p + A c (ω×p) + B c² ω×(ω×p),  V c v = c v + B c² ω×v + C c³ ω×(ω×v)
        xi = np.asarray(lu.se3_log(lu.se3_inverse(A) @ B), dtype=np.float64)
        w, v = xi[:3], xi[3:]
        c = alpha - a_ref
        theta = np.abs(c) * float(np.linalg.norm(w))
        cA = sinc(theta) * c
        cB = one_minus_cos_over_t2(theta) * c * c
        wp = np.cross(w, P)
        wv = np.cross(w, v)
        out = P + cA[:, None] * wp + cB[:, None] * (np.cross(w, wp) + wv)
        out += c[:, None] * v + (t_minus_sin_over_t3(theta) * c**3)[:, None] * np.cross(w, wv)
        return Deskewed(out, None, None, alpha, a_ref, unit)

    Ta, Ja0, Ja1, _ = interp_canonical(A, B, alpha, meth, jacobians)
    Tb, Jb0, Jb1, _ = interp_canonical(A, B, np.asarray(a_ref), meth, jacobians)
    D = lu.se3_inverse(Tb) @ Ta  # T_ref⁻¹ T(α)
    out = np.einsum("nij,nj->ni", D[:, :3, :3], P) + D[:, :3, 3]
    if not jacobians:
        return Deskewed(np.asarray(out), None, None, alpha, a_ref, unit)
    assert Ja0 is not None and Ja1 is not None and Jb0 is not None and Jb1 is not None
    # p' = B⁻¹A p: ∂p'/∂ε_A = R_BA [−[p]ₓ, I], ∂p'/∂ε_B = [[p']ₓ, −I] (canonical right (ω, v))
    dA = np.empty((n, 3, 6))
    dA[:, :, :3] = -D[:, :3, :3] @ hat3(P)
    dA[:, :, 3:] = D[:, :3, :3]
    dB = np.empty((n, 3, 6))
    dB[:, :, :3] = hat3(out)
    dB[:, :, 3:] = -np.eye(3)
    J0 = dA @ Ja0 + dB @ Jb0
    J1 = dA @ Ja1 + dB @ Jb1
    J0 = to_conv_columns(J0, conv, None, A)
    J1 = to_conv_columns(J1, conv, None, B)
    return Deskewed(np.asarray(out), J0, J1, alpha, a_ref, unit)
