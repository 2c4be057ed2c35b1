"""Deskew: KISS-ICP's own preprocessor as oracle, CT-ICP's formula, references, units, Jacobians."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from liebridge.check import numerical_jacobian
from liebridge.continuous import deskew
from liebridge.conventions import PRESETS, get
from liebridge.lie import se3

SE3_PRESETS = [c.name for c in PRESETS if c.group == "se3"]


def _scan(n: int = 200, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) * 10.0
    stamps = rng.uniform(0.0, 0.1, size=n)  # unsorted, as real scans are
    T_begin = se3.exp(rng.normal(size=6))
    T_end = T_begin @ se3.exp(np.array([0.05, -0.02, 0.3, 1.5, 0.2, -0.1]))
    return pts, stamps, T_begin, T_end


def test_kiss_icp_model_equals_kiss_icps_own_deskew() -> None:
    kiss = pytest.importorskip("kiss_icp.preprocess")
    pts, stamps, T_begin, T_end = _scan(500)
    delta = np.linalg.inv(T_begin) @ T_end  # KISS-ICP's relative_motion (constant velocity)
    pre = kiss.Preprocessor(max_range=1e9, min_range=0.0, deskew=True, max_num_threads=1)
    theirs = pre.preprocess(pts, stamps, delta)
    ours = deskew(pts, stamps, T_begin, T_end, model="kiss_icp").points
    assert theirs.shape == ours.shape
    np.testing.assert_allclose(ours, theirs, atol=1e-9)
    # and the wrong reference (scan start) is far from it
    wrong = deskew(pts, stamps, T_begin, T_end, "generic", reference="begin").points
    assert np.abs(wrong - theirs).max() > 0.1


def test_ct_icp_model_is_split_to_the_end_frame() -> None:
    """CT-ICP: SLERP/LERP between begin and end, then into the end pose's frame (an independent
    formula: scipy's Slerp on quaternions)."""
    pts, stamps, T_begin, T_end = _scan()
    alpha = (stamps - stamps.min()) / (stamps.max() - stamps.min())
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T_begin[:3, :3], T_end[:3, :3]])))
    R = slerp(alpha).as_matrix()
    t = (1 - alpha)[:, None] * T_begin[:3, 3] + alpha[:, None] * T_end[:3, 3]
    world = np.einsum("nij,nj->ni", R, pts) + t
    expected = (world - T_end[:3, 3]) @ T_end[:3, :3]
    out = deskew(pts, stamps, T_begin, T_end, model="ct_icp")
    np.testing.assert_allclose(out.points, expected, atol=1e-10)
    assert out.alpha_ref == 1.0 and out.time_unit == "s"
    geodesic = deskew(pts, stamps, T_begin, T_end, "generic", method="se3").points
    assert np.abs(geodesic - expected).max() > 1e-3  # split vs coupled differ


@pytest.mark.parametrize("reference", ["begin", "mid", "end", 0.025])
@pytest.mark.parametrize("method", ["se3", "split"])
def test_generic_reference_times(reference: str | float, method: str) -> None:
    pts, stamps, T_begin, T_end = _scan(50)
    out = deskew(
        pts,
        stamps,
        T_begin,
        T_end,
        "generic",
        reference=reference,
        method=method,
        t_begin=0.0,
        t_end=0.1,
    )
    a_ref = {"begin": 0.0, "mid": 0.5, "end": 1.0}.get(reference, 0.25)  # type: ignore[call-overload]
    assert out.alpha_ref == pytest.approx(a_ref)
    # the definition, point by point: T(α_ref)⁻¹·T(α)·p with T from the same interpolation
    from liebridge.continuous import interpolate

    Ta = interpolate(T_begin, T_end, stamps / 0.1, method, jacobians=False).T
    Tr = interpolate(T_begin, T_end, a_ref, method, jacobians=False).T
    D = np.linalg.inv(Tr) @ Ta
    np.testing.assert_allclose(
        out.points, np.einsum("nij,nj->ni", D[:, :3, :3], pts) + D[:, :3, 3], atol=1e-10
    )


def test_integer_nanoseconds_are_read_as_such() -> None:
    pts, stamps, T_begin, T_end = _scan(40)
    epoch = 1_700_000_000_000_000_000
    ns = epoch + np.round(stamps * 1e9).astype(np.int64)
    a = deskew(pts, ns, T_begin, T_end, "kiss_icp")
    b = deskew(pts, np.round(stamps * 1e9) * 1e-9, T_begin, T_end, "kiss_icp")
    assert a.time_unit == "ns" and b.time_unit == "s"
    np.testing.assert_allclose(a.points, b.points, atol=1e-9)
    ref = deskew(pts, ns, T_begin, T_end, "generic", reference=int(ns.min()))
    assert ref.alpha_ref == 0.0


@pytest.mark.parametrize("conv", SE3_PRESETS)
@pytest.mark.parametrize(
    "model,kw",
    [
        ("kiss_icp", {}),
        ("ct_icp", {}),
        ("generic", {"reference": "mid", "method": "split"}),
        ("generic", {"reference": "begin", "method": "se3"}),
    ],
)
def test_point_jacobians_match_central_differences(conv: str, model: str, kw: dict) -> None:
    c = get(conv)
    pts, stamps, T_begin, T_end = _scan(6)
    out = deskew(pts, stamps, T_begin, T_end, model, convention=c, jacobians=True, **kw)
    assert out.J_p_T_begin is not None and out.J_p_T_end is not None
    fb = lambda X: deskew(pts, stamps, X, T_end, model, **kw).points  # noqa: E731
    fe = lambda X: deskew(pts, stamps, T_begin, X, model, **kw).points  # noqa: E731
    Nb = numerical_jacobian(fb, T_begin, in_convention=c, out_local="euclidean", eps=1e-7)
    Ne = numerical_jacobian(fe, T_end, in_convention=c, out_local="euclidean", eps=1e-7)
    # numerical_jacobian stacks the (N, 3) output as rows of one vector
    np.testing.assert_allclose(out.J_p_T_begin.reshape(-1, 6), Nb.reshape(-1, 6), atol=5e-6)
    np.testing.assert_allclose(out.J_p_T_end.reshape(-1, 6), Ne.reshape(-1, 6), atol=5e-6)


def test_near_pi_motion_and_zero_motion() -> None:
    pts, stamps, T_begin, _ = _scan(20)
    T_end = T_begin @ se3.exp(np.array([0.0, 0.0, math.pi - 1e-4, 0.5, 0.0, 0.0]))
    for T1 in (T_end, T_begin):
        out = deskew(pts, stamps, T_begin, T1, "generic", method="split", jacobians=True)
        assert np.isfinite(out.points).all() and np.isfinite(out.J_p_T_end).all()
    still = deskew(pts, stamps, T_begin, T_begin, "kiss_icp")
    np.testing.assert_allclose(still.points, pts, atol=1e-12)


def test_bad_input_is_named() -> None:
    pts, stamps, T_begin, T_end = _scan(10)
    with pytest.raises(ValueError, match="t_max == t_min"):
        deskew(pts, np.full(10, 0.05), T_begin, T_end, "kiss_icp")
    with pytest.raises(ValueError, match="mixed time units"):
        deskew(pts, (stamps * 1e9).astype(np.int64), T_begin, T_end, "generic", reference=0.05)
    with pytest.raises(ValueError, match="mixed time units"):
        deskew(pts, stamps, T_begin, T_end, "generic", t_begin=0, t_end=100_000_000)
    with pytest.raises(ValueError, match="model"):
        deskew(pts, stamps, T_begin, T_end, "fast_lio")
    with pytest.raises(ValueError, match="reference: model 'kiss_icp' fixes it"):
        deskew(pts, stamps, T_begin, T_end, "kiss_icp", reference="mid")
    with pytest.raises(ValueError, match="stamps: expected shape \\(10,\\)"):
        deskew(pts, stamps[:9], T_begin, T_end)
    with pytest.raises(ValueError, match="points"):
        deskew(pts[:, :2], stamps, T_begin, T_end)
    with pytest.raises(ValueError, match="reference"):
        deskew(pts, stamps, T_begin, T_end, "generic", reference="middle")
    bad = pts.copy()
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match="points"):
        deskew(bad, stamps, T_begin, T_end)
    before = pts.copy()
    deskew(pts, stamps, T_begin, T_end, "ct_icp", jacobians=True)
    assert np.array_equal(pts, before)


@pytest.mark.parametrize("conv", SE3_PRESETS)
@pytest.mark.parametrize("model,kw", [("ct_icp", {}), ("generic", {"reference": "mid"})])
def test_point_jacobians_near_pi(conv: str, model: str, kw: dict) -> None:
    pts, stamps, T_begin, _ = _scan(5)
    T_end = T_begin @ se3.exp(
        np.array([0.0, 0.6 * (math.pi - 1e-3), 0.8 * (math.pi - 1e-3), 0.5, 0.0, 0.2])
    )
    c = get(conv)
    out = deskew(pts, stamps, T_begin, T_end, model, convention=c, jacobians=True, **kw)
    fe = lambda X: deskew(pts, stamps, T_begin, X, model, **kw).points  # noqa: E731
    Ne = numerical_jacobian(fe, T_end, in_convention=c, out_local="euclidean", eps=1e-8)
    np.testing.assert_allclose(out.J_p_T_end.reshape(-1, 6), Ne.reshape(-1, 6), atol=5e-5)
