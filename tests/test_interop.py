"""Other libraries' pose and rotation objects accepted wherever a pose or rotation is, and back.

Each installed library's objects are built with that library's own constructors from a rotation
and a translation (not from liebridge's matrices), so the test checks that liebridge reads the
pose the library means: every public function that takes a pose gives the same result for the
object as for the matrix built from the same rotation and translation.

sophuspy needs numpy < 2 and projectaria_tools ~1.6 GB of dependencies: their tests skip here
and run in their own environments (``PYTHONPATH=. <venv>/bin/python -m pytest
tests/test_interop.py``; see docs/interop.md).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import liebridge as lb
from liebridge import interop
from liebridge.lie import quaternion, se3, so3

R0 = so3.exp(np.array([0.3, -0.7, 1.1]))
T0_ = np.array([1.5, -2.0, 30.0])
T0 = np.eye(4)
T0[:3, :3], T0[:3, 3] = R0, T0_
R1 = so3.exp(np.array([-2.0, 0.4, 0.9]))
T1_ = np.array([-4.0, 0.5, 2.0])
T1 = np.eye(4)
T1[:3, :3], T1[:3, 3] = R1, T1_
COV = np.diag([1e-4, 2e-4, 3e-4, 1e-2, 2e-2, 3e-2])


# ------------------------------------------------------------------ library objects from (R, t)
def _gtsam(R: np.ndarray, t: np.ndarray | None) -> Any:
    gtsam = pytest.importorskip("gtsam")
    return gtsam.Rot3(R) if t is None else gtsam.Pose3(gtsam.Rot3(R), t)


def _pin(R: np.ndarray, t: np.ndarray | None) -> Any:
    pin = pytest.importorskip("pinocchio")
    if t is None:
        pytest.skip("Pinocchio has no rotation class (a 3×3 array is its rotation)")
    return pin.SE3(R, t)


def _spatialmath(R: np.ndarray, t: np.ndarray | None) -> Any:
    sm = pytest.importorskip("spatialmath")
    return sm.SO3(R) if t is None else sm.SE3.Rt(R, t)


def _scipy(R: np.ndarray, t: np.ndarray | None) -> Any:
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_rotvec(so3.log(R))  # the library's own constructor, not from_matrix
    if t is None:
        return rot
    from scipy.spatial.transform import RigidTransform

    return RigidTransform.from_components(t, rot)


def _sophuspy(R: np.ndarray, t: np.ndarray | None) -> Any:
    sp = pytest.importorskip("sophuspy")
    return sp.SO3.exp(so3.log(R)) if t is None else sp.SE3(R, t)


def _aria(R: np.ndarray, t: np.ndarray | None) -> Any:
    sophus = pytest.importorskip("projectaria_tools.core.sophus")
    rot = sophus.SO3.exp(so3.log(R))
    if t is None:
        return rot
    q = rot.to_quat()[0]  # (w, x, y, z)
    return sophus.SE3.from_quat_and_translation(float(q[0]), q[1:], np.asarray(t, dtype=float))


MAKERS: dict[str, Callable[[np.ndarray, np.ndarray | None], Any]] = {
    "gtsam": _gtsam,
    "pinocchio": _pin,
    "spatialmath": _spatialmath,
    "scipy": _scipy,
    "sophuspy": _sophuspy,
    "projectaria": _aria,
}
LIBS = list(MAKERS)

# every public function that takes a pose (name, call(pose_like))
POSE_FUNCS: dict[str, Callable[[Any], Any]] = {
    "se3.log": se3.log,
    "se3.inverse": se3.inverse,
    "se3.adjoint": se3.adjoint,
    "se3.compose": lambda X: se3.compose(X, T1),
    "se3.act": lambda X: se3.act(X, np.array([1.0, 2.0, 3.0])),
    "se3.interpolate": lambda X: se3.interpolate(X, T1, 0.3),
    "tangent_map": lambda X: lb.tangent_map(X, "gtsam", "sophus"),
    "Convention.element": lambda X: lb.conventions.get("sophus").element(X),
    "Convention.dim": lambda X: np.array(lb.conventions.get("sophus").dim(X)),
    "convert_tangent": lambda X: lb.convert_tangent(np.full(6, 0.1), X, "gtsam", "g2o"),
    "convert_covariance": lambda X: lb.convert_covariance(COV, X, "gtsam", "barfoot"),
    "convert_covariance_unscented": lambda X: lb.convert_covariance(
        COV, X, "gtsam", "symforce", method="unscented"
    ),
    "convert_information": lambda X: lb.convert_information(np.linalg.inv(COV), X, "gtsam", "ros"),
    "convert_jacobian": lambda X: lb.convert_jacobian(
        np.eye(6),
        X,
        "gtsam",
        "sophus",
        at_output=X,
    ),
    "Chart.retract": lambda X: lb.conventions.get("sophus").retract(X, np.full(6, 0.1)),
    "Chart.local": lambda X: lb.conventions.get("barfoot").local(X, T1),
    "io.poses.from_matrix": lambda X: lb.poses.from_matrix(X, layout="xyz_qxyzw"),
    "check.numerical_jacobian": lambda X: lb.check.numerical_jacobian(
        se3.log, X, in_convention="sophus", out_local="euclidean"
    ),
    "gtsam.to_pose3": lambda X: lb.gtsam_glue.from_pose3(lb.gtsam_glue.to_pose3(X)),
    "gtsam.between": lambda X: lb.factors.between(1, 2, X, COV, "barfoot").error(
        lb.gtsam_glue.to_values(np.stack([T0, T1]), [1, 2])
    ),
    "factors.between_custom": lambda X: lb.factors.between(
        1, 2, X, COV, "sophus", native=False
    ).error(lb.gtsam_glue.to_values(np.stack([T0, T1]), [1, 2])),
    "gtsam.prior": lambda X: lb.factors.prior(1, X, COV, "sophus").error(
        lb.gtsam_glue.to_values(T1[None], [1])
    ),
    "Chart.local_jacobian": lambda X: lb.conventions.get("g2o").local_jacobian(X, T1),
    "Chart.to_canonical": lambda X: lb.conventions.get("barfoot").to_canonical(X),
    "Chart.from_canonical": lambda X: lb.conventions.get("symforce").from_canonical(X),
    "group_input": lb.conventions.group_input,
    "check.monte_carlo_covariance": lambda X: lb.check.monte_carlo_covariance(
        X=X, cov=COV, src="gtsam", dst="ros", n=200, rng=np.random.default_rng(0)
    ),
    "io.trajectory.write_tum": lambda X: _written(
        lambda p: lb.trajectory_io.write_tum(p, [0.0, 1.0], [X, X])
    ),
    "io.trajectory.write_kitti": lambda X: _written(lambda p: lb.trajectory_io.write_kitti(p, [X])),
    "gtsam.to_values": lambda X: lb.gtsam_glue.from_values(
        lb.gtsam_glue.to_values([X, X], [3, 4]), [3, 4]
    ),
    "gtsam.ConventionGraph": lambda X: _graph(X),
    "imu.PreintegratedImu.predict": lambda X: np.concatenate(
        [a.ravel() for a in _pim().predict(X, np.zeros(3), np.zeros(6))]
    ),
    "imu.imu_residual": lambda X: lb.imu.imu_residual(
        X, np.zeros(3), T1, np.zeros(3), np.zeros(6), _pim(), jacobians=False
    )[0],
    "imu.combined_imu_residual": lambda X: lb.imu.combined_imu_residual(
        X, np.zeros(3), T1, np.zeros(3), np.zeros(6), np.zeros(6), _cpim(), jacobians=False
    )[0],
}


def _written(write: Callable[[str], None]) -> np.ndarray:
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "t.txt")
        write(path)
        return np.loadtxt(path)


def _graph(X: Any) -> np.ndarray:
    g = lb.ConventionGraph("sophus")
    g.insert(0, X)
    g.insert(1, T1)
    g.add_prior(0, X, np.eye(6) * 1e-6)
    g.add_between(0, 1, se3.compose(se3.inverse(X), T1), COV)
    return np.asarray(g.graph.error(g.values))


def _cpim() -> Any:
    gtsam = pytest.importorskip("gtsam")
    params = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
    n = 20
    return lb.imu.preintegrate_combined(
        np.tile([0.1, 0.0, 9.81], (n, 1)),
        np.tile([0.0, 0.1, 0.2], (n, 1)),
        np.full(n, 0.01),
        bias=np.zeros(6),
        params=params,
    )


def _pim() -> Any:
    gtsam = pytest.importorskip("gtsam")
    params = gtsam.PreintegrationParams.MakeSharedU(9.81)
    n = 20
    return lb.imu.preintegrate(
        np.tile([0.1, 0.0, 9.81], (n, 1)),
        np.tile([0.0, 0.1, 0.2], (n, 1)),
        np.full(n, 0.01),
        bias=np.zeros(6),
        params=params,
    )


ROT_FUNCS: dict[str, Callable[[Any], Any]] = {
    "so3.log": so3.log,
    "quaternion.from_matrix": lambda R: quaternion.from_matrix(R, order="xyzw"),
    "tangent_map(SO3)": lambda R: lb.tangent_map(R, "gtsam", "ceres_quaternion"),
    "convert_covariance(SO3)": lambda R: lb.convert_covariance(
        np.diag([1e-3, 2e-3, 3e-3]), R, "gtsam", "barfoot"
    ),
    "Chart.retract(SO3)": lambda R: lb.conventions.get("barfoot").retract(
        R, np.array([0.1, 0.2, 0.3])
    ),
    "so3.adjoint": so3.adjoint,
    "so3.inverse": so3.inverse,
    "so3.act": lambda R: so3.act(R, np.array([1.0, 2.0, 3.0])),
}

#: Parameters that hold a pose or rotation, by name; a public function with one of them must be
#: in POSE_FUNCS / ROT_FUNCS (or in NOT_A_POSE, saying why).
POSE_PARAMS = {"X", "T", "T0", "T1", "T2", "R", "pose", "poses", "measured", "pose_i", "pose_j",
               "at_input", "at_output", "x"}  # fmt: skip
NOT_A_POSE = {
    "se3.vee": "X is a 4×4 twist matrix (se(3)), not a pose",
    "io.poses.to_matrix": "x is a row in a layout (the matrix layout reads arrays)",
    "imu.imu": "pose_i, pose_j are GTSAM keys",
    "imu.combined_imu": "pose_i, pose_j are GTSAM keys",
    "interop.to_library": "T is liebridge's output; `like` is the library object",
    "Bundle.dim": "X is a block-diagonal bundle element (no library has a bundle object)",
    "Bundle.element": "X is a block-diagonal bundle element (no library has a bundle object)",
    "Bundle.split": "X is a block-diagonal bundle element (no library has a bundle object)",
    "NavChart.dim": "X is ignored: a navigation chart's tangent always has 9 entries",
    "NavChart.element": "X is a 5×5 SE₂(3) extended pose (no library object is one)",
    "pose_convention": "X is read for its shape only: the convention is what is checked",
    "Chart.dim": "the base of every chart kind: each defines it (Convention.dim is tested)",
    "Chart.element": "the base of every chart kind: each defines it (Convention.element is tested)",
    "Bundle.sub_element": "X is a block-diagonal bundle element (no library has a bundle object)",
    "Sphere.dim": "X is ignored: the tangent of S² always has 2 entries",
    "Sphere.element": "X is a [[I, g], [0, 1]] S² block of a bundle (no library has one)",
}
PUBLIC = [
    ("se3", "liebridge.lie.se3"),
    ("so3", "liebridge.lie.so3"),
    ("quaternion", "liebridge.lie.quaternion"),
    ("", "liebridge.conventions"),
    ("check", "liebridge.check"),
    ("io.poses", "liebridge.io.poses"),
    ("io.trajectory", "liebridge.io.trajectory"),
    ("gtsam", "liebridge.gtsam"),
    ("imu", "liebridge.imu"),
    ("interop", "liebridge.interop"),
]


def test_every_public_function_taking_a_pose_is_covered() -> None:
    """The lists above are complete: scanned from the public signatures, not typed by hand."""
    import importlib
    import inspect

    pytest.importorskip("gtsam")
    found = set()
    for prefix, modname in PUBLIC:
        mod = importlib.import_module(modname)
        for name in mod.__all__:
            obj = getattr(mod, name)
            members = (
                [(f"{name}.{a}", f) for a, f in vars(obj).items() if not a.startswith("_")]
                if inspect.isclass(obj)
                else [(name, obj)]
            )
            for label, f in members:
                try:
                    params = inspect.signature(f).parameters
                except (TypeError, ValueError):
                    continue
                if POSE_PARAMS & set(params):
                    found.add(f"{prefix}.{label}".lstrip("."))
    covered = {n.split("(")[0] for n in [*POSE_FUNCS, *ROT_FUNCS, *NOT_A_POSE]}
    covered |= (
        {  # exercised together by one entry
            "gtsam.ConventionGraph.insert",
            "gtsam.ConventionGraph.add_prior",
            "gtsam.ConventionGraph.add_between",
        }
        if "gtsam.ConventionGraph" in covered
        else set()
    )
    missing = sorted(found - covered)
    assert not missing, f"public functions taking a pose without an interop test: {missing}"


def _same(got: Any, want: Any) -> None:
    if hasattr(want, "matrix") and not isinstance(want, np.ndarray):
        got, want = got.matrix(), want.matrix()
    np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("func", list(POSE_FUNCS))
@pytest.mark.parametrize("lib", LIBS)
def test_every_pose_function_takes_the_librarys_pose(lib: str, func: str) -> None:
    if func.startswith(("gtsam", "factors", "imu")):
        pytest.importorskip("gtsam")  # absent from the sophuspy / projectaria environments
    obj = MAKERS[lib](R0, T0_)
    T = interop.from_library(obj)
    np.testing.assert_allclose(T, T0, rtol=0, atol=1e-14)  # the pose the library means
    f = POSE_FUNCS[func]
    _same(f(obj), f(T))  # and the function reads it as that matrix


@pytest.mark.parametrize("func", list(ROT_FUNCS))
@pytest.mark.parametrize("lib", LIBS)
def test_every_rotation_function_takes_the_librarys_rotation(lib: str, func: str) -> None:
    obj = MAKERS[lib](R0, None)
    R = interop.from_library(obj)
    np.testing.assert_allclose(R, R0, rtol=0, atol=1e-14)
    f = ROT_FUNCS[func]
    _same(f(obj), f(R))


@pytest.mark.parametrize("lib", LIBS)
def test_a_list_of_library_poses_is_a_batch(lib: str) -> None:
    objs = [MAKERS[lib](R0, T0_), MAKERS[lib](R1, T1_)]
    np.testing.assert_allclose(se3.log(objs), se3.log(np.stack([T0, T1])), atol=1e-12)
    np.testing.assert_allclose(se3.log(tuple(objs)), se3.log(np.stack([T0, T1])), atol=1e-12)


def test_vectorized_objects_are_read_whole_not_their_first_value() -> None:
    """np.asarray(spatialmath.SE3 holding 2 poses) is the first pose only: liebridge reads both."""
    sm = pytest.importorskip("spatialmath")
    from scipy.spatial.transform import Rotation

    two = sm.SE3([sm.SE3(T0), sm.SE3(T1)])
    assert np.asarray(two).shape == (4, 4)  # the trap
    np.testing.assert_allclose(interop.from_library(two), np.stack([T0, T1]), atol=1e-15)
    rots = Rotation.from_rotvec(np.stack([so3.log(R0), so3.log(R1)]))
    np.testing.assert_allclose(so3.log(rots), np.stack([so3.log(R0), so3.log(R1)]), atol=1e-12)


# ------------------------------------------------------------------------------- back: to_library
@pytest.mark.parametrize("lib", LIBS)
@pytest.mark.parametrize("group", ["pose", "rotation"])
def test_to_library_returns_the_callers_type(lib: str, group: str) -> None:
    like = MAKERS[lib](R1, None if group == "rotation" else T1_)
    M = T0 if group == "pose" else R0
    out = interop.to_library(M, like=like)
    assert type(out) is type(like)
    np.testing.assert_allclose(interop.from_library(out), M, atol=1e-12)
    # the class itself works too, and the library means the same pose as the matrix
    assert type(interop.to_library(M, like=type(like))) is type(like)
    np.testing.assert_allclose(
        interop.from_library(out),
        interop.from_library(MAKERS[lib](R0, None if group == "rotation" else T0_)),
        atol=1e-12,
    )


@pytest.mark.parametrize("lib", LIBS)
def test_to_library_of_a_batch(lib: str) -> None:
    like = MAKERS[lib](R1, T1_)
    batch = np.stack([T0, T1, T0])
    out = interop.to_library(batch, like=like)
    np.testing.assert_allclose(interop.from_library(out), batch, atol=1e-12)
    if isinstance(out, list):
        assert len(out) == 3 and all(type(o) is type(like) for o in out)


def test_results_flow_back_in_the_callers_type() -> None:
    gtsam = pytest.importorskip("gtsam")
    P = gtsam.Pose3(gtsam.Rot3(R0), T0_)
    Q = interop.to_library(se3.compose(P, se3.exp(np.full(6, 0.1))), like=P)
    assert isinstance(Q, gtsam.Pose3)
    assert Q.equals(P.compose(gtsam.Pose3.Expmap(np.full(6, 0.1))), 1e-12)


def test_planar_gtsam_round_trip() -> None:
    gtsam = pytest.importorskip("gtsam")
    p = gtsam.Pose2(1.0, -2.0, 2.5)
    q = interop.to_library(interop.from_library(p), like=gtsam.Pose2)
    assert q.equals(p, 1e-15)
    r = interop.to_library(interop.from_library(gtsam.Rot2(-1.0)), like=gtsam.Rot2)
    assert abs(r.theta() + 1.0) < 1e-15
    with pytest.raises(ValueError, match="T: not a planar rotation"):
        interop.to_library(np.diag([1.0, 2.0, 1.0]), like=gtsam.Pose2)


# ------------------------------------------------------------------------------- bad input
def test_unknown_objects_get_one_clear_error() -> None:
    class Pose:  # someone's own class
        pass

    with pytest.raises(TypeError, match=r"T: expected a numeric array, or a pose/rotation of GTS"):
        se3.log(Pose())
    with pytest.raises(TypeError, match=r"X: expected .* got .*Pose"):
        lb.convert_covariance(COV, Pose(), "gtsam", "ros")


def test_known_library_unsupported_class_is_named() -> None:
    gtsam = pytest.importorskip("gtsam")
    with pytest.raises(TypeError, match=r"T: gtsam\.NavState is not a pose or rotation"):
        se3.log(gtsam.NavState())
    with pytest.raises(TypeError, match=r"T: item 1 is a ndarray, item 0 a gtsam\.Pose3"):
        se3.log([gtsam.Pose3(), np.eye(4)])
    with pytest.raises(ValueError, match=r"T: expected shape \(\.\.\., 4, 4\), got \(3, 3\)"):
        se3.log(gtsam.Rot3())  # a rotation where a pose is expected
    with pytest.raises(TypeError, match="like: expected an object or class among"):
        interop.to_library(T0, like=np.eye(4))
    with pytest.raises(ValueError, match="T: not a rotation at batch index"):
        interop.to_library(np.diag([1.0, 1.0, 2.0, 1.0]), like=gtsam.Pose3)


def test_no_library_is_imported_unless_the_object_is_theirs() -> None:
    code = (
        "import sys, numpy as np, liebridge as lb\n"
        "lb.lie.se3.log(np.eye(4).tolist()); lb.convert_covariance(np.eye(6), np.eye(4), "
        "'gtsam', 'ros')\n"
        "try:\n    lb.lie.se3.log(object())\nexcept TypeError:\n    pass\n"
        "bad = [m for m in ('gtsam', 'pinocchio', 'spatialmath', 'sophuspy', "
        "'projectaria_tools', 'scipy.spatial.transform') if m in sys.modules]\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
