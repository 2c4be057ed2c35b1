"""``ConventionGraph``: a GTSAM graph for code that speaks another convention.

Everything that goes in or comes out is in the wrapper's convention: prior and between
covariances, marginal covariances. Inside it is an ordinary ``gtsam.NonlinearFactorGraph`` and
``gtsam.Values`` (``.graph``, ``.values``), so native GTSAM factors can be added alongside.

Factor choice (``native=None``, the default): a native GTSAM factor when the conversion to GTSAM's
tangent is exact (side, order, rotation scale — see :func:`liebridge.is_exactly_linear`), else
liebridge's custom factor with the convention's own residual and exact Jacobians. Sim(3) always
gets the custom factor: GTSAM 4.3.0's ``BetweenFactorSimilarity3``/``PriorFactorSimilarity3``
linearize with the zero-residual Jacobians (see :mod:`liebridge.gtsam.pose_factors`).

Every group: the wrapper's variables are of its convention's group — ``Pose3`` (SE(3)),
``Pose2`` (SE(2), e.g. ``ConventionGraph("g2o_se2_edge")``), ``Similarity3`` (Sim(3)), ``NavState``
(SE₂(3)) — and poses go in and come out as liebridge's matrices of that group (``(3, 3)`` for
SE(2), ``[sR t; 0 1]`` for Sim(3), ``(5, 5)`` for SE₂(3)).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gtsam

from .._validate import FloatArray
from ..conventions import Convention, ConventionLike, get, single_group
from ..conventions.convert import is_exactly_linear
from .build import gtsam_convention_of
from .glue import from_values, to_gtsam
from .groups import gtsam_group
from .marginals import gtsam_marginals, marginals

__all__ = ["ConventionGraph"]


class ConventionGraph:
    """A factor graph whose inputs and outputs are in ``convention``.

    Parameters
    ----------
    convention : Convention or str
        The user's convention (e.g. ``"sophus"``, ``"barfoot"``, ``"g2o"``).
    graph : gtsam.NonlinearFactorGraph, optional
        Wrap an existing graph (not copied).
    values : gtsam.Values, optional
        Wrap existing values (not copied).

    Examples
    --------
    >>> g = ConventionGraph("barfoot")
    >>> g.insert(0, np.eye(4)); g.insert(1, np.eye(4))
    >>> g.add_prior(0, np.eye(4), np.eye(6) * 1e-6)
    >>> g.add_between(0, 1, T_0_1, cov_in_barfoot_order)   # (ρ, φ), left perturbation
    >>> g.optimize(); g.marginal_covariance(1)              # (ρ, φ), left perturbation
    """

    def __init__(self, convention: ConventionLike, graph: Any = None, values: Any = None) -> None:
        self.convention: Convention = single_group(get(convention))
        self.group: str = gtsam_convention_of(self.convention.group).group
        self.graph = graph if graph is not None else gtsam.NonlinearFactorGraph()
        self.values = values if values is not None else gtsam.Values()
        self._marginals: Any = None

    def _native(self, native: bool | None) -> bool:
        if native is None:
            if gtsam_group(self.group).prefer_custom:  # e.g. Similarity3's zero-residual Jacobians
                return False
            return is_exactly_linear(self.convention, gtsam_convention_of(self.group))
        return native

    def _changed(self) -> None:
        self._marginals = None

    def insert(self, key: int, pose: Any) -> None:
        """Insert (or update) the initial estimate of ``T_world_key``.

        ``pose`` is a matrix of the convention's group (``(4, 4)`` for SE(3), ``(3, 3)`` for
        SE(2), ...).
        """
        arr = gtsam_group(self.group).group.element(pose, "pose")  # library objects too
        if arr.ndim != 2:
            raise ValueError(f"pose: expected one element, got shape {arr.shape}")
        p = to_gtsam(arr, self.group)
        if self.values.exists(key):
            self.values.update(key, p)
        else:
            self.values.insert(key, p)
        self._changed()

    def add_prior(self, key: int, pose: Any, cov: Any, *, native: bool | None = None) -> None:
        """Add a prior at ``pose`` with covariance ``cov`` in the wrapper's convention."""
        from .pose_factors import prior

        self.graph.add(prior(key, pose, cov, self.convention, native=self._native(native)))
        self._changed()

    def add_between(
        self, i: int, j: int, measured: Any, cov: Any, *, native: bool | None = None
    ) -> None:
        """Add ``T_i⁻¹T_j ≈ measured`` with ``cov`` in the wrapper's convention."""
        from .pose_factors import between

        self.graph.add(between(i, j, measured, cov, self.convention, native=self._native(native)))
        self._changed()

    def optimize(
        self, params: Any = None, *, progress: bool | Callable[[str], None] | None = None
    ) -> Any:
        """Optimize in place with :func:`liebridge.gtsam.optimize`; returns its result."""
        from .optimize import optimize

        result = optimize(self.graph, self.values, params, progress=progress)
        self.values = result.values
        self._changed()
        return result

    def pose(self, key: int) -> FloatArray:
        """Return the current estimate of ``T_world_key`` (``(4, 4)`` for SE(3))."""
        return from_values(self.values, [key], group=self.group)[0]

    def poses(self, keys: Sequence[int]) -> FloatArray:
        """Return the current estimates, ``(N, n, n)``."""
        return from_values(self.values, keys, group=self.group)

    def error(self) -> float:
        """Total graph error ``½ Σ ‖whitened residual‖²`` at the current values."""
        return float(self.graph.error(self.values))

    def marginal_covariances(self, keys: Sequence[int]) -> FloatArray:
        """Marginal covariances ``(N, n, n)`` in the wrapper's convention at the current values."""
        if self._marginals is None:
            self._marginals = gtsam_marginals(self.graph, self.values)
        return marginals(
            self.graph, self.values, keys, self.convention, marginals_object=self._marginals
        )

    def marginal_covariance(self, key: int) -> FloatArray:
        """Marginal covariance ``(n, n)`` of ``key`` in the wrapper's convention."""
        return self.marginal_covariances([key])[0]

    def __repr__(self) -> str:
        return (
            f"ConventionGraph({self.convention.name!r}, {self.graph.size()} factors, "
            f"{self.values.size()} values)"
        )
