"""Calibration files as the field writes them, read as the systems read them.

* ORB-SLAM3's settings in OpenCV's YAML dialect (``%YAML:1.0``, ``!!opencv-matrix`` with
  ``dt: f``, ``data:[...]`` and ``Key:value`` without a space), with ``cv2.FileStorage`` —
  what ORB-SLAM3 itself parses the file with — as the oracle.
* An OKVIS ``T_SC`` at the top level (what ``format_parameter(..., "okvis")`` prints), and one
  clear error naming the file and the key for every key every system's file needs.
* Second cameras: the label and the snippet agree for every system; ORB-SLAM3's second camera
  is ``Stereo.T_c1_c2`` (checked against the numbers ORB-SLAM3 ships for EuRoC), Basalt's and
  OKVIS's are the whole list.
* The API reference: no raw Sphinx role survives the Griffe extension mkdocs.yml loads.

The files are written here in the structure of the systems' own examples (ORB-SLAM3
``Examples/Stereo-Inertial/EuRoC.yaml``), with EuRoC's published calibration numbers.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.cli import main
from liebridge.frames import (
    CalibrationFile,
    OrbSlam3PrecisionWarning,
    Transform,
    calibration,
    export_extrinsic,
    format_parameter,
    read_extrinsic,
    system_names,
)
from liebridge.lie import se3

ROOT = Path(__file__).resolve().parents[1]

#: EuRoC's sensor.yaml T_BS of cam0 and cam1 (camera -> body/IMU), as OKVIS, OpenVINS and
#: VINS-Fusion ship them (body_T_cam0, body_T_cam1) and ORB-SLAM3 ships cam0's (IMU.T_b_c1).
EUROC_T_B_C0 = np.array(
    [
        [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975],
        [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768],
        [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
EUROC_T_B_C1 = np.array(
    [
        [0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556],
        [0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024],
        [-0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
#: ORB-SLAM3 Examples/Stereo-Inertial/EuRoC.yaml (v1.0 settings), Stereo.T_c1_c2
ORBSLAM3_EUROC_T_C1_C2 = np.array(
    [
        [0.999997256477797, -0.002317135723275, -0.000343393120620, 0.110074137800478],
        [0.002312067192432, 0.999898048507103, -0.014090668452683, -0.000156612054392],
        [0.000376008102320, 0.014089835846691, 0.999900662638081, 0.000889382785432],
        [0.0, 0.0, 0.0, 1.0],
    ]
)


def _cv_data(T: np.ndarray, sep: str = ", ", indent: str = "         ") -> str:
    rows = [sep.join(repr(float(x)) for x in r) for r in T]
    return f",\n{indent}".join(rows)


#: The structure of ORB-SLAM3's Examples/Stereo-Inertial/EuRoC.yaml (its settings v1.0 keys),
#: with its dialect: "%YAML:1.0", dt: f matrices, "data:[" and "Key:value" with no space.
ORBSLAM3_EUROC = f"""%YAML:1.0

#--------------------------------------------------------------------------------------------
# System config
#--------------------------------------------------------------------------------------------
File.version: "1.0"

#--------------------------------------------------------------------------------------------
# Camera Parameters. Adjust them!
#--------------------------------------------------------------------------------------------
Camera.type: "PinHole"

# Camera calibration and distortion parameters (OpenCV)
Camera1.fx: 458.654
Camera1.fy: 457.296
Camera1.cx: 367.215
Camera1.cy: 248.375

Camera1.k1: -0.28340811
Camera1.k2: 0.07395907
Camera1.p1: 0.00019359
Camera1.p2: 1.76187114e-05

Camera2.fx: 457.587
Camera2.fy: 456.134
Camera2.cx: 379.999
Camera2.cy: 255.238

Camera2.k1: -0.28368365
Camera2.k2: 0.07451284
Camera2.p1: -0.00010473
Camera2.p2: -3.55590700e-05

Camera.width: 752
Camera.height: 480

# Camera frames per second
Camera.fps: 20

# Color order of the images (0: BGR, 1: RGB. It is ignored if images are grayscale)
Camera.RGB: 1

Stereo.ThDepth: 60.0
Stereo.T_c1_c2: !!opencv-matrix
  rows: 4
  cols: 4
  dt: f
  data: [{_cv_data(ORBSLAM3_EUROC_T_C1_C2, sep=",")}]

# Transformation from camera 0 to body-frame (imu)
IMU.T_b_c1: !!opencv-matrix
   rows: 4
   cols: 4
   dt: f
   data:[{_cv_data(EUROC_T_B_C0)}]

# IMU noise
IMU.NoiseGyro: 1.7e-04 # 1.6968e-04
IMU.NoiseAcc: 2.0000e-03 # 2.0000e-3
IMU.GyroWalk: 1.9393e-05
IMU.AccWalk: 3.0000e-03 # 3.0000e-3
IMU.Frequency: 200.0

LEFT.D: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data:[-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0]

#--------------------------------------------------------------------------------------------
# ORB Parameters
#--------------------------------------------------------------------------------------------
ORBextractor.nFeatures: 1200
ORBextractor.scaleFactor: 1.2
ORBextractor.nLevels: 8
ORBextractor.iniThFAST: 20
ORBextractor.minThFAST: 7

#--------------------------------------------------------------------------------------------
# Viewer Parameters
#--------------------------------------------------------------------------------------------
Viewer.KeyFrameSize: 0.05
Viewer.KeyFrameLineWidth: 1.0
Viewer.GraphLineWidth: 0.9
Viewer.PointSize:2.0
Viewer.CameraSize: 0.08
Viewer.CameraLineWidth: 3.0
Viewer.ViewpointX: 0.0
Viewer.ViewpointY: -0.7
Viewer.ViewpointZ: -1.8
Viewer.ViewpointF: 500.0
"""

#: float32 (OpenCV's dt: f) rounds a number x to within |x| * 2**-24
F32 = 2.0**-24


@pytest.fixture
def orbslam3_file(tmp_path: Path) -> Path:
    path = tmp_path / "EuRoC.yaml"
    path.write_text(ORBSLAM3_EUROC)
    return path


JSON = ("--format", "json")


def _one_line_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


# ----------------------------------------------------------------------------- OpenCV's dialect
def test_orbslam3_euroc_yaml_dialect_read_as_opencv_reads_it(orbslam3_file: Path) -> None:
    """Every key of the file, as liebridge reads it, equals cv2.FileStorage's reading."""
    cv2 = pytest.importorskip("cv2")
    data = CalibrationFile.read(orbslam3_file).data
    fs = cv2.FileStorage(str(orbslam3_file), cv2.FILE_STORAGE_READ)
    keys = list(fs.root().keys())
    assert keys == list(data)  # the same keys, in file order ("Viewer.PointSize:2.0" included)
    for key in keys:
        node, ours = fs.getNode(key), data[key]
        if node.isMap():  # an !!opencv-matrix
            M = node.mat()
            dt = np.float32 if ours["dt"] == "f" else np.float64
            assert M.dtype == dt, key
            mine = np.reshape(np.asarray(ours["data"], dtype=float), (ours["rows"], ours["cols"]))
            # ours: the text's float64; OpenCV's: rounded to the file's dt (float32: 2**-24)
            tol = F32 if dt == np.float32 else 0.0
            np.testing.assert_allclose(mine, M.astype(float), rtol=tol, atol=0, err_msg=key)
        elif node.isString():
            assert ours == node.string(), key
        else:
            assert float(ours) == node.real(), key
    # the extrinsics as ORB-SLAM3 uses them: Tbc = IMU.T_b_c1, T_b_c2 = Tbc * Stereo.T_c1_c2
    Tbc = fs.getNode("IMU.T_b_c1").mat().astype(float)
    Tlr = fs.getNode("Stereo.T_c1_c2").mat().astype(float)
    fs.release()
    assert calibration.detect_file_system(orbslam3_file) == "orbslam3"
    T_c0_i = read_extrinsic(orbslam3_file)
    np.testing.assert_allclose(T_c0_i.inverse().T, Tbc, rtol=0, atol=F32)
    np.testing.assert_allclose(T_c0_i.inverse().T, EUROC_T_B_C0, rtol=0, atol=1e-12)
    T_c1_i = read_extrinsic(orbslam3_file, camera="cam1")
    assert (T_c1_i.target_frame, T_c1_i.source_frame) == ("cam1", "imu0")
    np.testing.assert_allclose(T_c1_i.inverse().T, Tbc @ Tlr, rtol=0, atol=4 * F32)
    # and ORB-SLAM3's T_c1_c2 is EuRoC's own cam0 -> cam1 geometry (T_B_C0^-1 T_B_C1)
    np.testing.assert_allclose(T_c1_i.inverse().T, EUROC_T_B_C1, atol=1e-12)


def test_opencv_dialect_tight_keys_only_under_opencv_header(tmp_path: Path) -> None:
    """``Key:value`` is OpenCV's, read so under ``%YAML:1.0``; plain YAML keeps YAML's rules."""
    path = tmp_path / "a.yaml"
    path.write_text("%YAML:1.0\nA.b:2\nc:[1, 2]\nurl: http://x.org/a:b\n")
    assert CalibrationFile.read(path).data == {"A.b": 2, "c": [1, 2], "url": "http://x.org/a:b"}
    path.write_text("a: 1\nb: x:y\n")  # no header: a plain scalar with a colon stays one
    assert CalibrationFile.read(path).data == {"a": 1, "b": "x:y"}


def test_orbslam3_double_matrix_is_read_with_a_warning_orbslam3_would_misread_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ORB-SLAM3's Converter::toSophus takes at<float> of any matrix: dt: d is misread there."""
    path = tmp_path / "orb.yaml"
    path.write_text(ORBSLAM3_EUROC.replace("dt: f", "dt: d"))
    with pytest.warns(OrbSlam3PrecisionWarning, match=r"IMU\.T_b_c1 is dt: d, but ORB-SLAM3"):
        T = read_extrinsic(path)
    np.testing.assert_allclose(T.inverse().T, EUROC_T_B_C0, atol=1e-12)  # read as written
    rc, out, err = _one_line_cli(
        ["extrinsics", "convert", str(path), "--to-system", "kalibr", "--camera", "cam1"], capsys
    )
    assert rc == 0 and out
    lines = err.splitlines()
    assert len(lines) == 2 and all(
        line.startswith("liebridge extrinsics convert: warning: ") for line in lines
    )
    assert "IMU.T_b_c1" in lines[0] and "Stereo.T_c1_c2" in lines[1]


def test_opencv_dialect_error_lines_are_the_files(tmp_path: Path) -> None:
    """The header is kept as a comment line: a YAML error names the file's own line."""
    path = tmp_path / "bad.yaml"
    path.write_text("%YAML:1.0\nA: 1\nB: [1, 2\nC: 3\n")
    with pytest.raises(ValueError, match=r"bad\.yaml: not valid YAML: .*line [34]") as exc:
        CalibrationFile.read(path)
    assert "\n" not in str(exc.value)


# ----------------------------------------------------------------------------- OKVIS T_SC
T_CAM0_IMU = Transform(se3.inverse(EUROC_T_B_C0), "cam0", "imu0")
T_CAM1_IMU = Transform(se3.inverse(EUROC_T_B_C1), "cam1", "imu0")


def test_okvis_top_level_T_SC_as_format_parameter_prints_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = format_parameter(export_extrinsic(T_CAM0_IMU, "okvis"))
    assert text.startswith("T_SC: [")
    path = tmp_path / "okvis.yaml"
    path.write_text(text)
    assert calibration.detect_file_system(path) == "okvis"
    np.testing.assert_allclose(read_extrinsic(path).T, T_CAM0_IMU.T, atol=1e-15)
    for extra in ([], ["--from-system", "okvis"]):
        rc, out, err = _one_line_cli(
            [
                "extrinsics",
                "convert",
                str(path),
                "--to-system",
                "kalibr",
                "--format",
                "json",
                *extra,
            ],
            capsys,
        )
        assert rc == 0 and err == ""
        np.testing.assert_allclose(json.loads(out)["T"], T_CAM0_IMU.T, atol=1e-15)
    # the top-level T_SC is camera 0's: cam1 is a missing key, not camera 0 again
    rc, _, err = _one_line_cli(
        ["extrinsics", "convert", str(path), "--to-system", "kalibr", "--camera", "cam1"], capsys
    )
    assert rc == 2 and "missing key 'cameras[1].T_SC'" in err and err.count("\n") == 1


# ----------------------------------------------------------------------------- missing keys
def _rows(T: np.ndarray, indent: str = "    ") -> str:
    return "".join(f"{indent}- [{', '.join(repr(float(x)) for x in r)}]\n" for r in T)


def _flat(T: np.ndarray) -> str:
    return ", ".join(repr(float(x)) for x in np.asarray(T).ravel())


def _opencv(key: str, T: np.ndarray, dt: str = "d") -> str:
    return f"{key}: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: {dt}\n   data: [{_flat(T)}]\n"


def _basalt_pose(T: np.ndarray) -> dict[str, float]:
    q = Rotation.from_matrix(T[:3, :3]).as_quat()  # x, y, z, w
    return dict(zip(("px", "py", "pz", "qx", "qy", "qz", "qw"), [*T[:3, 3], *q], strict=True))


B0, B1 = EUROC_T_B_C0, EUROC_T_B_C1  # T_imu_cam0, T_imu_cam1
#: one valid two-camera file per system, written by hand in the system's own layout
VALID: dict[str, str] = {
    "kalibr": f"cam0:\n  T_cam_imu:\n{_rows(se3.inverse(B0))}cam1:\n  T_cam_imu:\n"
    f"{_rows(se3.inverse(B1))}",
    "openvins": f"%YAML:1.0\ncam0:\n  T_imu_cam:\n{_rows(B0)}cam1:\n  T_imu_cam:\n{_rows(B1)}",
    "okvis": f"%YAML:1.0\ncameras:\n     - {{T_SC: [{_flat(B0)}],\n        image_dimension: "
    f"[752, 480]}}\n     - {{T_SC: [{_flat(B1)}],\n        image_dimension: [752, 480]}}\n",
    "orbslam3": "%YAML:1.0\n"
    + _opencv("IMU.T_b_c1", B0, "f")
    + _opencv("Stereo.T_c1_c2", se3.inverse(B0) @ B1, "f"),
    "vins_fusion": "%YAML:1.0\n" + _opencv("body_T_cam0", B0) + _opencv("body_T_cam1", B1),
    "basalt": json.dumps({"value0": {"T_imu_cam": [_basalt_pose(B0), _basalt_pose(B1)]}}),
    "opencv": "rvec: [0.1, -0.2, 0.3]\ntvec: [1.0, 2.0, 3.0]\n",
}


def _drop(text: str, old: str, new: str, nth: int = 0) -> str:
    """Replace the ``nth`` occurrence of ``old`` (the key is then missing)."""
    parts = text.split(old)
    assert len(parts) > nth + 1, (old, nth)
    return old.join(parts[: nth + 1]) + new + old.join(parts[nth + 1 :])


BASALT_REST = ("py", "pz", "qx", "qy", "qz")
#: (system, camera, key renamed away: (old, new, nth), the key the error must name)
MISSING = [
    ("kalibr", "cam0", ("cam0:", "camX:", 0), "cam0"),
    ("kalibr", "cam1", ("cam1:", "camX:", 0), "cam1"),
    ("kalibr", "cam0", ("T_cam_imu:", "T_cam_imx:", 0), "cam0.T_cam_imu"),
    ("kalibr", "cam1", ("T_cam_imu:", "T_cam_imx:", 1), "cam1.T_cam_imu"),
    ("openvins", "cam0", ("cam0:", "camX:", 0), "cam0"),
    ("openvins", "cam0", ("T_imu_cam:", "T_imu_cax:", 0), "cam0.T_imu_cam"),
    ("openvins", "cam1", ("T_imu_cam:", "T_imu_cax:", 1), "cam1.T_imu_cam"),
    ("okvis", "cam0", ("cameras:", "camerax:", 0), "cameras"),
    ("okvis", "cam0", ("T_SC:", "T_SX:", 0), "cameras[0].T_SC"),
    ("okvis", "cam1", ("T_SC:", "T_SX:", 1), "cameras[1].T_SC"),
    ("orbslam3", "cam0", ("IMU.T_b_c1:", "IMU.T_b_cX:", 0), "IMU.T_b_c1"),
    ("orbslam3", "cam1", ("IMU.T_b_c1:", "IMU.T_b_cX:", 0), "IMU.T_b_c1"),
    ("orbslam3", "cam1", ("Stereo.T_c1_c2:", "Stereo.T_cX:", 0), "Stereo.T_c1_c2"),
    ("orbslam3", "cam0", ("rows:", "rowz:", 0), "rows"),
    ("orbslam3", "cam0", ("cols:", "colz:", 0), "cols"),
    ("orbslam3", "cam0", ("dt:", "dtype:", 0), "dt"),
    ("orbslam3", "cam1", ("data:", "datum:", 1), "data"),
    ("vins_fusion", "cam0", ("body_T_cam0:", "body_T_camX:", 0), "body_T_cam0"),
    ("vins_fusion", "cam1", ("body_T_cam1:", "body_T_camX:", 0), "body_T_cam1"),
    ("vins_fusion", "cam1", ("dt:", "dtype:", 1), "dt"),
    ("basalt", "cam0", ('"T_imu_cam"', '"T_imu_cax"', 0), "T_imu_cam"),
    *[("basalt", "cam1", (f'"{k}"', '"zz"', 1), f"T_imu_cam[1].{k}") for k in ("px", "qw")],
    *[("basalt", "cam0", (f'"{k}"', '"zz"', 0), f"T_imu_cam[0].{k}") for k in BASALT_REST],
    ("opencv", "cam0", ("rvec:", "rvex:", 0), "rvec"),
    ("opencv", "cam0", ("tvec:", "tvex:", 0), "tvec"),
]


@pytest.mark.parametrize("system", sorted(VALID))
@pytest.mark.parametrize("camera", ["cam0", "cam1"])
def test_valid_file_of_every_system_reads(system: str, camera: str, tmp_path: Path) -> None:
    """The hand-written files of the missing-key test are valid before a key is removed."""
    path = tmp_path / ("calib.json" if system == "basalt" else "calib.yaml")
    path.write_text(VALID[system])
    assert calibration.detect_file_system(path) == system
    T = read_extrinsic(path, camera=camera)
    if system != "opencv":
        want = (T_CAM0_IMU if camera == "cam0" else T_CAM1_IMU).T
        tol = 4 * F32 if system == "orbslam3" else 1e-12
        np.testing.assert_allclose(T.T, want, atol=tol)


@pytest.mark.parametrize(("system", "camera", "edit", "key"), MISSING)
def test_missing_key_names_file_and_key(
    system: str,
    camera: str,
    edit: tuple[str, str, int],
    key: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = tmp_path / ("calib.json" if system == "basalt" else "calib.yaml")
    path.write_text(_drop(VALID[system], *edit))
    with pytest.raises(ValueError) as exc:
        read_extrinsic(path, system=system, camera=camera)
    msg = str(exc.value)
    assert str(path) in msg and "\n" not in msg
    assert re.search(rf"missing key '{re.escape(key)}\b", msg), msg
    argv = ["extrinsics", "convert", str(path), "--from-system", system, "--to-system", "kalibr"]
    rc, out, err = _one_line_cli([*argv, "--camera", camera], capsys)
    assert rc == 2 and out == "" and err.count("\n") == 1, err
    assert str(path) in err and f"missing key '{key}" in err and "Traceback" not in err


@pytest.mark.parametrize("system", [s for s in system_names() if s not in ("kalibr", "openvins")])
def test_extrinsics_convert_of_a_kalibr_file_with_another_from_names_the_key(
    system: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--from okvis`` (or any other system) on a Kalibr file: one line naming the key.

    (OpenVINS is left out: it reads a Kalibr file, inverting ``T_cam_imu``, as OpenVINS does.)
    """
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text(VALID["kalibr"])
    rc, out, err = _one_line_cli(
        ["extrinsics", "convert", str(path), "--from-system", system, "--to-system", "kalibr"],
        capsys,
    )
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert str(path) in err and "missing key '" in err and "KeyError" not in err


# ----------------------------------------------------------------------------- second cameras
@pytest.mark.parametrize("system", system_names())
def test_second_camera_label_matches_its_snippet(system: str, tmp_path: Path) -> None:
    """cam1's snippet, written to a file, reads back as cam1 — never as cam0 — for every system."""
    ext = export_extrinsic(T_CAM1_IMU, system, earlier_cameras=[T_CAM0_IMU])
    assert ext.camera == "cam1"
    text = format_parameter(ext)
    path = tmp_path / ("calib.json" if system == "basalt" else "calib.yaml")
    path.write_text(text)
    back = read_extrinsic(path, camera="cam1")
    tol = 4 * F32 if system == "orbslam3" else 1e-12
    np.testing.assert_allclose(back.T, T_CAM1_IMU.T, atol=tol)
    labels = {
        "kalibr": "T_cam_imu",
        "openvins": "T_imu_cam",
        "okvis": "cameras[1].T_SC",
        "orbslam3": "Stereo.T_c1_c2",
        "basalt": "T_imu_cam[1]",
        "vins_fusion": "body_T_cam1",
        "opencv": "rvec, tvec",
    }
    assert ext.parameter == labels[system]
    assert ext.direction.startswith(ext.parameter)
    key = ext.parameter.split(", ")[0].split("[")[0].split(".")[-1]
    assert key in text  # the label's key is what the snippet writes
    if system in ("kalibr", "openvins"):
        assert text.splitlines()[int(system == "openvins")] == "cam1:"
    if system == "vins_fusion":
        assert "body_T_cam0" not in text and "body_T_cam0" not in ext.direction


def test_second_camera_cli_label_is_the_snippets(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text(VALID["kalibr"])
    for system in system_names():
        argv = ["extrinsics", "convert", str(path), "--to-system", system, "--camera", "cam1"]
        rc, out, _ = _one_line_cli([*argv, "--format", "json"], capsys)
        obj = json.loads(out)
        assert rc == 0 and obj["camera"] == "cam1"
        snippet = tmp_path / ("s.json" if system == "basalt" else "s.yaml")
        snippet.write_text(obj["snippet"])
        rc, out2, _ = _one_line_cli(
            [
                "extrinsics",
                "convert",
                str(snippet),
                "--to-system",
                "kalibr",
                "--camera",
                "cam1",
                *JSON,
            ],
            capsys,
        )
        tol = 4 * F32 if system == "orbslam3" else 1e-12
        np.testing.assert_allclose(json.loads(out2)["T"], T_CAM1_IMU.T, atol=tol)
        rc, text, _ = _one_line_cli(argv, capsys)
        assert text.splitlines()[0].startswith(f"{system} {obj['parameter']} (")
        if system == "vins_fusion":
            assert "body_T_cam0" not in text


def test_second_camera_from_a_one_camera_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An rvec/tvec file holds one camera: cam0 is not read from it a second time."""
    path = tmp_path / "pnp.yaml"
    path.write_text(VALID["opencv"])
    for to in ("orbslam3", "okvis", "basalt"):
        argv = ["extrinsics", "convert", str(path), "--to-system", to, "--camera", "cam1"]
        rc, out, err = _one_line_cli(argv, capsys)
        assert rc == 2 and out == "" and "holds one camera" in err and err.count("\n") == 1
    rc, _, _ = _one_line_cli(
        ["extrinsics", "convert", str(path), "--to-system", "vins_fusion"], capsys
    )
    assert rc == 0


def test_orbslam3_second_camera_is_stereo_T_c1_c2_as_euroc_ships_it() -> None:
    """EuRoC's two T_BS give exactly the Stereo.T_c1_c2 ORB-SLAM3 ships (not its inverse).

    ORB-SLAM3 ``src/Settings.cc``: ``readCamera2`` reads ``Stereo.T_c1_c2`` into ``Tlr_``;
    ``precomputeRectificationMaps`` hands ``Tlr_.inverse()`` to ``cv::stereoRectify`` as
    ``R12, t12`` — OpenCV's rotation and translation from the first camera's coordinates to
    the second's: ``p_c2 = R12 p_c1 + t12``.
    """
    ext = export_extrinsic(T_CAM1_IMU, "orbslam3", earlier_cameras=[T_CAM0_IMU])
    assert ext.parameter == "Stereo.T_c1_c2"
    assert (ext.transform.target_frame, ext.transform.source_frame) == ("cam0", "cam1")
    np.testing.assert_allclose(ext.transform.T, ORBSLAM3_EUROC_T_C1_C2, atol=1e-12)
    assert np.abs(se3.inverse(ext.transform.T) - ORBSLAM3_EUROC_T_C1_C2).max() > 0.2
    T12 = se3.inverse(np.asarray(ext.transform.T))  # Tlr_.inverse(): R12, t12
    p_imu = np.array([0.4, -1.2, 3.5])
    p_c1 = T_CAM0_IMU.T[:3, :3] @ p_imu + T_CAM0_IMU.T[:3, 3]
    p_c2 = T_CAM1_IMU.T[:3, :3] @ p_imu + T_CAM1_IMU.T[:3, 3]
    np.testing.assert_allclose(T12[:3, :3] @ p_c1 + T12[:3, 3], p_c2, atol=1e-12)
    # the snippet keeps the first camera's IMU.T_b_c1 beside it
    text = format_parameter(ext)
    assert text.count("!!opencv-matrix") == 2 and "IMU.T_b_c1" in text
    assert "Stereo.T_c1_c2" in text and "dt: d" not in text


def test_orbslam3_second_camera_snippet_read_by_opencv(tmp_path: Path) -> None:
    cv2 = pytest.importorskip("cv2")
    ext = export_extrinsic(T_CAM1_IMU, "orbslam3", earlier_cameras=[T_CAM0_IMU])
    path = tmp_path / "orb.yaml"
    path.write_text(format_parameter(ext))
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    Tbc, Tlr = fs.getNode("IMU.T_b_c1").mat(), fs.getNode("Stereo.T_c1_c2").mat()
    fs.release()
    assert Tbc.dtype == np.float32 and Tlr.dtype == np.float32  # at<float> in ORB-SLAM3
    np.testing.assert_allclose(Tbc, EUROC_T_B_C0, atol=F32)
    np.testing.assert_allclose(Tlr, ORBSLAM3_EUROC_T_C1_C2, atol=F32)


def test_basalt_second_camera_snippet_is_the_full_list() -> None:
    """Basalt reads T_imu_cam[i] as camera i (basalt-headers ``Calibration::T_i_c``)."""
    ext = export_extrinsic(T_CAM1_IMU, "basalt", earlier_cameras=[T_CAM0_IMU])
    poses = json.loads(format_parameter(ext))["value0"]["T_imu_cam"]
    assert len(poses) == 2
    p_cam = np.array([0.3, 0.1, 2.0])
    for pose, T_cam_imu in zip(poses, (T_CAM0_IMU, T_CAM1_IMU), strict=True):
        R = Rotation.from_quat([pose[k] for k in ("qx", "qy", "qz", "qw")]).as_matrix()
        t = np.array([pose[k] for k in ("px", "py", "pz")])
        T_i_c = se3.inverse(np.asarray(T_cam_imu.T))  # T_w_c = T_w_i * T_i_c: p_i = T_i_c p_c
        np.testing.assert_allclose(R @ p_cam + t, T_i_c[:3, :3] @ p_cam + T_i_c[:3, 3], atol=1e-12)


def test_okvis_second_camera_snippet_is_the_cameras_list(tmp_path: Path) -> None:
    cv2 = pytest.importorskip("cv2")
    ext = export_extrinsic(T_CAM1_IMU, "okvis", earlier_cameras=[T_CAM0_IMU])
    path = tmp_path / "okvis.yaml"
    path.write_text(format_parameter(ext))
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    cams = fs.getNode("cameras")
    # okvis VioParametersReader.cpp: T_SC of cameras[i], 16 numbers row-major
    got = [np.array([cams.at(i).getNode("T_SC").at(k).real() for k in range(16)]) for i in (0, 1)]
    fs.release()
    np.testing.assert_allclose(got[0].reshape(4, 4), EUROC_T_B_C0, atol=1e-15)
    np.testing.assert_allclose(got[1].reshape(4, 4), EUROC_T_B_C1, atol=1e-15)


def test_second_camera_without_the_first_is_a_clear_error() -> None:
    for system in ("orbslam3", "okvis", "basalt"):
        with pytest.raises(ValueError, match=r"earlier_cameras: .* pass the T_cam_imu of cam0"):
            export_extrinsic(T_CAM1_IMU, system)
    with pytest.raises(ValueError, match="ORB-SLAM3 keeps two cameras"):
        export_extrinsic(T_CAM1_IMU, "orbslam3", camera="cam2", earlier_cameras=[T_CAM0_IMU] * 2)
    ext = export_extrinsic(T_CAM0_IMU, "vins_fusion")
    with pytest.raises(ValueError, match=r"camera: 'cam1', but ext holds cam0's body_T_cam0"):
        format_parameter(ext, "cam1")
    other_imu = Transform(T_CAM0_IMU.T, "cam0", "imu1")
    with pytest.raises(ValueError, match=r"earlier_cameras\[0\]: maps from 'imu1'"):
        export_extrinsic(T_CAM1_IMU, "basalt", earlier_cameras=[other_imu])


# ----------------------------------------------------------------------------- API reference
def _extension() -> Any:
    spec = importlib.util.spec_from_file_location(
        "griffe_sphinx_roles", ROOT / "tools" / "griffe_sphinx_roles.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _docstrings() -> list[tuple[str, str]]:
    out = []
    for path in sorted((ROOT / "liebridge").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                doc = ast.get_docstring(node, clean=False)
                if doc:
                    out.append((f"{path.relative_to(ROOT)}:{getattr(node, 'lineno', 1)}", doc))
    return out


def test_api_reference_renders_sphinx_roles_as_code() -> None:
    """mkdocs.yml loads the Griffe extension, and it leaves no raw role in any docstring."""
    assert "tools/griffe_sphinx_roles.py:SphinxRoles" in (ROOT / "mkdocs.yml").read_text()
    ext = _extension()
    assert ext.convert_roles(":class:`~liebridge.frames.Transform`") == "`Transform`"
    assert ext.convert_roles(":meth:`Transform.inverse`") == "`Transform.inverse()`"
    assert ext.convert_roles(":data:`SYSTEMS` and :py:mod:`x.y`") == "`SYSTEMS` and `x.y`"
    docs = _docstrings()
    with_roles = [(where, d) for where, d in docs if ext.RAW_ROLE.search(d)]
    assert len(with_roles) > 50  # the package uses roles: the check below is not vacuous
    raw = [where for where, d in with_roles if ext.RAW_ROLE.search(ext.convert_roles(d))]
    assert raw == []


def test_api_reference_griffe_loads_without_raw_roles() -> None:
    """The package as mkdocstrings loads it (Griffe with the extension): no raw role left."""
    griffe = pytest.importorskip("griffe")
    ext = _extension()
    pkg = griffe.load(
        "liebridge",
        search_paths=[str(ROOT)],
        extensions=griffe.load_extensions(ext.SphinxRoles()),
    )
    seen, raw = 0, []
    stack = [pkg]
    while stack:
        obj = stack.pop()
        if obj.is_alias:
            continue
        if obj.docstring is not None:
            seen += 1
            if ext.RAW_ROLE.search(obj.docstring.value):
                raw.append(obj.path)
        stack.extend(obj.members.values())
    assert seen > 500 and raw == []
