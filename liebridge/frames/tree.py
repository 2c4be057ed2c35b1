"""A tree of named frames answering "``T_a_b`` at time ``t``", from a list of transforms.

Built from :class:`~liebridge.frames.Transform` edges, each either **static** (one transform) or
**time-stamped** (a batch ``(N, 4, 4)`` with ``stamps`` ``(N,)``, strictly increasing, the same
clock as the queries). :meth:`TransformTree.lookup` finds the chain of edges between the two
frames, evaluates each edge at ``t`` and composes them (inverting an edge walked against its
direction). Like tf2, the frames form a tree: an edge that would close a loop is rejected, and a
time outside an edge's stamps is an extrapolation error, never a silent clamp.

Interpolation between two stamps (``τ = (t − t0)/(t1 − t0)``) is named, never implied:

``"lerp_slerp"`` (tf2's ``TimeCache::interpolate``, geometry2 ``tf2/src/cache.cpp``):
    translation ``(1 − τ) t0 + τ t1``, rotation ``slerp(q0, q1, τ)`` (shortest arc), on the edge
    *as stored* (``T_parent_child``). Not invariant under inversion: interpolating ``T_b_a``
    instead of ``T_a_b`` gives a different translation whenever the rotation changes.
``"geodesic"``:
    ``T0·Exp(τ·Log(T0⁻¹ T1))``, the constant-twist (screw) motion; the same whichever direction
    the edge is stored in.

They agree when the rotation does not change between the stamps, and otherwise differ at second
order in the motion between stamps.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..lie import quaternion as quat
from ..lie import unchecked as U
from .transform import Transform, frame_name

__all__ = ["FrameLookupError", "Interpolation", "StampedTransform", "TransformTree"]

Interpolation = Literal["lerp_slerp", "geodesic"]
_INTERPOLATIONS = ("lerp_slerp", "geodesic")


class FrameLookupError(ValueError):
    """A lookup that cannot be answered: unknown frame, no chain, or a time outside the data."""


@dataclass(frozen=True, eq=False)
class StampedTransform:
    """A time series of one edge: ``transform`` batched ``(N, 4, 4)`` and ``stamps`` ``(N,)``.

    ``stamps`` are strictly increasing (seconds, or any clock shared with the queries).
    """

    transform: Transform
    stamps: FloatArray

    def __post_init__(self) -> None:
        tf = self.transform
        if not isinstance(tf, Transform):
            raise TypeError(f"transform: expected a Transform, got {type(tf).__name__}")
        s = validate.as_float_array(self.stamps, f"stamps ({tf.name})")
        validate.check_finite(s, f"stamps ({tf.name})")
        if s.ndim != 1 or tf.batch_shape != s.shape or s.size == 0:
            raise ValueError(
                f"stamps ({tf.name}): expected shape (N,) matching the transforms' batch "
                f"{tf.batch_shape}, got {s.shape}"
            )
        bad = np.flatnonzero(s[1:] <= s[:-1])  # not np.diff: ±1e308 apart overflows
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"stamps ({tf.name}): not strictly increasing at index {i + 1} "
                f"({s[i]!r} then {s[i + 1]!r})"
            )
        s = np.array(s)
        s.setflags(write=False)
        object.__setattr__(self, "stamps", s)


Edge = Transform | StampedTransform


def _interpolate(edge: StampedTransform, t: FloatArray, how: str) -> FloatArray:
    """``T_parent_child`` at times ``t`` (shape ``t.shape + (4, 4)``), no extrapolation."""
    s, T = edge.stamps, edge.transform.T
    lo, hi = float(s[0]), float(s[-1])
    out_of_range = (t < lo) | (t > hi)
    if out_of_range.any():
        bad = float(t[tuple(np.argwhere(out_of_range)[0])])
        raise FrameLookupError(
            f"{edge.transform.name}: time {bad!r} is outside its data [{lo!r}, {hi!r}] "
            "(extrapolation is not done)"
        )
    if s.size == 1:
        return np.broadcast_to(T[0], (*t.shape, 4, 4)).copy()
    i1 = np.clip(np.searchsorted(s, t, side="right"), 1, s.size - 1)
    i0 = i1 - 1
    # halves first: stamps ±1e308 apart overflow a difference (exact otherwise: powers of two)
    tau = (0.5 * t - 0.5 * s[i0]) / (0.5 * s[i1] - 0.5 * s[i0])
    T0, T1 = T[i0], T[i1]
    if how == "geodesic":
        xi = U.se3_log(U.se3_inverse(T0) @ T1) * tau[..., None]
        return np.asarray(T0 @ U.se3_exp(xi), dtype=np.float64)
    q0 = quat.from_matrix(T0[..., :3, :3], order="wxyz")
    q1 = quat.from_matrix(T1[..., :3, :3], order="wxyz")
    R = quat.to_matrix(quat.slerp(q0, q1, tau, order="wxyz"), order="wxyz")
    tr = (1.0 - tau)[..., None] * T0[..., :3, 3] + tau[..., None] * T1[..., :3, 3]
    return U.se3_assemble(R, tr)


class TransformTree:
    """Named frames connected by static and time-stamped transforms (a tree, as in tf2).

    Parameters
    ----------
    edges : iterable of Transform or StampedTransform
        Each relates two frames; a static one must be a single transform (no batch).

    Raises
    ------
    ValueError
        For an edge between a frame and itself, a second edge between two already connected
        frames (a loop: the message names the existing chain), or a batched static transform.
    """

    def __init__(self, edges: Iterable[Edge] = ()) -> None:
        self._edges: list[Edge] = []
        self._adj: dict[str, list[tuple[str, int, bool]]] = {}
        for e in edges:
            self.add(e)

    @staticmethod
    def _tf(edge: Edge) -> Transform:
        return edge.transform if isinstance(edge, StampedTransform) else edge

    def add(self, edge: Edge) -> None:
        """Add one edge (see the class docstring for what is rejected)."""
        if not isinstance(edge, (Transform, StampedTransform)):
            raise TypeError(
                f"edge: expected a Transform or StampedTransform, got {type(edge).__name__}"
            )
        tf = self._tf(edge)
        if isinstance(edge, Transform) and tf.batch_shape:
            raise ValueError(
                f"{tf.name}: a batch of {tf.batch_shape} transforms without stamps; wrap it in "
                "StampedTransform(transform, stamps) for a time series"
            )
        a, b = tf.target_frame, tf.source_frame
        if a == b:
            raise ValueError(f"{tf.name}: relates frame {a!r} to itself")
        if a in self._adj and b in self._adj:
            path = self._path(a, b)
            if path is not None:
                chain = " -> ".join([a] + [p[0] for p in path])
                raise ValueError(
                    f"{tf.name}: frames {a!r} and {b!r} are already connected ({chain}); "
                    "a second edge would make a loop (a TF tree has one chain between two frames)"
                )
        k = len(self._edges)
        self._edges.append(edge)
        self._adj.setdefault(a, []).append((b, k, True))  # walking a -> b uses T_a_b as stored
        self._adj.setdefault(b, []).append((a, k, False))

    @property
    def frames(self) -> tuple[str, ...]:
        """All frame names, sorted."""
        return tuple(sorted(self._adj))

    def _path(self, a: str, b: str) -> list[tuple[str, int, bool]] | None:
        """Return the steps ``(next_frame, edge, forward)`` from ``a`` to ``b`` (BFS), or None."""
        prev: dict[str, tuple[str, int, bool] | None] = {a: None}
        queue = deque([a])
        while queue:
            f = queue.popleft()
            if f == b:
                break
            for g, k, fwd in self._adj.get(f, []):
                if g not in prev:
                    prev[g] = (f, k, fwd)
                    queue.append(g)
        if b not in prev:
            return None
        steps: list[tuple[str, int, bool]] = []
        node = b
        while prev[node] is not None:
            f, k, fwd = prev[node]  # type: ignore[misc]
            steps.append((node, k, fwd))
            node = f
        return steps[::-1]

    def _component(self, a: str) -> list[str]:
        seen = {a}
        queue = deque([a])
        while queue:
            for g, _, _ in self._adj.get(queue.popleft(), []):
                if g not in seen:
                    seen.add(g)
                    queue.append(g)
        return sorted(seen)

    def chain(self, target_frame: str, source_frame: str) -> list[str]:
        """Return the frames walked from ``target_frame`` to ``source_frame`` (both included)."""
        self._check_frames(target_frame, source_frame)
        path = self._path(target_frame, source_frame)
        if path is None:
            raise self._disconnected(target_frame, source_frame)
        return [target_frame] + [p[0] for p in path]

    def _check_frames(self, target_frame: str, source_frame: str) -> None:
        for what, f in (("target_frame", target_frame), ("source_frame", source_frame)):
            frame_name(f, what)
            if f not in self._adj:
                known = ", ".join(self.frames) or "(none)"
                raise FrameLookupError(f"{what}: unknown frame {f!r} (known frames: {known})")

    def _disconnected(self, a: str, b: str) -> FrameLookupError:
        return FrameLookupError(
            f"cannot look up T_{a}_{b}: frames {a!r} and {b!r} are not connected "
            f"({a!r} is connected to {self._component(a)}, {b!r} to {self._component(b)})"
        )

    def lookup(
        self,
        target_frame: str,
        source_frame: str,
        t: Any = None,
        *,
        interpolation: Interpolation | str = "lerp_slerp",
    ) -> Transform:
        """``T_target_source`` at time(s) ``t``.

        Parameters
        ----------
        target_frame, source_frame : str
        t : float or array_like, optional
            Query time(s); required when the chain holds a time-stamped edge. An array gives a
            batched result ``t.shape + (4, 4)``.
        interpolation : {"lerp_slerp", "geodesic"}
            See the module docstring. Each time-stamped edge is interpolated as stored.

        Returns
        -------
        Transform
            ``T_target_source``. Covariances of static edges are carried through the chain
            (first order, independent edges, see :meth:`Transform.compose`); time-stamped
            edges count as exact (their covariances are not interpolated).

        Raises
        ------
        FrameLookupError (a ValueError)
            Unknown frame, frames not connected (naming both and what each is connected to), a
            missing ``t`` for a time-stamped chain, or ``t`` outside an edge's stamps.
        """
        if interpolation not in _INTERPOLATIONS:
            raise ValueError(
                f"interpolation: expected one of {', '.join(_INTERPOLATIONS)}, got "
                f"{interpolation!r}"
            )
        self._check_frames(target_frame, source_frame)
        path = self._path(target_frame, source_frame)
        if path is None:
            raise self._disconnected(target_frame, source_frame)
        tt: FloatArray | None = None
        if t is not None:
            tt = validate.as_float_array(t, "t")
            validate.check_finite(tt, "t")
        shape: tuple[int, ...] = () if tt is None else tuple(tt.shape)
        result: Transform | None = None
        for _, k, fwd in path:
            edge = self._edges[k]
            if isinstance(edge, StampedTransform):
                if tt is None:
                    raise FrameLookupError(
                        f"cannot look up T_{target_frame}_{source_frame} without a time: "
                        f"{edge.transform.name} is time-stamped"
                    )
                e = edge.transform
                step = Transform(
                    _interpolate(edge, tt, interpolation), e.target_frame, e.source_frame
                )
            else:
                step = edge
            step = step if fwd else step.inverse()
            result = step if result is None else result @ step
        if result is None:  # target_frame == source_frame
            return Transform(np.broadcast_to(np.eye(4), (*shape, 4, 4)), target_frame, source_frame)
        if result.batch_shape != shape:  # a static chain queried at an array of times
            cov = None if result.cov is None else np.broadcast_to(result.cov, (*shape, 6, 6))
            T = np.broadcast_to(result.T, (*shape, 4, 4))
            result = Transform(T, target_frame, source_frame, cov, result.convention)
        return result

    def stamps_of(self, target_frame: str, source_frame: str) -> Sequence[FloatArray]:
        """Return the stamps of the time-stamped edges on the chain (the times a lookup may use)."""
        path = self._path(target_frame, source_frame) if target_frame in self._adj else None
        if path is None:
            self._check_frames(target_frame, source_frame)
            raise self._disconnected(target_frame, source_frame)
        return [e.stamps for _, k, _ in path if isinstance(e := self._edges[k], StampedTransform)]
