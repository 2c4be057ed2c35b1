"""pyceres cost functions, parameter blocks and covariances in any SE(3) convention.

See the package docstring (:mod:`liebridge.ceres`) for the blocks' conventions. Throughout,
``quat_order`` is the storage of the quaternion block: ``"wxyz"`` (``pyceres.QuaternionManifold``,
the default) or ``"xyzw"`` (``pyceres.EigenQuaternionManifold``); both manifolds have the same
tangent (left, half angle).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _validate as validate
from .. import lie
from .._validate import FloatArray
from ..conventions import get, single_group
from ..conventions import unchecked as cu
from ..conventions.convert import convert_covariance, tangent_map
from ..conventions.registry import Convention
from ..io import g2o as g2o_io
from ..lie import quaternion as quat
from ..lie import unchecked as lu

try:
    import pyceres
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "liebridge.ceres needs pyceres: pip install -e '.[ceres]' (pyceres >= 2.2)"
    ) from exc

QUAT_ORDERS = ("wxyz", "xyzw")
#: The tangent of pyceres's (quaternion, translation) blocks, rotation first.
CERES_TANGENT = "ceres_pose"


def _quat_order(quat_order: Any) -> str:
    return validate.option(quat_order, "quat_order", QUAT_ORDERS)


def _se3_convention(convention: Any, what: str = "convention") -> Convention:
    conv = single_group(get(convention), what)
    if conv.record is not lie.se3.GROUP:
        raise ValueError(
            f"{what}: {conv.name!r} is a convention of {conv.record.name}; liebridge.ceres "
            "builds SE(3) pose costs (a quaternion block and a translation block)"
        )
    return conv


def quaternion_manifold(quat_order: str = "wxyz") -> Any:
    """Return the pyceres manifold of a quaternion block stored in ``quat_order``.

    ``"wxyz"``: ``pyceres.QuaternionManifold``; ``"xyzw"``: ``pyceres.EigenQuaternionManifold``.
    Both: ``Plus(q, δ) = [cos‖δ‖, sin‖δ‖ δ/‖δ‖] ⊗ q`` (left, half angle: presets
    ``ceres_quaternion`` / ``ceres_eigen_quaternion``). False: ``q ⊗ Exp(δ)`` (right, full angle).
    """
    if _quat_order(quat_order) == "wxyz":
        return pyceres.QuaternionManifold()
    return pyceres.EigenQuaternionManifold()


def pose_blocks(T: Any, quat_order: str = "wxyz") -> tuple[FloatArray, FloatArray]:
    """Split pose(s) ``T`` into parameter blocks ``(q, t)``: fresh contiguous float64 arrays.

    Parameters
    ----------
    T : array_like, shape (4, 4) or (N, 4, 4)
        ``T_world_body``.
    quat_order : {"wxyz", "xyzw"}
        Storage of ``q`` (register it with :func:`quaternion_manifold` of the same order).

    Returns
    -------
    q : ndarray, shape (4,) or (N, 4)
        Unit quaternion of ``R``, ``w ≥ 0``. For a batch, row ``q[k]`` is the block of pose ``k``
        (a contiguous view Ceres can hold).
    t : ndarray, shape (3,) or (N, 3)
        Translation, the body origin in the world frame.
    """
    order = _quat_order(quat_order)
    A = validate.pose(T, "T")
    if A.ndim not in (2, 3):
        raise ValueError(f"T: expected shape (4, 4) or (N, 4, 4), got {A.shape}")
    q = quat.canonical(quat.from_matrix(A[..., :3, :3], order=order), order=order)  # type: ignore[arg-type]
    return np.ascontiguousarray(q, dtype=np.float64), np.ascontiguousarray(A[..., :3, 3])


def pose_from_blocks(q: Any, t: Any, quat_order: str = "wxyz") -> FloatArray:
    """Inverse of :func:`pose_blocks`: ``(..., 4, 4)`` from ``q (..., 4)``, ``t (..., 3)``.

    ``q`` is normalised first (Ceres's manifolds keep it unit to rounding).
    """
    order = _quat_order(quat_order)
    qa = validate.as_float_array(q, "q")
    ta = validate.as_float_array(t, "t")
    if qa.shape[-1:] != (4,) or ta.shape[-1:] != (3,) or qa.shape[:-1] != ta.shape[:-1]:
        raise ValueError(f"q, t: expected shapes (..., 4) and (..., 3), got {qa.shape}, {ta.shape}")
    n = np.linalg.norm(qa, axis=-1, keepdims=True)
    if np.any(~(n > 0)):
        bad = validate.batch_index(~(n[..., 0] > 0))
        raise ValueError(f"q: zero or non-finite quaternion at batch index {bad}")
    T = np.zeros((*qa.shape[:-1], 4, 4))
    T[..., :3, :3] = quat.to_matrix(qa / n, order=order)  # type: ignore[arg-type]
    T[..., :3, 3] = ta
    T[..., 3, 3] = 1.0
    return T


# ------------------------------------------------------------------ the chain rule
def _wxyz(q: FloatArray, order: str) -> FloatArray:
    return q if order == "wxyz" else q[[3, 0, 1, 2]]


def _pose_and_map(q_raw: FloatArray, t: FloatArray, order: str) -> tuple[FloatArray, FloatArray]:
    """Pose of stored blocks and ``D = ∂ξ/∂(q, t)`` (6×7), ``ξ = (ω, v)`` GTSAM's right tangent.

    The residual is extended off the unit sphere as ``r(q/‖q‖)``. With ``q̂ = q/‖q‖ = (w, u)``,
    ``R(q̂ + dq̂) = R·Exp(ω)`` gives ``ω = 2 vec(q̂* ⊗ dq̂)`` and ``t + dt = t + R v`` gives
    ``v = Rᵀ dt``: ``D = blkdiag(2 [−u, wI − [u]×] / ‖q‖, Rᵀ)`` (columns in storage order).
    """
    qw = _wxyz(q_raw, order)
    nq = float(np.sqrt(qw @ qw))
    if not (nq > 0 and np.isfinite(nq) and np.all(np.isfinite(t))):
        raise ValueError("pose blocks: zero or non-finite quaternion, or non-finite translation")
    w, x, y, z = qw / nq
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    u = np.array([x, y, z])
    hat = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    Q = np.empty((3, 4))
    Q[:, 0] = -u
    Q[:, 1:] = w * np.eye(3) - hat
    if order == "xyzw":
        Q = Q[:, [1, 2, 3, 0]]
    D = np.zeros((6, 7))
    D[:3, :4] = (2.0 / nq) * Q
    D[3:, 4:] = R.T
    return T, D


def _sqrt_information(cov: Any, name: str) -> FloatArray:
    C = validate.positive_definite(cov, name, 6)
    if C.shape != (6, 6):
        raise ValueError(f"{name}: expected one 6×6 covariance, got shape {C.shape}")
    info = np.linalg.inv(C)
    info = 0.5 * (info + info.T)
    return np.ascontiguousarray(np.linalg.cholesky(info).T)  # LᵀL = info


class _PoseCost(pyceres.CostFunction):
    """Shared machinery: blocks ``[q, t]`` per pose, residual 6, primed on construction."""

    def __init__(self, n_poses: int, conv: Convention, L: FloatArray, order: str) -> None:
        super().__init__()
        self.set_num_residuals(6)
        self.set_parameter_block_sizes([4, 3] * n_poses)
        self.convention, self.sqrt_information, self.quat_order = conv, L, order

    def _prime(self, T: Sequence[FloatArray]) -> None:
        # pyceres 2.6 segfaults when evaluate_residuals is a Python cost's first evaluation; one
        # evaluation with Jacobians (on private copies of the blocks) makes every later call safe.
        blocks = [b for X in T for b in pose_blocks(X, self.quat_order)]
        problem = pyceres.Problem()
        problem.add_residual_block(self, None, blocks)
        problem.evaluate_jacobian()

    def residual_and_jacobians(
        self, parameters: Sequence[Any]
    ) -> tuple[FloatArray, list[FloatArray]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def Evaluate(self, parameters: Any, residuals: Any, jacobians: Any) -> bool:
        """Ceres's callback: residual, and flat row-major ``(6 × block size)`` Jacobians."""
        try:
            r, J = self.residual_and_jacobians([np.asarray(p) for p in parameters])
        except (ValueError, FloatingPointError, np.linalg.LinAlgError):
            return False
        residuals[:] = r
        if jacobians is not None:
            for k, Jk in enumerate(J):
                if jacobians[k] is not None:
                    jacobians[k][:] = Jk.ravel()
        return True


class BetweenCost(_PoseCost):
    """``r = L · conv.local(Z, T_i⁻¹ T_j)`` over blocks ``[q_i, t_i, q_j, t_j]``."""

    def __init__(self, Z: FloatArray, conv: Convention, L: FloatArray, order: str) -> None:
        super().__init__(2, conv, L, order)
        self.measured = Z
        self._prime([np.eye(4), Z])

    def residual_and_jacobians(
        self, parameters: Sequence[Any]
    ) -> tuple[FloatArray, list[FloatArray]]:
        """Residual and the four stored-block Jacobians ``(6, 4), (6, 3), (6, 4), (6, 3)``."""
        Ti, Di = _pose_and_map(parameters[0], parameters[1], self.quat_order)
        Tj, Dj = _pose_and_map(parameters[2], parameters[3], self.quat_order)
        # the blocks were checked (finite, q ≠ 0) by _pose_and_map: the unchecked kernels apply
        Y = lu.se3_inverse(Ti) @ Tj
        conv, L = self.convention, self.sqrt_information
        r = L @ cu.local(conv, self.measured, Y)
        if not np.all(np.isfinite(r)):
            raise ValueError("between cost: non-finite residual")
        # ∂r/∂ξ_j (Y·Exp(ξ_j)); T_i·Exp(ξ_i) moves Y to Y·Exp(−Ad(Y⁻¹) ξ_i)
        G = L @ cu.local_jacobian(conv, self.measured, Y) @ cu.from_canonical(conv, Y)
        Ji = -(G @ lu.se3_adjoint(lu.se3_inverse(Y))) @ Di
        Jj = G @ Dj
        return r, [Ji[:, :4], Ji[:, 4:], Jj[:, :4], Jj[:, 4:]]


class PriorCost(_PoseCost):
    """``r = L · conv.local(T_prior, T)`` over blocks ``[q, t]``."""

    def __init__(self, T0: FloatArray, conv: Convention, L: FloatArray, order: str) -> None:
        super().__init__(1, conv, L, order)
        self.prior = T0
        self._prime([T0])

    def residual_and_jacobians(
        self, parameters: Sequence[Any]
    ) -> tuple[FloatArray, list[FloatArray]]:
        """Residual and the two stored-block Jacobians ``(6, 4), (6, 3)``."""
        T, D = _pose_and_map(parameters[0], parameters[1], self.quat_order)
        conv, L = self.convention, self.sqrt_information
        r = L @ cu.local(conv, self.prior, T)
        if not np.all(np.isfinite(r)):
            raise ValueError("prior cost: non-finite residual")
        J = L @ cu.local_jacobian(conv, self.prior, T) @ cu.from_canonical(conv, T) @ D
        return r, [J[:, :4], J[:, 4:]]


def between_cost(
    T_i_j: Any, cov: Any, convention: Any = "gtsam", *, quat_order: str = "wxyz"
) -> Any:
    """Build a ``pyceres.CostFunction`` for a relative-pose measurement in any SE(3) convention.

    Residual ``r = L · conv.local(T_i_j, T_i⁻¹ T_j)`` (6), ``LᵀL = cov⁻¹``; parameter blocks
    ``[q_i, t_i, q_j, t_j]`` (sizes 4, 3, 4, 3) as made by :func:`pose_blocks`. The Jacobians
    are with respect to the **stored** blocks, ``(6, 4)`` and ``(6, 3)``, delivered flat
    row-major as pyceres expects; Ceres applies the quaternion manifold's ``PlusJacobian``.

    Parameters
    ----------
    T_i_j : array_like, shape (4, 4)
        Measurement ``Z``: pose ``j`` in the frame of pose ``i``.
    cov : array_like, shape (6, 6)
        Covariance of the measurement in ``convention``'s tangent (its order and side), so the
        information means what the convention says.
    convention : str or Convention
        An SE(3) convention (``"gtsam"``, ``"sophus"``, ``"barfoot"``, ...). With ``gtsam``, the
        residual is GTSAM's ``BetweenFactorPose3`` error whitened the same way.
    quat_order : {"wxyz", "xyzw"}

    Notes
    -----
    Conventions whose ``local`` is a fixed linear image of GTSAM's (``sophus``: reordered;
    ``barfoot``: ``Ad_Z``) give the same objective when ``cov`` is converted with
    :func:`liebridge.convert_covariance` at ``Z``; split-chart conventions (``ros``,
    ``symforce``) define a different objective.
    """
    Z = np.ascontiguousarray(validate.pose(T_i_j, "T_i_j"))
    if Z.shape != (4, 4):
        raise ValueError(f"T_i_j: expected one pose (4, 4), got shape {Z.shape}")
    conv = _se3_convention(convention)
    return BetweenCost(Z, conv, _sqrt_information(cov, "cov"), _quat_order(quat_order))


def prior_cost(T: Any, cov: Any, convention: Any = "gtsam", *, quat_order: str = "wxyz") -> Any:
    """Build a ``pyceres.CostFunction`` for an absolute-pose prior in any SE(3) convention.

    Residual ``r = L · conv.local(T, X)`` for the pose ``X`` held in blocks ``[q, t]``,
    ``LᵀL = cov⁻¹`` with ``cov`` in ``convention``'s tangent at ``T``. Jacobians with respect
    to the stored blocks, as :func:`between_cost`. With ``gtsam``: ``PriorFactorPose3``'s error.
    """
    T0 = np.ascontiguousarray(validate.pose(T, "T"))
    if T0.shape != (4, 4):
        raise ValueError(f"T: expected one pose (4, 4), got shape {T0.shape}")
    conv = _se3_convention(convention)
    return PriorCost(T0, conv, _sqrt_information(cov, "cov"), _quat_order(quat_order))


def evaluate_residuals(problem: Any) -> FloatArray:
    """``problem.evaluate_residuals()`` made safe for any Python cost: Jacobians evaluated first.

    pyceres 2.6 segfaults when ``evaluate_residuals`` is the first evaluation of a Python cost
    function that has never been evaluated with Jacobians. liebridge's costs are primed when
    built; this also covers the user's own costs in the same problem.
    """
    problem.evaluate_jacobian()
    return np.asarray(problem.evaluate_residuals())


# ------------------------------------------------------------------ covariances out
def covariance(
    problem: Any,
    blocks_i: Sequence[Any],
    blocks_j: Sequence[Any] | None = None,
    convention: Any = "gtsam",
    *,
    quat_order: str = "wxyz",
    options: Any = None,
) -> FloatArray:
    """Covariance of one pose (6×6) or two poses jointly (12×12) from a solved problem.

    Reads ``Covariance.get_covariance_block_tangent_space`` over the rotation and translation
    blocks (cross terms included: rotation–translation of each pose, and between the poses),
    i.e. the covariance in the ``ceres_pose`` tangent at each pose (left half-angle rotation,
    world translation, rotation first), and maps it exactly (``M Σ Mᵀ``, ``M`` the first-order
    tangent map at the current blocks' pose, block-diagonal over the poses) into
    ``convention``. For ``gtsam`` this is ``M = blkdiag(2Rᵀ, Rᵀ)`` and is what
    ``gtsam.Marginals`` returns for the same objective.

    Parameters
    ----------
    problem : pyceres.Problem
        Solved; the blocks hold the estimate.
    blocks_i, blocks_j : (q, t)
        The blocks of pose ``i`` (and ``j``) as registered.
    convention : str or Convention
        Where the result lives. Joint: ``[[Σ_ii, Σ_ij], [Σ_ji, Σ_jj]]``, pose ``i`` first.
    quat_order : {"wxyz", "xyzw"}
    options : pyceres.CovarianceOptions, optional

    Returns
    -------
    ndarray, shape (6, 6) or (12, 12)

    Raises
    ------
    ValueError
        If pyceres cannot compute the covariance (rank-deficient problem: fix the gauge with a
        prior or a constant block).
    """
    order = _quat_order(quat_order)
    conv = _se3_convention(convention)
    poses = [blocks_i] if blocks_j is None else [blocks_i, blocks_j]
    blocks: list[Any] = []
    for k, pair in enumerate(poses):
        if len(pair) != 2:
            raise ValueError(f"blocks_{'ij'[k]}: expected (q, t), got {len(pair)} arrays")
        blocks += list(pair)
    pairs = [(blocks[a], blocks[b]) for a in range(len(blocks)) for b in range(a, len(blocks))]
    cov = pyceres.Covariance(options if options is not None else pyceres.CovarianceOptions())
    if not cov.compute(pairs, problem):
        raise ValueError("covariance: pyceres could not compute it (rank-deficient problem?)")
    sizes = [3, 3] * len(poses)
    offs = [3 * k for k in range(len(sizes) + 1)]
    n = offs[-1]
    S = np.zeros((n, n))
    for a in range(len(blocks)):
        for b in range(a, len(blocks)):
            B = np.asarray(cov.get_covariance_block_tangent_space(blocks[a], blocks[b], problem))
            B = B.reshape(sizes[a], sizes[b])
            S[offs[a] : offs[a + 1], offs[b] : offs[b + 1]] = B
            S[offs[b] : offs[b + 1], offs[a] : offs[a + 1]] = B.T
    M = np.zeros((n, n))
    for k, (q, t) in enumerate(poses):
        T = pose_from_blocks(q, t, order)
        M[6 * k : 6 * k + 6, 6 * k : 6 * k + 6] = tangent_map(T, CERES_TANGENT, conv)
    out: FloatArray = M @ S @ M.T
    return 0.5 * (out + out.T)


# ------------------------------------------------------------------ graphs
@dataclass
class CeresProblem:
    """A pose graph as a pyceres problem: the problem, and each key's ``(q, t)`` blocks.

    Attributes
    ----------
    problem : pyceres.Problem
    blocks : dict of int to (q, t)
        The registered arrays; Ceres writes the solution into them.
    quat_order : str
    """

    problem: Any
    blocks: dict[int, tuple[FloatArray, FloatArray]]
    quat_order: str = "wxyz"
    costs: list[Any] = field(default_factory=list, repr=False)

    def solve(self, options: Any = None) -> Any:
        """Run ``pyceres.solve``; return the ``SolverSummary``.

        Default options: Levenberg–Marquardt, sparse normal Cholesky, at most 500 iterations,
        function/gradient/parameter tolerances 1e-16 (run to convergence: pose graphs have flat
        directions along which Ceres's default 1e-6 stops visibly short of the optimum).
        """
        if options is None:
            options = pyceres.SolverOptions()
            options.linear_solver_type = pyceres.LinearSolverType.SPARSE_NORMAL_CHOLESKY
            options.max_num_iterations = 500
            options.function_tolerance = 1e-16
            options.gradient_tolerance = 1e-16
            options.parameter_tolerance = 1e-16
        summary = pyceres.SolverSummary()
        pyceres.solve(options, self.problem, summary)
        return summary

    def poses(self) -> dict[int, FloatArray]:
        """Return the current ``T_world_body`` per key, ``(4, 4)``."""
        return {k: pose_from_blocks(q, t, self.quat_order) for k, (q, t) in self.blocks.items()}

    def cost(self) -> float:
        """Return Ceres's cost ``½‖r‖²`` at the current blocks (GTSAM's ``graph.error``)."""
        r = evaluate_residuals(self.problem)
        return 0.5 * float(r @ r)

    def covariance(
        self, key_i: int, key_j: int | None = None, convention: Any = "gtsam"
    ) -> FloatArray:
        """:func:`covariance` of key ``key_i`` (jointly with ``key_j``) in ``convention``."""
        bj = None if key_j is None else self.blocks[key_j]
        return covariance(
            self.problem, self.blocks[key_i], bj, convention, quat_order=self.quat_order
        )


def graph_from_g2o(path: str | Path, information: str = "g2o") -> g2o_io.G2OGraph:
    """Read a 3D g2o/TORO file (:func:`liebridge.io.g2o.read`) for :func:`problem_from_values`."""
    return g2o_io.read(path, information)  # type: ignore[arg-type]


def problem_from_values(
    graph: Any,
    values: Any = None,
    *,
    convention: Any = "gtsam",
    quat_order: str = "wxyz",
) -> CeresProblem:
    """Build the same pose graph as a pyceres problem with liebridge's costs.

    Parameters
    ----------
    graph : gtsam.NonlinearFactorGraph or liebridge.io.g2o.G2OGraph
        GTSAM: ``BetweenFactorPose3`` and ``PriorFactorPose3`` with Gaussian noise models (their
        covariance is in GTSAM's tangent). g2o: every edge, its information over GTSAM's tangent
        (:func:`graph_from_g2o`); ``FIX`` ids become constant blocks.
    values : gtsam.Values, optional
        Initial poses (required with a GTSAM graph; a g2o graph carries its own).
    convention : str or Convention
        The convention the costs are written in; covariances are converted into it at the
        measurement (``convert_covariance(cov, Z, "gtsam", convention)``), which is exact for the
        conventions whose residuals are linear images of GTSAM's (``sophus``, ``barfoot``).
    quat_order : {"wxyz", "xyzw"}

    Returns
    -------
    CeresProblem
    """
    import gtsam

    order = _quat_order(quat_order)
    conv = _se3_convention(convention)
    problem = pyceres.Problem()
    blocks: dict[int, tuple[FloatArray, FloatArray]] = {}
    costs: list[Any] = []

    def add(key: int, T: Any) -> None:
        q, t = pose_blocks(T, order)
        blocks[key] = (q, t)
        problem.add_parameter_block(q, 4)
        problem.set_manifold(q, quaternion_manifold(order))
        problem.add_parameter_block(t, 3)

    def cov_in(cov: FloatArray, Z: FloatArray) -> FloatArray:
        out = convert_covariance(cov, Z, "gtsam", conv)
        return 0.5 * (out + out.T)

    if isinstance(graph, g2o_io.G2OGraph):
        for key, T in zip(graph.vertex_ids.tolist(), graph.poses, strict=True):
            add(int(key), T)
        covs = np.linalg.inv(graph.information)
        for (i, j), Z, C in zip(graph.edges.tolist(), graph.measured, covs, strict=True):
            c = between_cost(Z, cov_in(C, Z), conv, quat_order=order)
            costs.append(c)
            problem.add_residual_block(c, None, [*blocks[int(i)], *blocks[int(j)]])
        for key in graph.fixed:
            for b in blocks[int(key)]:
                problem.set_parameter_block_constant(b)
        return CeresProblem(problem, blocks, order, costs)

    if not isinstance(graph, gtsam.NonlinearFactorGraph):
        raise TypeError(
            f"graph: expected gtsam.NonlinearFactorGraph or liebridge.io.g2o.G2OGraph, got "
            f"{type(graph).__name__}"
        )
    if not isinstance(values, gtsam.Values):
        raise TypeError("values: a gtsam.Values with the initial poses is required")
    for key in values.keys():
        try:
            T = values.atPose3(key).matrix()
        except RuntimeError:
            raise TypeError(f"values: key {int(key)} does not hold a gtsam.Pose3") from None
        add(int(key), T)
    for k in range(graph.size()):
        f = graph.at(k)
        if f is None:
            continue
        kinds = (gtsam.BetweenFactorPose3, gtsam.PriorFactorPose3)
        if not isinstance(f, kinds):
            raise TypeError(
                f"graph: factor {k} is {type(f).__name__}; problem_from_values reads "
                "BetweenFactorPose3 and PriorFactorPose3"
            )
        try:
            C = np.asarray(f.noiseModel().covariance())  # type: ignore[attr-defined]
        except AttributeError:
            raise TypeError(
                f"graph: factor {k}'s noise model ({type(f.noiseModel()).__name__}) is not Gaussian"
            ) from None
        keys = [int(x) for x in f.keys()]
        missing = [x for x in keys if x not in blocks]
        if missing:
            raise ValueError(f"graph: factor {k} uses key(s) {missing} not in values")
        if isinstance(f, gtsam.BetweenFactorPose3):
            Z = f.measured().matrix()
            c = between_cost(Z, cov_in(C, Z), conv, quat_order=order)
            problem.add_residual_block(c, None, [*blocks[keys[0]], *blocks[keys[1]]])
        else:
            Z = f.prior().matrix()
            c = prior_cost(Z, cov_in(C, Z), conv, quat_order=order)
            problem.add_residual_block(c, None, list(blocks[keys[0]]))
        costs.append(c)
    return CeresProblem(problem, blocks, order, costs)
