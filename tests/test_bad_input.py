"""What bad input gets (DESIGN.md): one table of cases, each with the message fragment it must show.

Every case calls a public function with one defect and expects a ``ValueError`` (``TypeError`` for
a wrong type) whose message names the argument, the batch index and the size of the violation
(files: the file and line). The tolerances are those documented in ``liebridge._validate``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import liebridge as lb
from liebridge import _validate
from liebridge.conventions import Convention, ConventionNotDetected, get
from liebridge.gtsam.pose_factors import between, prior
from liebridge.io import g2o, poses
from liebridge.io import trajectory as trajectory_io
from liebridge.lie import quaternion as Q
from liebridge.lie import se3, so3

# --------------------------------------------------------------------------- fixtures as data
R0 = Rotation.from_rotvec([0.3, -0.4, 0.5]).as_matrix()
T0 = np.eye(4)
T0[:3, :3] = R0
T0[:3, 3] = [1.0, -2.0, 0.5]
C6 = np.diag([1.0, 2.0, 3.0, 0.1, 0.2, 0.3])
I6 = np.eye(6)


def batch(x: np.ndarray, n: int = 3) -> np.ndarray:
    return np.stack([x] * n)


def with_entry(x: np.ndarray, index: tuple[int, ...], value: float) -> np.ndarray:
    y = np.array(x, dtype=np.float64, copy=True)
    y[index] = value
    return y


def scaled_rotation(T: np.ndarray, k: int, s: float) -> np.ndarray:
    """Batch of 3 copies of T with the rotation of element k scaled by s (not orthonormal)."""
    Tb = batch(T)
    Tb[k, :3, :3] *= s
    return Tb


def reflected(T: np.ndarray) -> np.ndarray:
    out = np.array(T, copy=True)
    out[..., :3, 2] *= -1.0  # det −1, still orthonormal
    return out


REFLECTION_2D = np.broadcast_to(T0, (2, 3, 4, 4)).copy()
REFLECTION_2D[0, 1] = reflected(T0)
ASYM = batch(C6)
ASYM[1, 0, 5] += 0.5
INDEFINITE = np.diag([1.0, 1.0, -1.0, 1.0, 1.0, 1.0])
QUAT_BATCH = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))
QUAT_BATCH[1] = [0.0, 0.0, 0.0, 2.0]
POSE7 = np.tile([1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0], (3, 1))
POSE7[1, 6] = 2.0
# Ad(X) holds t₀·R₁₀ − t₁·R₀₀ = 0.707·(1.5e308 + 1.5e308): not representable
HUGE_T = np.eye(4)
HUGE_T[:3, :3] = Rotation.from_rotvec([0.0, 0.0, np.pi / 4]).as_matrix()
HUGE_T[:3, 3] = [1.5e308, -1.5e308, 0.0]


class Case:
    """One row of the table: a call, the exception type and a regex its message must match."""

    def __init__(
        self, id: str, call: Callable[[], Any], match: str, exc: type[Exception] = ValueError
    ) -> None:
        self.id, self.call, self.match, self.exc = id, call, match, exc


def bad_retract_shape(X: Any, d: Any) -> np.ndarray:
    return np.eye(3)


CASES = [
    # --- NaN / Inf: the argument, the batch index and the entry -----------------------------
    Case(
        "nan-rotvec-batch",
        lambda: so3.exp(with_entry(np.zeros((3, 3)), (1, 0), np.nan)),
        r"w: contains NaN or Inf at batch index \(1,\), entry \(0,\)",
    ),
    Case(
        "inf-pose-translation",
        lambda: se3.log(with_entry(batch(T0), (2, 1, 3), np.inf)),
        r"T: contains NaN or Inf at batch index \(2,\), entry \(1, 3\)",
    ),
    Case(
        "nan-tangent_map-X",
        lambda: lb.tangent_map(with_entry(T0, (0, 0), np.nan), "gtsam", "sophus"),
        r"X: contains NaN or Inf at batch index \(\), entry \(0, 0\)",
    ),
    Case(
        "nan-covariance",
        lambda: lb.convert_covariance(with_entry(C6, (2, 2), np.nan), T0, "gtsam", "barfoot"),
        r"cov: contains NaN or Inf at batch index \(\), entry \(2, 2\)",
    ),
    Case(
        "inf-retract-increment",
        lambda: get("sophus").retract(T0, with_entry(np.zeros(6), (4,), -np.inf)),
        r"d: contains NaN or Inf at batch index \(\), entry \(4,\)",
    ),
    Case(
        "nan-jacobian",
        lambda: lb.convert_jacobian(
            with_entry(batch(I6), (1, 0, 0), np.nan),
            T0,
            "gtsam",
            "sophus",
        ),
        r"J: contains NaN or Inf at batch index \(1,\), entry \(0, 0\)",
    ),
    Case(
        "nan-interpolation-tau",
        lambda: se3.interpolate(T0, T0, np.nan),
        r"tau: contains NaN or Inf",
    ),
    Case(
        "nan-pose-layout",
        lambda: poses.to_matrix(with_entry(POSE7[0], (1,), np.nan), layout="xyz_qxyzw"),
        r"x: contains NaN or Inf at index \(1,\)",
    ),
    Case(
        "nan-factor-covariance",
        lambda: between(0, 1, T0, with_entry(C6, (0, 0), np.nan), "barfoot"),
        r"cov: contains NaN or Inf",
    ),
    # --- wrong shapes -----------------------------------------------------------------------
    Case(
        "shape-rotvec", lambda: so3.exp(np.zeros(4)), r"w: expected shape \(\.\.\., 3\), got \(4,\)"
    ),
    Case("shape-pose", lambda: se3.log(np.eye(3, 4)), r"T: expected shape \(\.\.\., 4, 4\), got"),
    Case(
        "shape-group-element",
        lambda: lb.tangent_map(np.eye(5), "gtsam", "sophus"),
        r"X: expected a pose \(\.\.\., 4, 4\) or a rotation \(\.\.\., 3, 3\), got \(5, 5\)",
    ),
    Case(
        "shape-covariance",
        lambda: lb.convert_covariance(np.eye(6, 5), T0, "gtsam", "barfoot"),
        r"cov: expected shape \(\.\.\., 6, 6\), got \(6, 5\)",
    ),
    Case(
        "shape-covariance-for-rotation",
        lambda: lb.convert_covariance(C6, R0, "gtsam", "barfoot"),
        r"cov: expected shape \(\.\.\., 3, 3\), got \(6, 6\)",
    ),
    Case(
        "shape-increment",
        lambda: get("gtsam").retract(T0, np.zeros(3)),
        r"d: expected shape \(\.\.\., 6\), got \(3,\)",
    ),
    Case(
        "shape-local-mixed-groups",
        lambda: get("gtsam").local(T0, R0),
        r"Y: shape \(3, 3\) does not match X \(4, 4\)",
    ),
    Case(
        "shape-local_jacobian-mixed-groups",
        lambda: get("gtsam").local_jacobian(T0, R0),
        r"Y: shape \(3, 3\) does not match X \(4, 4\)",
    ),
    Case(
        "shape-jacobian-vector",
        lambda: lb.convert_jacobian(np.zeros(6), T0, "gtsam", "sophus"),
        r"J: expected shape \(\.\.\., m, n\), got \(6,\)",
    ),
    Case(
        "shape-jacobian-columns",
        lambda: lb.convert_jacobian(np.zeros((6, 5)), T0, "gtsam", "sophus"),
        r"J: 5 columns, but the input tangent has 6",
    ),
    Case(
        "shape-pose-layout",
        lambda: poses.to_matrix(np.zeros(8), layout="xyz_qxyzw"),
        r"x: layout 'xyz_qxyzw' expects shape \(\.\.\., 7\), got \(8,\)",
    ),
    Case(
        "shape-factor-batch",
        lambda: between(0, 1, batch(T0), C6, "gtsam"),
        r"measured: expected one se3 element \(Pose3\) \(4, 4\) for convention .gtsam., "
        r"got \(3, 4, 4\)",
    ),
    # --- batch shapes that do not broadcast: both arguments named ---------------------------
    Case(
        "batch-compose",
        lambda: se3.compose(batch(T0, 2), batch(T0, 3)),
        r"batch shapes do not broadcast: T1 \(2,\), T2 \(3,\)",
    ),
    Case(
        "batch-retract",
        lambda: get("barfoot").retract(batch(T0, 2), np.zeros((3, 6))),
        r"batch shapes do not broadcast: X \(2,\), d \(3,\)",
    ),
    Case(
        "batch-covariance",
        lambda: lb.convert_covariance(batch(C6, 3), batch(T0, 2), "gtsam", "barfoot"),
        r"batch shapes do not broadcast: cov \(3,\), X \(2,\)",
    ),
    Case(
        "batch-jacobian",
        lambda: lb.convert_jacobian(batch(I6, 3), None, "gtsam", "sophus", at_output=batch(T0, 2)),
        r"batch shapes do not broadcast: J \(3,\), at_output \(2,\)",
    ),
    Case(
        "batch-slerp",
        lambda: Q.slerp(QUAT_BATCH[[0, 2]], QUAT_BATCH[[0, 2, 0]], 0.5, order="xyzw"),
        r"batch shapes do not broadcast: q0 \(2,\), q1 \(3,\), tau \(\)",
    ),
    # --- not orthonormal: batch index, size, tolerance, the explicit projection -------------
    Case(
        "rotation-not-orthonormal",
        lambda: so3.log(scaled_rotation(T0, 1, 1.001)[:, :3, :3]),
        r"R: not a rotation at batch index \(1,\): max\|RᵀR − I\| = 0\.002 > tolerance 1e-06 "
        r"\(use liebridge\.lie\.so3\.project",
    ),
    Case(
        "pose-not-orthonormal",
        lambda: se3.inverse(scaled_rotation(T0, 2, 1 + 1e-5)),
        r"T: not a rotation at batch index \(2,\): max\|RᵀR − I\| = 2e-05 > tolerance 1e-06",
    ),
    Case(
        "convention-not-orthonormal",
        lambda: get("pinocchio").to_canonical(scaled_rotation(T0, 0, 0.9)),
        r"X: not a rotation at batch index \(0,\)",
    ),
    Case(
        "factor-measurement-not-orthonormal",
        lambda: between(0, 1, scaled_rotation(T0, 0, 1.01)[0], C6, "barfoot"),
        r"measured: not a rotation at batch index \(\)",
    ),
    Case(
        "pose-bottom-row",
        lambda: lb.tangent_map(with_entry(batch(T0), (1, 3, 0), 1e-9), "gtsam", "sophus"),
        r"X: bottom row is \[1e-09, 0\.0, 0\.0, 1\.0\], not \[0, 0, 0, 1\], at batch index \(1,\)",
    ),
    # --- det < 0 -----------------------------------------------------------------------------
    Case(
        "rotation-reflection",
        lambda: so3.log(reflected(R0)),
        r"R: det\(R\) = -1 < 0 at batch index \(\) \(a reflection\)",
    ),
    Case(
        "pose-reflection-2d-batch",
        lambda: lb.tangent_map(REFLECTION_2D, "gtsam", "barfoot"),
        r"X: det\(R\) = -1 < 0 at batch index \(0, 1\)",
    ),
    Case(
        "kitti-layout-reflection",
        lambda: poses.to_matrix(reflected(T0)[:3].reshape(12), layout="kitti"),
        r"x: det\(R\) = -1 < 0",
    ),
    Case(
        "prior-reflection",
        lambda: prior(0, reflected(T0), C6, "gtsam"),
        r"pose: det\(R\) = -1 < 0",
    ),
    # --- non-unit quaternions ----------------------------------------------------------------
    Case(
        "quaternion-norm",
        lambda: Q.to_matrix([1.0, 1.0, 0.0, 0.0], order="wxyz"),
        r"q: quaternion norm off by 0\.414 at batch index \(\) \(tolerance 1e-06\)",
    ),
    Case(
        "quaternion-norm-batch",
        lambda: Q.multiply(QUAT_BATCH, QUAT_BATCH[0], order="xyzw"),
        r"q1: quaternion norm off by 1 at batch index \(1,\)",
    ),
    Case(
        "quaternion-conjugate-zero",
        lambda: Q.conjugate(np.zeros(4), order="wxyz"),
        r"q: quaternion norm off by 1",
    ),
    Case(
        "pose-layout-quaternion",
        lambda: poses.to_matrix(POSE7, layout="xyz_qxyzw"),
        r"quaternion norm off by 1 at batch index \(1,\) \(tolerance 1e-06\)",
    ),
    # --- covariances -------------------------------------------------------------------------
    Case(
        "covariance-asymmetric",
        lambda: lb.convert_covariance(ASYM, batch(T0), "gtsam", "barfoot"),
        r"cov: not symmetric at batch index \(1,\): relative asymmetry 0\.167",
    ),
    Case(
        "covariance-indefinite",
        lambda: lb.convert_covariance(INDEFINITE, T0, "gtsam", "barfoot"),
        r"cov: not positive semi-definite at batch index \(\): smallest eigenvalue -1",
    ),
    Case(
        "information-indefinite",
        lambda: lb.convert_information(batch(INDEFINITE, 2), T0, "g2o", "gtsam"),
        r"info: not positive semi-definite at batch index \(0,\)",
    ),
    Case(
        "factor-covariance-asymmetric",
        lambda: prior(0, T0, ASYM[1], "sophus"),
        r"cov: not symmetric at batch index \(\)",
    ),
    # --- unknown names: the closest suggestions ----------------------------------------------
    Case(
        "convention-misspelt",
        lambda: lb.tangent_map(T0, "gtsam", "barfot"),
        r"convention: unknown name 'barfot'; did you mean 'barfoot'",
    ),
    Case(
        "convention-misspelt-get",
        lambda: get("sophsu"),
        r"unknown name 'sophsu'; did you mean 'sophus'\?",
    ),
    Case(
        "convention-not-a-name",
        lambda: lb.convert_covariance(C6, T0, 3, "gtsam"),
        r"convention: expected a Convention or a name, got int",
        TypeError,
    ),
    Case(
        "factor-convention-misspelt",
        lambda: between(0, 1, T0, C6, "pinochio"),
        r"did you mean 'pinocchio'",
    ),
    Case(
        "convention-field",
        lambda: Convention("mine", "up", "rot_first", "se3", "exp", "wxyz"),  # type: ignore[arg-type]
        r"Convention\.side: expected one of \('right', 'left'\), got 'up'",
    ),
    Case(
        "layout-misspelt",
        lambda: poses.to_matrix(POSE7[0], layout="xyz_qwxy"),
        r"layout: unknown layout 'xyz_qwxy'; did you mean 'xyz_qwxyz'",
    ),
    Case(
        "layout-library-name",
        lambda: poses.from_matrix(T0, layout="tum"),
        r"unknown layout 'tum'; did you mean 'xyz_qxyzw'",
    ),
    Case(
        "quaternion-order",
        lambda: Q.to_matrix([1.0, 0.0, 0.0, 0.0], order="qwxyz"),  # type: ignore[arg-type]
        r"order: expected one of 'wxyz', 'xyzw', 'jpl', got 'qwxyz'",
    ),
    Case(
        "covariance-method",
        lambda: lb.convert_covariance(C6, T0, "gtsam", "g2o", method="sigma"),  # type: ignore[arg-type]
        r"method: expected 'linear' or 'unscented', got 'sigma'",
    ),
    # --- wrong types -------------------------------------------------------------------------
    Case(
        "type-complex",
        lambda: se3.exp(np.zeros(6) + 1j),
        r"xi: expected a real numeric array, got complex values",
        TypeError,
    ),
    Case(
        "type-string",
        lambda: so3.hat(["1", "2", "3"]),
        r"w: expected a numeric array, got dtype <U1",
        TypeError,
    ),
    Case("type-none", lambda: lb.tangent_map(None, "gtsam", "sophus"), r"X: .*got None", TypeError),
    Case(
        "type-ragged",
        lambda: se3.exp([[0.0] * 6, [0.0] * 5]),
        r"xi: expected a numeric array, got list",
        TypeError,
    ),
    Case(
        "int-too-large",
        lambda: so3.exp([10**400, 0, 0]),
        r"w: a value does not fit in float64",
    ),
    # --- magnitudes float64 cannot compute with: an error, never Inf/NaN ---------------------
    Case(
        "rotvec-too-large",
        lambda: so3.exp(batch(np.array([1e200, 1e200, 0.0]))),
        r"w: rotation part of norm 1\.41e\+200 at batch index \(0,\) exceeds 1e\+12 rad",
    ),
    Case(
        "increment-too-large",
        lambda: get("sophus").retract(T0, [0.0, 0.0, 0.0, 0.0, 2e12, 0.0]),
        r"d: rotation part of norm 2e\+12 at batch index \(\) exceeds 1e\+12 rad",
    ),
    Case(
        "overflow-twist",
        lambda: se3.exp([0.0, 0.0, 1.5, 1.5e308, 1.5e308, 0.0]),
        r"se3\.exp: the result overflows float64 \(entry \(\d, 3\) is not finite\)",
    ),
    Case(
        "overflow-tangent_map",
        lambda: lb.tangent_map(HUGE_T, "gtsam", "barfoot"),
        r"tangent_map: the result overflows float64",
    ),
    Case(
        "overflow-covariance",
        lambda: lb.convert_covariance(C6 * 1e300, with_entry(T0, (0, 3), 1e10), "gtsam", "barfoot"),
        r"convert_covariance: the result overflows float64",
    ),
    # --- domains of rotation coordinates -----------------------------------------------------
    Case(
        "quat_vec-outside-unit-ball",
        lambda: get("g2o").retract(T0, [0.0, 0.0, 0.0, 1.5, 0.0, 0.0]),
        r"d: quaternion-vector rotation coordinates need ‖r‖ ≤ 1, got ‖r‖ = 1\.5",
    ),
    Case(
        "cayley-at-pi",
        lambda: lb.convert_tangent(
            np.array([np.pi, 0, 0, 0, 0, 0]), np.eye(4), "gtsam", "gtsam_cayley"
        ),
        r"Cayley coordinates are undefined for a rotation by π",
    ),
    # --- detect_convention with a bad retraction ---------------------------------------------
    Case(
        "detect-not-callable",
        lambda: lb.detect_convention(3),  # type: ignore[arg-type]
        r"retract: expected a callable retract\(X, d\), got int",
        TypeError,
    ),
    Case(
        "detect-returns-text",
        lambda: lb.detect_convention(lambda X, d: "pose"),
        r"retract\(X, d\) at probe 0: expected a numeric array, got dtype <U4",
        TypeError,
    ),
    Case(
        "detect-returns-none",
        lambda: lb.detect_convention(lambda X, d: None),
        r"retract\(X, d\) at probe 0: expected a numeric array, got None",
        TypeError,
    ),
    Case(
        "detect-returns-nan",
        lambda: lb.detect_convention(lambda X, d: np.full((4, 4), np.nan)),
        r"retract\(X, d\) at probe 0: contains NaN or Inf",
    ),
    Case(
        "detect-returns-wrong-shape",
        lambda: lb.detect_convention(bad_retract_shape),
        r"retract\(X, d\) at probe 0 returned shape \(3, 3\), expected \(4, 4\)",
        ConventionNotDetected,
    ),
    Case(
        "detect-group",
        lambda: lb.detect_convention(lambda X, d: X, group="se4"),  # type: ignore[arg-type]
        r"group: expected one of 'so2', 'se2', 'so3', 'se3', 'sim3', 'se23'(, '\w+')*, got 'se4'",
    ),
]


# numpy reports the overflow it met before liebridge turns the result into a ValueError
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_table(case: Case) -> None:
    with pytest.raises(case.exc, match=case.match):
        case.call()


def test_table_ids_are_unique() -> None:
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))


# --------------------------------------------------------------------------- malformed files
INFO21 = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1"
VERTICES = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
EDGE = f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {INFO21}\n"

FILE_CASES: list[tuple[str, str, Callable[[Path], Any], bytes | str, str]] = [
    # (id, file name, reader, content, message fragment after "<path>:")
    (
        "g2o-short-edge",
        "a.g2o",
        g2o.read,
        VERTICES + "EDGE_SE3:QUAT 0 1 1 0 0\n",
        r":3: EDGE_SE3:QUAT expects 28 values after the id\(s\) .* got 3",
    ),
    (
        "g2o-not-a-number",
        "b.g2o",
        g2o.read,
        VERTICES + EDGE.replace(" 1 0 0 0 0 0 1 ", " 1 0 0 x 0 0 1 ", 1),
        r":3: not a number: 'x' \(EDGE_SE3:QUAT\)",
    ),
    (
        "g2o-nan",
        "c.g2o",
        g2o.read,
        VERTICES.replace("1 1 0", "1 nan 0"),
        r":2: NaN or Inf \(VERTEX_SE3:QUAT\)",
    ),
    (
        "g2o-quaternion",
        "d.g2o",
        g2o.read,
        VERTICES.replace("0 0 0 1\nVERTEX_SE3:QUAT 1", "0 0 0 2\nVERTEX_SE3:QUAT 1"),
        r":1: quaternion norm off by 1 \(tolerance",
    ),
    (
        "g2o-unknown-tag",
        "e.g2o",
        g2o.read,
        VERTICES + "EDGE_SE3:EULER 0 1\n",
        r":3: unsupported tag 'EDGE_SE3:EULER'",
    ),
    (
        "g2o-2d",
        "f.g2o",
        g2o.read,
        "VERTEX_SE2 0 0 0 0\n",
        r":1: 2-D type VERTEX_SE2 in a 3-D file: read it with liebridge.io.g2o2d.read",
    ),
    (
        "g2o-indefinite-information",
        "g.g2o",
        g2o.read,
        VERTICES + EDGE.replace(INFO21, "-1" + INFO21[1:]),
        r":3: information: not positive semi-definite",
    ),
    (
        "g2o-duplicate-vertex",
        "h.g2o",
        g2o.read,
        VERTICES + VERTICES[:33],
        r":3: vertex 0 already defined on line 1",
    ),
    (
        "g2o-missing-vertex",
        "i.g2o",
        g2o.read,
        VERTICES + EDGE.replace("0 1 1", "0 7 1", 1),
        r":3: edge refers to vertex 7, which has no VERTEX line",
    ),
    ("g2o-not-utf8", "j.g2o", g2o.read, VERTICES.encode() + b"\xff\xfe\n", r":3: not UTF-8 text"),
    (
        "tum-short-line",
        "a.txt",
        trajectory_io.read_tum,
        "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n",
        r":2: expected 8 numbers \(timestamp tx ty tz qx qy qz qw\), got 7",
    ),
    (
        "tum-quaternion",
        "b.txt",
        trajectory_io.read_tum,
        "# header\n0 0 0 0 0.5 0 0 1\n",
        r":2: quaternion norm off by 0\.118",
    ),
    ("tum-inf", "c.txt", trajectory_io.read_tum, "0 inf 0 0 0 0 0 1\n", r":1: NaN or Inf"),
    (
        "tum-not-utf8",
        "d.txt",
        trajectory_io.read_tum,
        b"0 0 0 0 0 0 0 1\n\n\xe9t\xe9\n",
        r":3: not UTF-8 text",
    ),
    (
        "kitti-word",
        "a.kitti",
        trajectory_io.read_kitti,
        "1 0 0 0 0 1 0 0 0 0 one 0\n",
        r":1: not a number: 'one'",
    ),
    (
        "kitti-reflection",
        "b.kitti",
        trajectory_io.read_kitti,
        "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 -1 0\n",
        r":2: rotation block is not a rotation: .* det = -1",
    ),
    (
        "kitti-not-orthonormal",
        "c.kitti",
        trajectory_io.read_kitti,
        "1 0 0 0 0 1 0 0 0 0 1.01 0\n",
        r":1: rotation block is not a rotation: max\|RᵀR − I\| = 0\.0201",
    ),
]


@pytest.mark.parametrize("case", FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_malformed_file_names_file_and_line(
    case: tuple[str, str, Callable[[Path], Any], bytes | str, str], tmp_path: Path
) -> None:
    _, name, reader, content, fragment = case
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    with pytest.raises(ValueError, match=str(path).replace(".", r"\.") + fragment):
        reader(path)


# --------------------------------------------------------------------------- documented tolerances
def test_rotation_tolerance_is_the_documented_one() -> None:
    assert _validate.ROTATION_TOL == 1e-6
    inside = R0 * (1 + 0.4e-6)  # max|RᵀR − I| ≈ 0.8e-6
    outside = R0 * (1 + 0.6e-6)  # ≈ 1.2e-6
    so3.log(inside)
    with pytest.raises(ValueError, match="not a rotation"):
        so3.log(outside)
    # a looser tolerance is the caller's explicit choice
    poses.to_matrix(_kitti(outside), layout="kitti", tol=1e-5)


def _kitti(R: np.ndarray) -> np.ndarray:
    return np.concatenate([R, np.zeros((3, 1))], axis=1).reshape(12)


def test_projection_is_the_explicit_opt_in() -> None:
    drifted = R0 + 1e-3 * np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"use liebridge\.lie\.so3\.project"):
        so3.log(drifted)
    fixed = so3.project(drifted)
    np.testing.assert_allclose(so3.log(fixed), so3.log(R0), atol=2e-3)
    np.testing.assert_allclose(fixed.T @ fixed, np.eye(3), atol=1e-15)


def test_quaternion_tolerance_is_the_documented_one() -> None:
    assert _validate.QUATERNION_TOL == 1e-6
    Q.to_matrix([1.0 + 0.9e-6, 0.0, 0.0, 0.0], order="wxyz")
    with pytest.raises(ValueError, match=r"quaternion norm off by 1\.1e-06"):
        Q.to_matrix([1.0 + 1.1e-6, 0.0, 0.0, 0.0], order="wxyz")


def test_covariance_tolerances_and_semidefinite_input() -> None:
    assert _validate.COVARIANCE_TOL == 1e-9
    # positive semi-definite but singular (no Cholesky factor): accepted by the exact check
    singular = np.zeros((6, 6))
    singular[:3, :3] = np.eye(3)
    lb.convert_covariance(singular, T0, "gtsam", "barfoot")
    lb.convert_covariance(np.zeros((2, 6, 6)), batch(T0, 2), "gtsam", "barfoot")
    # asymmetry and negative eigenvalues within the relative tolerance
    near = C6.copy()
    near[0, 1] += 1e-10
    lb.convert_covariance(near, T0, "gtsam", "sophus")
    lb.convert_covariance(C6 - 1e-10 * np.eye(6) * 3.0, T0, "gtsam", "sophus")
    tiny_negative = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, -1e-10])
    lb.convert_covariance(tiny_negative, T0, "gtsam", "sophus")
    with pytest.raises(ValueError, match="not positive semi-definite"):
        lb.convert_covariance(np.diag([1.0, 1.0, 1.0, 1.0, 1.0, -1e-8]), T0, "gtsam", "sophus")


def test_certificate_and_exact_check_agree_on_single_elements() -> None:
    """The fast certificate never accepts what the exact (batched) check rejects."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        T = T0.copy()
        kind = rng.integers(5)
        if kind == 0:
            T[:3, :3] *= 1 + rng.choice([-1, 1]) * 10.0 ** rng.uniform(-8, -5)
        elif kind == 1:
            T[:3, :3] = reflected(T[:3, :3])
        elif kind == 2:
            T[3, rng.integers(4)] += 10.0 ** rng.uniform(-300, 0)
        elif kind == 3:
            T[rng.integers(3), 3] = rng.choice([np.inf, -np.inf, np.nan, 1e300])
        single_ok = _accepts(lambda T=T: _validate.pose(T, "T"))
        batch_ok = _accepts(lambda T=T: _validate.pose(np.stack([T, T0]), "T"))
        assert single_ok == batch_ok, (kind, T)


def _accepts(fn: Callable[[], Any]) -> bool:
    try:
        fn()
    except ValueError:
        return False
    return True


def test_inputs_are_not_mutated_by_failing_calls() -> None:
    bad = scaled_rotation(T0, 1, 1.1)
    keep = bad.copy()
    with pytest.raises(ValueError):
        lb.convert_covariance(batch(C6), bad, "gtsam", "barfoot")
    np.testing.assert_array_equal(bad, keep)
