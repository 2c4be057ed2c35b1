"""Fuzz the public API (hypothesis): only ValueError/TypeError escape, no NaN out, no input mutated.

Arguments are drawn as a valid value of the right kind (rotations up to and at π, translations up
to 1e300, batches including empty ones), a valid value with one defect (NaN/Inf, scaled rotation,
reflection, wrong trailing shape, complex/str/bool/int dtypes, a list) or an arbitrary array
(random shape, dtype and magnitude). Every call must then either raise ``ValueError`` /
``TypeError`` or return a finite result, emit no ``RuntimeWarning`` (an overflow or invalid
operation that was not turned into an error) and leave its inputs unchanged. A second property
checks that the single-pose (table) and batched (blockwise) evaluations of the conversion maps
agree, since they are two evaluations of one description.
"""

from __future__ import annotations

import math
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.spatial.transform import Rotation

import liebridge as lb
from liebridge.conventions import PRESETS, get
from liebridge.conventions import names as conventions_names
from liebridge.gtsam.pose_factors import between, prior
from liebridge.io import g2o, poses
from liebridge.io import trajectory as trajectory_io
from liebridge.lie import quaternion as Q
from liebridge.lie import se3, so3

PI = math.pi
BATCHES = [(), (1,), (3,), (2, 2), (0,)]
ANGLES = [0.0, 1e-15, 1e-9, 1e-4, 0.3, 0.5, 1.0, 2.0, 3.0, PI - 1e-3, PI - 1e-9, PI - 1e-12, PI]
SCALES = [0.0, 1e-12, 1e-3, 1.0, 30.0, 1e4, 1e8, 1e15, 1e100, 1e300]
NAMES = [c.name for c in PRESETS]


# --------------------------------------------------------------------------- strategies
@st.composite
def rotvecs(draw: st.DrawFn, batch: tuple[int, ...]) -> np.ndarray:
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(*batch, 3))
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
    angle = draw(st.sampled_from(ANGLES) | st.floats(0.0, PI))
    return np.asarray(angle * axis)


@st.composite
def rotations(draw: st.DrawFn, batch: tuple[int, ...]) -> np.ndarray:
    w = draw(rotvecs(batch))
    return Rotation.from_rotvec(w.reshape(-1, 3)).as_matrix().reshape((*batch, 3, 3))


@st.composite
def translations(draw: st.DrawFn, batch: tuple[int, ...]) -> np.ndarray:
    seed = draw(st.integers(0, 2**32 - 1))
    scale = draw(st.sampled_from(SCALES))
    return np.asarray(scale * np.random.default_rng(seed).normal(size=(*batch, 3)))


@st.composite
def poses_(draw: st.DrawFn, batch: tuple[int, ...]) -> np.ndarray:
    T = np.zeros((*batch, 4, 4))
    T[..., :3, :3] = draw(rotations(batch))
    T[..., :3, 3] = draw(translations(batch))
    T[..., 3, 3] = 1.0
    return T


@st.composite
def tangents(draw: st.DrawFn, batch: tuple[int, ...], n: int) -> np.ndarray:
    w = draw(rotvecs(batch)) * draw(st.sampled_from([1.0, 1.0, 0.4, 2.5, 1e6]))
    if n == 3:
        return w
    return np.concatenate([w, draw(translations(batch))], axis=-1)


@st.composite
def covariances(draw: st.DrawFn, batch: tuple[int, ...], n: int) -> np.ndarray:
    seed = draw(st.integers(0, 2**32 - 1))
    rank = draw(st.integers(0, n))
    A = np.random.default_rng(seed).normal(size=(*batch, n, rank))
    scale = draw(st.sampled_from([1e-12, 1e-3, 1.0, 1e6, 1e150, 1e300]))
    return np.asarray(scale * (A @ np.swapaxes(A, -1, -2)))


@st.composite
def quaternions(draw: st.DrawFn, batch: tuple[int, ...]) -> np.ndarray:
    q = Rotation.from_matrix(draw(rotations(batch)).reshape(-1, 3, 3)).as_quat()
    return q.reshape((*batch, 4))


def valid(kind: str, batch: tuple[int, ...]) -> st.SearchStrategy[Any]:
    return {
        "vec3": tangents(batch, 3),
        "vec6": tangents(batch, 6),
        "rot": rotations(batch),
        "pose": poses_(batch),
        "group": poses_(batch) | rotations(batch),
        "quat": quaternions(batch),
        "cov6": covariances(batch, 6),
        "cov3": covariances(batch, 3),
        "jac": st.integers(1, 7).flatmap(lambda m: hnp.arrays(np.float64, (*batch, m, 6))),
        "tau": hnp.arrays(np.float64, batch, elements=st.floats(-2.0, 3.0)),
        "point": translations(batch),
    }[kind]


@st.composite
def corrupted(draw: st.DrawFn, x: np.ndarray) -> Any:
    """One defect: a bad entry, a distorted rotation, a reflection, a bad shape or dtype."""
    y = np.array(x, dtype=np.float64, copy=True)
    how = draw(
        st.sampled_from(
            ["nan", "inf", "scale", "reflect", "trailing", "complex", "str", "bool", "int", "list"]
        )
    )
    if how in ("nan", "inf") and y.size:
        flat = y.reshape(-1)
        flat[draw(st.integers(0, y.size - 1))] = np.nan if how == "nan" else -np.inf
        return y
    if how == "scale" and y.ndim >= 2:
        y[..., :3, :3] *= draw(st.sampled_from([1.0 + 1e-9, 1.0 + 3e-6, 0.9, 2.0, 0.0]))
        return y
    if how == "reflect" and y.ndim >= 2:
        y[..., :, 0] *= -1.0
        return y
    if how == "trailing" and y.ndim >= 1:
        return y[..., :-1]
    if how == "complex":
        return y + 0j
    if how == "str":
        return y.astype(str)
    if how == "bool":
        return y.astype(bool)
    if how == "int":
        return np.clip(y, -1e9, 1e9).astype(np.int64)
    return y.tolist()


ARBITRARY = st.sampled_from([np.float64, np.float32, np.int64, np.bool_, np.complex128]).flatmap(
    lambda dtype: hnp.arrays(
        dtype, hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=5)
    )
)  # default elements: every value of the dtype, NaN, ±Inf and 1e308 included


@st.composite
def argument(draw: st.DrawFn, kind: str, batch: tuple[int, ...]) -> Any:
    mode = draw(st.sampled_from(["valid", "valid", "valid", "corrupt", "arbitrary"]))
    if mode == "arbitrary":
        return draw(ARBITRARY)
    x = draw(valid(kind, batch))
    return x if mode == "valid" else draw(corrupted(x))


# --------------------------------------------------------------------------- the property
def _arrays_in(x: Any) -> list[np.ndarray]:
    if isinstance(x, np.ndarray):
        return [x]
    if isinstance(x, tuple | list):
        return [a for item in x for a in _arrays_in(item)]
    return []


def check_call(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """Call ``fn``; only ValueError/TypeError may escape; a result is finite; inputs unchanged."""
    before = [(a, a.copy()) for arg in (*args, *kwargs.values()) for a in _arrays_in(arg)]
    lists = [(arg, repr(arg)) for arg in (*args, *kwargs.values()) if isinstance(arg, list)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = fn(*args, **kwargs)
        except (ValueError, TypeError):
            out = None
        else:
            runtime = [w for w in caught if issubclass(w.category, RuntimeWarning)]
            assert not runtime, f"returned a result after {runtime[0].message}"
            for a in _arrays_in(out):
                if a.dtype.kind in "fc":
                    assert np.isfinite(a).all(), f"non-finite output from {fn.__name__}"
    for a, copy in before:
        assert a.dtype == copy.dtype and a.shape == copy.shape
        np.testing.assert_array_equal(a, copy, err_msg=f"{fn.__name__} mutated its input")
    for lst, text in lists:
        assert repr(lst) == text, f"{fn.__name__} mutated a list argument"
    return out


def _call_with(data: st.DataObject, fn: Callable[..., Any], kinds: list[str], **kw: Any) -> None:
    batch = data.draw(st.sampled_from(BATCHES), label="batch")
    args = [data.draw(argument(k, batch), label=k) for k in kinds]
    check_call(fn, *args, **kw)


# --------------------------------------------------------------------------- the kernel
LIE = {
    "so3.hat": (so3.hat, ["vec3"]),
    "so3.vee": (so3.vee, ["rot"]),
    "so3.exp": (so3.exp, ["vec3"]),
    "so3.log": (so3.log, ["rot"]),
    "so3.jr": (so3.jr, ["vec3"]),
    "so3.jl": (so3.jl, ["vec3"]),
    "so3.jr_inv": (so3.jr_inv, ["vec3"]),
    "so3.jl_inv": (so3.jl_inv, ["vec3"]),
    "so3.adjoint": (so3.adjoint, ["rot"]),
    "so3.project": (so3.project, ["rot"]),
    "so3.inverse": (so3.inverse, ["rot"]),
    "so3.compose": (so3.compose, ["rot", "rot"]),
    "so3.act": (so3.act, ["rot", "point"]),
    "so3.interpolate": (so3.interpolate, ["rot", "rot", "tau"]),
    "se3.hat": (se3.hat, ["vec6"]),
    "se3.vee": (se3.vee, ["pose"]),
    "se3.exp": (se3.exp, ["vec6"]),
    "se3.log": (se3.log, ["pose"]),
    "se3.inverse": (se3.inverse, ["pose"]),
    "se3.compose": (se3.compose, ["pose", "pose"]),
    "se3.act": (se3.act, ["pose", "point"]),
    "se3.adjoint": (se3.adjoint, ["pose"]),
    "se3.ad": (se3.ad, ["vec6"]),
    "se3.jr": (se3.jr, ["vec6"]),
    "se3.jl": (se3.jl, ["vec6"]),
    "se3.jr_inv": (se3.jr_inv, ["vec6"]),
    "se3.jl_inv": (se3.jl_inv, ["vec6"]),
    "se3.interpolate": (se3.interpolate, ["pose", "pose", "tau"]),
}
QUAT = {
    "to_matrix": (Q.to_matrix, ["quat"]),
    "from_matrix": (Q.from_matrix, ["rot"]),
    "multiply": (Q.multiply, ["quat", "quat"]),
    "conjugate": (Q.conjugate, ["quat"]),
    "canonical": (Q.canonical, ["quat"]),
    "slerp": (Q.slerp, ["quat", "quat", "tau"]),
    "jpl_to_hamilton": (Q.jpl_to_hamilton, ["quat"]),
    "hamilton_to_jpl": (Q.hamilton_to_jpl, ["quat"]),
}


def test_fuzz_tables_cover_the_public_kernel() -> None:
    assert {k.split(".")[1] for k in LIE if k.startswith("so3.")} == set(so3.__all__)
    assert {k.split(".")[1] for k in LIE if k.startswith("se3.")} == set(se3.__all__)
    assert set(QUAT) == set(Q.__all__)


@given(st.data())
def test_fuzz_lie_kernel(data: st.DataObject) -> None:
    name = data.draw(st.sampled_from(sorted(LIE)), label="function")
    fn, kinds = LIE[name]
    _call_with(data, fn, kinds)


@given(st.data())
def test_fuzz_quaternions(data: st.DataObject) -> None:
    name = data.draw(st.sampled_from(sorted(QUAT)), label="function")
    fn, kinds = QUAT[name]
    order = data.draw(st.sampled_from(["wxyz", "xyzw", "wxyz", "xyzw", "WXYZ", ""]), label="order")
    _call_with(data, fn, kinds, order=order)


# --------------------------------------------------------------------------- conventions
CONV_METHODS = {
    "retract": ["group", "vec6"],
    "local": ["group", "group"],
    "local_jacobian": ["group", "group"],
    "to_canonical": ["group"],
    "from_canonical": ["group"],
}


@given(st.data())
def test_fuzz_convention_methods(data: st.DataObject) -> None:
    conv = get(data.draw(st.sampled_from(NAMES), label="convention"))
    method = data.draw(st.sampled_from(sorted(CONV_METHODS)), label="method")
    kinds = list(CONV_METHODS[method])
    if method == "retract" and data.draw(st.booleans(), label="rotation"):
        kinds = ["rot", "vec3"]
    _call_with(data, getattr(conv, method), kinds)


CONVERT = {
    "tangent_map": (lb.tangent_map, ["group"]),
    "convert_tangent": (
        lambda d, X, a, b: lb.convert_tangent(d, X, a, b, exact=True),
        ["vec6", "pose"],
    ),
    "convert_tangent_linear": (
        lambda d, X, a, b: lb.convert_tangent(d, X, a, b, exact=False),
        ["vec6", "pose"],
    ),
    "convert_covariance": (lb.convert_covariance, ["cov6", "pose"]),
    "convert_covariance_rotation": (lb.convert_covariance, ["cov3", "rot"]),
    "convert_covariance_unscented": (
        lambda C, X, a, b: lb.convert_covariance(C, X, a, b, method="unscented"),
        ["cov6", "pose"],
    ),
    "convert_information": (lb.convert_information, ["cov6", "pose"]),
    "convert_jacobian": (
        lambda J, X, a, b: lb.convert_jacobian(J, X, a, b, at_output=X),
        ["jac", "pose"],
    ),
}


@given(st.data())
def test_fuzz_conversions(data: st.DataObject) -> None:
    name = data.draw(st.sampled_from(sorted(CONVERT)), label="function")
    fn, kinds = CONVERT[name]
    src = data.draw(st.sampled_from([*NAMES, "sophsu", ""]), label="src")
    dst = data.draw(st.sampled_from(NAMES), label="dst")
    batch = data.draw(st.sampled_from(BATCHES), label="batch")
    args = [data.draw(argument(k, batch), label=k) for k in kinds]
    check_call(fn, *args, src, dst)


@given(st.data())
def test_fuzz_pose_layouts(data: st.DataObject) -> None:
    layout = data.draw(st.sampled_from([*poses.layouts(), "tum", "xyz_qwxy", "matrix "]), "layout")
    batch = data.draw(st.sampled_from(BATCHES), label="batch")
    if data.draw(st.booleans(), label="to_matrix"):
        T = data.draw(poses_(batch), label="T")
        x = poses.from_matrix(T, layout=layout) if layout in poses.layouts() else T[..., 0, :]
        if data.draw(st.booleans(), label="corrupt"):
            x = data.draw(corrupted(np.asarray(x)), label="bad x")
        check_call(poses.to_matrix, x, layout=layout)
    else:
        check_call(poses.from_matrix, data.draw(argument("pose", batch), label="T"), layout=layout)


@given(st.sampled_from(NAMES) | st.text(max_size=12))
@example("ROS_POSE2")  # regression: a non-SE(3) registry name, found by hypothesis
def test_fuzz_convention_names(name: str) -> None:
    out = check_call(get, name)
    # any registered preset of any group (the SE(3) NAMES are only what is sampled)
    assert out is None or out.name in conventions_names()


RESULTS = st.one_of(
    ARBITRARY,
    hnp.arrays(np.float64, (4, 4), elements={"allow_nan": True, "allow_infinity": True}),
    st.sampled_from([None, "pose", [[1.0, 2.0]], object()]),
)


@given(RESULTS, st.sampled_from(["se3", "so3"]))
def test_fuzz_detect_convention_bad_results(result: Any, group: str) -> None:
    """A retraction returning junk (any shape, dtype, NaN, not an array) gets a clean error."""

    def retract(X: np.ndarray, d: np.ndarray) -> Any:
        return result

    out = check_call(lb.detect_convention, retract, group=group)
    assert out is None or out.name  # junk that happens to be a retraction is allowed to match


@given(st.data())
def test_fuzz_factors(data: st.DataObject) -> None:
    conv = data.draw(st.sampled_from([*NAMES, "barfot"]), label="convention")
    native = data.draw(st.booleans(), label="native")
    Z = data.draw(argument("pose", ()), label="measured")
    cov = data.draw(argument("cov6", ()), label="cov")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # first-order native conversion notice
        if data.draw(st.booleans(), label="between"):
            check_call(between, 0, 1, Z, cov, conv, native=native)
        else:
            check_call(prior, 0, Z, cov, conv, native=native)


# --------------------------------------------------------------------------- files
TOKENS = st.sampled_from(
    [
        *("0", "1", "-1", "0.5", "1e-3", "1.5", "2", "3", "0.7071067811865476"),
        *("nan", "inf", "-inf", "1e400", "x"),
    ]
)
TAGS = st.sampled_from(
    ["VERTEX_SE3:QUAT", "EDGE_SE3:QUAT", "VERTEX3", "EDGE3", "FIX", "VERTEX_SE2", "#", "FOO"]
)


@st.composite
def g2o_text(draw: st.DrawFn) -> str:
    lines = []
    for _ in range(draw(st.integers(0, 6))):
        tag = draw(TAGS)
        n = draw(st.sampled_from([1, 2, 8, 9, 29, 30, 31]))
        lines.append(" ".join([tag, *draw(st.lists(TOKENS, min_size=n, max_size=n))]))
    return "\n".join(lines) + "\n"


@st.composite
def trajectory_text(draw: st.DrawFn, width: int) -> str:
    lines = []
    for _ in range(draw(st.integers(0, 4))):
        n = draw(st.sampled_from([width - 1, width, width, width + 1]))
        lines.append(" ".join(draw(st.lists(TOKENS, min_size=n, max_size=n))))
    return "\n".join(lines) + "\n"


@given(
    st.one_of(
        g2o_text().map(lambda s: ("g2o", s.encode())),
        trajectory_text(8).map(lambda s: ("tum", s.encode())),
        trajectory_text(12).map(lambda s: ("kitti", s.encode())),
        st.tuples(st.sampled_from(["g2o", "tum", "kitti"]), st.binary(max_size=40)),
    )
)
def test_fuzz_file_readers(case: tuple[str, bytes]) -> None:
    kind, content = case
    reader = {"g2o": g2o.read, "tum": trajectory_io.read_tum, "kitti": trajectory_io.read_kitti}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"fuzz.{kind}"
        path.write_bytes(content)
        try:
            out = reader[kind](path)
        except ValueError as exc:  # a malformed line names the file (and, mostly, the line)
            assert str(path) in str(exc) or "information" in str(exc), str(exc)
            return
    arrays = _arrays_in(out) if kind != "g2o" else [out.poses, out.measured, out.information]
    for a in arrays:
        assert np.isfinite(a).all()


# --------------------------------------------------------------------------- one description
@given(st.data())
def test_single_and_batched_evaluations_agree(data: st.DataObject) -> None:
    """The table product (small batches) and the blockwise path (large) give the same map."""
    src = get(data.draw(st.sampled_from(NAMES), label="src"))
    dst = get(data.draw(st.sampled_from(NAMES), label="dst"))
    rotation = data.draw(st.booleans(), label="rotation")
    X = data.draw(rotations((40,)) if rotation else poses_((40,)), label="X")
    if not rotation:
        X[..., :3, 3] = np.clip(X[..., :3, 3], -1e100, 1e100)
    many = lb.tangent_map(X, src, dst)
    one = np.stack([lb.tangent_map(x, src, dst) for x in X[:5]])
    # both sum the same few products in different orders; a product of two maps (Ad·Ad⁻¹)
    # cancels terms of size |t|², so the rounding is relative to that
    t = 0.0 if rotation else float(np.abs(X[:5, :3, 3]).max())
    np.testing.assert_allclose(one, many[:5], rtol=0, atol=64 * 2.2e-16 * (1.0 + t) ** 2)
