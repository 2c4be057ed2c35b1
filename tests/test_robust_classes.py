"""Regression tests for the 13 classes of wrong outcome, one or more per class.

Each test is named after its class (``test_classN_...``) and failed on the code before the fix:
a silent wrong answer, a traceback instead of one clear error, or a hang. What each class gets
now is tabulated in ``docs/bad-input.md``.
"""

from __future__ import annotations

import math
import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import gtsam
import numpy as np
import pytest

from liebridge.gtsam import between, optimize, prior


@contextmanager
def within(seconds: float) -> Iterator[None]:
    """Fail (instead of hanging the suite) if the block runs longer than ``seconds``."""
    if sys.platform == "win32":
        yield
        return

    def _timeout(signum: int, frame: object) -> None:
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, _timeout)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


T1 = np.eye(4)
T1[0, 3] = 1.0


def _small_graph() -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(0, np.eye(4), np.eye(6), native=False))
    g.add(between(0, 1, T1, np.eye(6)))
    v = gtsam.Values()
    v.insert(0, gtsam.Pose3(gtsam.Rot3.Rx(0.2), [0.1, 0.0, 0.0]))
    v.insert(1, gtsam.Pose3())
    return g, v


# --------------------------------------------------------------------------- class 5
@pytest.mark.parametrize("batch", [True, False])
def test_class5_unused_key_is_optimized_like_gtsam(batch: bool) -> None:
    g, v = _small_graph()
    v.insert(7, gtsam.Pose3(gtsam.Rot3.Ry(0.3), [1.0, 2.0, 3.0]))  # no factor uses key 7
    res = optimize(g, v, batch=batch)
    ref = gtsam.LevenbergMarquardtOptimizer(g, v, gtsam.LevenbergMarquardtParams()).optimize()
    assert res.initial_error > 0.1
    assert res.final_error < 1e-12
    assert abs(res.final_error - g.error(ref)) < 1e-12
    assert res.values.atPose3(7).equals(v.atPose3(7), 0.0)  # unused key returned unchanged
    assert res.values.size() == 3


def test_class13_factor_key_missing_from_values_is_a_clear_error() -> None:
    g, v = _small_graph()
    g.add(gtsam.BetweenFactorPose3(1, 9, gtsam.Pose3(), gtsam.noiseModel.Unit.Create(6)))
    with pytest.raises(ValueError, match=r"values: no value for key 9 .*factor 2"):
        optimize(g, v)


# --------------------------------------------------------------------------- class 11
def _lm(**kw: float) -> gtsam.LevenbergMarquardtParams:
    p = gtsam.LevenbergMarquardtParams()
    for name, val in kw.items():
        getattr(p, "set" + name)(val)
    return p


@pytest.mark.parametrize(
    ("setting", "match"),
    [
        ({"lambdaInitial": math.nan}, r"params\.lambdaInitial: .*nan"),
        ({"lambdaInitial": -1.0}, r"params\.lambdaInitial: .*-1"),
        ({"lambdaInitial": 0.0}, r"params\.lambdaInitial"),
        ({"lambdaFactor": 1.0}, r"params\.lambdaFactor"),
        ({"lambdaFactor": math.inf}, r"params\.lambdaFactor"),
        ({"lambdaUpperBound": math.nan}, r"params\.lambdaUpperBound"),
        ({"lambdaLowerBound": -1.0}, r"params\.lambdaLowerBound"),
        ({"RelativeErrorTol": math.nan}, r"params\.relativeErrorTol"),
        ({"AbsoluteErrorTol": -1.0}, r"params\.absoluteErrorTol"),
        ({"ErrorTol": math.nan}, r"params\.errorTol"),
    ],
)
def test_class11_bad_lm_parameters_raise_before_work(setting: dict[str, float], match: str) -> None:
    g, v = _small_graph()
    with within(10.0), pytest.raises(ValueError, match=match):
        optimize(g, v, _lm(**setting))


def test_class11_lambda_bounds_that_cannot_hold_are_refused() -> None:
    g, v = _small_graph()
    with pytest.raises(ValueError, match=r"params\.lambdaLowerBound .* lambdaUpperBound"):
        optimize(g, v, _lm(lambdaLowerBound=10.0, lambdaUpperBound=1.0))


@pytest.mark.parametrize("params", ["fast", gtsam.GaussNewtonParams(), 3])
def test_class13_params_of_another_kind_are_refused(params: object) -> None:
    g, v = _small_graph()
    with pytest.raises(TypeError, match=r"params: expected gtsam\.LevenbergMarquardtParams"):
        optimize(g, v, params)


# --------------------------------------------------------------------------- class 7
SINGULAR = [
    ("zero", np.zeros((6, 6))),
    ("rank5", np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])),
    ("numerically-singular", np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 1e-17])),
]


@pytest.mark.parametrize(("label", "cov"), SINGULAR, ids=[s[0] for s in SINGULAR])
@pytest.mark.parametrize("native", [True, False])
@pytest.mark.parametrize("kind", ["between", "prior"])
def test_class7_singular_covariance_is_refused_at_construction(
    label: str, cov: np.ndarray, native: bool, kind: str
) -> None:
    with pytest.raises(ValueError, match=r"cov: singular covariance .*smallest eigenvalue"):
        if kind == "between":
            between(0, 1, T1, cov, "barfoot", native=native)
        else:
            prior(0, T1, cov, "sophus", native=native)


def test_class7_well_conditioned_but_anisotropic_covariance_is_accepted() -> None:
    cov = np.diag([1e-8, 1e-8, 1e-8, 1e4, 1e4, 1e4])  # condition 1e12: legitimate
    between(0, 1, T1, cov, native=False)
    prior(0, T1, cov)


def _imu_params(gyro_var: float = 1e-4) -> gtsam.PreintegrationParams:
    p = gtsam.PreintegrationParams.MakeSharedU(9.81)
    p.setAccelerometerCovariance(1e-3 * np.eye(3))
    p.setGyroscopeCovariance(gyro_var * np.eye(3))
    p.setIntegrationCovariance(0.0 * np.eye(3))
    return p


def test_class7_imu_factor_with_singular_covariance_is_refused() -> None:
    from liebridge.imu import imu, preintegrate

    p = _imu_params()
    p.setAccelerometerCovariance(np.zeros((3, 3)))
    p.setGyroscopeCovariance(np.zeros((3, 3)))
    pim = preintegrate(np.ones((4, 3)), np.zeros((4, 3)), 0.01, bias=np.zeros(6), params=p)
    with pytest.raises(ValueError, match=r"preintegrated\.covariance: singular"):
        imu(0, 1, 2, 3, 4, pim)


# --------------------------------------------------------------------------- class 13 (IMU keys)
def test_class13_imu_factor_with_duplicate_keys_is_refused() -> None:
    from liebridge.imu import imu, preintegrate

    pim = preintegrate(
        np.ones((4, 3)), np.full((4, 3), 0.1), 0.01, bias=np.zeros(6), params=_imu_params()
    )
    with pytest.raises(ValueError, match=r"pose_j: the same key as pose_i \(0\)"):
        imu(0, 1, 0, 3, 4, pim)


# --------------------------------------------------------------------------- class 6
EXTREME = [
    ("gyro", "gyro", np.full((5, 3), 1e160)),
    ("dt", "dt", 1e300),
    ("acc", "acc", np.full((5, 3), 1e308)),
    ("bias", "bias", np.full(6, 1e300)),
]


@pytest.mark.parametrize(("label", "name", "value"), EXTREME, ids=[e[0] for e in EXTREME])
@pytest.mark.parametrize("streaming", [False, True])
def test_class6_extreme_finite_imu_inputs_are_a_clear_error(
    label: str, name: str, value: object, streaming: bool
) -> None:
    import warnings

    from liebridge.imu import ImuPreintegrator, preintegrate

    kw: dict[str, object] = {
        "acc": np.ones((5, 3)),
        "gyro": np.full((5, 3), 0.1),
        "dt": 0.01,
        "bias": np.zeros(6),
    }
    kw[name] = value
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"preintegration overflows float64"):
            if streaming:
                pre = ImuPreintegrator(_imu_params(), kw["bias"])
                pre.integrate(kw["acc"], kw["gyro"], kw["dt"])
                pre.result()
            else:
                preintegrate(kw["acc"], kw["gyro"], kw["dt"], bias=kw["bias"], params=_imu_params())


# --------------------------------------------------------------------------- class 2 (factors)
@pytest.mark.parametrize("batch", [True, False])
def test_class2_keys_at_or_above_2_63_work_in_factors_and_optimize(batch: bool) -> None:
    k0, k1 = 2**63, 2**64 - 2
    g = gtsam.NonlinearFactorGraph()
    g.add(prior(k0, np.eye(4), np.eye(6), native=False))
    g.add(between(k0, k1, T1, np.eye(6), "sophus", native=False))
    v = gtsam.Values()
    v.insert(k0, gtsam.Pose3(gtsam.Rot3.Rx(0.2), [0.1, 0.0, 0.0]))
    v.insert(k1, gtsam.Pose3())
    res = optimize(g, v, batch=batch)
    assert res.final_error < 1e-12
    np.testing.assert_allclose(res.values.atPose3(k1).matrix(), T1, atol=1e-8)


@pytest.mark.parametrize("key", [-1, 2**64, 2**64 - 1, 1.5, True])
def test_class2_keys_outside_uint64_or_reserved_are_refused(key: object) -> None:
    with pytest.raises((ValueError, TypeError), match=r"^i: .*key"):
        prior(key, np.eye(4), np.eye(6), native=False)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- readers: 1, 2, 3, 4
from pathlib import Path  # noqa: E402

from liebridge.io import g2o  # noqa: E402
from liebridge.io import trajectory as tio  # noqa: E402

INFO21 = " ".join(
    ("1.0" if r == c else "0.0") for r in range(6) for c in range(r, 6)
)  # identity, upper triangle


@pytest.mark.parametrize(
    "fmt",
    ["g2o", "tum", "kitti"],
)
def test_class1_extreme_exponent_zero_in_a_rotation_field_reads(tmp_path: Path, fmt: str) -> None:
    p = tmp_path / f"x.{fmt}"
    if fmt == "g2o":
        p.write_text(
            f"VERTEX_SE3:QUAT 0 0 0 0 0e400 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
            f"EDGE_SE3:QUAT 0 1 1 0 0 0e-400 0e400 0 1 {INFO21}\n"
        )
        g = g2o.read(p)
        assert np.array_equal(g.vertex_xyz_qxyzw[0, 3:], [0.0, 0.0, 0.0, 1.0])
    elif fmt == "tum":
        p.write_text("0.0 1 2 3 0e400 0 0 1\n")
        _, T = tio.read_tum(p)
        assert np.array_equal(T[0, :3, :3], np.eye(3))
    else:
        p.write_text("1 0e400 0 0 0 1 0 0 0 0 1 0\n")
        assert np.array_equal(tio.read_kitti(p).T[0], np.eye(4))


def test_class1_text_tolerance_of_extreme_exponents_is_finite() -> None:
    from liebridge.io import poses

    for fields in (["0e400", "0", "0", "1"], ["1e-400", "0", "0", "1"], ["0e99999999", "1"]):
        tol = poses.text_quaternion_tol(fields)
        assert math.isfinite(tol) and tol > 0


def test_class2_g2o_vertex_ids_at_or_above_2_63_round_trip(tmp_path: Path) -> None:
    big = [2**63, 2**64 - 2]
    p = tmp_path / "big.g2o"
    p.write_text(
        f"VERTEX_SE3:QUAT {big[0]} 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT {big[1]} 1 0 0 0 0 0 1\n"
        f"EDGE_SE3:QUAT {big[0]} {big[1]} 1 0 0 0 0 0 1 {INFO21}\nFIX {big[0]}\n"
    )
    g = g2o.read(p)
    assert [int(k) for k in g.vertex_ids] == big
    assert [int(k) for k in g.edges[0]] == big
    graph, values = g.to_gtsam(prior=None)
    assert values.exists(big[1]) and graph.size() == 1
    g2o.write(tmp_path / "out.g2o", g)
    assert (tmp_path / "out.g2o").read_text().split()[1] == str(big[0])


def test_class2_g2o_vertex_id_beyond_uint64_names_the_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.g2o"
    p.write_text(f"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT {2**64} 0 0 0 0 0 0 1\n")
    with pytest.raises(ValueError, match=r"bad\.g2o:2: vertex id .* outside"):
        g2o.read(p)


def test_class3_huge_finite_information_round_trips(tmp_path: Path) -> None:
    import warnings

    info = INFO21.split()
    info[0] = "9e307"  # t-t block
    info[15] = "1.7e308"  # qx-qx entry: /4 on reading, ×4 on writing
    info[1] = "-1.0"  # tx-ty
    p = tmp_path / "huge.g2o"
    p.write_text(
        "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
        f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {' '.join(info)}\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for reading in ("g2o", "gtsam"):
            g = g2o.read(p, reading)  # type: ignore[arg-type]
            assert np.isfinite(g.information).all()
            g2o.write(tmp_path / "out.g2o", g)
            assert "inf" not in (tmp_path / "out.g2o").read_text()
            g2 = g2o.read(tmp_path / "out.g2o", reading)  # type: ignore[arg-type]
            assert np.array_equal(g2.information, g.information)


def test_class3_information_that_overflows_on_writing_is_refused(tmp_path: Path) -> None:
    info = np.eye(6)[None].copy()
    info[0, 0, 0] = 1e308  # ω block: ×4 in the file
    g = g2o.G2OGraph.from_matrices([0, 1], np.stack([np.eye(4), T1]), [[0, 1]], T1[None], info)
    with pytest.raises(ValueError, match=r"information\[0\]: .*overflow"):
        g2o.write(tmp_path / "out.g2o", g)
    assert not (tmp_path / "out.g2o").exists()


def _bits(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a, dtype=np.float64).tobytes()


def test_class4_g2o_round_trip_keeps_negative_zero(tmp_path: Path) -> None:
    info = INFO21.split()
    info[1] = "-0.0"
    info[16] = "-0.0"
    p = tmp_path / "z.g2o"
    p.write_text(
        "VERTEX_SE3:QUAT 0 -0.0 0 0 -0.0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
        f"EDGE_SE3:QUAT 0 1 1 -0.0 0 0 0 -0.0 1 {' '.join(info)}\n"
    )
    for reading in ("g2o", "gtsam"):
        g = g2o.read(p, reading)  # type: ignore[arg-type]
        assert math.copysign(1.0, g.information[0, 3, 4]) == -1.0 or reading == "gtsam"
        g2o.write(tmp_path / "o.g2o", g)
        g2 = g2o.read(tmp_path / "o.g2o", reading)  # type: ignore[arg-type]
        for name in ("vertex_xyz_qxyzw", "measured_xyz_qxyzw", "information"):
            assert _bits(getattr(g2, name)) == _bits(getattr(g, name)), name
        assert "-0.0" in (tmp_path / "o.g2o").read_text()


def test_class4_g2o_quaternion_off_unit_by_1e9_round_trips(tmp_path: Path) -> None:
    s = 1.0 + 1e-9
    q = np.array([0.0, 0.0, math.sin(0.3), math.cos(0.3)]) * s
    x = np.array([[0.0, 0.0, 0.0, *q], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]])
    g = g2o.G2OGraph(
        vertex_ids=np.array([0, 1]),
        vertex_xyz_qxyzw=x,
        edges=np.array([[0, 1]]),
        measured_xyz_qxyzw=x[1:],
        information=np.eye(6)[None],
    )
    g2o.write(tmp_path / "q.g2o", g)
    g2 = g2o.read(tmp_path / "q.g2o")
    assert _bits(g2.vertex_xyz_qxyzw) == _bits(g.vertex_xyz_qxyzw)
    assert abs(np.linalg.norm(g.vertex_xyz_qxyzw[0, 3:]) - 1.0) < 1e-15


# --------------------------------------------------------------------------- class 13: descriptors
@pytest.mark.parametrize("reader", ["tum", "g2o", "kitti"])
def test_class13_readers_leave_the_callers_file_descriptor_open(
    tmp_path: Path, reader: str
) -> None:
    import os

    p = tmp_path / "t.txt"
    if reader == "tum":
        p.write_text("0.0 1 2 3 0 0 0 1\n")
    elif reader == "kitti":
        p.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    else:
        p.write_text("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n")
    fd = os.open(p, os.O_RDONLY)
    try:
        {"tum": tio.read_tum, "kitti": tio.read_kitti, "g2o": g2o.read}[reader](fd)
        os.fstat(fd)  # raises OSError if the reader closed it
    finally:
        os.close(fd)


# --------------------------------------------------------------------- command line: 8, 9, 10, 13
from liebridge.cli import main  # noqa: E402

SMALL_G2O = (
    "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
    f"EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 {INFO21}\n"
)


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    try:
        code = main(list(args))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 0
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_clean_line(err: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and "Warning" not in err, err


def test_class8_long_number_argument_is_numbers_not_a_file_name(
    capsys: pytest.CaptureFixture[str],
) -> None:
    diag = " ".join(repr(0.1 + k * 1e-17 + 1 / 3) for k in range(6))
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([0.1, -0.2, 0.3]).as_matrix()
    T[:3, 3] = [1 / 3, 2 / 3, -1 / 7]
    pose = ", ".join(repr(float(x)) for x in T.reshape(-1))
    assert len(pose) > 255
    cov = ", ".join([diag] * 3)  # 18 numbers: not 6 or 36, but long
    code, out, err = cli(
        capsys, "convert-cov", "--from", "gtsam", "--to", "sophus", "--pose", pose, "--cov", diag
    )
    assert code == 0, err
    assert "# covariance from gtsam" in out
    code, _, err = cli(
        capsys, "convert-cov", "--from", "gtsam", "--to", "sophus", "--pose", pose, "--cov", cov
    )
    assert code == 2
    assert_one_clean_line(err)
    assert "File name too long" not in err and "expected 36 numbers" in err


def test_class9_complex_npy_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "c.npy"
    np.save(f, np.eye(6) * (1 + 1j))
    code, _, err = cli(
        capsys,
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "sophus",
        "--pose",
        " ".join(["1", "0", "0", "0"] * 4)[:0] + "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1",
        "--cov",
        str(f),
    )
    assert code == 2
    assert_one_clean_line(err)
    assert "complex" in err


def test_class9_npy_header_promising_an_enormous_shape_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "huge.npy"
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (100000000000, 6, 6), }"
    header = header + " " * (118 - len(header)) + "\n"
    f.write_bytes(
        b"\x93NUMPY\x01\x00"
        + len(header).to_bytes(2, "little")
        + header.encode()
        + np.zeros(36).tobytes()
    )
    code, _, err = cli(
        capsys,
        "convert-cov",
        "--from",
        "gtsam",
        "--to",
        "sophus",
        "--pose",
        "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1",
        "--cov",
        str(f),
    )
    assert code == 2
    assert_one_clean_line(err)
    assert "huge.npy" in err and "shape" in err


def test_class10_g2o_convert_never_rewrites_its_input_through_a_hard_link(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import os

    inp = tmp_path / "in.g2o"
    inp.write_text(SMALL_G2O)
    link = tmp_path / "link.g2o"
    os.link(inp, link)
    code, _, err = cli(capsys, "g2o", "convert", str(inp), str(link), "--information", "g2o:gtsam")
    assert code == 2
    assert_one_clean_line(err)
    assert "the input file" in err
    assert inp.read_text() == SMALL_G2O


def test_class10_writers_replace_the_file_and_never_write_through_a_link(tmp_path: Path) -> None:
    import os

    inp = tmp_path / "in.g2o"
    inp.write_text(SMALL_G2O)
    link = tmp_path / "link.g2o"
    os.link(inp, link)
    g = g2o.read(inp)
    g2o.write(link, g)  # the library's writer: OUT is replaced, IN's data never touched
    assert inp.read_text() == SMALL_G2O
    assert g2o.read(link).edges.shape == (1, 2)


def test_class13_g2o_convert_to_dev_null(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import os

    if not os.path.exists(os.devnull):
        pytest.skip("no /dev/null")
    inp = tmp_path / "in.g2o"
    inp.write_text(SMALL_G2O)
    code, _, err = cli(capsys, "g2o", "convert", str(inp), os.devnull, "--information", "g2o:gtsam")
    assert code == 0, err
    assert os.path.exists(os.devnull) and not os.path.isfile(os.devnull)


@pytest.mark.parametrize("option", ["--plot", "--out-cov"])
def test_class13_unwritable_output_fails_before_optimizing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str
) -> None:
    inp = tmp_path / "in.g2o"
    inp.write_text(SMALL_G2O)
    target = "/proc/liebridge-no-such.png" if option == "--plot" else "/proc/liebridge-no.npy"
    if option == "--plot":
        pytest.importorskip("matplotlib")
    code, out, err = cli(capsys, "optimize", str(inp), option, target)
    assert code == 2
    assert_one_clean_line(err)
    assert option in err and "cannot write" in err
    assert "optimizing" not in out + err


@pytest.mark.parametrize("n", [str(2**31), str(10**30)])
def test_class13_out_of_range_max_iterations_is_one_clear_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], n: str
) -> None:
    inp = tmp_path / "in.g2o"
    inp.write_text(SMALL_G2O)
    code, _, err = cli(capsys, "optimize", str(inp), "--max-iterations", n)
    assert code == 2
    assert_one_clean_line(err)
    assert "--max-iterations" in err and "incompatible function arguments" not in err


@pytest.mark.parametrize(
    ("key", "match"), [(5, r"keys\[0\]: key 5 is not in values"), (7, r"used by no factor")]
)
def test_class13_marginal_of_a_key_not_in_the_graph_is_a_clear_error(key: int, match: str) -> None:
    from liebridge.gtsam import marginals

    g, v = _small_graph()
    v.insert(7, gtsam.Pose3())
    with pytest.raises(ValueError, match=match):
        marginals(g, v, [key], "sophus")
