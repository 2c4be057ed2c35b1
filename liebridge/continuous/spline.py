"""Uniform cumulative B-splines on SE(3), with the conventions of basalt, kontiki and GTSAM named.

A spline of order ``k`` (``k = 4``: cubic) has knots ``T_0 … T_{N−1}`` (``T_world_body``), a start
time ``t0`` and a knot spacing ``dt``. Time ``t`` falls in segment ``s = ⌊(t − t0)/dt⌋`` at
``u = (t − t0)/dt − s`` and uses knots ``s … s+k−1``; the valid span is
``[t0, t0 + (N − k + 1)·dt]`` (basalt's ``minTimeNs``/``maxTimeNs``, kontiki's
``MinTime``/``MaxTime``). ``b̃_j(u)`` is the cumulative basis (``b̃_0 ≡ 1``).

``kind`` and ``form`` say what is interpolated:

``kind="coupled", form="product"`` (kontiki, Sommer et al.)
    ``T(t) = T_s · ∏_{j=1}^{k−1} Exp(b̃_j(u)·d_j)``, ``d_j = Log(T_{s+j−1}⁻¹·T_{s+j})`` on SE(3).
``kind="split", form="product"`` (basalt ``Se3Spline``)
    ``R(t) = R_s · ∏ Exp(b̃_j·Log(R_{s+j−1}ᵀR_{s+j}))`` on SO(3), and the world translation a plain
    B-spline of the knots' translations.
``kind="coupled", form="sum"`` (GTSAM 4.3 ``CumulativeSplineTrajectoryPose3``)
    ``T(t) = T_0 · Exp(Σ_{i=1}^{N−1} c_i(t)·ξ_i)``, ``ξ_i = Log(T_{i−1}⁻¹T_i)`` over *all* knots
    (GTSAM's default sample window), ``c_i`` the cumulative basis shifted to increment ``i``
    (1 for increments already passed). One exponential of a weighted sum: it equals the product
    form only when the increments commute, and it does not pass near the knots' product
    ``T_0·Exp(ξ_1)·Exp(ξ_2)…`` once the curve turns. It extrapolates outside the knots.

Velocities and accelerations name their frames (:class:`Velocity`, :class:`Acceleration`):
``omega_body`` (basalt's ``rotVelBody``), ``omega_world`` (kontiki's ``AngularVelocity``),
``v_world = ṗ`` (basalt's ``transVelWorld``), ``v_body = Rᵀṗ``; all per **second** whatever the
time unit. Tempting and false: ``omega_body`` and ``omega_world`` are interchangeable in an IMU
residual (they differ by ``R``), and GTSAM's ``sampleTrajectoryDerivative`` is a velocity (it
is ``u̇``, the rate of the accumulated tangent coordinate; the body twist is ``Jr(u)·u̇``).

Knot Jacobians (:meth:`Spline.jacobians`): ``∂T(t)/∂knot_m`` with the knot perturbed by the
convention's retraction (columns in its tangent at the knot) and ``T(t)`` measured in the same
convention at ``T(t)`` (rows).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg

from .. import _validate as validate
from .._validate import FloatArray
from ..conventions import GTSAM, SOPHUS, Convention, ConventionLike, convert_covariance
from ..conventions import unchecked as cu
from ..lie import unchecked as lu
from ._common import (
    NS_PER_S,
    TIME_UNITS,
    convention,
    cumulative_basis,
    same_unit,
    se3_ad,
    se3_jr,
    se3_jr_inv,
    time_array,
)

__all__ = [
    "BASALT",
    "GTSAM_CUMULATIVE",
    "KONTIKI",
    "SPLINE_PRESETS",
    "Acceleration",
    "Spline",
    "SplineJacobians",
    "SplinePreset",
    "Velocity",
    "convert_knot_covariance",
    "convert_velocity",
]

KINDS: tuple[str, ...] = ("coupled", "split")
FORMS: tuple[str, ...] = ("product", "sum")


@dataclass(frozen=True)
class SplinePreset:
    """A library's spline convention as data.

    Attributes
    ----------
    name : str
    kind : {"coupled", "split"}
    form : {"product", "sum"}
    time_unit : {"s", "ns"}
    omega_frame, v_frame : str
        Frames of the library's own angular and linear velocity (``"body"``/``"world"``; GTSAM:
        ``"none"``, its derivative is ``u̇``).
    knot_convention : Convention
        How the library perturbs a knot in its optimiser (for knot covariances).
    extrapolates : bool
        Whether the library evaluates outside its knots (else liebridge raises, as it asserts).
    source : str
        Where each fact comes from; ``V`` run here, ``S`` source-read (repo@commit path:line).
    """

    name: str
    kind: str
    form: str
    time_unit: str
    omega_frame: str
    v_frame: str
    knot_convention: Convention
    extrapolates: bool
    source: str


BASALT = SplinePreset(
    name="basalt",
    kind="split",
    form="product",
    time_unit="ns",
    omega_frame="body",
    v_frame="world",
    knot_convention=Convention(
        name="basalt_spline_knot",
        side="right",
        order="trans_first",
        chart="so3xr3_world",
        rotation="exp",
        quat_order="xyzw",
        source="S basalt-headers@a585db3 include/basalt/spline/ceres_local_param.hpp:74-90 "
        "(LieLocalParameterization<SO3>: knot ← knot·exp(δ)); rd_spline.h (world translation, "
        "additive); se3_spline.h d_pose_d_t translation first",
    ),
    extrapolates=False,
    source="S (source-read, not run: basalt does not install here) "
    "VladyslavUsenko/basalt-headers@a585db3 include/basalt/spline/se3_spline.h:51-57 (So3Spline + "
    "RdSpline<3>), :101-108 (int64 ns), :299-317 (rotVelBody, transVelWorld); "
    "so3_spline.h:119-121 (maxTimeNs = start + (N − k + 1)·dt − 1), :213-260 (segment "
    "s = st_ns / dt_ns, u = (st_ns % dt_ns)/dt_ns, product of Exps, asserts inside the knots)",
)
KONTIKI = SplinePreset(
    name="kontiki",
    kind="coupled",
    form="product",
    time_unit="s",
    omega_frame="world",
    v_frame="world",
    knot_convention=SOPHUS,
    extrapolates=False,
    source="S (source-read, not run: kontiki does not install here) hovren/kontiki@4c44edb "
    "cpplib/include/kontiki/trajectories/uniform_se3_spline_trajectory.h:161-164 (Log(P_a⁻¹P_b) "
    "on SE(3)), :23-30 (knot ← knot·exp(δ), Sophus (υ, ω)), :93-96 (ω̂ = Ṙ Rᵀ: world frame); "
    "spline_base.h:47-54 (MinTime = t0, MaxTime = t0 + (n − 3)·dt), :148-150 (s = (t − t0)/dt); "
    "uniform_se3_spline_trajectory.h:118-127 (throws unless 0 ≤ ⌊s⌋ ≤ N − 4: t = MaxTime "
    "itself is refused)",
)
GTSAM_CUMULATIVE = SplinePreset(
    name="gtsam_cumulative",
    kind="coupled",
    form="sum",
    time_unit="s",
    omega_frame="none",
    v_frame="none",
    knot_convention=GTSAM,
    extrapolates=True,
    source="V GTSAM 4.3.0 PyPI wheel CumulativeSplineTrajectoryPose3 (sampleTrajectory, "
    "sampleTrajectoryDerivative; tests/test_continuous_spline.py); S borglab/gtsam@30e6a8d "
    "gtsam/basis/CumulativeSplineTrajectory.h (cumulativePathSum: expmap(points.front(), "
    "Σ wᵢ·logmap(points[i−1], points[i])); default window = every control point, a window "
    "keeps knots ⌊ws·density⌋ − 3 … ⌈we·density⌉ (padFront: − 0 … + 3), its first the base; "
    "padFront=False: t0 = 3/density, True: t0 = 0)",
)
#: The spline presets, by name.
SPLINE_PRESETS: dict[str, SplinePreset] = {p.name: p for p in (BASALT, KONTIKI, GTSAM_CUMULATIVE)}


class Velocity(NamedTuple):
    """Angular and linear velocity, each in a named frame (per second).

    ``omega_world = R·omega_body``; ``v_world = ṗ`` (world translation's rate);
    ``v_body = Rᵀ·ṗ``. ``(omega_body, v_body)`` is the body twist ``T⁻¹Ṫ`` in (ω, v).
    """

    omega_body: FloatArray
    omega_world: FloatArray
    v_body: FloatArray
    v_world: FloatArray


class Acceleration(NamedTuple):
    """Angular and linear acceleration, each in a named frame (per second²).

    ``alpha_body = d/dt omega_body``, ``alpha_world = R·alpha_body`` (also ``d/dt omega_world``);
    ``a_world = p̈``; ``a_body = Rᵀ·p̈`` (what an accelerometer senses, less gravity) — *not*
    ``d/dt v_body``, which misses ``ω × v``.
    """

    alpha_body: FloatArray
    alpha_world: FloatArray
    a_body: FloatArray
    a_world: FloatArray


class SplineJacobians(NamedTuple):
    """``T(t)`` and its Jacobians with respect to the knots it depends on.

    ``J_T_knots[i, m] = ∂T(t_i)/∂knot[first_knot[i] + m]`` (6×6, rows at ``T(t_i)``, columns at
    the knot, both in the convention's tangent).
    """

    T: FloatArray
    J_T_knots: FloatArray
    first_knot: np.ndarray[Any, np.dtype[np.intp]]


def _so3_jr(w: FloatArray) -> FloatArray:
    return np.asarray(lu.so3_jl(-w), dtype=np.float64)


def _phi(order: int, y: FloatArray, derivative: int) -> FloatArray:
    """Cumulative basis as one function of ``y`` (0 below 0, 1 from ``k − 1`` on)."""
    k = order
    f = np.floor(y)
    inside = (y >= 0) & (y < k - 1)
    fi = np.clip(f, 0, k - 2).astype(np.intp)
    vals = cumulative_basis(k, np.where(inside, y - f, 0.0), derivative)
    m = (k - 1) - fi
    out = np.take_along_axis(vals, m[..., None], axis=-1)[..., 0]
    out = np.where(inside, out, 0.0)
    if derivative == 0:
        out = np.where(y >= k - 1, 1.0, out)
    return np.asarray(out, dtype=np.float64)


def _dexp_dir(u: FloatArray, du: FloatArray) -> FloatArray:
    """``d/dε Jr(u + ε·du)`` at 0, exactly (block-triangular matrix exponential)."""
    X = -se3_ad(u)
    E = -se3_ad(du)
    n = u.shape[0]
    W = np.zeros((n, 18, 18))
    W[:, :6, :6] = X
    W[:, 6:12, 6:12] = X
    W[:, :6, 6:12] = E
    W[:, 6:12, 12:] = np.eye(6)
    return np.asarray(scipy.linalg.expm(W)[:, :6, 12:], dtype=np.float64)


class Spline:
    """A uniform cumulative B-spline on SE(3).

    Parameters
    ----------
    knots_T : array_like, shape (N, 4, 4)
        Knots ``T_world_body`` (N ≥ order).
    t0 : float or int
        Start of the valid span (float seconds, or integer nanoseconds).
    dt : float or int
        Knot spacing, in the same unit as ``t0``.
    order : int
        Spline order ``k`` (4: cubic; 2: piecewise geodesic).
    kind : {"coupled", "split"}
        SE(3) or SO(3) × R³ (see the module docstring).
    time_unit : {"s", "ns"}, optional
        Checked against the type of ``t0`` and ``dt`` (float → s, int → ns); queries must use it.
    form : {"product", "sum"}
        Product of exponentials (Sommer et al., basalt, kontiki) or one exponential of a sum
        (GTSAM); ``"sum"`` is coupled only.
    extrapolate : bool
        Evaluate outside ``[t_min, t_max]`` (the product form continues its end segment; the sum
        form as GTSAM does). Default: raise.
    end_inclusive : bool
        Whether ``t_max`` itself is valid (default True: the last segment at ``u = 1``). basalt
        and kontiki exclude it (basalt's ``maxTimeNs`` is ``t_max − 1`` ns; kontiki's
        ``MaxTime()`` returns ``t_max`` but evaluating there throws), so their presets set False.
    preset : str, optional
        Name shown in messages and kept as :attr:`preset`.
    """

    def __init__(
        self,
        knots_T: Any,
        t0: Any,
        dt: Any,
        order: int = 4,
        kind: str = "coupled",
        time_unit: str | None = None,
        *,
        form: str = "product",
        extrapolate: bool = False,
        end_inclusive: bool = True,
        preset: str | None = None,
    ) -> None:
        self.kind = validate.option(kind, "kind", KINDS)
        self.form = validate.option(form, "form", FORMS)
        if self.form == "sum" and self.kind != "coupled":
            raise ValueError("form: 'sum' (GTSAM's) is implemented for kind='coupled' only")
        if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 2:
            raise ValueError(f"order: expected an integer ≥ 2, got {order!r}")
        self.order = int(order)
        K = validate.pose(knots_T, "knots_T")
        if K.ndim != 3:
            raise ValueError(f"knots_T: expected shape (N, 4, 4), got {K.shape}")
        need = 1 if self.form == "sum" else self.order
        if K.shape[0] < need:
            raise ValueError(
                f"knots_T: an order-{self.order} {self.form}-form spline needs at least {need} "
                f"knots, got {K.shape[0]}"
            )
        self.knots = np.array(K, dtype=np.float64)
        self.knots.setflags(write=False)
        a0, u0 = time_array(t0, "t0")
        a1, u1 = time_array(dt, "dt")
        same_unit(u0, "t0", u1, "dt")
        if time_unit is not None:
            same_unit(validate.option(time_unit, "time_unit", TIME_UNITS), "time_unit", u0, "t0")
        if a0.ndim or a1.ndim:
            raise ValueError(f"t0, dt: expected scalars, got shapes {a0.shape}, {a1.shape}")
        if not a1[()] > 0:
            raise ValueError(f"dt: expected a positive knot spacing, got {a1[()]!r}")
        self.time_unit = u0
        self.t0: int | float = a0.item()
        self.dt: int | float = a1.item()
        self.dt_s = float(self.dt) / NS_PER_S if u0 == "ns" else float(self.dt)
        self.extrapolate = bool(extrapolate)
        self.end_inclusive = bool(end_inclusive)
        self.preset = preset
        #: Index of ``knots[0]`` in the caller's knot list (GTSAM's sample windows use a slice);
        #: :meth:`jacobians` reports ``first_knot`` in the caller's indexing.
        self.knot_offset = 0
        inc = lu.se3_inverse(K[:-1]) @ K[1:]
        if self.kind == "coupled":
            self._inc = np.asarray(lu.se3_log(inc), dtype=np.float64)
        else:
            self._inc_w = np.asarray(lu.so3_log(inc[:, :3, :3]), dtype=np.float64)
            self._inc_p = np.asarray(K[1:, :3, 3] - K[:-1, :3, 3], dtype=np.float64)

    # ------------------------------------------------------------------ time
    @property
    def n_knots(self) -> int:
        """Number of knots ``N``."""
        return int(self.knots.shape[0])

    @property
    def t_min(self) -> Any:
        """Start of the valid span (the spline's unit)."""
        return self.t0

    @property
    def t_max(self) -> Any:
        """End of the valid span, ``t0 + (N − k + 1)·dt`` (basalt's last valid ns is one less)."""
        return self.t0 + (self.n_knots - self.order + 1) * self.dt

    def _sigma(
        self, t: Any
    ) -> tuple[FloatArray, FloatArray, np.ndarray[Any, Any], tuple[int, ...]]:
        """Query times → (σ, u, s) with the range check."""
        tq, unit = time_array(t, "t")
        same_unit(self.time_unit, f"the spline ({self.preset or 'this spline'})", unit, "t")
        shape = tq.shape
        tq = tq.reshape(-1)
        nseg = max(1, self.n_knots - self.order + 1)
        if self.time_unit == "ns":
            st = tq - np.int64(self.t0)
            s = st // np.int64(self.dt)
            u = (st % np.int64(self.dt)).astype(np.float64) / float(self.dt)
            sigma = s.astype(np.float64) + u
        else:
            sigma = (tq - float(self.t0)) / float(self.dt)
            s = np.floor(sigma)
            u = sigma - s
        out = (sigma < 0) | ((sigma > nseg) if self.end_inclusive else (sigma >= nseg))
        if out.any() and not self.extrapolate:
            k = int(np.flatnonzero(out)[0])
            end = "]" if self.end_inclusive else ") (the end excluded, as the library does)"
            raise ValueError(
                f"t: query {k} ({tq[k].item()!r} {self.time_unit}) is outside the spline's knots "
                f"[{self.t_min!r}, {self.t_max!r}{end} {self.time_unit} ({int(out.sum())} of "
                f"{tq.size} queries); {self.preset or 'this spline'} does not extrapolate "
                f"(extrapolate=True continues the end segments)"
            )
        s = np.asarray(s, dtype=np.intp)
        sc = np.clip(s, 0, nseg - 1)
        u = np.asarray(sigma - sc, dtype=np.float64)
        return sigma, u, sc, shape

    # ------------------------------------------------------------------ product form
    def _product(
        self, t: Any, derivs: int
    ) -> tuple[FloatArray, list[FloatArray], FloatArray, np.ndarray[Any, Any], tuple[int, ...]]:
        """T(t) and the k−1 factors A_j (and the basis with its derivatives)."""
        _, u, s, shape = self._sigma(t)
        k = self.order
        b = [cumulative_basis(k, u, d) for d in range(derivs + 1)]
        B = np.stack(b)  # (derivs+1, M, k)
        K0 = self.knots[s]
        if self.kind == "coupled":
            d = [self._inc[s + j - 1] for j in range(1, k)]
            A = [lu.se3_exp(B[0, :, j, None] * d[j - 1]) for j in range(1, k)]
            T = K0
            for Aj in A:
                T = T @ Aj
            return np.asarray(T), A, B, s, shape
        w = [self._inc_w[s + j - 1] for j in range(1, k)]
        A = [lu.so3_exp(B[0, :, j, None] * w[j - 1]) for j in range(1, k)]
        R = K0[:, :3, :3]
        for Aj in A:
            R = R @ Aj
        p = K0[:, :3, 3] + sum(B[0, :, j, None] * self._inc_p[s + j - 1] for j in range(1, k))
        return np.asarray(lu.se3_assemble(R, p)), A, B, s, shape

    # ------------------------------------------------------------------ sum form
    def _sum(self, t: Any, derivs: int) -> tuple[list[FloatArray], FloatArray, tuple[int, ...]]:
        sigma, _, _, shape = self._sigma(t)
        n = self.n_knots
        i = np.arange(1, n)
        y = sigma[:, None] - i[None, :] + (self.order - 1)
        us = []
        for d in range(derivs + 1):
            c = _phi(self.order, y, d) / self.dt_s**d
            us.append(np.asarray(c @ self._inc, dtype=np.float64))
        weights = _phi(self.order, y, 0)
        return us, weights, shape

    # ------------------------------------------------------------------ public
    def evaluate(self, t: Any) -> FloatArray:
        """``T_world_body(t)``, shape ``t.shape + (4, 4)``."""
        if self.form == "sum":
            (u,), _, shape = self._sum(t, 0)
            T = self.knots[0] @ lu.se3_exp(u)
        else:
            T, _, _, _, shape = self._product(t, 0)
        return np.asarray(T, dtype=np.float64).reshape((*shape, 4, 4))

    def tangent_rate(self, t: Any, derivative: int = 1) -> FloatArray:
        """Sum form only: ``u``, ``u̇`` or ``ü`` (GTSAM's ``sampleTrajectoryDerivative``).

        A rate of the accumulated tangent coordinate, in **no** frame; per second.
        """
        if self.form != "sum":
            raise ValueError("tangent_rate: defined for form='sum' (GTSAM's) splines only")
        if derivative not in (0, 1, 2):
            raise ValueError(f"derivative: expected 0, 1 or 2, got {derivative!r}")
        us, _, shape = self._sum(t, derivative)
        return us[derivative].reshape((*shape, 6))

    def _twist(self, t: Any, accel: bool) -> tuple[FloatArray, FloatArray, FloatArray, Any]:
        """Body twist (ω_b, v_b), its derivative, R, shape."""
        if self.form == "sum":
            us, _, shape = self._sum(t, 2 if accel else 1)
            u, du = us[0], us[1]
            T = self.knots[0] @ lu.se3_exp(u)
            Jr = se3_jr(u)
            tw = (Jr @ du[..., None])[..., 0]
            dtw = np.zeros_like(tw)
            if accel:
                dtw = (Jr @ us[2][..., None])[..., 0] + (_dexp_dir(u, du) @ du[..., None])[..., 0]
            return tw, dtw, T[:, :3, :3], shape
        k = self.order
        T, A, B, s, shape = self._product(t, 2 if accel else 1)
        m = T.shape[0]
        inv_dt = 1.0 / self.dt_s
        if self.kind == "coupled":
            tw = np.zeros((m, 6))
            dtw = np.zeros((m, 6))
            for j in range(1, k):
                dj = self._inc[s + j - 1]
                Ad = lu.se3_adjoint(lu.se3_inverse(A[j - 1]))
                bd = B[1, :, j, None] * dj * inv_dt
                if accel:
                    dtw = (
                        (Ad @ dtw[..., None])[..., 0]
                        - (se3_ad(bd) @ (Ad @ tw[..., None]))[..., 0]
                        + B[2, :, j, None] * dj * inv_dt**2
                    )
                tw = (Ad @ tw[..., None])[..., 0] + bd
            return tw, dtw, T[:, :3, :3], shape
        w_b = np.zeros((m, 3))
        dw_b = np.zeros((m, 3))
        for j in range(1, k):
            wj = self._inc_w[s + j - 1]
            At = np.swapaxes(A[j - 1], -1, -2)
            bd = B[1, :, j, None] * wj * inv_dt
            if accel:
                dw_b = (
                    (At @ dw_b[..., None])[..., 0]
                    - np.cross(bd, (At @ w_b[..., None])[..., 0])
                    + B[2, :, j, None] * wj * inv_dt**2
                )
            w_b = (At @ w_b[..., None])[..., 0] + bd
        R = T[:, :3, :3]
        Rt = np.swapaxes(R, -1, -2)
        dp = sum(B[1, :, j, None] * self._inc_p[s + j - 1] for j in range(1, k)) * inv_dt
        tw = np.concatenate([w_b, (Rt @ dp[..., None])[..., 0]], axis=-1)
        if not accel:
            return tw, np.zeros_like(tw), R, shape
        ddp = sum(B[2, :, j, None] * self._inc_p[s + j - 1] for j in range(1, k)) * inv_dt**2
        # d/dt (Rᵀ ṗ) = −ω_b × v_b + Rᵀ p̈
        dv_b = -np.cross(w_b, tw[:, 3:]) + (Rt @ ddp[..., None])[..., 0]
        return tw, np.concatenate([dw_b, dv_b], axis=-1), R, shape

    def velocity(self, t: Any) -> Velocity:
        """Angular and linear velocity at ``t``, in every named frame (per second)."""
        tw, _, R, shape = self._twist(t, False)
        w_b, v_b = tw[:, :3], tw[:, 3:]
        w_w = (R @ w_b[..., None])[..., 0]
        v_w = (R @ v_b[..., None])[..., 0]
        return Velocity(*(x.reshape((*shape, 3)) for x in (w_b, w_w, v_b, v_w)))

    def acceleration(self, t: Any) -> Acceleration:
        """Angular and linear acceleration at ``t``, in every named frame (per second²)."""
        tw, dtw, R, shape = self._twist(t, True)
        w_b, v_b = tw[:, :3], tw[:, 3:]
        al_b = dtw[:, :3]
        a_b = np.cross(w_b, v_b) + dtw[:, 3:]  # Rᵀp̈ = ω_b × v_b + v̇_b
        al_w = (R @ al_b[..., None])[..., 0]
        a_w = (R @ a_b[..., None])[..., 0]
        return Acceleration(*(x.reshape((*shape, 3)) for x in (al_b, al_w, a_b, a_w)))

    def jacobians(self, t: Any, convention: ConventionLike = "gtsam") -> SplineJacobians:
        """``T(t)`` and ``∂T(t)/∂knots`` in ``convention`` (see :class:`SplineJacobians`).

        Product form: the ``order`` knots of each query's segment; sum form (GTSAM's window):
        every knot.
        """
        conv = _convention(convention)
        T, J, first = self._jacobians_canonical(t)
        shape = T.shape[:-2]
        T = T.reshape(-1, 4, 4)
        J = J.reshape(-1, J.shape[-3], J.shape[-2], J.shape[-1])
        first = first.reshape(-1)
        if conv.name != "gtsam":
            idx = first[:, None] + np.arange(J.shape[1])[None, :]
            Kin = self.knots[idx]
            J = cu.from_canonical(conv, T)[:, None] @ J @ cu.to_canonical(conv, Kin)
        return SplineJacobians(
            T.reshape((*shape, 4, 4)),
            np.asarray(J, dtype=np.float64).reshape(shape + J.shape[1:]),
            first.reshape(shape) + self.knot_offset,
        )

    def _jacobians_canonical(self, t: Any) -> tuple[FloatArray, FloatArray, np.ndarray[Any, Any]]:
        k = self.order
        if self.form == "sum":
            (u,), c, shape = self._sum(t, 0)
            m, n = u.shape[0], self.n_knots
            T = self.knots[0] @ lu.se3_exp(u)
            Jr = se3_jr(u)
            inc = self._inc
            J = np.zeros((m, n, 6, 6))
            J[:, 0] = lu.se3_adjoint(lu.se3_exp(-u))
            jr_inv = se3_jr_inv(inc)  # (n−1, 6, 6)
            jl_inv = lu.se3_jl_inv(inc)
            for i in range(n - 1):  # increment i between knots i and i+1, weight c[:, i]
                ci = c[:, i, None, None]
                J[:, i + 1] += Jr @ (ci * jr_inv[i])
                J[:, i] -= Jr @ (ci * jl_inv[i])
            return (
                np.asarray(T).reshape((*shape, 4, 4)),
                J.reshape((*shape, n, 6, 6)),
                np.zeros(shape, dtype=np.intp),
            )
        T, A, B, s, shape = self._product(t, 0)
        m = T.shape[0]
        J = np.zeros((m, k, 6, 6))
        if self.kind == "coupled":
            # P_j = A_{j+1}…A_{k−1}; W_j = Ad(P_j⁻¹)·Jr(b̃_j d_j)·b̃_j
            P = np.broadcast_to(np.eye(4), (m, 4, 4))
            W: list[FloatArray] = [np.zeros(0)] * k
            for j in range(k - 1, 0, -1):
                dj = self._inc[s + j - 1]
                bj = B[0, :, j, None]
                AdP = lu.se3_adjoint(lu.se3_inverse(P))
                W[j] = AdP @ se3_jr(bj * dj) * bj[..., None]
                J[:, j] += W[j] @ se3_jr_inv(dj)
                J[:, j - 1] -= W[j] @ lu.se3_jl_inv(dj)
                P = A[j - 1] @ P
            J[:, 0] += lu.se3_adjoint(lu.se3_inverse(P))
        else:
            P3 = np.broadcast_to(np.eye(3), (m, 3, 3))
            for j in range(k - 1, 0, -1):
                wj = self._inc_w[s + j - 1]
                bj = B[0, :, j, None]
                Wj = np.swapaxes(P3, -1, -2) @ _so3_jr(bj * wj) * bj[..., None]
                J[:, j, :3, :3] += Wj @ lu.so3_jr_inv(wj)
                J[:, j - 1, :3, :3] -= Wj @ lu.so3_jl_inv(wj)
                P3 = A[j - 1] @ P3
            J[:, 0, :3, :3] += np.swapaxes(P3, -1, -2)
            Rt = np.swapaxes(T[:, :3, :3], -1, -2)
            bt = np.concatenate([B[0], np.zeros((m, 1))], axis=1)
            for j in range(k):
                beta = (bt[:, j] - bt[:, j + 1])[:, None, None]
                J[:, j, 3:, 3:] = beta * Rt @ self.knots[s + j][:, :3, :3]
        return T.reshape((*shape, 4, 4)), J.reshape((*shape, k, 6, 6)), s.reshape(shape)

    # ------------------------------------------------------------------ presets, fit
    @classmethod
    def from_preset(
        cls,
        name: str,
        knots_T: Any,
        t0: Any = None,
        dt: Any = None,
        *,
        density: float | None = None,
        pad_front: bool = False,
        window: tuple[float, float] = (0.0, -1.0),
    ) -> Spline:
        """Build a spline with a library's definitions (see :data:`SPLINE_PRESETS`).

        ``basalt``: ``t0``, ``dt`` integer nanoseconds (``start_t_ns``, ``dt_ns``); ``kontiki``:
        float seconds; ``gtsam_cumulative``: ``density`` (control points per unit time, GTSAM's
        constructor argument) and ``pad_front`` instead (``t0 = 3/density`` without front
        padding, ``0`` with it; ``dt = 1/density``) and GTSAM's sample ``window =
        (windowStart, windowEnd)`` (default ``(0, −1)``: every knot). A window keeps the knots
        ``start … end−1`` with ``start = max(0, ⌊windowStart·density⌋ − 3)`` (``− 0`` with front
        padding) and ``end = min(N, ⌈windowEnd·density⌉ + 0)`` (``+ 3`` with front padding; all
        knots when ``windowEnd < 0``); ``knots[start]`` becomes the base — measured against
        ``sampleTrajectory(t, windowStart, windowEnd)``.
        """
        p = SPLINE_PRESETS[validate.option(name, "name", tuple(SPLINE_PRESETS))]
        if p.name == "gtsam_cumulative":
            if t0 is not None or dt is not None:
                raise ValueError("gtsam_cumulative: give density (and pad_front), not t0/dt")
            dens = 1.0 if density is None else float(density)
            if not dens > 0:
                raise ValueError(f"density: expected a positive number, got {density!r}")
            t_start = 0.0 if pad_front else 3.0 / dens
            K = validate.pose(knots_T, "knots_T")
            if K.ndim != 3:
                raise ValueError(f"knots_T: expected shape (N, 4, 4), got {K.shape}")
            try:
                w0, w1 = (float(w) for w in window)
            except (TypeError, ValueError):
                raise ValueError(
                    f"window: expected (windowStart, windowEnd), got {window!r}"
                ) from None
            n = K.shape[0]
            lo = max(0, int(np.floor(w0 * dens)) - (0 if pad_front else 3))
            hi = n if w1 < 0 else min(n, int(np.ceil(w1 * dens)) + (3 if pad_front else 0))
            if lo >= hi:
                raise ValueError(
                    f"window: {window!r} holds no control point (knots {lo}…{hi - 1} of {n}); "
                    f"GTSAM raises here too"
                )
            sp = cls(
                K[lo:hi],
                t_start + lo / dens,
                1.0 / dens,
                4,
                "coupled",
                form="sum",
                extrapolate=True,
                preset=p.name,
            )
            sp.knot_offset = lo
            return sp
        if density is not None or window != (0.0, -1.0):
            raise ValueError(f"density, window: only for gtsam_cumulative, not {p.name}")
        if t0 is None or dt is None:
            raise ValueError(f"{p.name}: t0 and dt are required ({p.time_unit})")
        return cls(
            knots_T,
            t0,
            dt,
            4,
            p.kind,
            p.time_unit,
            form=p.form,
            end_inclusive=False,
            preset=p.name,
        )

    @classmethod
    def fit(
        cls,
        stamps: Any,
        T: Any,
        dt: Any,
        *,
        order: int = 4,
        kind: str = "coupled",
        t0: Any = None,
        max_iterations: int = 50,
        tol: float = 1e-10,
    ) -> Spline:
        """Least-squares product-form spline through timestamped poses.

        Minimises ``Σᵢ ‖Log(T_i⁻¹·S(t_i))‖²`` (GTSAM's right (ω, v) tangent, radians and metres
        weighted equally) over the knots by Levenberg–Marquardt with the analytic knot
        Jacobians (block-banded normal equations, ``scipy.linalg.solveh_banded``: linear in the
        number of knots); knots are initialised on the geodesic through the samples.

        Parameters
        ----------
        stamps : array_like, shape (M,)
            Strictly increasing (float seconds or integer nanoseconds).
        T : array_like, shape (M, 4, 4)
            ``T_world_body`` at ``stamps``.
        dt : float or int
            Knot spacing, the stamps' unit.
        order, kind : see :class:`Spline`.
        t0 : optional
            Start of the spline (default ``stamps[0]``); the knots cover the last stamp.

        Returns
        -------
        Spline
        """
        st, unit = time_array(stamps, "stamps")
        if st.ndim != 1 or st.size < 2:
            raise ValueError(f"stamps: expected shape (M,) with M ≥ 2, got {st.shape}")
        bad = np.flatnonzero(np.diff(st) <= 0)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"stamps: must be strictly increasing; index {i + 1} ({st[i + 1]!r}) follows "
                f"{st[i]!r} ({bad.size} of {st.size - 1} steps not increasing); sort the "
                f"samples (np.argsort) first"
            )
        Tm = validate.pose(T, "T")
        if Tm.shape != (st.size, 4, 4):
            raise ValueError(f"T: expected shape ({st.size}, 4, 4) to match stamps, got {Tm.shape}")
        dta, du = time_array(dt, "dt")
        same_unit(unit, "stamps", du, "dt")
        start = st[0] if t0 is None else time_array(t0, "t0")[0][()]
        if t0 is not None:
            same_unit(unit, "stamps", time_array(t0, "t0")[1], "t0")
        if start > st[0]:
            raise ValueError(f"t0: {start!r} is after the first stamp {st[0]!r}")
        dtv = dta[()]
        if not dtv > 0:
            raise ValueError(f"dt: expected a positive knot spacing, got {dtv!r}")
        span = float(st[-1] - start) / float(dtv)
        nseg = max(1, int(np.ceil(span - 1e-12)))
        n = nseg + order - 1
        # initial knots: the samples' geodesic at the knots' nominal times (clamped)
        rel = (st - start).astype(np.float64) / float(dtv)
        nominal = np.arange(n) - (order - 2) / 2.0
        nominal = np.clip(nominal, rel[0], rel[-1])
        j = np.clip(np.searchsorted(rel, nominal, side="right") - 1, 0, rel.size - 2)
        tau = (nominal - rel[j]) / (rel[j + 1] - rel[j])
        xi = lu.se3_log(lu.se3_inverse(Tm[j]) @ Tm[j + 1])
        knots = np.asarray(Tm[j] @ lu.se3_exp(tau[:, None] * xi), dtype=np.float64)
        spl = cls(knots, start, dtv, order, kind, extrapolate=True)
        Tinv = lu.se3_inverse(Tm)

        def cost_and_jac(sp: Spline) -> tuple[float, FloatArray, FloatArray, Any]:
            S, J, first = sp._jacobians_canonical(st)
            r = np.asarray(lu.se3_log(Tinv @ S), dtype=np.float64)
            Jr = se3_jr_inv(r)[:, None] @ J  # (M, k, 6, 6)
            return float(np.sum(r * r)), r, Jr, first

        lam = 1e-6
        cost, r, Jr, first = cost_and_jac(spl)
        upper = 6 * order - 1  # the normal equations are block-banded: `order` knots per sample
        six = np.arange(6)
        for _ in range(max_iterations):
            ab = np.zeros(
                (upper + 1, n * 6)
            )  # upper banded storage: ab[upper + i − j, j] = H[i, j]
            g = np.zeros(n * 6)
            for a in range(order):
                ia = (first + a)[:, None] * 6 + six[None, :]
                g += np.bincount(
                    ia.ravel(), np.einsum("mij,mi->mj", Jr[:, a], r).ravel(), minlength=n * 6
                )
                for b in range(a, order):
                    ib = (first + b)[:, None] * 6 + six[None, :]
                    blk = np.einsum("mki,mkj->mij", Jr[:, a], Jr[:, b])
                    rows = np.broadcast_to(ia[:, :, None], blk.shape)
                    cols = np.broadcast_to(ib[:, None, :], blk.shape)
                    keep = rows <= cols
                    flat = (upper + rows[keep] - cols[keep]) * (n * 6) + cols[keep]
                    ab += np.bincount(flat, blk[keep], minlength=ab.size).reshape(ab.shape)
            diag = ab[upper].copy()
            while True:
                ab[upper] = diag + lam * (diag + 1.0)
                step = -np.asarray(scipy.linalg.solveh_banded(ab, g), dtype=np.float64)
                trial = cls(
                    spl.knots @ lu.se3_exp(step.reshape(n, 6)),
                    start,
                    dtv,
                    order,
                    kind,
                    extrapolate=True,
                )
                c2, r2, J2, f2 = cost_and_jac(trial)
                if c2 <= cost:
                    lam = max(lam / 10.0, 1e-12)
                    break
                lam *= 10.0
                if lam > 1e12:
                    break
            if c2 > cost:
                break
            converged = cost - c2 <= tol * max(cost, 1e-300) or float(np.abs(step).max()) < 1e-12
            spl, cost, r, Jr, first = trial, c2, r2, J2, f2
            if converged:
                break
        return cls(spl.knots, start, dtv, order, kind)


def _convention(c: ConventionLike) -> Convention:
    return convention(c)


def _frames(x: Any, name: str) -> tuple[str, str]:
    if isinstance(x, str):
        p = SPLINE_PRESETS.get(x.strip().lower())
        if p is None:
            raise ValueError(
                f"{name}: expected a spline preset or (omega_frame, v_frame), got {x!r}"
            )
        if p.omega_frame == "none":
            raise ValueError(
                f"{name}: {p.name}'s derivative is u̇ (no frame); take Spline.velocity(t) "
                f"of the gtsam_cumulative spline, which is the body twist Jr(u)·u̇"
            )
        return p.omega_frame, p.v_frame
    try:
        a, b = x
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a preset name or (omega_frame, v_frame)") from None
    frames = ("body", "world")
    return validate.option(a, name, frames), validate.option(b, name, frames)


def convert_velocity(
    omega: Any, v: Any, R_world_body: Any, src: Any, dst: Any
) -> tuple[FloatArray, FloatArray]:
    """Re-express ``(omega, v)`` between the velocity frames of two presets.

    Parameters
    ----------
    omega, v : array_like, shape (..., 3)
    R_world_body : array_like, shape (..., 3, 3)
        The body's orientation at that time.
    src, dst : str or (str, str)
        A preset name (``"basalt"``: body ω, world v; ``"kontiki"``: world ω, world v) or a pair
        ``(omega_frame, v_frame)`` of ``"body"``/``"world"``.

    Returns
    -------
    (omega, v) in ``dst``'s frames.
    """
    fs, fd = _frames(src, "src"), _frames(dst, "dst")
    w = validate.as_float_array(omega, "omega")
    vv = validate.as_float_array(v, "v")
    R = validate.rotation(R_world_body, "R_world_body")
    out = []
    for x, a, b in ((w, fs[0], fd[0]), (vv, fs[1], fd[1])):
        if a == b:
            out.append(np.array(x))
        elif a == "body":
            out.append((R @ x[..., None])[..., 0])
        else:
            out.append((np.swapaxes(R, -1, -2) @ x[..., None])[..., 0])
    return out[0], out[1]


def convert_knot_covariance(cov: Any, knot_T: Any, src: Any, dst: Any) -> FloatArray:
    """Move a knot's 6×6 covariance between two presets' knot perturbations.

    ``src``/``dst``: a spline preset name (its :attr:`SplinePreset.knot_convention`) or any SE(3)
    convention. Same formula as :func:`liebridge.convert_covariance` (exact: the maps are linear).
    """

    def knot_conv(x: Any) -> Convention:
        if isinstance(x, str) and x.strip().lower() in SPLINE_PRESETS:
            return SPLINE_PRESETS[x.strip().lower()].knot_convention
        return convention(x)

    return convert_covariance(cov, knot_T, knot_conv(src), knot_conv(dst))
