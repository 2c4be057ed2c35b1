"""g2o / TORO-iSAM pose-graph files with explicit information semantics.

Old path: also reachable as ``lb.g2o`` (earlier releases); new code writes ``lb.io.g2o``.

Read with :func:`read`, write with :func:`write`, hand to GTSAM with :meth:`G2OGraph.to_gtsam`
(with ``liebridge optimize``'s gauge prior unless ``prior=None``: a graph of relative
measurements alone fixes no pose, and GTSAM's marginals fail on it).
Inside, every information matrix is over **GTSAM's tangent** of the edge error,
``ξ = (ω, v) = Log(Z⁻¹·Ti⁻¹·Tj)`` (rotation first; what ``gtsam.BetweenFactorPose3`` whitens),
whatever the file held. Supported lines::

    VERTEX_SE3:QUAT id x y z qx qy qz qw
    EDGE_SE3:QUAT   i j x y z qx qy qz qw  I11 I12 .. I16 I22 .. I66   (21 numbers)
    VERTEX3         id x y z roll pitch yaw
    EDGE3           i j x y z roll pitch yaw  A11 A12 .. A16 A22 .. A66 (21 numbers)
    FIX             id [id ...]

(2-D files are read by :mod:`liebridge.io.g2o2d`.) A measurement ``Z`` is
``T_i_j``, pose ``j`` in the frame of pose ``i`` (``Ti⁻¹·Tj`` when consistent).

``EDGE_SE3:QUAT`` (g2o, ``types/slam3d/edge_se3.cpp``)
    The information is over g2o's own error ``e = (t, qvec)`` of ``Z⁻¹·Ti⁻¹·Tj``: translation,
    then the **vector part of the unit quaternion** (sign chosen with ``w ≥ 0``), 21 numbers =
    the upper triangle, row-major. To first order ``e = M ξ`` with ``M = [[0, I], [I/2, 0]]``
    (:func:`_g2o_error_map`; the quaternion vector part is half the rotation angle), so the
    format's own definition gives ``Λ_gtsam = Mᵀ Λ_g2o M``: the blocks swapped, the rotation block
    **divided by 4** and the cross blocks by 2 (``information="g2o"``, the default).
    ``gtsam.readG2o`` only swaps the blocks (``information="gtsam"`` reproduces it): it reads the
    information on ``qvec ≈ θ/2`` as information on ``θ``, a rotation weight 4× heavier than g2o's
    own (and twice the cross terms). Both readings give the same χ² only if one of them is
    rescaled; pick the one your data was made for.

``EDGE3`` / ``VERTEX3`` (TORO / iSAM 3D format; ``sphere2500.txt``)
    ``x y z roll pitch yaw``, with ``R = Rz(yaw)·Ry(pitch)·Rx(roll)`` (rotation about the fixed
    x axis by roll, then fixed y by pitch, then fixed z by yaw; GTSAM ``Rot3.Ypr(yaw, pitch,
    roll)``). The 21 numbers are an upper triangle, row-major, over the parameter difference
    ``(x, y, z, roll, pitch, yaw)(Ti⁻¹Tj) − (x, y, z, roll, pitch, yaw)(Z)``. What they *are*
    differs between the readers of the format:

    * iSAM 1.x (Kaess et al., MIT; ``Loader.cpp``, ``$Id: Loader.cpp 2955``) reads ``EDGE3`` as
      ``x y z roll pitch yaw`` + the upper-triangular **square-root information** ``S``
      (``Λ = SᵀS``), reordering the angle block to its internal ``(yaw, pitch, roll)``; its
      ``slam3d.h`` ``Pose3d_Pose3d_Factor::basic_error`` is ``vector(p2 ⊖ p1) − vector(measure)``
      with the angles wrapped. The sphere datasets come from iSAM.
    * g2o (RainerKuemmerle/g2o ``g2o/types/slam3d_addons/edge_se3_euler.cpp``,
      ``EdgeSE3Euler::read``, registered as ``EDGE3``) reads the 21 numbers as the
      **information** over ``(x, y, z, roll, pitch, yaw)``.
    * TORO (Grisetti et al.; ``posegraph3.cpp`` ``TreePoseGraph3::load``, read in the copy
      vendored by introlab/rtabmap under ``corelib/src/optimizer/toro3d/``) reads them as
      information indexed like its internal ``Pose3`` ``(roll, pitch, yaw, x, y, z)``
      (``transformation3.h``; ``treeoptimizer3_iteration.cpp`` takes rotational weights from
      ``W[0..2][0..2]``). GTSAM (borglab/gtsam ``gtsam/slam/dataset.cpp``,
      ``ParseMeasurement<Pose3>``) uses them as-is as information on ``(ω, v)`` — rotation
      first, like TORO — and builds ``Rot3::Ypr(yaw, pitch, roll)``.

    The data decides: in ``sphere2500.txt`` every edge holds ``diag(10, 10, 10, 100, 100, 25)``,
    and against ``sphere2500_groundtruth.txt`` the measurement noise has standard deviations
    ``(0.10, 0.10, 0.10, 0.010, 0.010, 0.040)`` in ``(x, y, z, roll, pitch, yaw)`` — exactly the
    reciprocals, i.e. iSAM's square-root information in file order (``tests/test_g2o.py``
    checks this, and that ``Rz·Ry·Rx`` closes the ground-truth loops while ``Rx·Ry·Rz`` does not).
    Read with ``information="gtsam"`` the same file gets a rotation weight of 10 instead of
    ``10⁴`` and translation weights ``(100, 100, 25)`` instead of 100.
    With ``information="g2o"`` (the format's definition), ``edge3="sqrt_information"`` (default,
    iSAM) or ``edge3="information"`` (g2o's ``EdgeSE3Euler``) selects ``Λ_e``, and
    ``Λ_gtsam = Eᵀ Λ_e E`` with ``E = ∂(x, y, z, roll, pitch, yaw)(Z·Exp(ξ))/∂ξ`` at ``ξ = 0``
    (:func:`_euler_error_map`: ``[[0, R_Z], [W(roll, pitch), 0]]``, ``W`` the body-rate → ZYX
    Euler-rate matrix), exact to first order at the measurement. (iSAM's own reordering is exact
    only for a diagonal angle block; g2o's ``EdgeSE3Euler`` converts by differentiating the
    parameters of ``Z`` itself rather than of ``Z⁻¹·Ti⁻¹·Tj``, which agrees only near ``Z = I``.)

Graphs without ``VERTEX`` lines (``sphere2500.txt``) get initial values by chaining the
odometry edges ``(k−1, k)`` from the identity at the smallest id.

Numbers are written with ``repr`` (the shortest text that reads back to the same double) and
the pose parameters are stored exactly as read, so ``read(write(g))`` reproduces every array of
``g`` bit for bit; ``gtsam.writeG2o`` prints 6 significant digits. A malformed line raises
``ValueError`` naming the file and the 1-based line number.
"""

from __future__ import annotations

import io
import itertools
import math
import os
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from itertools import repeat
from operator import itemgetter
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions.convert import tangent_map
from ..conventions.rotation_coords import GIMBAL_TOL, euler_rate_map, euler_to_matrix
from ..lie import quaternion as quat
from . import poses as _layouts
from .trajectory import field_numbers, open_text, text_lines

__all__ = ["GAUGE_PRIOR_SIGMA", "G2OGraph", "GaugePriorNotice", "read", "write"]

PathLike = str | os.PathLike[str]
KeyArray = npt.NDArray[np.uint64]  # vertex ids are GTSAM keys: uint64, 2**63 and above included
InformationReading = Literal["g2o", "gtsam"]
Edge3Numbers = Literal["sqrt_information", "information"]

_2D_TAGS = frozenset(
    {"VERTEX_SE2", "EDGE_SE2", "VERTEX2", "EDGE2", "VERTEX", "EDGE", "VERTEX_XY", "EDGE_SE2_XY"}
)
#: σ of the default gauge prior of :meth:`G2OGraph.to_gtsam` (and of ``liebridge optimize``), in
#: every direction of GTSAM's tangent (radians and metres alike).
GAUGE_PRIOR_SIGMA = 1e-4
_TRIU = np.triu_indices(6)
_TRIU_NAMES = [f"[{r}, {c}]" for r, c in zip(*_TRIU, strict=True)]
#: A quaternion whose norm is this close to 1 is taken as already normalised (dividing again
#: could flip its last bits, and ``read(write(g))`` must reproduce ``g`` exactly).
_UNIT_NORM_SLACK = 8 * np.finfo(np.float64).eps


def _g2o_error_map() -> FloatArray:
    """First-order map from GTSAM's tangent to g2o's ``EDGE_SE3:QUAT`` error, ``e = M ξ``.

    ``ξ = (ω, v) = Log(Z⁻¹·Ti⁻¹·Tj)`` (GTSAM) and ``e = (t, qvec)`` of the same ``Z⁻¹·Ti⁻¹·Tj``
    (g2o, ``w ≥ 0``). ``Exp(ξ)`` has translation ``Jl(ω)·v = v + O(|ξ|²)`` and quaternion vector
    part ``sin(θ/2)·ω/θ = ω/2 + O(θ³)``, so ``M = [[0, I], [I/2, 0]]`` (rows ``t, qvec``; columns
    ``ω, v``), checked by finite differences in ``tests/test_g2o.py``. Information maps as
    ``Λ_gtsam = Mᵀ Λ_g2o M`` (and back with ``M⁻¹ = [[0, 2I], [I, 0]]``); with entries 0, 1, ½
    and one nonzero per column both maps are exact in floating point.

    It is the conversion core's ``tangent_map(Z, "gtsam", "g2o")`` (``δ_dst = M δ_src``), which
    for these two presets does not depend on ``Z``: the ``g2o`` preset *is* this error's chart.
    """
    return tangent_map(np.eye(4), "gtsam", "g2o")


def _rpy_matrix(rpy: FloatArray) -> FloatArray:
    """``Rz(yaw)·Ry(pitch)·Rx(roll)`` for ``rpy = (roll, pitch, yaw)`` ``(..., 3)``."""
    return euler_to_matrix(rpy, "euler_rpy")


def _euler_error_map(rpy: FloatArray) -> FloatArray:
    """``E = ∂(x, y, z, roll, pitch, yaw)(Z·Exp(ξ))/∂ξ`` at ``ξ = 0``, ``(..., 6, 6)``.

    ``Z = (Rz(yaw)·Ry(pitch)·Rx(roll), t)``; columns ``ξ = (ω, v)`` (GTSAM). The translation of
    ``Z·Exp(ξ)`` is ``t + R_Z·v + O(|ξ|²)``; the ZYX Euler rates for a body rate ``ω`` are
    ``W ω`` (:func:`liebridge.conventions.rotation_coords.euler_rate_map`, ``euler_rpy``),
    singular at ``cos(pitch) = 0`` (gimbal lock: an error there). So ``E = [[0, R_Z], [W, 0]]``.
    """
    R = _rpy_matrix(rpy)
    W = euler_rate_map(rpy, "euler_rpy", "EDGE3 measurement")
    E = np.zeros((*rpy.shape[:-1], 6, 6))
    E[..., :3, 3:] = R
    E[..., 3:, :3] = W
    return E


def _swap_blocks(A: FloatArray) -> FloatArray:
    """``P A P`` with ``P`` exchanging the two 3-blocks: (t, r) order ↔ (r, t) order."""
    out = np.empty_like(A)
    out[..., :3, :3] = A[..., 3:, 3:]
    out[..., 3:, 3:] = A[..., :3, :3]
    out[..., :3, 3:] = A[..., 3:, :3]
    out[..., 3:, :3] = A[..., :3, 3:]
    return out


def _symmetrised(A: FloatArray) -> FloatArray:
    """Return ``(A + Aᵀ)/2`` without overflow (halves first), exact where ``A`` is symmetric.

    ``0.5·(A + Aᵀ)`` turns entries ≥ 9e307 into ``inf``, and halving a
    subnormal loses its last bit, so entries that already equal their mirror are kept as they are.
    """
    At = np.swapaxes(A, -1, -2)
    return np.where(A == At, A, 0.5 * A + 0.5 * At)


#: Entrywise factors of ``Λ_gtsam = Mᵀ Λ_g2o M`` after the block swap, in (ω, v) order: the
#: rotation block /4, the cross blocks /2. Powers of two, applied entrywise: exact (no matmul
#: that would turn ``-0.0`` into ``0.0`` or round).
_G2O_TO_GTSAM_SCALE = np.block(
    [[np.full((3, 3), 0.25), np.full((3, 3), 0.5)], [np.full((3, 3), 0.5), np.ones((3, 3))]]
)


def _ids(x: Any, name: str) -> KeyArray:
    """Validate vertex ids (integers in ``[0, 2**64 − 2]``: GTSAM keys); return them as uint64."""
    a = np.asarray(x)
    if a.dtype == object or (a.size == 0 and a.dtype.kind == "f"):
        try:
            a = np.array([int(k) for k in a.reshape(-1)], dtype=object).reshape(a.shape)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: expected integer ids") from None
    elif not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name}: expected integer ids, got dtype {a.dtype}")
    if a.dtype != object:  # integer arrays: checked in place (no Python int per id)
        bad = a < 0 if a.dtype.kind == "i" else a > validate.MAX_KEY
        if not bad.any():
            return a.astype(np.uint64, copy=False)
    flat = [int(k) for k in a.reshape(-1).tolist()]
    bad_ids = [k for k in flat if not 0 <= k <= validate.MAX_KEY]
    if bad_ids:
        raise ValueError(
            f"{name}: id {bad_ids[0]} is outside [0, 2**64 - 2] (GTSAM keys are uint64)"
        )
    return np.array(flat, dtype=np.uint64).reshape(a.shape)


def _triu_to_sym(vals: FloatArray) -> FloatArray:
    m = np.zeros((*vals.shape[:-1], 6, 6))
    m[..., _TRIU[0], _TRIU[1]] = vals
    m[..., _TRIU[1], _TRIU[0]] = vals
    return m


def _triu_to_upper(vals: FloatArray) -> FloatArray:
    m = np.zeros((*vals.shape[:-1], 6, 6))
    m[..., _TRIU[0], _TRIU[1]] = vals
    return m


#: Rows per pass of the batched conversions and checks: bounds their temporaries.
_CHUNK = 1 << 15


def _covariances(x: Any, name: str, dim: int) -> FloatArray:
    """:func:`liebridge._validate.covariance` of a batch ``(M, dim, dim)``, chunk by chunk.

    The check is per matrix, so chunks find what the whole batch would; the error is then
    raised by the whole batch, naming the batch index in it. Temporaries are a chunk's size.
    """
    arr = validate.as_float_array(x, name)
    if arr.ndim != 3 or arr.shape[0] <= _CHUNK:
        return validate.covariance(arr, name, dim)
    try:
        for lo in range(0, arr.shape[0], _CHUNK):
            validate.covariance(arr[lo : lo + _CHUNK], name, dim)
    except ValueError:
        validate.covariance(arr, name, dim)
        raise
    return arr


def has_duplicates(ids: KeyArray) -> bool:
    """Whether an id occurs twice (one sort: ``np.unique`` is several times slower here)."""
    s = np.sort(ids)
    return bool((s[1:] == s[:-1]).any())


def _check_vertex_refs(ids: Any, e: Any) -> None:
    """Raise unless the vertex ids are unique and every edge names two of them."""
    if has_duplicates(ids):
        raise ValueError("vertex_ids: ids are not unique")
    missing = ~np.isin(e, ids)
    if missing.any():
        k = int(np.argwhere(missing)[0][0])
        raise ValueError(f"edges[{k}]: {tuple(int(x) for x in e[k])} refers to a missing vertex")


def _symmetrised_copy(A: FloatArray, copy: bool = True) -> FloatArray:
    """Return :func:`_symmetrised` ``(A)`` ``(M, n, n)`` read-only, chunk by chunk.

    Exactly symmetric input is returned as it is (made read-only in place) unless ``copy``.
    """
    exact = all(
        bool((a == np.swapaxes(a, -1, -2)).all())
        for a in (A[lo : lo + _CHUNK] for lo in range(0, A.shape[0], _CHUNK))
    )
    if exact and not copy:
        out = A
    else:
        out = np.empty(A.shape)
        for lo in range(0, A.shape[0], _CHUNK):
            out[lo : lo + _CHUNK] = _symmetrised(A[lo : lo + _CHUNK])
    out.flags.writeable = False
    return out


def _readonly(a: npt.NDArray[Any], copy: bool = True) -> npt.NDArray[Any]:
    a = np.array(a, copy=True) if copy else np.asarray(a)
    a.flags.writeable = False
    return a


class GaugePriorNotice(UserWarning):
    """Shown (once per calling line) when ``to_gtsam()`` adds its default gauge prior.

    Pass ``prior=None`` (no prior), a σ or a covariance to choose, and the notice is not shown;
    or silence it with ``warnings.filterwarnings("ignore", category=GaugePriorNotice)``.
    """


def prior_covariance(prior: Any, dim: int) -> FloatArray | None:
    """Return the ``(dim, dim)`` covariance a ``to_gtsam(prior=...)`` argument stands for, or None.

    ``"gauge"``: ``GAUGE_PRIOR_SIGMA² I``; ``None``: no prior; a number σ: ``σ² I``; ``dim``
    numbers: the σ of each tangent direction; a ``(dim, dim)`` symmetric positive definite
    matrix: that covariance. Anything else is a ``TypeError``/``ValueError`` naming ``prior``.
    """
    if prior is None:
        return None
    if isinstance(prior, str):
        if prior == "gauge":
            return np.eye(dim) * GAUGE_PRIOR_SIGMA**2
        raise ValueError(
            f"prior: expected 'gauge', None, a standard deviation, {dim} standard deviations or "
            f"a ({dim}, {dim}) covariance, got {prior!r}"
        )
    if isinstance(prior, bool | np.bool_):
        raise TypeError(f"prior: expected 'gauge', None, a number or an array, got {prior!r}")
    try:
        a = np.array(prior, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(
            f"prior: expected 'gauge', None, a number or an array, got {type(prior).__name__}"
        ) from None
    if a.ndim == 0 or a.shape == (dim,):
        sig = np.broadcast_to(a, (dim,))
        bad = np.flatnonzero(~(np.isfinite(sig) & (sig > 0)))
        if bad.size:
            where = "" if a.ndim == 0 else f"[{bad[0]}]"
            got = float(sig[bad[0]])
            raise ValueError(f"prior{where}: a standard deviation must be finite, > 0, got {got!r}")
        return np.diag(sig**2)
    if a.shape != (dim, dim):
        raise ValueError(
            f"prior: expected a standard deviation, {dim} of them or a ({dim}, {dim}) covariance, "
            f"got shape {a.shape}"
        )
    if not np.isfinite(a).all():
        r, c = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"prior[{r}, {c}]: the covariance is not finite ({float(a[r, c])!r})")
    asym = float(np.abs(a - a.T).max())
    if asym > 1e-9 * max(float(np.abs(a).max()), np.finfo(float).tiny):
        raise ValueError(f"prior: the covariance is not symmetric (|C - Cᵀ| up to {asym:.3g})")
    a = 0.5 * (a + a.T)
    low = float(np.linalg.eigvalsh(a)[0])
    if low <= 0:
        raise ValueError(
            f"prior: the covariance is not positive definite (smallest eigenvalue {low:.3g})"
        )
    return a


def gauge_keys(vertex_ids: Any, fixed: Sequence[int]) -> list[int]:
    """Return the vertices the gauge prior holds: the ``FIX`` ones, else the first vertex."""
    if fixed:
        known = {int(k) for k in np.asarray(vertex_ids).tolist()}
        for n, k in enumerate(fixed):
            if int(k) not in known:
                raise ValueError(f"fixed[{n}]: FIX id {int(k)} is not a vertex of the graph")
        return [int(k) for k in fixed]
    return [int(vertex_ids[0])] if len(vertex_ids) else []


def gauge_notice(where: str, keys: list[int], sigma_words: str, stacklevel: int = 3) -> None:
    """Tell the user (once per calling line) which gauge prior ``to_gtsam()`` added."""
    shown = ", ".join(str(k) for k in keys[:5]) + (", ..." if len(keys) > 5 else "")
    warnings.warn(
        f"{where}: added a gauge prior on vertex {shown} at its initial pose "
        f"(σ = {GAUGE_PRIOR_SIGMA:g} {sigma_words}), as `liebridge optimize` does; "
        "prior=None adds none, prior=σ or a covariance another",
        GaugePriorNotice,
        stacklevel=stacklevel,
    )


@dataclass(frozen=True, eq=False)
class G2OGraph:
    """A 3D pose graph as read from (or to be written to) a g2o file.

    Attributes
    ----------
    vertex_ids : ndarray of uint64, shape (N,)
        Vertex ids, used as GTSAM keys by :meth:`to_gtsam`.
    vertex_xyz_qxyzw : ndarray, shape (N, 7)
        Vertex poses ``T_world_vertex`` as stored in the file, layout ``"xyz_qxyzw"`` (unit
        quaternion, sign as written). :attr:`poses` gives the matrices.
    edges : ndarray of uint64, shape (M, 2)
        ``(i, j)`` vertex ids of each edge.
    measured_xyz_qxyzw : ndarray, shape (M, 7)
        Measurements ``Z = T_i_j``, layout ``"xyz_qxyzw"``. :attr:`measured` gives the matrices.
    information : ndarray, shape (M, 6, 6)
        Information of each edge over GTSAM's tangent ``ξ = (ω, v) = Log(Z⁻¹·Ti⁻¹·Tj)``,
        rotation first, whatever the file stored (see the module docstring).
    information_reading : {"g2o", "gtsam"}
        How the file's numbers were turned into :attr:`information`; :func:`write` inverts it.
    fixed : tuple of int
        Ids from ``FIX`` lines (kept and written back; :meth:`to_gtsam`'s gauge prior holds
        them, or the first vertex when there are none).
    vertices_from_odometry : bool
        True if the file had no vertices and :attr:`poses` were chained from odometry edges.
    """

    vertex_ids: KeyArray
    vertex_xyz_qxyzw: FloatArray
    edges: KeyArray
    measured_xyz_qxyzw: FloatArray
    information: FloatArray
    information_reading: InformationReading = "g2o"
    fixed: tuple[int, ...] = field(default=())
    vertices_from_odometry: bool = False

    def __post_init__(self) -> None:
        self._check_and_freeze(copy=True)

    @classmethod
    def _adopt(cls, **fields: Any) -> G2OGraph:
        """Build from arrays the reader has just made and hands over (not copied).

        The same checks as the constructor; the arrays are made read-only in place instead of
        copied, so the reader's peak memory stays within 3× of the arrays returned.
        """
        graph = object.__new__(cls)
        for name, value in fields.items():
            object.__setattr__(graph, name, value)
        graph._check_and_freeze(copy=False)
        return graph

    def _check_and_freeze(self, *, copy: bool) -> None:
        """Validate the fields; store them read-only (copies if ``copy``), exactly symmetric."""
        ids = _ids(self.vertex_ids, "vertex_ids")
        if ids.ndim != 1:
            raise ValueError(f"vertex_ids: expected a 1-D integer array, got {ids.shape}")
        n = ids.shape[0]
        vx = validate.vector(self.vertex_xyz_qxyzw, "vertex_xyz_qxyzw", 7)
        if vx.shape != (n, 7):
            raise ValueError(f"vertex_xyz_qxyzw: expected shape ({n}, 7), got {vx.shape}")
        validate.quaternion(vx[:, 3:], "vertex_xyz_qxyzw quaternion")
        vx = _unit_rows(vx)
        e = _ids(self.edges, "edges")
        if e.ndim != 2 or e.shape[1] != 2:
            raise ValueError(f"edges: expected an (M, 2) integer array, got {e.shape}")
        m = e.shape[0]
        mx = validate.vector(self.measured_xyz_qxyzw, "measured_xyz_qxyzw", 7)
        if mx.shape != (m, 7):
            raise ValueError(f"measured_xyz_qxyzw: expected shape ({m}, 7), got {mx.shape}")
        validate.quaternion(mx[:, 3:], "measured_xyz_qxyzw quaternion")
        mx = _unit_rows(mx)
        info = _covariances(self.information, "information", 6)
        if info.shape != (m, 6, 6):
            raise ValueError(f"information: expected shape ({m}, 6, 6), got {info.shape}")
        if self.information_reading not in ("g2o", "gtsam"):
            raise ValueError(
                f"information_reading: expected 'g2o' or 'gtsam', got {self.information_reading!r}"
            )
        _check_vertex_refs(ids, e)
        object.__setattr__(self, "vertex_ids", _readonly(ids, copy))
        object.__setattr__(self, "vertex_xyz_qxyzw", _readonly(vx, copy))
        object.__setattr__(self, "edges", _readonly(e, copy))
        object.__setattr__(self, "measured_xyz_qxyzw", _readonly(mx, copy))
        # exactly symmetric, so that writing the upper triangle loses nothing
        object.__setattr__(self, "information", _symmetrised_copy(info, copy))
        fixed = _ids(np.asarray(list(self.fixed), dtype=object), "fixed")
        object.__setattr__(self, "fixed", tuple(int(i) for i in fixed))

    def __repr__(self) -> str:
        """One line: sizes and the information reading, not every array."""
        fixed = f", fixed={list(self.fixed)}" if self.fixed else ""
        origin = ", vertices chained from odometry" if self.vertices_from_odometry else ""
        return (
            f"G2OGraph({self.vertex_ids.shape[0]} vertices, {self.edges.shape[0]} edges, "
            f"information_reading={self.information_reading!r}{fixed}{origin})"
        )

    @cached_property
    def poses(self) -> FloatArray:
        """Vertex poses ``T_world_vertex``, ``(N, 4, 4)`` (read-only)."""
        return _readonly(_layouts.to_matrix(self.vertex_xyz_qxyzw, layout="xyz_qxyzw"))

    @cached_property
    def measured(self) -> FloatArray:
        """Edge measurements ``Z = T_i_j``, ``(M, 4, 4)`` (read-only)."""
        return _readonly(_layouts.to_matrix(self.measured_xyz_qxyzw, layout="xyz_qxyzw"))

    @classmethod
    def from_matrices(
        cls,
        vertex_ids: Any,
        poses: Any,
        edges: Any,
        measured: Any,
        information: Any,
        *,
        information_reading: InformationReading = "g2o",
        fixed: Iterable[int] = (),
    ) -> G2OGraph:
        """Build a graph from matrices (for instance an optimisation result) to :func:`write`.

        ``poses`` ``(N, 4, 4)`` and ``measured`` ``(M, 4, 4)`` are stored as ``"xyz_qxyzw"``
        (``w ≥ 0``), so :attr:`poses` equals the input to rounding (~1e-16), not bitwise;
        ``information`` ``(M, 6, 6)`` is over GTSAM's ``(ω, v)``; ``information_reading`` is the
        reading :func:`write` will invert.
        """
        return cls(
            vertex_ids=_ids(vertex_ids, "vertex_ids").reshape(-1),
            vertex_xyz_qxyzw=_layouts.from_matrix(poses, layout="xyz_qxyzw").reshape(-1, 7),
            edges=_ids(edges, "edges").reshape(-1, 2),
            measured_xyz_qxyzw=_layouts.from_matrix(measured, layout="xyz_qxyzw").reshape(-1, 7),
            information=np.asarray(information, dtype=np.float64).reshape(-1, 6, 6),
            information_reading=information_reading,
            fixed=tuple(fixed),
        )

    def to_gtsam(self, prior: Any = "gauge") -> tuple[Any, Any]:
        """GTSAM factor graph and initial values, with a gauge prior unless ``prior=None``.

        A graph of relative measurements alone fixes no pose: its linear system is
        indeterminate (GTSAM's marginals fail on it, and an optimizer drifts in the free
        directions). The default adds the same gauge prior ``liebridge optimize`` adds, and says
        so once (:class:`GaugePriorNotice`).

        Parameters
        ----------
        prior : "gauge", None, float, array of shape (6,) or (6, 6)
            ``"gauge"`` (default): one ``gtsam.PriorFactorPose3`` at the initial pose of each
            ``FIX`` vertex, or of the first vertex when there are none, σ =
            :data:`GAUGE_PRIOR_SIGMA` in each direction. ``None``: no prior (the graph is then
            gauge-free unless you add one). A number σ, six σ's or a ``(6, 6)`` covariance: that
            prior on the same vertices instead, over **GTSAM's tangent** ``(ω, v)`` of
            ``X̂·Exp(δ)`` (rotation first, right perturbation; not ROS's or Sophus's
            translation-first order). An explicit prior is added silently.

        Returns
        -------
        graph : gtsam.NonlinearFactorGraph
            One ``BetweenFactorPose3(i, j, Z, noiseModel.Gaussian.Information(Λ))`` per edge, in
            file order (``Λ`` = :attr:`information`; GTSAM's "smart" constructor returns a
            ``Diagonal`` or ``Isotropic`` model when ``Λ`` is one, as ``gtsam.readG2o`` does),
            then the prior factors (``gtsam.readG2o``'s graph plus the prior).
        values : gtsam.Values
            :attr:`poses` under their vertex ids.
        """
        import gtsam  # the library itself: io stays below liebridge's gtsam layer

        cov = prior_covariance(prior, 6)
        graph = gtsam.NonlinearFactorGraph()
        for (i, j), Zk, info in zip(
            self.edges.tolist(), self.measured.reshape(-1, 4, 4), self.information, strict=True
        ):
            noise = gtsam.noiseModel.Gaussian.Information(info)
            graph.add(gtsam.BetweenFactorPose3(i, j, gtsam.Pose3(Zk), noise))
        values = gtsam.Values()
        for k, T in zip(self.vertex_ids.tolist(), self.poses.reshape(-1, 4, 4), strict=True):
            values.insert(k, gtsam.Pose3(T))
        if cov is not None:
            keys = gauge_keys(self.vertex_ids, self.fixed)
            noise = gtsam.noiseModel.Gaussian.Covariance(cov)
            for k in keys:
                graph.add(gtsam.PriorFactorPose3(k, values.atPose3(k), noise))
            if isinstance(prior, str) and keys:
                gauge_notice("G2OGraph.to_gtsam", keys, "in each of GTSAM's (ω, v) directions")
        return graph, values


class _Parser:
    """Line-by-line parser that names the file and line in every error."""

    def __init__(self, path: PathLike) -> None:
        self.path = path

    def fail(self, lineno: int, msg: str) -> ValueError:
        return ValueError(f"{self.path}:{lineno}: {msg}")

    def numbers(self, lineno: int, tag: str, fields: list[str], n: int, what: str) -> list[float]:
        """Parse exactly ``n`` finite numbers from ``fields`` (the values after the ids)."""
        if len(fields) != n:
            raise self.fail(
                lineno, f"{tag} expects {n} values after the id(s) ({what}), got {len(fields)}"
            )
        try:
            out = list(map(float, fields))
        except ValueError:
            out = [math.nan]
        if not all(map(math.isfinite, out)):
            words = what.split(" + ")[0].split()
            names = words + [f"information{_TRIU_NAMES[k]}" for k in range(n - len(words))]
            # fields numbered on the line: after the tag and one (vertex) or two (edge) ids
            skip = 2 if tag.startswith("VERTEX") else 3
            _, bad = field_numbers(["0"] * skip + fields, ["tag/id"] * skip + names, tag)
            raise self.fail(lineno, str(bad))
        return out

    def vertex_id(self, lineno: int, f: str) -> int:
        try:
            k = int(f)
        except ValueError:
            raise self.fail(lineno, f"vertex id {f!r} is not an integer") from None
        if not 0 <= k <= validate.MAX_KEY:
            raise self.fail(
                lineno, f"vertex id {k} is outside [0, 2**64 - 2] (GTSAM keys are uint64)"
            )
        return k

    def unit_quaternion(self, lineno: int, fields: list[str], q: list[float]) -> list[float]:
        """Normalise within the printed precision; already-unit input (repr) is kept bit for bit."""
        norm = float(np.linalg.norm(q))
        tol = _layouts.text_quaternion_tol(fields)
        if abs(norm - 1.0) > tol:
            raise self.fail(
                lineno,
                f"quaternion norm off by {abs(norm - 1.0):.3g} (tolerance {tol:g} for numbers "
                "printed with this precision)",
            )
        return _unit_rows(np.array([[0.0, 0.0, 0.0, *q]]))[0, 3:].tolist()


def _unit_rows(x: FloatArray) -> FloatArray:
    """Rows ``x y z qx qy qz qw`` with the quaternion normalised, except when it already is.

    A quaternion within :data:`_UNIT_NORM_SLACK` of unit norm is kept bit for bit (dividing
    again could flip its last bits); the others are divided by their norm. The reader and
    :class:`G2OGraph` both apply it, so ``read(write(g))`` reproduces ``g``.
    """
    norm = np.linalg.norm(x[:, 3:], axis=-1)
    off = np.abs(norm - 1.0) > _UNIT_NORM_SLACK
    if not off.any():
        return x
    out = np.array(x, copy=True)
    out[off, 3:] = x[off, 3:] / norm[off, None]
    return out


def read(
    path: PathLike,
    information: InformationReading = "g2o",
    *,
    edge3: Edge3Numbers = "sqrt_information",
) -> G2OGraph:
    """Read a 3D g2o / TORO file.

    Parameters
    ----------
    path : str or os.PathLike
    information : {"g2o", "gtsam"}
        ``"g2o"`` (default): the format's own definition, mapped exactly (to first order at the
        measurement) to GTSAM's tangent — ``EDGE_SE3:QUAT``: ``Λ = Mᵀ Λ_file M`` (rotation block
        /4, cross blocks /2 after the block swap); ``EDGE3``: ``Λ = Eᵀ Λ_e E`` with ``Λ_e`` per
        ``edge3``. ``"gtsam"``: what ``gtsam.readG2o(path, is3D=True)`` does — ``EDGE_SE3:QUAT``:
        block swap only (a 4× heavier rotation weight than g2o uses); ``EDGE3``: the 21 numbers
        as-is as information on ``(ω, v)``. See the module docstring for the evidence.
    edge3 : {"sqrt_information", "information"}
        With ``information="g2o"``, what the 21 ``EDGE3`` numbers are: iSAM's upper-triangular
        square-root information (default; what ``sphere2500.txt`` holds, checked against its
        ground truth) or g2o ``EdgeSE3Euler``'s information, both over
        ``(x, y, z, roll, pitch, yaw)``.

    Returns
    -------
    G2OGraph

    Raises
    ------
    ValueError
        On a malformed or unsupported line (naming the file and line number), an edge to a
        missing vertex, or a file without vertices whose odometry chain has a gap.

    Notes
    -----
    A well-formed file is parsed by ``numpy.loadtxt``, one pass per line type (:func:`read_tagged`;
    a 254 MiB file within 2× of ``loadtxt`` alone, memory within 3× of the arrays
    returned). Anything unusual — a malformed line, a quaternion norm off by more than full
    precision allows and beyond the precision it was printed with, an id out of range, a
    duplicate vertex, a singular Euler chart, an information matrix that is not positive
    semi-definite — sends the file to the line-by-line reader, which gives the same graph and
    names the first faulty line. A file of ``EDGE3`` lines only (TORO / iSAM, ``sphere2500.txt``)
    is parsed and converted in chunks (:func:`_read_edge3_only`), its information maps written by
    3×3 blocks on columns and its initial values chained by a blocked scan; equal to the line
    reader's to rounding.
    """
    information = validate.option(information, "information", ("g2o", "gtsam"))  # type: ignore[assignment]
    edge3 = validate.option(edge3, "edge3", ("sqrt_information", "information"))  # type: ignore[assignment]
    fast = _read_tables(path, information, edge3)
    if fast is not None:
        return fast
    return _read_lines(path, information, edge3)


class _BadEdge(Exception):
    """Edge ``k`` (0-based, file order) is faulty: the line reader names its line."""

    def __init__(self, k: int, msg: str) -> None:
        super().__init__(msg)
        self.k, self.msg = k, msg


def _read_lines(path: PathLike, information: InformationReading, edge3: Edge3Numbers) -> G2OGraph:
    """Read line by line, naming every fault by file and line (the reference reader)."""
    P = _Parser(path)
    v_ids: list[int] = []
    v_line: dict[int, int] = {}
    # raw numbers; rotation as a normalised quaternion (xyzw) or roll, pitch, yaw (+ padding)
    v_raw: list[list[float]] = []
    v_euler: list[bool] = []
    e_ids: list[tuple[int, int]] = []
    e_raw: list[list[float]] = []  # x y z, 4 rotation numbers, 21 information numbers
    e_euler: list[bool] = []
    e_lines: list[int] = []
    fixed: list[int] = []
    for lineno, line in text_lines(path):
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        tag = fields[0]
        if tag in ("VERTEX_SE3:QUAT", "VERTEX3"):
            if len(fields) < 2:
                raise P.fail(lineno, f"{tag} without an id")
            k = P.vertex_id(lineno, fields[1])
            if k in v_line:
                raise P.fail(lineno, f"vertex {k} already defined on line {v_line[k]}")
            if tag == "VERTEX_SE3:QUAT":
                x = P.numbers(lineno, tag, fields[2:], 7, "x y z qx qy qz qw")
                x = x[:3] + P.unit_quaternion(lineno, fields[5:9], x[3:])
            else:
                x = [*P.numbers(lineno, tag, fields[2:], 6, "x y z roll pitch yaw"), 0.0]
            v_ids.append(k)
            v_raw.append(x)
            v_euler.append(tag == "VERTEX3")
            v_line[k] = lineno
        elif tag in ("EDGE_SE3:QUAT", "EDGE3"):
            if len(fields) < 3:
                raise P.fail(lineno, f"{tag} without two vertex ids")
            i, j = P.vertex_id(lineno, fields[1]), P.vertex_id(lineno, fields[2])
            if i == j:
                raise P.fail(lineno, f"{tag} from vertex {i} to itself")
            if tag == "EDGE_SE3:QUAT":
                x = P.numbers(lineno, tag, fields[3:], 28, "x y z qx qy qz qw + 21 information")
                x = x[:3] + P.unit_quaternion(lineno, fields[6:10], x[3:7]) + x[7:]
            else:
                x = P.numbers(lineno, tag, fields[3:], 27, "x y z roll pitch yaw + 21 information")
                if information == "g2o" and abs(np.cos(x[4])) < 1e-9:
                    raise P.fail(lineno, "pitch = ±π/2: the Euler-angle information is singular")
                x = [*x[:6], 0.0, *x[6:]]
            e_ids.append((i, j))
            e_raw.append(x)
            e_euler.append(tag == "EDGE3")
            e_lines.append(lineno)
        elif tag == "FIX":
            if len(fields) < 2:
                raise P.fail(lineno, "FIX without an id")
            fixed.extend(P.vertex_id(lineno, f) for f in fields[1:])
        elif tag in _2D_TAGS:
            raise P.fail(
                lineno,
                f"2-D type {tag} in a 3-D file: read it with liebridge.io.g2o2d.read",
            )
        else:
            raise P.fail(
                lineno,
                f"unsupported tag {tag!r} (supported: VERTEX_SE3:QUAT, EDGE_SE3:QUAT, "
                "VERTEX3, EDGE3, FIX)",
            )

    vraw = np.array(v_raw, dtype=np.float64).reshape(-1, 7)
    eraw = np.array(e_raw, dtype=np.float64).reshape(-1, 28)
    euler = np.array(e_euler, dtype=bool)
    try:
        measured, info = _edge_arrays(eraw[:, :7], eraw[:, 7:], euler, information, edge3)
        _name_bad_information(info)
    except _BadEdge as exc:
        raise P.fail(e_lines[exc.k], exc.msg) from None
    edges = np.array(e_ids, dtype=np.uint64).reshape(-1, 2)
    ids, vpar, from_odometry = vertices(
        P,
        (np.array(v_ids, dtype=np.uint64), _params_from_raw(vraw, np.array(v_euler, dtype=bool))),
        (edges, e_lines, lambda: _layouts.to_matrix(measured, layout="xyz_qxyzw")),
        fixed,
        lambda T: _layouts.from_matrix(T, layout="xyz_qxyzw"),
    )
    return G2OGraph(
        vertex_ids=ids,
        vertex_xyz_qxyzw=vpar,
        edges=edges,
        measured_xyz_qxyzw=measured,
        information=info,
        information_reading=information,
        fixed=tuple(fixed),
        vertices_from_odometry=from_odometry,
    )


def _edge_arrays(
    raw7: FloatArray,
    nums: FloatArray,
    euler: npt.NDArray[np.bool_],
    information: InformationReading,
    edge3: Edge3Numbers,
) -> tuple[FloatArray, FloatArray]:
    """Measurements ``"xyz_qxyzw"`` ``(M, 7)`` and information over ``(ω, v)`` ``(M, 6, 6)``.

    ``raw7``: rows ``x y z qx qy qz qw`` (quaternion already normalised) or ``x y z roll pitch
    yaw 0`` where ``euler``; ``nums``: the 21 information numbers of each edge as read. Both
    readers call it; conversions run in chunks of :data:`_CHUNK` rows. Raises :class:`_BadEdge`
    for the first faulty edge: a gimbal-locked ``EDGE3`` (``information="g2o"``), then
    information overflowing float64 in the conversion (:func:`_name_bad_information` checks
    the matrices next, in the line reader; :class:`G2OGraph` checks them in any case).
    """
    m = raw7.shape[0]
    measured = _params_from_raw(raw7, euler)
    if information == "g2o" and euler.any():
        k_euler = np.flatnonzero(euler)
        cp = np.abs(np.cos(raw7[k_euler, 4]))
        for k in np.flatnonzero(~(cp >= GIMBAL_TOL)).tolist()[:1]:
            raise _BadEdge(
                int(k_euler[k]),
                f"EDGE3 measurement at pitch = ±90° (|cos pitch| = {float(cp[k]):.3g}): gimbal "
                "lock, where the roll-pitch-yaw chart of its information matrix is singular; "
                "read it with information='gtsam' to keep the numbers as they are",
            )
    info = np.empty((m, 6, 6))
    finite = np.ones(m, dtype=bool)
    for lo in range(0, m, _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        if euler[sl].any():
            info[sl] = _edge_information(raw7[sl], nums[sl], euler[sl], information, edge3)
            finite[sl] = np.isfinite(info[sl]).all(axis=(-1, -2))
        else:  # finite numbers gathered and scaled by 1, 1/2, 1/4: finite, written in place
            np.take(nums[sl], _SWAPPED_TRIU, axis=1, out=info[sl].reshape(-1, 36))
            if information == "g2o":
                info[sl] *= _G2O_TO_GTSAM_SCALE  # = Mᵀ Λ M, exactly
    for k in np.flatnonzero(~finite).tolist()[:1]:
        raise _BadEdge(
            k,
            "information: finite numbers whose conversion to GTSAM's (ω, v) overflows float64 "
            f"(largest |entry| {float(np.abs(nums[k]).max()):.3g})",
        )
    return measured, info


def _name_bad_information(info: FloatArray) -> None:
    """Raise :class:`_BadEdge` for the first information matrix that is not a covariance."""
    try:
        _covariances(info, "information", 6)
    except ValueError:
        for k, lam_k in enumerate(info):  # name the line
            try:
                validate.covariance(lam_k, "information", 6)
            except ValueError as exc:
                raise _BadEdge(k, f"{exc} (after conversion to GTSAM's (ω, v))") from None
        raise


#: ``_swap_blocks(_triu_to_sym(nums))`` as one gather: the index into the 21 numbers of each
#: entry of the (ω, v) matrix (the same values, moved).
_SWAPPED_TRIU = _swap_blocks(_triu_to_sym(np.arange(21.0))).astype(np.intp).reshape(36)


def _edge_information(
    raw7: FloatArray,
    nums: FloatArray,
    euler: npt.NDArray[np.bool_],
    information: InformationReading,
    edge3: Edge3Numbers,
) -> FloatArray:
    """Information over GTSAM's ``(ω, v)`` of a chunk of edges (see :func:`_edge_arrays`)."""
    info = np.empty((raw7.shape[0], 6, 6))
    q = ~euler
    if information == "g2o":
        info[q] = nums[q][:, _SWAPPED_TRIU].reshape(-1, 6, 6) * _G2O_TO_GTSAM_SCALE  # = Mᵀ Λ M
        if euler.any():
            with np.errstate(over="ignore", invalid="ignore"):  # reported per line
                if edge3 == "sqrt_information":
                    S = _triu_to_upper(nums[euler])
                    lam_e = np.swapaxes(S, -1, -2) @ S
                else:
                    lam_e = _triu_to_sym(nums[euler])
                E = _euler_error_map(raw7[euler, 3:6])
                lam = np.swapaxes(E, -1, -2) @ lam_e @ E
                info[euler] = _symmetrised(lam)
    else:
        info[q] = nums[q][:, _SWAPPED_TRIU].reshape(-1, 6, 6)
        info[euler] = _triu_to_sym(nums[euler])
    return info


class _Table(NamedTuple):
    """The lines of one tag, parsed: ``lines`` (1-based), ``ids`` ``(K, n_ids)``, ``values``."""

    lines: npt.NDArray[np.intp]
    ids: KeyArray
    values: FloatArray


class RowSink(Protocol):
    """Takes the rows of one tag chunk by chunk as :func:`read_tagged` parses them.

    ``start(n)`` is called once with the number of rows, then ``take(lo, values)`` for the
    values of rows ``lo .. lo + len(values)`` (file order, already checked finite); ``take``
    returns False to refuse the file (the line reader then names the fault).
    """

    def start(self, n: int) -> None: ...

    def take(self, lo: int, values: FloatArray) -> bool: ...


#: Rows per ``loadtxt`` call when a tag's rows go to a :class:`RowSink` (a few MiB of records,
#: reused by the allocator: the parsed table of the whole file is never held).
_STREAM_ROWS = 1 << 15


def read_tagged(
    path: PathLike,
    columns: dict[str, tuple[int, int]],
    skip: Sequence[str] = (),
    sinks: dict[str, RowSink] | None = None,
) -> tuple[dict[str, _Table], list[int], dict[str, int]] | None:
    """Parse a well-formed graph file with ``numpy.loadtxt``, one pass per tag.

    ``columns[tag] = (n_ids, n_values)``: lines ``TAG id... value...``, the ids unsigned
    integers, the values finite floats. Returns ``(tables by tag, FIX ids, count of each tag
    in skip)``, or ``None`` as soon as anything is unusual — an unknown tag, a wrong field
    count, a field that ``loadtxt`` does not read as Python would, NaN/Inf, an id above
    ``2**64 − 2``, a file descriptor, text that is not UTF-8 — leaving the file to the
    line-by-line reader, which names the line. A first pass records the tag of each line
    (``#`` comments and blank lines skipped, as the line reader does); then each tag's lines
    go to one ``loadtxt`` call: read from the file itself (``skiprows``, ``max_rows``) when
    they form one block with nothing but comments between them (vertices, then edges: the
    usual layout), else picked out by :func:`itertools.compress`. Memory is the tables, never
    a copy of the file. The rows of a tag in ``sinks`` are instead parsed
    :data:`_STREAM_ROWS` at a time (``loadtxt`` on :func:`itertools.islice` of the tag's lines)
    and handed to its :class:`RowSink` (the table of the whole file is never held, and
    its memory is not touched twice); that tag's table then has ``values`` of width 0.
    """
    if not isinstance(path, str | os.PathLike):
        return None
    code = {tag: k + 1 for k, tag in enumerate(columns)}
    fixed: list[int] = []
    skipped: dict[str, int] = {}

    def take(fields: list[str]) -> int | None:
        """Code of an unusual line split as the reader splits it; None: not for this path."""
        if not fields:
            return 0  # blank or comment
        if fields[0] in code:
            return code[fields[0]]
        if fields[0] == "FIX" and len(fields) > 1:
            fix = [int(f) for f in fields[1:]]
            if not all(0 <= i <= validate.MAX_KEY for i in fix):
                return None
            fixed.extend(fix)
            return _OTHER
        if fields[0] in skip:
            skipped[fields[0]] = skipped.get(fields[0], 0) + 1
            return _OTHER
        return None

    try:
        with open(path, encoding="utf-8") as fh:  # the tag of each line, in C: 0 if unusual
            tags = map(itemgetter(0), map(str.split, fh, repeat(" "), repeat(1)))
            codes = bytearray(map(code.get, tags, repeat(0)))
        if 0 in codes:  # blank, comment, FIX, another separator ...: split as the reader does
            with open(path, encoding="utf-8") as fh:
                unusual = np.frombuffer(codes, dtype=np.uint8) == 0
                for k, line in itertools.compress(enumerate(fh), unusual.tobytes()):
                    c = take(line.split("#", 1)[0].split())
                    if c is None:
                        return None
                    codes[k] = c
        tag_of_line = np.frombuffer(codes, dtype=np.uint8)
        tables = {}
        for tag, (n_ids, n_values) in columns.items():
            mask = tag_of_line == code[tag]
            lines = np.flatnonzero(mask) + 1
            dtype = np.dtype([("tag", "S1"), ("ids", "u8", (n_ids,)), ("x", "f8", (n_values,))])
            block = tag_of_line[lines[0] - 1 : lines[-1]] if lines.shape[0] else tag_of_line[:0]
            if sinks is not None and tag in sinks:
                ids = _stream_rows(path, mask, dtype, sinks[tag], lines.shape[0])
                if ids is None:
                    return None
                tables[tag] = _Table(lines, ids, np.zeros((lines.shape[0], 0)))
                continue
            if lines.shape[0] == 0:
                rec = np.zeros(0, dtype=dtype)
            elif ((block == code[tag]) | (block == 0)).all():  # one block: numpy reads the file
                with warnings.catch_warnings():
                    warnings.simplefilter("error")  # not a number numpy would read with a warning
                    # comment lines inside the block: not rows, as intended
                    warnings.filterwarnings("ignore", "Input line", UserWarning)
                    rec = np.loadtxt(
                        path,
                        dtype=dtype,
                        comments="#",
                        skiprows=int(lines[0]) - 1,
                        max_rows=lines.shape[0],
                        ndmin=1,
                        encoding="utf-8",
                    )
            else:
                with open(path, encoding="utf-8") as fh:
                    rec = np.loadtxt(
                        itertools.compress(fh, mask.tobytes()), dtype=dtype, comments="#", ndmin=1
                    )
            if rec.shape != lines.shape:
                return None
            ids, x = rec["ids"], rec["x"]
            if (ids > validate.MAX_KEY).any() or not _all_finite(x):
                return None
            tables[tag] = _Table(lines, ids, x)
    except (ValueError, Warning, OSError):  # a field loadtxt cannot read, not UTF-8, no file:
        return None  # the line reader raises what it raises
    return tables, fixed, skipped


#: Tag code of a line :func:`read_tagged` has taken (FIX, a skipped tag): not a blank line.
_OTHER = 255


def _stream_rows(
    path: PathLike, mask: npt.NDArray[np.bool_], dtype: np.dtype[Any], sink: RowSink, n: int
) -> KeyArray | None:
    """Parse the lines ``mask`` picks, :data:`_STREAM_ROWS` at a time, into ``sink``; the ids."""
    sink.start(n)
    ids = np.empty((n, dtype["ids"].shape[0]), dtype=np.uint64)
    lo = 0
    with open(path, encoding="utf-8") as fh, warnings.catch_warnings():
        warnings.simplefilter("error")  # not a number numpy would read with a warning
        rows = itertools.compress(fh, mask.tobytes())
        while lo < n:
            rec = np.loadtxt(
                itertools.islice(rows, _STREAM_ROWS), dtype=dtype, comments="#", ndmin=1
            )
            k = rec.shape[0]
            if k == 0 or lo + k > n:
                return None
            x = rec["x"]
            if (rec["ids"] > validate.MAX_KEY).any() or not _all_finite(x):
                return None
            ids[lo : lo + k] = rec["ids"]
            if not sink.take(lo, x):
                return None
            lo += k
    return ids


def _all_finite(x: FloatArray) -> bool:
    return all(bool(np.isfinite(x[lo : lo + _CHUNK]).all()) for lo in range(0, x.shape[0], _CHUNK))


def quaternions_within_text_tol(
    path: PathLike, table: _Table, cols: slice, field0: int
) -> FloatArray | None:
    """Rows ``table.values[:, cols]`` (quaternions) normalised, or None if one is off.

    Norms within :data:`liebridge.io.poses.QUATERNION_TOL` of 1 pass; the others are judged by
    the precision their text was printed with (:func:`liebridge.io.poses.text_quaternion_tol`,
    fields ``field0 .. field0 + 3`` of the line), as the line reader judges every line.
    """
    q = table.values[:, cols]
    err = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
    suspect = np.flatnonzero(err > _layouts.QUATERNION_TOL)
    if suspect.size:
        wanted = dict(zip(table.lines[suspect].tolist(), suspect.tolist(), strict=True))
        for lineno, line in text_lines(path):
            r = wanted.get(lineno)
            if r is not None:
                fields = line.split("#", 1)[0].split()
                if err[r] > _layouts.text_quaternion_tol(fields[field0 : field0 + 4]):
                    return None
    out = np.zeros((q.shape[0], 7))
    out[:, 3:] = q
    return _unit_rows(out)[:, 3:]


def in_file_order(
    parts: list[tuple[npt.NDArray[np.intp], npt.NDArray[Any]]],
) -> npt.NDArray[Any]:
    """Rows of several tables (``(lines, rows)`` each) merged in the order of their lines."""
    nonempty = [(ln, r) for ln, r in parts if ln.shape[0]]
    if len(nonempty) == 1:
        return nonempty[0][1]
    rows = np.concatenate([r for _, r in parts])
    return rows[np.argsort(np.concatenate([ln for ln, _ in parts]), kind="stable")]


def _read_tables(
    path: PathLike, information: InformationReading, edge3: Edge3Numbers
) -> G2OGraph | None:
    """Read with :func:`read_tagged` and batched checks; None if anything is unusual."""
    columns = {
        "VERTEX_SE3:QUAT": (1, 7),
        "VERTEX3": (1, 6),
        "EDGE_SE3:QUAT": (2, 28),
        "EDGE3": (2, 27),
    }
    sink = _Edge3Sink(information, edge3)
    got = _read_edge3_only(path, columns, sink)
    if got is None:
        sink = _Edge3Sink(information, edge3)
        got = read_tagged(path, columns, sinks={"EDGE3": sink})
    if got is None:
        return None
    tables, fixed, _ = got
    vq, v3, eq, e3 = (tables[t] for t in ("VERTEX_SE3:QUAT", "VERTEX3", "EDGE_SE3:QUAT", "EDGE3"))
    # vertices: x y z qx qy qz qw (quaternion normalised) or x y z roll pitch yaw 0
    qv = quaternions_within_text_tol(path, vq, slice(3, 7), 5)
    qe = quaternions_within_text_tol(path, eq, slice(3, 7), 6)
    if qv is None or qe is None:
        return None
    v_ids = np.array(in_file_order([(vq.lines, vq.ids[:, 0]), (v3.lines, v3.ids[:, 0])]))
    if has_duplicates(v_ids):
        return None
    v_euler = in_file_order(
        [(vq.lines, np.zeros(vq.lines.shape, bool)), (v3.lines, np.ones(v3.lines.shape, bool))]
    )
    vraw = in_file_order(
        [
            (vq.lines, np.concatenate([vq.values[:, :3], qv], axis=-1)),
            (v3.lines, np.concatenate([v3.values, np.zeros((v3.lines.shape[0], 1))], axis=-1)),
        ]
    )
    # edges: the same, plus 21 information numbers; from their tables, in file order
    e_lines = in_file_order([(eq.lines, eq.lines), (e3.lines, e3.lines)])
    edges = in_file_order([(eq.lines, eq.ids), (e3.lines, e3.ids)])
    if (edges[:, 0] == edges[:, 1]).any():
        return None
    # EDGE3 rows: converted by the sink as they were parsed; EDGE_SE3:QUAT rows: here
    raw7 = np.concatenate([eq.values[:, :3], qe], axis=-1)
    try:
        measured_q, info_q = _edge_arrays(
            raw7, eq.values[:, 7:], np.zeros(eq.lines.shape, bool), information, edge3
        )
    except _BadEdge:
        return None
    del raw7
    measured = in_file_order([(eq.lines, measured_q), (e3.lines, sink.measured)])
    info = in_file_order([(eq.lines, info_q), (e3.lines, sink.info)])
    del measured_q, info_q, sink
    if isinstance(edges.base, np.ndarray) and edges.base.dtype.names:  # a view of a parsed
        edges = np.array(edges)  # table: copied, so that the table is freed
    del tables, vq, v3, eq, e3, got  # the parsed tables: freed before the copies
    P = _Parser(path)
    try:
        ids, vpar, from_odometry = vertices(
            P,
            (v_ids, _params_from_raw(vraw, v_euler)),
            (edges, e_lines, lambda: _layouts.to_matrix(measured, layout="xyz_qxyzw")),
            fixed,
            lambda T: _layouts.from_matrix(T, layout="xyz_qxyzw"),
            chain=lambda: _chain_odometry(edges, measured),
        )
        return G2OGraph._adopt(
            vertex_ids=ids,
            vertex_xyz_qxyzw=vpar,
            edges=edges,
            measured_xyz_qxyzw=measured,
            information=info,
            information_reading=information,
            fixed=tuple(fixed),
            vertices_from_odometry=from_odometry,
        )
    except ValueError:
        return None


#: Rows added to the estimate of :func:`_read_edge3_only` (the arrays grow if it falls short).
_EDGE3_SLACK_ROWS = 1024


def _read_edge3_only(
    path: PathLike, columns: dict[str, tuple[int, int]], sink: _Edge3Sink
) -> tuple[dict[str, _Table], list[int], dict[str, int]] | None:
    """:func:`read_tagged` for a file of ``EDGE3`` lines only (TORO / iSAM), without its tag pass.

    Tried when the file starts with ``EDGE3``: the lines are parsed :data:`_STREAM_ROWS` at a
    time into ``sink`` with the tag read as a field and checked, the sink's arrays sized from
    the bytes the first rows took (grown if the estimate falls short, trimmed at the end).
    Comments and blank lines are skipped as ``loadtxt`` skips them (no line number is needed
    unless a line is faulty). ``None`` — and :func:`read_tagged` decides — unless every other
    line is an ``EDGE3`` line with ids and 27 finite numbers (another tag, ``FIX``, a bad field).
    """
    if not isinstance(path, str | os.PathLike):
        return None
    try:
        with open(path, "rb") as fb:
            if not fb.read(6) == b"EDGE3 ":
                return None
            size = os.fstat(fb.fileno()).st_size
        dtype = np.dtype([("tag", "S8"), ("ids", "u8", (2,)), ("x", "f8", (27,))])
        ids = np.empty((0, 2), dtype=np.uint64)
        lo = 0
        with (
            open(path, "rb") as raw,
            io.TextIOWrapper(raw, encoding="utf-8") as fh,
            warnings.catch_warnings(),
        ):
            warnings.simplefilter("error")  # a number read with a warning
            warnings.filterwarnings("ignore", "loadtxt: input contained no data", UserWarning)
            warnings.filterwarnings("ignore", "Input line", UserWarning)  # comment lines
            while True:
                rec = np.loadtxt(
                    itertools.islice(fh, _STREAM_ROWS), dtype=dtype, comments="#", ndmin=1
                )
                k = rec.shape[0]
                if k == 0:
                    if fh.readline():  # a block of comment or blank lines only: unusual
                        return None
                    break
                if lo + k > ids.shape[0]:  # rows so far, per byte so far: the rest, and 5 % more
                    done = max(raw.tell(), 1)
                    cap = lo + k + int(1.05 * (lo + k) * max(size - done, 0) / done)
                    cap += _EDGE3_SLACK_ROWS
                    sink.resize(cap, lo)
                    ids = np.concatenate([ids[:lo], np.empty((cap - lo, 2), np.uint64)])
                if not (rec["tag"] == b"EDGE3").all():
                    return None
                x = rec["x"]
                if (rec["ids"] > validate.MAX_KEY).any() or not _all_finite(x):
                    return None
                ids[lo : lo + k] = rec["ids"]
                if not sink.take(lo, x):
                    return None
                lo += k
    except (ValueError, Warning, OSError):
        return None
    sink.resize(lo, lo)
    tables = {
        tag: _Table(
            np.zeros(0, dtype=np.intp), np.zeros((0, k_ids), np.uint64), np.zeros((0, k_values))
        )
        for tag, (k_ids, k_values) in columns.items()
    }
    # rows numbered 1..n: on this path no line is named (a faulty one goes to the line reader)
    tables["EDGE3"] = _Table(np.arange(1, lo + 1), ids[:lo], np.zeros((lo, 0)))
    return tables, [], {}


# ---------------------------------------------------------------- EDGE3 fast path


class _Edge3Sink(RowSink):
    """``EDGE3`` rows → measurements ``"xyz_qxyzw"`` and information over ``(ω, v)``, by chunk.

    Values are ``x y z roll pitch yaw`` + the 21 numbers; :meth:`take` refuses a
    gimbal-locked measurement (``information="g2o"``) or a conversion that overflows, which
    the line reader then names.
    """

    def __init__(self, information: InformationReading, edge3: Edge3Numbers) -> None:
        self.information, self.edge3 = information, edge3
        self.measured = np.zeros((0, 7))
        self.info = np.zeros((0, 6, 6))

    def start(self, n: int) -> None:
        self.measured = np.empty((n, 7))
        self.info = np.empty((n, 6, 6))

    def resize(self, n: int, keep: int) -> None:
        """Room for ``n`` rows, the first ``keep`` kept: trimmed as views, grown by a copy."""
        if n <= self.measured.shape[0]:
            self.measured, self.info = self.measured[:n], self.info[:n]
        else:
            measured, info = np.empty((n, 7)), np.empty((n, 6, 6))
            measured[:keep], info[:keep] = self.measured[:keep], self.info[:keep]
            self.measured, self.info = measured, info

    def take(self, lo: int, values: FloatArray) -> bool:
        hi = lo + values.shape[0]
        if self.information == "g2o" and (np.abs(np.cos(values[:, 4])) < GIMBAL_TOL).any():
            return False
        self.measured[lo:hi, :3] = values[:, :3]
        return _edge3_table(
            values[:, 3:6],
            values[:, 6:],
            self.information,
            self.edge3,
            self.measured[lo:hi, 3:],
            self.info[lo:hi],
        )


def _edge3_table(
    rpy: FloatArray,
    nums: FloatArray,
    information: InformationReading,
    edge3: Edge3Numbers,
    q: FloatArray,
    info: FloatArray,
) -> bool:
    """Write the quaternions ``(K, 4)`` and information over ``(ω, v)`` of ``EDGE3`` rows.

    The batched form of :func:`_edge_information` for ``EDGE3`` rows (gimbal lock excluded by
    the caller), written into ``q`` and ``info``. With ``E = [[0, R], [W, 0]]``
    (:func:`_euler_error_map`) the product ``Eᵀ Λ_e E`` is formed by blocks,
    ``Λ_ωω = Wᵀ Λ_rr W``, ``Λ_ωv = Wᵀ Λ_rt R``, ``Λ_vv = Rᵀ Λ_tt R`` (``Λ_e`` in the file's
    ``(x, y, z, roll, pitch, yaw)`` order), entry by entry on columns of the batch
    (:func:`_mul3`; numpy's stacked 3×3 ``matmul`` costs several times more per product),
    skipping the zeros of ``W`` and of ``Λ_e``. When every row holds the same 21 numbers (TORO /
    iSAM files usually do) ``Λ_e`` is formed once, and ``Λ_tt = c·I`` gives ``Λ_vv = c·I``
    (``RᵀR = I``). The diagonal blocks are computed on and above the diagonal and mirrored
    (exactly symmetric). Equal to :func:`_edge_information` to rounding
    (``tests/test_g2o_fast.py``). Returns False if a conversion overflows.
    """
    m = rpy.shape[0]
    lam_common = None
    if information == "g2o" and m and bool((nums == nums[0]).all()):
        with np.errstate(over="ignore", invalid="ignore"):  # reported below
            lam_common = _lambda_e(nums[:1], edge3)[0]
    # |numbers| ≤ 1e100, |W| ≤ 1/GIMBAL_TOL: every product below stays far below 1.8e308
    bounded = bool(np.abs(nums[:1] if lam_common is not None else nums).max(initial=0) <= 1e100)
    step = 8192  # columns of this many rows: the temporaries stay in cache
    for lo in range(0, m, step):
        sl = slice(lo, lo + step)
        roll, pitch, yaw = (np.ascontiguousarray(rpy[sl, c]) for c in range(3))
        q[sl] = _rpy_quaternion(rpy[sl])
        out = info[sl]
        if information == "gtsam":
            out[...] = _triu_to_sym(nums[sl])
            continue
        cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (np.cos, np.sin))
        R = [  # Rz(yaw)·Ry(pitch)·Rx(roll), as in euler_to_matrix
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
        W = [  # ZYX Euler rates per body rate, as in euler_rate_map
            [1.0, sr * sp / cp, cr * sp / cp],
            [0.0, cr, -sr],
            [0.0, sr / cp, cr / cp],
        ]
        with np.errstate(over="ignore", invalid="ignore"):  # reported below
            if lam_common is not None:
                L: list[list[Any]] = lam_common.tolist()
            else:
                cols = [np.ascontiguousarray(nums[sl, c]) for c in range(21)]
                L = _lambda_e_columns(cols, edge3)
            rr = [row[3:] for row in L[3:]]
            rt = [row[:3] for row in L[3:]]
            tt = [row[:3] for row in L[:3]]
            Wt = _transpose3(W)
            ww = _mul3(Wt, _mul3(rr, W), sym=True)
            wv = _mul3(Wt, _mul3(rt, R))
            if lam_common is not None and _is_scaled_identity(lam_common[:3, :3]):
                vv = [[tt[i][i] if i == j else 0.0 for j in range(3)] for i in range(3)]
            else:
                vv = _mul3(_transpose3(R), _mul3(tt, R), sym=True)
            entries = {}
            for i in range(3):
                for j in range(3):
                    entries[i, j] = ww[i][j]
                    entries[i, 3 + j] = entries[3 + j, i] = wv[i][j]
                    entries[3 + i, 3 + j] = vv[i][j]
            const = {ij: v for ij, v in entries.items() if isinstance(v, float)}
            if len(const) > 9:  # constants (zeros, c·I): one contiguous fill, then the columns
                template = np.zeros((6, 6))
                for ij, v in const.items():
                    template[ij] = v
                out[...] = template
                entries = {ij: v for ij, v in entries.items() if ij not in const}
            for (i, j), v in entries.items():
                out[:, i, j] = v
        if not bounded and not _all_finite(out):
            return False
    return True


def _is_scaled_identity(A: FloatArray) -> bool:
    return bool((A == A[0, 0] * np.eye(A.shape[0])).all())


def _transpose3(A: list[list[Any]]) -> list[list[Any]]:
    return [[A[j][i] for j in range(3)] for i in range(3)]


def _mul3(A: list[list[Any]], B: list[list[Any]], sym: bool = False) -> list[list[Any]]:
    """Return ``A @ B`` of 3×3 matrices given entry by entry (floats or columns of a batch).

    Terms with a float factor ``0.0`` are skipped and float factors ``1.0`` not multiplied. With
    ``sym`` the product is known symmetric: the entries below the diagonal are mirrored.
    """
    out: list[list[Any]] = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i if sym else 0, 3):
            acc: Any = 0.0
            for k in range(3):
                a, b = A[i][k], B[k][j]
                if (isinstance(a, float) and a == 0.0) or (isinstance(b, float) and b == 0.0):
                    continue
                term = (
                    b
                    if isinstance(a, float) and a == 1.0
                    else a
                    if (isinstance(b, float) and b == 1.0)
                    else a * b
                )
                acc = term if isinstance(acc, float) and acc == 0.0 else acc + term
            out[i][j] = acc
            if sym:
                out[j][i] = acc
    return out


def _lambda_e_columns(cols: list[FloatArray], edge3: Edge3Numbers) -> list[list[Any]]:
    """:func:`_lambda_e` entry by entry on the 21 columns of a batch (``SᵀS`` or as is)."""
    U: list[list[Any]] = [[0.0] * 6 for _ in range(6)]
    for k, (r, c) in enumerate(zip(*_TRIU, strict=True)):
        U[r][c] = cols[k]
    if edge3 == "information":
        return [[U[min(i, j)][max(i, j)] for j in range(6)] for i in range(6)]
    out: list[list[Any]] = [[0.0] * 6 for _ in range(6)]
    for i in range(6):
        for j in range(i, 6):
            acc: Any = 0.0
            for k in range(min(i, j) + 1):  # (SᵀS)[i, j] = Σ_k S[k, i]·S[k, j], S upper
                acc = U[k][i] * U[k][j] if k == 0 else acc + U[k][i] * U[k][j]
            out[i][j] = out[j][i] = acc
    return out


def _rpy_quaternion(rpy: FloatArray) -> FloatArray:
    """Return quaternions ``(K, 4)``, ``x y z w``, ``w ≥ 0``, of ``Rz(yaw)·Ry(pitch)·Rx(roll)``.

    In closed form, ``q = q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll)`` (half angles; no matrix →
    quaternion round trip), the sign chosen with ``w ≥ 0`` as
    :func:`liebridge.lie.quaternion.from_matrix` chooses it. Equal to
    ``quat.from_matrix(_rpy_matrix(rpy))`` to rounding (``tests/test_g2o_fast.py``).
    """
    h = 0.5 * rpy
    cr, sr = np.cos(h[:, 0]), np.sin(h[:, 0])
    cp, sp = np.cos(h[:, 1]), np.sin(h[:, 1])
    cy, sy = np.cos(h[:, 2]), np.sin(h[:, 2])
    w = cr * cp * cy + sr * sp * sy
    sign = np.where(w < 0.0, -1.0, 1.0)
    q = np.empty((rpy.shape[0], 4))
    q[:, 0] = sign * (sr * cp * cy - cr * sp * sy)
    q[:, 1] = sign * (cr * sp * cy + sr * cp * sy)
    q[:, 2] = sign * (cr * cp * sy - sr * sp * cy)
    q[:, 3] = sign * w
    return q


def _lambda_e(nums: FloatArray, edge3: Edge3Numbers) -> FloatArray:
    """``Λ_e`` over ``(x, y, z, roll, pitch, yaw)`` from the 21 numbers (``SᵀS`` or as is)."""
    if edge3 == "sqrt_information":
        S = _triu_to_upper(nums)
        return np.swapaxes(S, -1, -2) @ S
    return _triu_to_sym(nums)


def _compose(
    qa: FloatArray, ta: FloatArray, qb: FloatArray, tb: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """``(qa, ta)·(qb, tb) = (qa ⊗ qb, ta + R(qa)·tb)``: rigid transforms, quaternions ``x y z w``.

    Arrays ``(..., 4)`` and ``(..., 3)``; :func:`_compose_columns` on their columns.
    """
    a = tuple(qa[..., i] for i in range(4)) + tuple(ta[..., i] for i in range(3))
    b = tuple(qb[..., i] for i in range(4)) + tuple(tb[..., i] for i in range(3))
    c = _compose_columns(a, b)
    return np.stack(c[:4], axis=-1), np.stack(c[4:], axis=-1)


Columns = tuple[FloatArray, ...]


def _compose_columns(a: Columns, b: Columns) -> Columns:
    """Compose rigid transforms given as 7 columns ``(qx, qy, qz, qw, tx, ty, tz)`` (broadcast).

    ``(qa, ta)·(qb, tb) = (qa ⊗ qb, ta + R(qa)·tb)``, Hamilton product; ``R(q)·v = v + w·c +
    u × c`` with ``c = 2u × v``, ``u = (x, y, z)`` (unit ``q``).
    """
    x1, y1, z1, w1, ax, ay, az = a
    x2, y2, z2, w2, vx, vy, vz = b
    cx = 2.0 * (y1 * vz - z1 * vy)
    cy = 2.0 * (z1 * vx - x1 * vz)
    cz = 2.0 * (x1 * vy - y1 * vx)
    return (
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        ax + vx + w1 * cx + (y1 * cz - z1 * cy),
        ay + vy + w1 * cy + (z1 * cx - x1 * cz),
        az + vz + w1 * cz + (x1 * cy - y1 * cx),
    )


def _prefix_compose(q: FloatArray, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Inclusive prefix products ``P_k = s_0·s_1·…·s_k`` of rigid transforms ``(q, t)``.

    ``q`` ``(n, 4)`` (``x y z w``), ``t`` ``(n, 3)``; :func:`_prefix_columns` on their columns.
    Products are associated differently from a left-to-right loop, so results agree with it
    to rounding.
    """
    cols = _prefix_columns(tuple(q[:, i] for i in range(4)) + tuple(t[:, i] for i in range(3)))
    return np.stack(cols[:4], axis=-1), np.stack(cols[4:], axis=-1)


def _prefix_columns(s: Columns) -> Columns:
    """Inclusive prefix products of rigid transforms given as 7 columns ``(n,)`` each.

    :func:`_prefix_blocks` on the columns laid out in blocks of 32, identity-padded.
    """
    n, B = s[0].shape[0], _SCAN_BLOCK
    nb = -(-n // B)
    blocks = []
    for i, c in enumerate(s):
        padded = np.full(nb * B, 1.0 if i == 3 else 0.0)  # identity padding: q = (0, 0, 0, 1)
        padded[:n] = c
        blocks.append(np.ascontiguousarray(padded.reshape(nb, B).T))  # (B, nb)
    _prefix_blocks(blocks)
    return tuple(c.T.reshape(-1)[:n] for c in blocks)


#: Block length of the scan in :func:`_prefix_blocks`.
_SCAN_BLOCK = 32


def _prefix_blocks(blocks: list[FloatArray]) -> None:
    """Replace transforms ``s`` by their inclusive prefix products ``s_0·s_1·…·s_(b·B + k)``.

    ``blocks``: 7 columns (``qx qy qz qw tx ty tz``), each ``(B, nb)``, element ``b·B + k`` at
    ``[k, b]``; replaced in place.

    A blocked scan with no Python loop over the elements: the prefixes inside all ``nb``
    blocks are formed together, one position at a time (``B − 1`` batched products of rows);
    the blocks' totals (the last row) are scanned the same way, recursively; each block's
    prefixes are then composed with the product of the blocks before it, row by row (the
    temporaries stay a row's size). Products are associated differently from a left-to-right
    loop, so results agree with it to rounding.
    """
    B, nb = blocks[0].shape
    for k in range(1, B):
        new = _compose_columns(tuple(c[k - 1] for c in blocks), tuple(c[k] for c in blocks))
        for c, v in zip(blocks, new, strict=True):
            c[k] = v
    if nb == 1:
        return
    totals = [c[-1] for c in blocks]  # products of each block
    m = -(-nb // B)
    tb = []
    for i, c in enumerate(totals):
        padded = np.full(m * B, 1.0 if i == 3 else 0.0)
        padded[:nb] = c
        tb.append(np.ascontiguousarray(padded.reshape(m, B).T))
    _prefix_blocks(tb)
    before = tuple(c.T.reshape(-1)[: nb - 1] for c in tb)  # products of blocks 0..b
    for k in range(B):
        new = _compose_columns(before, tuple(c[k, 1:] for c in blocks))
        for c, v in zip(blocks, new, strict=True):
            c[k, 1:] = v


def _chain_odometry(edges: KeyArray, measured: FloatArray) -> tuple[KeyArray, FloatArray] | None:
    """Chain initial poses from odometry edges, batched; None where :func:`vertices` must say why.

    The same choice of edges as the loop in :func:`vertices` — for vertex ``k`` the first edge
    ``(k−1, k)`` in the file, else the last ``(k, k−1)``, inverted — and the same poses
    ``T_k = T_{k−1}·Z``, from the identity at the smallest id, formed by
    :func:`_prefix_blocks` on ``(q, t)`` instead of one 4×4 product per vertex. ``None`` if
    the ids have a gap or a vertex has no odometry edge (the loop then raises its error).
    Returns ``(ids, "xyz_qxyzw" rows)`` (quaternions ``w ≥ 0``). Memory: a few columns of the
    vertex count besides the result (fresh memory is most of the cost).
    """
    lo, hi = int(edges.min()), int(edges.max())
    n = hi - lo  # steps: vertices lo + 1 .. hi
    if n + 1 > edges.size:  # some id in [lo, hi] is missing
        return None
    i, j = edges[:, 0], edges[:, 1]
    none = edges.shape[0]
    fwd = np.flatnonzero(j == i + np.uint64(1))
    first_fwd = np.full(n + 1, none, dtype=np.intp)
    np.minimum.at(first_fwd, (j[fwd] - np.uint64(lo)).astype(np.intp), fwd)  # the first (k−1, k)
    rev = np.flatnonzero(i == j + np.uint64(1))
    last_rev = np.full(n + 1, -1, dtype=np.intp)
    np.maximum.at(last_rev, (i[rev] - np.uint64(lo)).astype(np.intp), rev)  # else the last (k, k−1)
    inverted = first_fwd[1:] == none
    step = np.where(inverted, last_rev[1:], first_fwd[1:])
    del first_fwd, last_rev, fwd, rev
    if (step < 0).any():  # a vertex without an odometry edge (every id then has one: no gap)
        return None
    B = _SCAN_BLOCK
    nb = -(-n // B)
    pos = np.zeros(nb * B, dtype=np.intp)  # element b·B + k of the chain at [k, b]
    pos[:n] = step
    pos = np.ascontiguousarray(pos.reshape(nb, B).T)
    pad = np.zeros(nb * B, dtype=bool)
    pad[n:] = True
    pad = pad.reshape(nb, B).T
    blocks = []
    for column in (3, 4, 5, 6, 0, 1, 2):  # qx qy qz qw tx ty tz
        col = np.take(measured[:, column], pos)
        col[pad] = 1.0 if column == 6 else 0.0  # identity padding
        blocks.append(col)
    inv = np.zeros(nb * B, dtype=bool)
    inv[:n] = inverted
    inv = inv.reshape(nb, B).T
    if inverted.any():  # (q, t)⁻¹ = (q*, −R(q)ᵀ t): conjugate quaternion, rotated back
        q_inv = (-blocks[0][inv], -blocks[1][inv], -blocks[2][inv], blocks[3][inv])
        zero = np.zeros(q_inv[0].shape[0])
        t_inv = _compose_columns(
            (*q_inv, zero, zero, zero), (*q_inv, *(-blocks[4 + a][inv] for a in range(3)))
        )[4:]
        for c, v in zip(blocks, (*q_inv, *t_inv), strict=True):
            c[inv] = v
    del pos, pad, inv
    _prefix_blocks(blocks)
    out = np.empty((1 + nb * B, 7))
    out[0] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    rows = out[1:].reshape(nb, B, 7)
    for k in range(B):  # row by row: the temporaries stay a row's size
        x, y, z, w = (blocks[a][k] for a in range(4))
        # w ≥ 0, as from_matrix chooses; unit norm again (n products drift by ~√n ulps)
        scale = np.where(w < 0.0, -1.0, 1.0) / np.sqrt(x * x + y * y + z * z + w * w)
        for a in range(4):
            rows[:, k, 3 + a] = blocks[a][k] * scale
        for a in range(3):
            rows[:, k, a] = blocks[4 + a][k]
    return np.uint64(lo) + np.arange(n + 1, dtype=np.uint64), out[: n + 1]


def _params_from_raw(raw: FloatArray, euler: npt.NDArray[np.bool_]) -> FloatArray:
    """``(K, 7)`` rows ``x y z qx qy qz qw`` or ``x y z roll pitch yaw 0`` → ``"xyz_qxyzw"``."""
    out = np.array(raw, dtype=np.float64)
    if euler.any():
        out[euler, 3:] = quat.from_matrix(_rpy_matrix(raw[euler, 3:6]), order="xyzw")
    return out


def vertices(
    P: _Parser,
    read_vertices: tuple[KeyArray, FloatArray],
    read_edges: tuple[KeyArray, Sequence[int] | npt.NDArray[np.intp], Callable[[], FloatArray]],
    fixed: list[int],
    to_params: Any,
    chain: Callable[[], tuple[KeyArray, FloatArray] | None] | None = None,
) -> tuple[KeyArray, FloatArray, bool]:
    """Vertex ids and poses of a graph file (2-D and 3-D alike), checked against its edges.

    ``read_vertices = (ids (N,), pose parameters)``; ``read_edges = (edges (M, 2), line of
    each edge, a function returning the measurements as homogeneous matrices (M, n, n))``.
    Without vertex lines the poses are chained from the odometry edges ``(k−1, k)`` (or
    ``(k, k−1)``, inverted) from the identity at the smallest id and returned as
    ``to_params(T)``; ``chain``, if given, is tried first: a batched chaining returning
    ``(ids, params)`` the same, or ``None`` (the loop then runs, and names any gap). Returns
    ``(ids, params, chained)``. Raises naming the file and line for an
    edge to a missing vertex, a gap in the odometry chain, or a ``FIX`` of a vertex that does not
    exist.
    """
    ids, vpar = read_vertices
    edges, e_lines, measured_matrices = read_edges
    chained = ids.shape[0] == 0
    if not chained:
        missing = ~np.isin(edges, ids)
        if missing.any():
            k, end = (int(x) for x in np.argwhere(missing)[0])
            raise P.fail(
                int(e_lines[k]),
                f"edge refers to vertex {int(edges[k, end])}, which has no VERTEX line",
            )
    elif edges.shape[0] == 0:
        Z = measured_matrices()
        ids, vpar = np.zeros(0, dtype=np.uint64), to_params(np.zeros((0, *Z.shape[1:])))
    elif chain is not None and (batched := chain()) is not None:
        ids, vpar = batched
    else:
        Z = measured_matrices()
        ids = np.unique(edges)
        step: dict[int, FloatArray] = {}
        for k in range(edges.shape[0] - 1, -1, -1):  # first occurrence wins
            i, j = int(edges[k, 0]), int(edges[k, 1])
            if j == i + 1:
                step[j] = Z[k]
            elif i == j + 1 and i not in step:
                step[i] = _rigid_inverse(Z[k])
        T = np.empty((ids.shape[0], *Z.shape[1:]))
        T[0] = np.eye(Z.shape[-1])
        for n in range(1, ids.shape[0]):
            k = int(ids[n])
            if k != int(ids[n - 1]) + 1 or k not in step:
                raise ValueError(
                    f"{P.path}: no vertex lines and no odometry edge {k - 1} -> {k}: cannot "
                    "chain initial values (add vertex lines, or use gtsam.InitializePose3)"
                )
            T[n] = T[n - 1] @ step[k]
        vpar = to_params(T)
    if fixed:
        absent = ~np.isin(np.array(fixed, dtype=np.uint64), ids)
        if absent.any():
            k = fixed[int(np.argmax(absent))]
            raise ValueError(f"{P.path}: FIX refers to vertex {k}, which does not exist")
    return ids, vpar, chained


def _rigid_inverse(Z: FloatArray) -> FloatArray:
    """``[[Rᵀ, −Rᵀt], [0, 1]]`` of one rigid transform of any size (closed form)."""
    n = Z.shape[-1] - 1
    inv = np.eye(n + 1)
    inv[:n, :n] = Z[:n, :n].T
    inv[:n, n] = -Z[:n, :n].T @ Z[:n, n]
    return inv


def write(path: PathLike, graph: G2OGraph) -> None:
    """Write ``graph`` as ``VERTEX_SE3:QUAT`` / ``EDGE_SE3:QUAT`` / ``FIX`` lines.

    Every number is written with ``repr`` (full precision). The information is converted back to
    the file's ``(t, qvec)`` order by inverting ``graph.information_reading``: for ``"g2o"``,
    ``Λ_file = M⁻ᵀ Λ M⁻¹`` (rotation block ×4, cross blocks ×2 after the swap); for ``"gtsam"``
    the block swap only (what ``gtsam.writeG2o`` does, but at full precision). Both maps are exact
    in floating point, so ``read(path, graph.information_reading)`` returns ``graph`` bit for bit
    (``EDGE3`` / ``VERTEX3`` input is written in the quaternion types).

    Parameters
    ----------
    path : str or os.PathLike
    graph : G2OGraph
    """
    if not isinstance(graph, G2OGraph):
        raise TypeError(f"graph: expected G2OGraph, got {type(graph).__name__}")
    lam = graph.information
    with np.errstate(over="ignore"):
        if graph.information_reading == "g2o":  # M⁻ᵀ Λ M⁻¹: ×4, ×2 entrywise, then the swap
            file_info = _swap_blocks(lam * (1.0 / _G2O_TO_GTSAM_SCALE))
        else:
            file_info = _swap_blocks(lam)
    bad = ~np.isfinite(file_info).all(axis=(-1, -2))
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(
            f"information[{k}]: the file's (t, qvec) information overflows float64 (the g2o "
            f"reading multiplies the rotation block by 4; largest |entry| "
            f"{float(np.abs(lam[k]).max()):.3g}); it cannot be written"
        )
    r = repr
    lines = [
        f"VERTEX_SE3:QUAT {int(k)} " + " ".join(r(float(c)) for c in x) + "\n"
        for k, x in zip(graph.vertex_ids, graph.vertex_xyz_qxyzw, strict=True)
    ]
    for (i, j), x, m in zip(graph.edges, graph.measured_xyz_qxyzw, file_info, strict=True):
        nums = [*x.tolist(), *m[_TRIU].tolist()]
        lines.append(f"EDGE_SE3:QUAT {int(i)} {int(j)} " + " ".join(r(c) for c in nums) + "\n")
    if graph.fixed:
        lines.append("FIX " + " ".join(str(k) for k in graph.fixed) + "\n")
    with open_text(path, "w") as fh:  # via a temporary file: a link to the input is replaced
        fh.writelines(lines)
