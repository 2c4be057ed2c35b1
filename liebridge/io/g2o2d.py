"""2-D g2o / TORO pose-graph files with explicit information semantics.

Read with :func:`read`, write with :func:`write`, hand to GTSAM with :meth:`G2OGraph2D.to_gtsam`.
Supported lines::

    VERTEX_SE2 id x y theta
    EDGE_SE2   i j dx dy dtheta  I11 I12 I13 I22 I23 I33     (g2o: upper triangle, row-major)
    VERTEX2    id x y theta                                  (TORO)
    EDGE2      i j dx dy dtheta  6 numbers                    (TORO; order: see below)
    FIX        id [id ...]
    EQUIV      i j                                           (TORO; skipped, counted)

A pose is ``(x, y, θ)``: ``T = [[cos θ, −sin θ, x], [sin θ, cos θ, y], [0, 0, 1]]``. A measurement
``Z`` is ``T_i_j`` (pose ``j`` in the frame of pose ``i``). Inside, every information matrix is
over **GTSAM's Pose2 tangent** of the edge error, ``ξ = (vx, vy, ω) = Logmap(Z⁻¹·Ti⁻¹·Tj)``
(what ``gtsam.BetweenFactorPose2`` whitens).

``EDGE_SE2`` (g2o, ``types/slam2d/edge_se2.h``)
    g2o's error is ``(x, y, θ)`` of ``Z⁻¹·Ti⁻¹·Tj`` (``SE2::toVector``); GTSAM's is
    ``Logmap`` of the same pose, whose translation is ``V(ω)⁻¹·(x, y)``. The two agree to first
    order at zero error (``V(0) = I``): the information matrix is the same in both readings, the
    objectives differ at second order (a factor in the ``g2o_se2_edge`` convention keeps g2o's own).
    Unlike the 3-D ``EDGE_SE3:QUAT`` (whose quaternion-vector error is half the angle) there is no
    rescaling trap here.

``EDGE2`` (TORO 2-D, ``w10000.graph``)
    TORO writes the six numbers as ``Ixx Ixy Iyy Iθθ Ixθ Iyθ`` (its 2-D loader; GTSAM's
    ``w100.graph`` and ``w10000.graph`` hold identities in this order, ``1 0 1 1 0 0``); other
    writers (``w100_30.g2o`` in GTSAM's data) use g2o's order ``I11 I12 I13 I22 I23 I33``.
    ``gtsam.readG2o`` always reads g2o's order and refuses a file where that gives an indefinite
    matrix (``"looks like this is not G2O matrix order"``, on ``w100.graph`` and
    ``w10000.graph``). ``edge2="auto"`` (default) takes g2o's order when every ``EDGE2`` matrix
    is positive definite in it, else TORO's when every one is in that, else raises naming the
    first line that is neither; ``edge2="g2o"`` / ``"toro"`` force one. The order used is kept in
    :attr:`G2OGraph2D.edge2_order` and :func:`write` uses it.

Graphs without vertex lines get initial values by chaining the odometry edges ``(k−1, k)``.
Numbers are written with ``repr``, so ``read(write(g))`` reproduces every array of ``g`` bit
for bit. A malformed line raises ``ValueError`` naming the file, the 1-based line and the field;
a 3-D line in a 2-D file (or the reverse, in :func:`liebridge.io.g2o.read`) says which reader to
use. ``gtsam.readG2o(path, is3D=True)`` returns an *empty* graph for a 2-D file; these readers
refuse instead.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from .. import _validate as validate
from .._validate import FloatArray
from .atomic import atomic_write
from .g2o import (
    _check_vertex_refs,
    _covariances,
    _ids,
    _Parser,
    _readonly,
    _symmetrised_copy,
    gauge_keys,
    gauge_notice,
    has_duplicates,
    in_file_order,
    prior_covariance,
    read_tagged,
    vertices,
)
from .trajectory import text_lines

__all__ = ["G2OGraph2D", "is_2d", "read", "write"]

PathLike = str | os.PathLike[str]
KeyArray = npt.NDArray[np.uint64]  # vertex ids are GTSAM keys: uint64
Edge2Order = Literal["auto", "g2o", "toro"]

_2D_VERTEX = ("VERTEX_SE2", "VERTEX2")
_2D_EDGE = ("EDGE_SE2", "EDGE2")
_3D_TAGS = ("VERTEX_SE3:QUAT", "EDGE_SE3:QUAT", "VERTEX3", "EDGE3")
#: position in the symmetric 3×3 of each of the six numbers, per order
_G2O_ORDER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
_TORO_ORDER = ((0, 0), (0, 1), (1, 1), (2, 2), (0, 2), (1, 2))


def _sym(nums: FloatArray, order: tuple[tuple[int, int], ...]) -> FloatArray:
    out = np.empty((*nums.shape[:-1], 3, 3))
    for k, (r, c) in enumerate(order):
        out[..., r, c] = nums[..., k]
        out[..., c, r] = nums[..., k]
    return out


def _unsym(lam: FloatArray, order: tuple[tuple[int, int], ...]) -> FloatArray:
    return np.stack([lam[..., r, c] for r, c in order], axis=-1)


def _positive_definite(lam: FloatArray) -> npt.NDArray[np.bool_]:
    """Whether each symmetric ``lam[...]`` (..., 3, 3) is positive definite (one batched call)."""
    if lam.shape[0] == 0:
        return np.ones(lam.shape[:-2], dtype=bool)
    with np.errstate(invalid="ignore", over="ignore"):
        return np.asarray(np.linalg.eigvalsh(lam)[..., 0] > 0.0)


def pose2_matrix(xytheta: Any) -> FloatArray:
    """``(..., 3)`` rows ``(x, y, θ)`` → ``(..., 3, 3)`` homogeneous SE(2) matrices."""
    p = np.asarray(xytheta, dtype=np.float64)
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    T = np.zeros((*p.shape[:-1], 3, 3))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2] = c, -s, p[..., 0]
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2] = s, c, p[..., 1]
    T[..., 2, 2] = 1.0
    return T


def pose2_params(T: Any) -> FloatArray:
    """Inverse of :func:`pose2_matrix`: ``(x, y, atan2(R10, R00))`` with θ in ``(−π, π]``."""
    M = np.asarray(T, dtype=np.float64)
    return np.stack([M[..., 0, 2], M[..., 1, 2], np.arctan2(M[..., 1, 0], M[..., 0, 0])], axis=-1)


@dataclass(frozen=True, eq=False)
class G2OGraph2D:
    """A 2-D pose graph as read from a g2o/TORO file (arrays; GTSAM objects by :meth:`to_gtsam`).

    Attributes
    ----------
    vertex_ids : ndarray of uint64, shape (N,)
        Vertex ids (GTSAM keys in :meth:`to_gtsam`).
    vertex_xytheta : ndarray, shape (N, 3)
        Poses ``T_world_vertex`` as ``(x, y, θ)``, exactly as read.
    edges : ndarray of uint64, shape (M, 2)
        ``(i, j)`` per edge.
    measured_xytheta : ndarray, shape (M, 3)
        ``Z = T_i_j`` as ``(x, y, θ)``, exactly as read.
    information : ndarray, shape (M, 3, 3)
        Over GTSAM's Pose2 tangent ``(vx, vy, ω)`` of ``Logmap(Z⁻¹·Ti⁻¹·Tj)`` (= the file's
        ``(x, y, θ)`` order: see the module docstring).
    fixed : tuple of int
        Ids from ``FIX`` lines.
    edge2_order : {"g2o", "toro", "none"}
        The order of the six ``EDGE2`` numbers that was used (``"none"``: no ``EDGE2`` line).
    skipped : tuple of (str, int)
        Lines skipped by tag, with their count (``EQUIV``).
    vertices_from_odometry : bool
        True when the file had no vertex lines and the poses were chained from odometry.
    """

    vertex_ids: KeyArray
    vertex_xytheta: FloatArray
    edges: KeyArray
    measured_xytheta: FloatArray
    information: FloatArray
    fixed: tuple[int, ...] = ()
    edge2_order: str = "none"
    skipped: tuple[tuple[str, int], ...] = ()
    vertices_from_odometry: bool = False

    def __post_init__(self) -> None:
        self._check_and_freeze(copy=True)

    @classmethod
    def _adopt(cls, **fields: Any) -> G2OGraph2D:
        """Build from arrays the reader has just made (the same checks; frozen, not copied)."""
        graph = object.__new__(cls)
        for name, value in fields.items():
            object.__setattr__(graph, name, value)
        graph._check_and_freeze(copy=False)
        return graph

    def _check_and_freeze(self, *, copy: bool) -> None:
        """Validate the fields as :class:`~liebridge.io.g2o.G2OGraph` does; store them read-only.

        Integer ids in ``[0, 2**64 − 2]``, unique; edges between existing vertices; finite
        poses and measurements; information symmetric positive semi-definite (NaN refused). The
        caller's arrays are copied (``copy``), never frozen in place.
        """
        ids = _ids(self.vertex_ids, "vertex_ids")
        if ids.ndim != 1:
            raise ValueError(f"vertex_ids: expected a 1-D integer array, got {ids.shape}")
        n = ids.shape[0]
        vx = validate.vector(self.vertex_xytheta, "vertex_xytheta", 3)
        if vx.shape != (n, 3):
            raise ValueError(f"vertex_xytheta: expected ({n}, 3), got {vx.shape}")
        e = _ids(self.edges, "edges")
        if e.ndim != 2 or e.shape[1] != 2:
            raise ValueError(f"edges: expected an (M, 2) integer array, got {e.shape}")
        m = e.shape[0]
        mx = validate.vector(self.measured_xytheta, "measured_xytheta", 3)
        if mx.shape != (m, 3):
            raise ValueError(f"measured_xytheta: expected ({m}, 3), got {mx.shape}")
        info = _covariances(self.information, "information", 3)
        if info.shape != (m, 3, 3):
            raise ValueError(f"information: expected ({m}, 3, 3), got {info.shape}")
        if self.edge2_order not in ("g2o", "toro", "none"):
            raise ValueError(
                f"edge2_order: expected 'g2o', 'toro' or 'none', got {self.edge2_order!r}"
            )
        _check_vertex_refs(ids, e)
        object.__setattr__(self, "vertex_ids", _readonly(ids, copy))
        object.__setattr__(self, "vertex_xytheta", _readonly(vx, copy))
        object.__setattr__(self, "edges", _readonly(e, copy))
        object.__setattr__(self, "measured_xytheta", _readonly(mx, copy))
        object.__setattr__(self, "information", _symmetrised_copy(info, copy))
        fixed = _ids(np.asarray(list(self.fixed), dtype=object), "fixed")
        object.__setattr__(self, "fixed", tuple(int(i) for i in fixed))

    def __repr__(self) -> str:
        return (
            f"G2OGraph2D({self.vertex_ids.shape[0]} vertices, {self.edges.shape[0]} edges, "
            f"fixed={list(self.fixed)}, edge2_order={self.edge2_order!r})"
        )

    @property
    def poses(self) -> FloatArray:
        """Vertex poses as ``(N, 3, 3)`` SE(2) matrices."""
        return pose2_matrix(self.vertex_xytheta)

    @property
    def measured(self) -> FloatArray:
        """Measurements ``T_i_j`` as ``(M, 3, 3)`` SE(2) matrices."""
        return pose2_matrix(self.measured_xytheta)

    def to_gtsam(self, prior: Any = "gauge") -> tuple[Any, Any]:
        """GTSAM factor graph (``BetweenFactorPose2`` with ``Gaussian.Information``) and values.

        The between factors equal ``gtsam.readG2o(path, is3D=False)``'s for files it reads
        (g2o-order numbers); the prior factors follow them.

        Parameters
        ----------
        prior : "gauge", None, float, array of shape (3,) or (3, 3)
            ``"gauge"`` (default): one ``gtsam.PriorFactorPose2`` at the initial pose of each
            ``FIX`` vertex, or of the first vertex when there are none, σ =
            :data:`liebridge.io.g2o.GAUGE_PRIOR_SIGMA` in each direction, as
            ``liebridge optimize`` adds for a 2-D file; said once
            (:class:`liebridge.io.g2o.GaugePriorNotice`). ``None``: no prior (gauge-free:
            GTSAM's marginals fail on it). A number σ, three σ's or a ``(3, 3)`` covariance: that
            prior instead, over **GTSAM's Pose2 tangent** ``(vx, vy, ω)`` of ``X̂·Exp(δ)``
            (translation first here, unlike Pose3), added silently.
        """
        import gtsam  # the library itself: io stays below liebridge's gtsam layer

        cov = prior_covariance(prior, 3)
        graph = gtsam.NonlinearFactorGraph()
        for (i, j), z, info in zip(
            self.edges.tolist(), self.measured_xytheta.tolist(), self.information, strict=True
        ):
            noise = gtsam.noiseModel.Gaussian.Information(np.array(info))
            graph.add(gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(*z), noise))
        values = gtsam.Values()
        for k, p in zip(self.vertex_ids.tolist(), self.vertex_xytheta.tolist(), strict=True):
            values.insert(k, gtsam.Pose2(*p))
        if cov is not None:
            keys = gauge_keys(self.vertex_ids, self.fixed)
            noise = gtsam.noiseModel.Gaussian.Covariance(cov)
            for k in keys:
                graph.add(gtsam.PriorFactorPose2(k, values.atPose2(k), noise))
            if isinstance(prior, str) and keys:
                gauge_notice(
                    "G2OGraph2D.to_gtsam", keys, "in each of GTSAM's (vx, vy, ω) directions"
                )
        return graph, values


def is_2d(path: PathLike) -> bool:
    """Whether the first pose line of a g2o/TORO file is 2-D (``VERTEX_SE2``, ``EDGE2``, ...)."""
    for _, line in text_lines(path):
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        if fields[0] in _2D_VERTEX + _2D_EDGE:
            return True
        if fields[0] in _3D_TAGS:
            return False
    return False


def read(path: PathLike, *, edge2: Edge2Order = "auto") -> G2OGraph2D:
    """Read a 2-D g2o / TORO file.

    Parameters
    ----------
    path : str or os.PathLike
    edge2 : {"auto", "g2o", "toro"}
        Order of the six information numbers of ``EDGE2`` lines (``EDGE_SE2`` is always g2o's);
        see the module docstring.

    Returns
    -------
    G2OGraph2D

    Raises
    ------
    ValueError
        On a malformed, 3-D or unsupported line (naming the file, line and field), an edge to a
        missing vertex, an information matrix that is not positive definite, or a file without
        vertices whose odometry chain has a gap.

    Notes
    -----
    A well-formed file is parsed by ``numpy.loadtxt``, one pass per line type
    (:func:`liebridge.io.g2o.read_tagged`, issue 23); anything unusual sends it to the
    line-by-line reader, which returns the same graph or names the first faulty line.
    """
    if edge2 not in ("auto", "g2o", "toro"):
        raise ValueError(f"edge2: expected 'auto', 'g2o' or 'toro', got {edge2!r}")
    fast = _read_tables(path, edge2)
    if fast is not None:
        return fast
    return _read_lines(path, edge2)


def _read_tables(path: PathLike, edge2: Edge2Order) -> G2OGraph2D | None:
    """Read a well-formed file by ``numpy.loadtxt`` (:func:`liebridge.io.g2o.read_tagged`).

    Returns None when anything is unusual (a malformed line, a duplicate vertex, an edge from a
    vertex to itself, an information matrix that fails, ...): the line reader then names it.
    """
    got = read_tagged(
        path,
        {"VERTEX_SE2": (1, 3), "VERTEX2": (1, 3), "EDGE_SE2": (2, 9), "EDGE2": (2, 9)},
        skip=("EQUIV",),
    )
    if got is None:
        return None
    tables, fixed, skipped = got
    vs, v2, es, e2 = (tables[t] for t in ("VERTEX_SE2", "VERTEX2", "EDGE_SE2", "EDGE2"))
    v_ids = np.array(in_file_order([(vs.lines, vs.ids[:, 0]), (v2.lines, v2.ids[:, 0])]))
    edges = np.array(in_file_order([(es.lines, es.ids), (e2.lines, e2.ids)]))
    if has_duplicates(v_ids) or (edges[:, 0] == edges[:, 1]).any():
        return None
    vpar = np.array(in_file_order([(vs.lines, vs.values), (v2.lines, v2.values)]))
    eraw = np.array(in_file_order([(es.lines, es.values), (e2.lines, e2.values)]))
    toro_tag = in_file_order(
        [(es.lines, np.zeros(es.lines.shape, bool)), (e2.lines, np.ones(e2.lines.shape, bool))]
    )
    e_lines = in_file_order([(es.lines, es.lines), (e2.lines, e2.lines)])
    del got, tables, vs, v2, es, e2  # the parsed tables: freed before the conversions
    try:
        return _graph(
            _Parser(path), (v_ids, vpar), (edges, eraw, toro_tag, e_lines), fixed, skipped, edge2
        )
    except ValueError:
        return None


def _read_lines(path: PathLike, edge2: Edge2Order) -> G2OGraph2D:
    """Read line by line, naming every fault by file, line and field (the reference reader)."""
    P = _Parser(path)
    v_ids: list[int] = []
    v_line: dict[int, int] = {}
    v_raw: list[list[float]] = []
    e_ids: list[tuple[int, int]] = []
    e_raw: list[list[float]] = []
    e_toro_tag: list[bool] = []
    e_lines: list[int] = []
    fixed: list[int] = []
    skipped: dict[str, int] = {}
    for lineno, line in text_lines(path):
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        tag = fields[0]
        if tag in _2D_VERTEX:
            if len(fields) < 2:
                raise P.fail(lineno, f"{tag} without an id")
            k = P.vertex_id(lineno, fields[1])
            if k in v_line:
                raise P.fail(lineno, f"vertex {k} already defined on line {v_line[k]}")
            v_raw.append(P.numbers(lineno, tag, fields[2:], 3, "x y theta"))
            v_ids.append(k)
            v_line[k] = lineno
        elif tag in _2D_EDGE:
            if len(fields) < 3:
                raise P.fail(lineno, f"{tag} without two vertex ids")
            i, j = P.vertex_id(lineno, fields[1]), P.vertex_id(lineno, fields[2])
            if i == j:
                raise P.fail(lineno, f"{tag} from vertex {i} to itself")
            e_raw.append(P.numbers(lineno, tag, fields[3:], 9, "dx dy dtheta + 6 information"))
            e_ids.append((i, j))
            e_toro_tag.append(tag == "EDGE2")
            e_lines.append(lineno)
        elif tag == "FIX":
            if len(fields) < 2:
                raise P.fail(lineno, "FIX without an id")
            fixed.extend(P.vertex_id(lineno, f) for f in fields[1:])
        elif tag == "EQUIV":
            skipped[tag] = skipped.get(tag, 0) + 1
        elif tag in _3D_TAGS:
            raise P.fail(
                lineno, f"3-D type {tag} in a 2-D file: read it with liebridge.io.g2o.read"
            )
        else:
            raise P.fail(
                lineno,
                f"unsupported tag {tag!r} (supported: VERTEX_SE2, EDGE_SE2, VERTEX2, EDGE2, FIX, "
                "EQUIV)",
            )
    return _graph(
        P,
        (np.array(v_ids, dtype=np.uint64), np.array(v_raw, dtype=np.float64).reshape(-1, 3)),
        (
            np.array(e_ids, dtype=np.uint64).reshape(-1, 2),
            np.array(e_raw, dtype=np.float64).reshape(-1, 9),
            np.array(e_toro_tag, dtype=bool),
            e_lines,
        ),
        fixed,
        skipped,
        edge2,
    )


def _graph(
    P: _Parser,
    read_vertices: tuple[KeyArray, FloatArray],
    read_edges: tuple[KeyArray, FloatArray, npt.NDArray[np.bool_], Any],
    fixed: list[int],
    skipped: dict[str, int],
    edge2: Edge2Order,
) -> G2OGraph2D:
    """Build the graph from the parsed lines (both readers): information order, checks.

    ``read_edges = (edges (M, 2), rows dx dy dθ + 6 numbers (M, 9), EDGE2 tag (M,), line of
    each edge)``.
    """
    edges, eraw, toro_tag, e_lines = read_edges
    nums = eraw[:, 3:]
    info = _sym(nums, _G2O_ORDER)
    order = "none"
    if toro_tag.any():
        as_g2o = _positive_definite(info[toro_tag])
        as_toro = _positive_definite(_sym(nums[toro_tag], _TORO_ORDER))
        if edge2 == "auto":
            if as_g2o.all():
                order = "g2o"
            elif as_toro.all():
                order = "toro"
            else:
                k = int(np.flatnonzero(toro_tag)[np.flatnonzero(~as_g2o & ~as_toro)[0]])
                raise P.fail(
                    int(e_lines[k]),
                    "EDGE2 information is not positive definite in g2o's order "
                    "(I11 I12 I13 I22 I23 I33) nor in TORO's (Ixx Ixy Iyy Itt Ixt Iyt)",
                )
        else:
            order = edge2
        if order == "toro":
            info[toro_tag] = _sym(nums[toro_tag], _TORO_ORDER)
    try:
        _covariances(info, "information", 3)  # in chunks: bounded temporaries (issue 23)
    except ValueError:
        for k, lam_k in enumerate(info):  # name the line
            try:
                validate.covariance(lam_k, "information", 3)
            except ValueError as exc:
                raise P.fail(int(e_lines[k]), f"{exc} (over (x, y, theta))") from None
        raise
    measured = eraw[:, :3].copy()
    ids, vpar, from_odometry = vertices(
        P,
        read_vertices,
        (edges, e_lines, lambda: pose2_matrix(measured)),
        fixed,
        pose2_params,
    )
    return G2OGraph2D._adopt(
        vertex_ids=ids,
        vertex_xytheta=vpar,
        edges=edges,
        measured_xytheta=measured,
        information=info,
        fixed=tuple(fixed),
        edge2_order=order,
        skipped=tuple(sorted(skipped.items())),
        vertices_from_odometry=from_odometry,
    )


def write(path: PathLike, graph: G2OGraph2D) -> None:
    """Write ``graph`` as ``VERTEX_SE2`` / ``EDGE_SE2`` / ``FIX`` lines (``repr`` numbers).

    ``EDGE_SE2`` numbers are in g2o's order whatever ``graph.edge2_order`` was (the information
    is the same matrix), so ``read(path)`` returns ``graph``'s arrays bit for bit.
    """
    if not isinstance(graph, G2OGraph2D):
        raise TypeError(f"graph: expected G2OGraph2D, got {type(graph).__name__}")
    r = repr
    lines = [
        f"VERTEX_SE2 {int(k)} " + " ".join(r(float(c)) for c in x) + "\n"
        for k, x in zip(graph.vertex_ids, graph.vertex_xytheta, strict=True)
    ]
    file_info = _unsym(np.asarray(graph.information), _G2O_ORDER)
    for (i, j), x, m in zip(graph.edges, graph.measured_xytheta, file_info, strict=True):
        nums = [*x.tolist(), *m.tolist()]
        lines.append(f"EDGE_SE2 {int(i)} {int(j)} " + " ".join(r(c) for c in nums) + "\n")
    if graph.fixed:
        lines.append("FIX " + " ".join(str(k) for k in graph.fixed) + "\n")
    with atomic_write(path, "w") as fh:  # the one helper: whole or nothing, links and FIFOs safe
        fh.writelines(lines)
