"""Position ellipses and ellipsoids of uncertain poses and points (``plot`` extra: matplotlib).

The position of an :class:`~liebridge.uncertain.UncertainPose` is ``t`` of ``T_parent_body``;
its covariance in the parent frame is ``act(A, 0).cov`` (first order, in any convention: the
convention's tangent is mapped, not read off a diagonal block — a right-perturbation
covariance's translation block is in the *body* frame). An ellipse is the ``n_sigma`` level set
of the Gaussian projected (marginalised) onto two parent-frame axes; an ellipsoid uses all three.

:func:`ellipse_points` and :func:`ellipsoid_points` are plain numpy (no matplotlib);
:func:`plot_position_ellipse` / :func:`plot_position_ellipsoid` draw them on a given axes.
:func:`position` keeps a torch/JAX pose's array type; the drawing functions read a detached host
copy of it (a plot ends the graph), and the point functions return numpy arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _validate as validate
from .. import arrays
from .._validate import FloatArray
from .ops import act
from .pose import UncertainPoint, UncertainPose

__all__ = [
    "ellipse_points",
    "ellipsoid_points",
    "plot_position_ellipse",
    "plot_position_ellipsoid",
    "position",
]


def position(X: UncertainPose | UncertainPoint) -> UncertainPoint:
    """Return the parent-frame position of an uncertain pose (``act(X, 0)``) or the point."""
    if isinstance(X, UncertainPoint):
        return X
    if not isinstance(X, UncertainPose) or X.is_rotation:
        raise TypeError("X: expected an UncertainPose of poses (4, 4) or an UncertainPoint")
    return act(X, np.zeros(3))


def _host(x: Any) -> Any:
    """Return a torch/JAX array as a detached host numpy copy (plots are drawn on the host)."""
    return arrays.to_numpy(x) if arrays.is_foreign(x) else x


def _sqrt(cov: FloatArray) -> FloatArray:
    lam, Q = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, -1, -2)))
    return np.asarray(Q * np.sqrt(np.clip(lam, 0.0, None))[..., None, :], dtype=np.float64)


def ellipse_points(mean: Any, cov: Any, n_sigma: float = 2.0, num: int = 100) -> FloatArray:
    """``num`` points on the ellipse ``(x − m)ᵀ Σ⁻¹ (x − m) = n_sigma²`` (2-D), shape (num, 2).

    A singular ``Σ`` gives a degenerate (segment or point) ellipse, not an error.
    """
    m = validate.vector(_host(mean), "mean", 2)
    C = validate.covariance(_host(cov), "cov", 2)
    a = np.linspace(0.0, 2.0 * np.pi, num)
    circle = np.stack([np.cos(a), np.sin(a)], axis=-1)
    return np.asarray(m + n_sigma * circle @ _sqrt(C).T, dtype=np.float64)


def ellipsoid_points(
    mean: Any, cov: Any, n_sigma: float = 2.0, num: int = 24
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Surface grids ``(x, y, z)``, each ``(num, num)``, of the 3-D ``n_sigma`` ellipsoid."""
    m = validate.vector(_host(mean), "mean", 3)
    C = validate.covariance(_host(cov), "cov", 3)
    uu, vv = np.meshgrid(np.linspace(0, 2 * np.pi, num), np.linspace(0, np.pi, num))
    sphere = np.stack([np.cos(uu) * np.sin(vv), np.sin(uu) * np.sin(vv), np.cos(vv)], axis=-1)
    pts = m + n_sigma * sphere @ _sqrt(C).T
    return pts[..., 0], pts[..., 1], pts[..., 2]


def plot_position_ellipse(
    ax: Any,
    X: UncertainPose | UncertainPoint,
    dims: tuple[int, int] = (0, 1),
    n_sigma: float = 2.0,
    **kwargs: Any,
) -> list[Any]:
    """Draw the ``n_sigma`` position ellipse(s) of ``X`` projected on parent axes ``dims``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    X : UncertainPose or UncertainPoint
        Any batch shape: one ellipse per element.
    dims : (int, int)
        Parent-frame axes (0 = x, 1 = y, 2 = z) of the projection (a marginal of the 3×3).
    n_sigma : float
    **kwargs
        Passed to ``ax.plot`` (``color``, ``label``, ...; the label goes to the first ellipse).

    Returns
    -------
    list of matplotlib.lines.Line2D
    """
    pt = position(X)
    i, j = dims
    p = _host(pt.p).reshape(-1, 3)
    c = _host(pt.cov).reshape(-1, 3, 3)
    lines = []
    for k in range(p.shape[0]):
        e = ellipse_points(p[k, [i, j]], c[k][np.ix_([i, j], [i, j])], n_sigma)
        lines += ax.plot(e[:, 0], e[:, 1], **kwargs)
        kwargs.pop("label", None)
    return lines


def plot_position_ellipsoid(
    ax: Any, X: UncertainPose | UncertainPoint, n_sigma: float = 2.0, **kwargs: Any
) -> list[Any]:
    """Draw the ``n_sigma`` position ellipsoid(s) of ``X`` as wireframes on a 3-D axes."""
    pt = position(X)
    p = _host(pt.p).reshape(-1, 3)
    c = _host(pt.cov).reshape(-1, 3, 3)
    kwargs.setdefault("linewidth", 0.5)
    return [
        ax.plot_wireframe(*ellipsoid_points(p[k], c[k], n_sigma), **kwargs)
        for k in range(p.shape[0])
    ]
