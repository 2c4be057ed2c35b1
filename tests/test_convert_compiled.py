"""The compiled validate-and-convert pass (``liebridge/conventions/_convert_ext.c``) against numpy.

Every public conversion it serves (``tangent_map``, ``convert_covariance``,
``convert_information``, ``convert_jacobian``) is run twice: as it is (the compiled pass where it
is built) and with the module's ``_convert_ext`` set to None (the numpy path, the reference).
Results agree to rounding over all SE(3) preset pairs, batch shapes and edge-case poses; bad input
gets the same error text either way; nothing is mutated. Independently of both paths, the
gtsam → barfoot and gtsam → ros maps are checked against GTSAM's own ``Pose3.AdjointMap``.
Where the extension is not built, the comparisons compare numpy with itself and still pass; the
CI run (``LIEBRIDGE_REQUIRE_COMPILED=1``) makes a missing build a failure.
"""

from __future__ import annotations

import importlib
import itertools
import os
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from _strategies import EDGE_ANGLES, PI_AXES, assemble, pi_rotations, poses, rotation_from_rotvec
from hypothesis import given, settings
from hypothesis import strategies as st

import liebridge as lb
from liebridge.conventions import registry

cv = importlib.import_module("liebridge.conventions.convert")

SE3_PRESETS = registry.names("se3")
#: Pairs that reach the compiled pass (all but Euler-angle presets, which the kernel leaves to
#: numpy); every SE(3) pair is compared all the same.
PAIRS = list(itertools.product(SE3_PRESETS, SE3_PRESETS))
P_SWAP = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])


def _numpy(fn: Callable[[], Any]) -> Any:
    """``fn()`` on the numpy path (the compiled pass switched off for this call only)."""
    ext = cv._convert_ext
    cv._convert_ext = None
    try:
        return fn()
    finally:
        cv._convert_ext = ext


def _both(fn: Callable[[], Any]) -> tuple[Any, Any]:
    return fn(), _numpy(fn)


def _errors(fn: Callable[[], Any]) -> tuple[str, str]:
    """The error text of ``fn()`` on both paths (each must raise)."""
    msgs = []
    for run in (fn, lambda: _numpy(fn)):
        with pytest.raises((ValueError, TypeError)) as exc:
            run()
        msgs.append(f"{type(exc.value).__name__}: {exc.value}")
    return msgs[0], msgs[1]


def _close(a: np.ndarray, b: np.ndarray, rtol: float = 1e-13) -> None:
    assert a.shape == b.shape and a.dtype == b.dtype == np.float64
    scale = max(float(np.abs(b).max(initial=0.0)), 1e-300)
    assert float(np.abs(a - b).max(initial=0.0)) <= rtol * scale


def _edge_poses() -> np.ndarray:
    """θ = 0, tiny, near and exactly π about several axes, with 0, 1 m and 30 m translations."""
    rng = np.random.default_rng(7)
    Rs = [rotation_from_rotvec(a * np.array([0.6, 0.0, 0.8])) for a in EDGE_ANGLES]
    Rs += list(pi_rotations())
    Rs += [rotation_from_rotvec((np.pi - 1e-9) * np.array(u)) for u in PI_AXES[:3]]
    out = []
    for R in Rs:
        for norm in (0.0, 1.0, 30.0):
            t = rng.normal(size=3)
            out.append(assemble(R, norm * t / np.linalg.norm(t)))
    return np.array(out)


def _covs(n: int, dim: int = 6, seed: int = 1) -> np.ndarray:
    A = np.random.default_rng(seed).normal(size=(n, dim, dim))
    return np.asarray(A @ A.swapaxes(-1, -2) + 0.1 * np.eye(dim))


EDGE_X = _edge_poses()
EDGE_C = _covs(len(EDGE_X))


def test_compiled_pass_is_built_where_ci_requires_it() -> None:
    """.ci/run sets LIEBRIDGE_REQUIRE_COMPILED=1: there a silently skipped build is a failure."""
    if os.environ.get("LIEBRIDGE_REQUIRE_COMPILED") == "1":
        assert cv.COMPILED


requires_compiled = pytest.mark.skipif(not cv.COMPILED, reason="compiled pass not built")


@requires_compiled
def test_the_compiled_pass_is_the_one_taken() -> None:
    """Valid float64 input is converted in C (-1), not silently sent to numpy."""
    assert cv._convert_ext is not None
    plan = cv._compiled_plan("gtsam", "barfoot")
    assert plan is not None
    out = np.empty(EDGE_C.shape)
    assert cv._convert_ext.transform(1, plan, EDGE_X, EDGE_C, out) == -1
    _close(out, _numpy(lambda: lb.convert_covariance(EDGE_C, EDGE_X, "gtsam", "barfoot")))
    # Euler-angle presets are left to numpy
    assert cv._compiled_plan("gtsam", registry.get("gtsam")) is not None
    assert cv._compiled_plan("gtsam", "gtsam_pose2") is None


@pytest.mark.parametrize(("src", "dst"), PAIRS)
def test_all_preset_pairs_agree_with_numpy_at_edge_poses(src: str, dst: str) -> None:
    X, C = EDGE_X, EDGE_C
    J = np.random.default_rng(3).normal(size=(len(X), 6, 6))
    for fn in (
        lambda: lb.tangent_map(X, src, dst),
        lambda: lb.convert_covariance(C, X, src, dst),
        lambda: lb.convert_information(C, X, src, dst),
        lambda: lb.convert_jacobian(J, X, src, dst, at_output=X[::-1].copy()),
    ):
        _close(*_both(fn))


@pytest.mark.parametrize("shape", [(), (1,), (7,), (2, 3), (0,)])
@pytest.mark.parametrize(
    ("src", "dst"),
    [
        ("gtsam", "barfoot"),
        ("gtsam", "ros"),
        ("ros", "ceres_pose"),
        ("barfoot", "pytransform3d_global"),
    ],
)
def test_batch_shapes(shape: tuple[int, ...], src: str, dst: str) -> None:
    m = int(np.prod(shape))
    X = EDGE_X[:m].reshape((*shape, 4, 4))
    C = EDGE_C[:m].reshape((*shape, 6, 6))
    Jin = np.random.default_rng(4).normal(size=(*shape, 2, 6))
    Jout = np.random.default_rng(5).normal(size=(*shape, 6, 4))
    for fn in (
        lambda: lb.tangent_map(X, src, dst),
        lambda: lb.convert_covariance(C, X, src, dst),
        lambda: lb.convert_information(C, X, src, dst),
        lambda: lb.convert_jacobian(Jin, X, src, dst),
        lambda: lb.convert_jacobian(Jout, None, src, dst, at_output=X),
    ):
        a, b = _both(fn)
        assert a.shape == b.shape
        _close(a, b)


@pytest.mark.parametrize(
    ("src", "dst"), [("gtsam", "barfoot"), ("sophus", "ceres_pose"), ("ros", "g2o_expmap")]
)
def test_rotations_with_pose_conventions(src: str, dst: str) -> None:
    """A rotation ``(..., 3, 3)`` with SE(3) conventions: the 3×3 rotation-tangent map."""
    R = EDGE_X[:, :3, :3].copy()
    C = EDGE_C[:, :3, :3].copy()
    for fn in (
        lambda: lb.tangent_map(R, src, dst),
        lambda: lb.convert_covariance(C, R, src, dst),
        lambda: lb.convert_information(C, R, src, dst),
        lambda: lb.convert_jacobian(C, R, src, dst, at_output=R),
    ):
        _close(*_both(fn))


@pytest.mark.parametrize("dst", ["barfoot", "ros"])
def test_against_gtsam_adjoint(dst: str) -> None:
    """Independent reference: GTSAM's ``Pose3.AdjointMap`` (ξ_gtsam = (ω, v), right) per pose.

    barfoot (left, (ρ, φ)): ``δ = P·Ad_X ξ``; ros (left, (ρ, φ), translation perturbed in the
    world frame and rotation on the left): ``δ = P·diag(R, R) ξ``.
    """
    gtsam = pytest.importorskip("gtsam")
    X, C = EDGE_X, EDGE_C
    M = []
    for T in X:
        R = T[:3, :3]
        if dst == "barfoot":
            M.append(P_SWAP @ gtsam.Pose3(T).AdjointMap())
        else:
            M.append(P_SWAP @ np.block([[R, np.zeros((3, 3))], [np.zeros((3, 3)), R]]))
    Mr = np.array(M)
    _close(lb.tangent_map(X, "gtsam", dst), Mr, 1e-14)
    ref = Mr @ C @ Mr.swapaxes(-1, -2)
    _close(lb.convert_covariance(C, X, "gtsam", dst), ref, 1e-13)


@settings(max_examples=30, deadline=None)
@given(st.lists(poses(), min_size=1, max_size=5), st.sampled_from(PAIRS))
def test_random_poses_agree_with_numpy(Xs: list[np.ndarray], pair: tuple[str, str]) -> None:
    X = np.array(Xs)
    C = _covs(len(X), seed=len(X))
    src, dst = pair
    _close(*_both(lambda: lb.convert_covariance(C, X, src, dst)))
    _close(*_both(lambda: lb.convert_information(C, X, src, dst)))


def test_outputs_are_symmetric_and_new_arrays() -> None:
    out = lb.convert_covariance(EDGE_C, EDGE_X, "gtsam", "barfoot")
    if cv.COMPILED:  # the kernel mirrors the upper triangle
        np.testing.assert_array_equal(out, out.swapaxes(-1, -2))
    assert not np.shares_memory(out, EDGE_C) and out.flags.writeable


def test_inputs_are_not_mutated() -> None:
    X, C = EDGE_X.copy(), EDGE_C.copy()
    J = np.random.default_rng(6).normal(size=C.shape)
    Xb, Cb, Jb = X.tobytes(), C.tobytes(), J.tobytes()
    lb.tangent_map(X, "gtsam", "barfoot")
    lb.convert_covariance(C, X, "gtsam", "barfoot")
    lb.convert_information(C, X, "gtsam", "ros")
    lb.convert_jacobian(J, X, "gtsam", "ros", at_output=X)
    assert (X.tobytes(), C.tobytes(), J.tobytes()) == (Xb, Cb, Jb)
    Xr = np.require(X, requirements=["C"])
    Xr.flags.writeable = False  # read-only input is fine
    Cr = C.copy()
    Cr.flags.writeable = False
    _close(*_both(lambda: lb.convert_covariance(Cr, Xr, "gtsam", "barfoot")))


def test_inputs_the_kernel_does_not_take_still_work() -> None:
    """Strided views, float32, lists and broadcasting batch shapes go through numpy."""
    X, C = EDGE_X[:6], EDGE_C[:6]
    ref = _numpy(lambda: lb.convert_covariance(C, X, "gtsam", "barfoot"))
    Xs = np.stack([X, X], axis=1)[:, 0]  # a strided view of X
    _close(lb.convert_covariance(C, Xs, "gtsam", "barfoot"), ref)
    C32 = C.astype(np.float32)
    _close(*_both(lambda: lb.convert_covariance(C32, X, "gtsam", "barfoot")))
    _close(lb.convert_covariance(C.tolist(), X.tolist(), "gtsam", "barfoot"), ref)
    one = lb.convert_covariance(C[0], X, "gtsam", "barfoot")  # broadcast: one cov, 6 poses
    _close(one, _numpy(lambda: lb.convert_covariance(C[0], X, "gtsam", "barfoot")))
    _close(lb.convert_covariance(C, X, registry.get("gtsam"), registry.get("barfoot")), ref)


def _bad_pose_cases() -> list[tuple[str, np.ndarray, np.ndarray]]:
    X, C = EDGE_X[:5].copy(), EDGE_C[:5].copy()
    cases = []
    Xa = X.copy()
    Xa[3, :3, :3] *= 1.001  # not a rotation at index 3
    cases.append(("not a rotation", Xa, C))
    Xb = X.copy()
    Xb[2, :3, :3] = -Xb[2, :3, :3]  # a reflection
    cases.append(("reflection", Xb, C))
    Xc = X.copy()
    Xc[1, 3, 0] = 1e-3  # bottom row
    cases.append(("bottom row", Xc, C))
    Xd = X.copy()
    Xd[4, 1, 3] = np.nan
    cases.append(("NaN translation", Xd, C))
    Xe = X.copy()
    Xe[0, 0, 0] = np.inf
    cases.append(("Inf rotation", Xe, C))
    Ca = C.copy()
    Ca[2, 0, 5] += 1e-3  # asymmetric beyond tolerance
    cases.append(("asymmetric", X, Ca))
    Cb = C.copy()
    Cb[1] = -np.eye(6)  # not PSD
    cases.append(("not PSD", X, Cb))
    Cc = C.copy()
    Cc[3, 2, 2] = np.nan
    cases.append(("NaN cov", X, Cc))
    Cd = C.copy()
    Cd[0] *= 1e300  # the result overflows
    Xf = X.copy()
    Xf[0, :3, 3] = 1e10
    cases.append(("overflow", Xf, Cd))
    return cases


@pytest.mark.parametrize(
    ("what", "X", "C"), _bad_pose_cases(), ids=lambda v: v if isinstance(v, str) else ""
)
def test_bad_input_gives_the_same_error(what: str, X: np.ndarray, C: np.ndarray) -> None:
    J = np.ones((5, 2, 6))
    calls: list[Callable[[], Any]] = [
        lambda: lb.convert_covariance(C, X, "gtsam", "barfoot"),
        lambda: lb.convert_information(C, X, "gtsam", "ros"),
        lambda: lb.convert_covariance(C[1], X[1], "gtsam", "barfoot"),  # one pose
        lambda: lb.convert_covariance(C[1:4].reshape(3, 1, 6, 6), X[1:4, None], "gtsam", "ros"),
    ]
    if what not in ("asymmetric", "not PSD", "NaN cov", "overflow"):  # X itself is bad
        calls += [
            lambda: lb.tangent_map(X, "gtsam", "barfoot"),
            lambda: lb.convert_jacobian(J, X, "gtsam", "ros"),
            lambda: lb.convert_jacobian(J.swapaxes(-1, -2), None, "gtsam", "ros", at_output=X),
        ]
    raised = 0
    for fn in calls:
        if _raises(fn):
            compiled, numpy = _errors(fn)
            assert compiled == numpy
            raised += 1
        else:  # the single pose may be a good one
            _close(*_both(fn))
    assert raised >= 1


def _raises(fn: Callable[[], Any]) -> bool:
    try:
        _numpy(fn)
    except (ValueError, TypeError):
        return True
    return False


def test_bad_input_messages_name_index_and_size() -> None:
    """The compiled path's failures are explained by the numpy checks (spot checks of text)."""
    cases = {c[0]: c for c in _bad_pose_cases()}
    _, X, C = cases["not a rotation"]
    with pytest.raises(
        ValueError, match=r"X: not a rotation at batch index \(3,\): max\|RᵀR − I\|"
    ):
        lb.convert_covariance(C, X, "gtsam", "barfoot")
    _, X, C = cases["not PSD"]
    with pytest.raises(ValueError, match=r"cov: not positive semi-definite at batch index \(1,\)"):
        lb.convert_covariance(C, X, "gtsam", "barfoot")
    with pytest.raises(ValueError, match=r"info: not positive semi-definite at batch index \(1,\)"):
        lb.convert_information(C, X, "gtsam", "barfoot")
    _, X, C = cases["asymmetric"]
    with pytest.raises(ValueError, match=r"cov: not symmetric at batch index \(2,\)"):
        lb.convert_covariance(C, X, "gtsam", "barfoot")
    _, X, C = cases["overflow"]
    with pytest.raises(ValueError, match="convert_covariance: the result overflows float64"):
        lb.convert_covariance(C, X, "gtsam", "barfoot")
    with pytest.raises(ValueError, match=r"unknown name 'gtsamm'"):
        lb.convert_covariance(C, X, "gtsamm", "barfoot")


OVERFLOW_CALLS = {
    "convert_covariance": lambda C, X: lb.convert_covariance(C, X, "gtsam", "barfoot"),
    "convert_information": lambda C, X: lb.convert_information(C, X, "gtsam", "barfoot"),
    "convert_jacobian": lambda C, X: lb.convert_jacobian(C, X, "gtsam", "barfoot"),
    "convert_jacobian_out": lambda C, X: lb.convert_jacobian(
        C, None, "gtsam", "barfoot", at_output=X
    ),
}


@pytest.mark.parametrize("name", sorted(OVERFLOW_CALLS))
def test_overflow_is_one_error_without_a_runtime_warning(name: str) -> None:
    """Regression: the numpy path warned 'overflow encountered in matmul' before its error."""
    _, X, C = {c[0]: c for c in _bad_pose_cases()}["overflow"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"convert_\w+: the result overflows float64"):
            OVERFLOW_CALLS[name](C, X)


def test_valid_input_the_certificate_does_not_accept_is_converted() -> None:
    """Singular PSD covariances, asymmetry within tolerance and rotations off by < 1e-6 pass
    the exact checks: the numpy path converts them, with the same result either way."""
    X, C = EDGE_X[:4].copy(), EDGE_C[:4].copy()
    C[1] = np.diag([1.0, 0.0, 2.0, 0.0, 3.0, 0.0])  # singular: Cholesky fails, eigvalsh accepts
    C[2, 0, 1] += 1e-14 * np.abs(C[2]).max()  # asymmetric within COVARIANCE_TOL
    X[3, :3, :3] *= 1.0 + 2e-7  # within ROTATION_TOL
    for fn in (
        lambda: lb.convert_covariance(C, X, "gtsam", "barfoot"),
        lambda: lb.convert_information(C, X, "gtsam", "ros"),
        lambda: lb.tangent_map(X, "gtsam", "barfoot"),
    ):
        _close(*_both(fn))
