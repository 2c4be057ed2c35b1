"""No public function returns non-finite output for finite input without saying why.

Property: every public function of :mod:`liebridge.lie` (each group of the record
:data:`liebridge.lie.GROUPS`), :mod:`liebridge.conventions` (the charts' maps and the
conversions), :mod:`liebridge.uncertain` and :mod:`liebridge.traj`, given finite but extreme
input — translations of 1e-300 m and 1e300 m, angles at and next to π, covariances of 1e-300 —
returns finite output or raises a ``ValueError`` that says why (an overflow, an underflow, a
degenerate input). Anything else (``inf``/``nan`` returned, ``LinAlgError``, ``OverflowError``,
``ZeroDivisionError``, ``IndexError``...) fails. hypothesis draws the inputs (derandomized in CI);
the extreme values are drawn often on purpose (``sampled_from`` next to ``floats``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import liebridge as lb
from liebridge import conventions as C
from liebridge import traj
from liebridge import uncertain as U
from liebridge.lie import GROUPS, so3

PI = math.pi
#: Finite values at the edges of float64 and of the charts: zero, subnormal-adjacent, the
#: half-turn and its neighbours, field scales, and magnitudes whose squares overflow.
EXTREMES = [
    0.0,
    1e-300,
    -1e-300,
    1e-12,
    -1e-12,
    1.0,
    PI,
    -PI,
    PI - 1e-12,
    math.nextafter(PI, 0.0),
    30.0,
    1e8,
    -1e154,
    1e155,
    1e200,
    -1e300,
    1e300,
]
SCALARS = st.one_of(
    st.sampled_from(EXTREMES),
    st.floats(-1e300, 1e300, allow_nan=False, allow_infinity=False),
)
TINY_OR_HUGE = st.sampled_from([1e-300, 1e-200, 1e-100, 1e-20, 1e-6, 1.0, 1e6, 1e100, 1e200])
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _finite_or_value_error(what: str, f: Callable[[], Any]) -> Any:
    """Call ``f``; return its output if every number in it is finite, None on ValueError.

    Warnings are not this property's concern (tests/test_real_files_misc.py holds those): they are
    silenced so that numpy's text does not fill the log.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            out = f()
        except ValueError as exc:
            assert str(exc).strip(), f"{what}: a ValueError without a message"
            return None
    for k, a in enumerate(_arrays(out)):
        assert np.isfinite(a).all(), f"{what}: non-finite output (part {k}) for finite input"
    return out


def _arrays(out: Any) -> list[np.ndarray]:
    if isinstance(out, np.ndarray | float | int | np.floating):
        return [np.asarray(out, dtype=np.float64)]
    if isinstance(out, tuple | list):
        return [a for o in out for a in _arrays(o)]
    if isinstance(out, U.UncertainPose):
        return _arrays((out.T, out.cov))
    if isinstance(out, U.UncertainPoint):
        return _arrays((out.p, out.cov))
    if hasattr(out, "__dataclass_fields__"):
        return _arrays(
            tuple(
                getattr(out, k)
                for k in out.__dataclass_fields__
                if isinstance(getattr(out, k), np.ndarray | float | int)
                and not isinstance(getattr(out, k), bool)
            )
        )
    return []


@st.composite
def rotvecs(draw: st.DrawFn) -> np.ndarray:
    """Rotation vectors with angle in [0, π]: extreme angles about random and axis directions."""
    axis = draw(
        st.one_of(
            st.sampled_from([np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), np.ones(3) / 3**0.5]),
            st.tuples(*[st.floats(-1, 1)] * 3)
            .map(np.array)
            .filter(lambda v: np.linalg.norm(v) > 0.1),
        )
    )
    angle = draw(st.one_of(st.sampled_from([0.0, 1e-300, 1e-12, PI - 1e-12, PI]), st.floats(0, PI)))
    return angle * axis / np.linalg.norm(axis)


@st.composite
def tangents(draw: st.DrawFn, group: str) -> np.ndarray:
    """A tangent of ``group``: rotation part a valid angle, every other entry extreme."""
    g = GROUPS[group]
    xi = np.array([draw(SCALARS) for _ in range(g.dim)])
    if g.rot is not None:
        n = g.rot.stop - g.rot.start
        xi[g.rot] = draw(rotvecs()) if n == 3 else [draw(st.floats(-PI, PI))]
    if g.scale is not None:  # a log-scale whose exponential float64 holds most of the time
        xi[g.scale] = draw(
            st.one_of(st.sampled_from([0.0, 1e-300, -700.0, 700.0, -800.0]), st.floats(-750, 750))
        )
    return xi


@st.composite
def poses(draw: st.DrawFn) -> np.ndarray:
    """A pose with an extreme translation and a rotation at or near a half turn (or not)."""
    T = np.eye(4)
    T[:3, :3] = so3.exp(draw(rotvecs()))
    T[:3, 3] = [draw(SCALARS) for _ in range(3)]
    return T


# ----------------------------------------------------------------------------- liebridge.lie


GROUP_PARAMS = list(GROUPS)


@pytest.mark.parametrize("group", GROUP_PARAMS)
# no shrinking: a failure would spend half a minute minimising its example
@settings(SETTINGS, phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(data=st.data())
def test_every_group_function_is_finite_or_says_why(group, data):
    g = GROUPS[group]
    xi = data.draw(tangents(group), "xi")
    for name in ("exp", "jr", "jl", "jr_inv", "jl_inv"):
        _finite_or_value_error(f"{group}.{name}", lambda name=name: getattr(g, name)(xi))
    X = _finite_or_value_error(f"{group}.exp", lambda: g.exp(xi))
    if X is None:
        return
    g.element(X, "exp(xi)")  # an element of the group, not only finite numbers
    Y = _finite_or_value_error(f"{group}.exp", lambda: g.exp(data.draw(tangents(group), "xi2")))
    n = g.matrix - len(g.cols)
    p = np.array([data.draw(SCALARS) for _ in range(n)])
    calls: dict[str, Callable[[], Any]] = {
        "log": lambda: g.log(X),
        "inverse": lambda: g.inverse(X),
        "adjoint": lambda: g.adjoint(X),
        "act": lambda: g.act(X, p),
    }
    if Y is not None:
        calls["compose"] = lambda: g.compose(X, Y)
        calls["interpolate"] = lambda: g.interpolate(X, Y, data.draw(st.floats(0, 1), "tau"))
    for name, f in calls.items():
        _finite_or_value_error(f"{group}.{name}", f)


# ----------------------------------------------------------------------------- conventions

SE3_PRESETS = [c.name for c in C.PRESETS]


@SETTINGS
@given(
    T=poses(),
    src=st.sampled_from(SE3_PRESETS),
    dst=st.sampled_from(SE3_PRESETS),
    sigma=TINY_OR_HUGE,
    d=st.tuples(*[SCALARS] * 6).map(np.array),
)
def test_every_convention_function_is_finite_or_says_why(T, src, dst, sigma, d):
    cov = sigma * np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    a = C.get(src)
    Y = _finite_or_value_error("retract", lambda: a.retract(T, 1e-3 * np.tanh(d)))
    calls: dict[str, Callable[[], Any]] = {
        "tangent_map": lambda: lb.tangent_map(T, src, dst),
        "convert_covariance": lambda: lb.convert_covariance(cov, T, src, dst),
        "convert_covariance unscented": lambda: lb.convert_covariance(
            cov, T, src, dst, method="unscented"
        ),
        "convert_information": lambda: lb.convert_information(cov, T, src, dst),
        "convert_jacobian": lambda: lb.convert_jacobian(sigma * np.eye(6), T, src, dst),
        "convert_tangent": lambda: lb.convert_tangent(d, T, src, dst),
        "convert_tangent first order": lambda: lb.convert_tangent(d, T, src, dst, exact=False),
        "Chart.retract": lambda: a.retract(T, d),
        "Chart.to_canonical": lambda: a.to_canonical(T),
        "Chart.from_canonical": lambda: a.from_canonical(T),
    }
    if Y is not None:
        calls["Chart.local"] = lambda: a.local(T, Y)
        calls["Chart.local_jacobian"] = lambda: a.local_jacobian(T, Y)
    for name, f in calls.items():
        _finite_or_value_error(f"{name} ({src} → {dst})", f)


# ----------------------------------------------------------------------------- uncertain


@SETTINGS
@given(
    A=poses(),
    B=poses(),
    conv=st.sampled_from(["gtsam", "ros", "barfoot", "sophus", "symforce"]),
    sa=TINY_OR_HUGE,
    sb=TINY_OR_HUGE,
    p=st.tuples(*[SCALARS] * 3).map(np.array),
)
def test_every_uncertain_function_is_finite_or_says_why(A, B, conv, sa, sb, p):
    ua = _finite_or_value_error("UncertainPose", lambda: U.UncertainPose(A, sa * np.eye(6), conv))
    ub = _finite_or_value_error("UncertainPose", lambda: U.UncertainPose(B, sb * np.eye(6), conv))
    if ua is None or ub is None:
        return
    calls: dict[str, Callable[[], Any]] = {
        "compose": lambda: U.compose(ua, ub),
        "compose unscented": lambda: U.compose(ua, ub, method="unscented"),
        "inverse": lambda: U.inverse(ua),
        "relative": lambda: U.relative(ua, ub),
        "transform": lambda: U.transform(ua, B),
        "act": lambda: U.act(ua, p),
        "fuse": lambda: U.fuse(ua, U.UncertainPose(A, sb * np.eye(6), conv)),
        "average": lambda: U.average([ua, U.UncertainPose(A, sb * np.eye(6), conv)]),
    }
    for name, f in calls.items():
        _finite_or_value_error(f"uncertain.{name} ({conv})", f)


# ----------------------------------------------------------------------------- traj


def _trajectory(unit: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 4.0, n)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = so3.exp(np.column_stack([0.3 * np.sin(s), 0.2 * np.cos(s), s]))
    T[:, :3, 3] = unit * np.column_stack([np.cos(s), np.sin(2 * s), 0.1 * s + rng.normal(size=n)])
    return T


@SETTINGS
@given(
    unit_ref=st.sampled_from([1e-300, 1e-150, 1e-3, 1.0, 30.0, 1e150, 1e200, 1e300]),
    unit_est=st.sampled_from([1e-300, 1e-150, 1e-3, 1.0, 30.0, 1e150, 1e200, 1e300]),
    sigma=TINY_OR_HUGE,
    seed=st.integers(0, 2**16),
    kind=st.sampled_from(["se3", "sim3", "4dof", "none"]),
    relation=st.sampled_from(list(traj.POSE_RELATIONS)),
)
def test_every_traj_function_is_finite_or_says_why(unit_ref, unit_est, sigma, seed, kind, relation):
    n = 12
    T_ref, T_est = _trajectory(unit_ref, n, seed), _trajectory(unit_est, n, seed + 1)
    cov = np.tile(sigma * np.eye(6), (n, 1, 1))
    t = 1.7e9 + 0.1 * np.arange(n)
    calls: dict[str, Callable[[], Any]] = {
        "ape": lambda: traj.ape(T_ref, T_est, relation),
        "rpe": lambda: traj.rpe(T_ref, T_est, 1, "frames", relation),
        "rpe by path length": lambda: traj.rpe(T_ref, T_est, 1.0, "m", relation),
        "kitti_segment_errors": lambda: traj.kitti_segment_errors(T_ref, T_est, [unit_ref]),
        "statistics": lambda: traj.statistics(traj.ape(T_ref, T_est)),
        "nees": lambda: traj.nees(T_ref, T_est, cov, "gtsam"),
        "align": lambda: traj.align(T_ref, T_est, kind).matrix,
        "synchronize": lambda: traj.synchronize(t, T_ref, t + 1e-3, T_est).T_est,
    }
    for name, f in calls.items():
        _finite_or_value_error(f"traj.{name}", f)
    A = _finite_or_value_error("traj.align", lambda: traj.align(T_ref, T_est, kind))
    if A is not None:
        _finite_or_value_error("Alignment.apply", lambda: A.apply(T_est))
        _finite_or_value_error(
            "Alignment.transform_covariance",
            lambda: A.transform_covariance(T_est, cov, "barfoot"),
        )


#: Presets of the other groups (SO(2), SE(2), Sim(3), SE₂(3)) and the whole-state charts, by group.
OTHER_PRESETS: dict[str, list[Any]] = {}
for _c in C.GROUP_PRESETS:
    OTHER_PRESETS.setdefault(_c.group, []).append(_c)
OTHER_PRESETS["se23"].append(C.get("mola"))


@pytest.mark.parametrize("group", sorted(OTHER_PRESETS))
@SETTINGS
@given(data=st.data())
def test_every_convention_function_of_other_groups_is_finite_or_says_why(group, data):
    g = GROUPS[group]
    a = data.draw(st.sampled_from(OTHER_PRESETS[group]), "src")
    b = data.draw(st.sampled_from(OTHER_PRESETS[group]), "dst")
    X = _finite_or_value_error(f"{group}.exp", lambda: g.exp(data.draw(tangents(group), "xi")))
    if X is None:
        return
    n = a.dim(X)
    sigma = data.draw(TINY_OR_HUGE, "sigma")
    cov = sigma * np.diag(np.arange(1.0, n + 1))
    d = np.array([data.draw(SCALARS) for _ in range(n)])
    calls: dict[str, Callable[[], Any]] = {
        "tangent_map": lambda: lb.tangent_map(X, a, b),
        "convert_covariance": lambda: lb.convert_covariance(cov, X, a, b),
        "convert_covariance unscented": lambda: lb.convert_covariance(
            cov, X, a, b, method="unscented"
        ),
        "convert_information": lambda: lb.convert_information(cov, X, a, b),
        "convert_tangent": lambda: lb.convert_tangent(d, X, a, b),
        "Chart.retract": lambda: a.retract(X, d),
        "Chart.to_canonical": lambda: a.to_canonical(X),
        "Chart.from_canonical": lambda: a.from_canonical(X),
    }
    Y = _finite_or_value_error("retract", lambda: a.retract(X, 1e-3 * np.tanh(d)))
    if Y is not None:
        calls["Chart.local"] = lambda: a.local(X, Y)
        calls["Chart.local_jacobian"] = lambda: a.local_jacobian(X, Y)
    for name, f in calls.items():
        _finite_or_value_error(f"{name} ({a.name} → {b.name})", f)


@pytest.mark.parametrize("lam", [-800.0, -1e200])
def test_sim3_record_exp_refuses_a_scale_that_underflows(lam):
    """The record's exp and the module's agree: a log-scale below −708.4 is a ValueError."""
    xi = np.array([0.1, 0.2, 0.3, 1.0, 2.0, 3.0, lam])
    with pytest.raises(ValueError, match="log-scale"):
        lb.lie.sim3.exp(xi)
    with pytest.raises(ValueError):
        GROUPS["sim3"].exp(xi)
