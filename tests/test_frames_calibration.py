"""Calibration files: a known T_cam_imu exported to every system and used as the system uses it.

Each ``test_use_*`` re-implements, in numpy, the lines of the system's own source that consume
the parameter (file cited in the test), feeds it the exported matrix, and checks that a test
point lands where Kalibr's ``T_cam_imu`` puts it. The EuRoC test compares with the numbers the
systems ship in their own EuRoC configs.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebridge.frames import (
    Transform,
    calibration,
    export_extrinsic,
    format_parameter,
    from_liosam,
    from_rvec_tvec,
    read_extrinsic,
    read_kalibr,
    system_names,
    to_liosam,
    to_rvec_tvec,
    write_kalibr,
)
from liebridge.lie import se3, so3

#: EuRoC MAV cam0 extrinsic as shipped, identically, by three systems' EuRoC configs:
#: okvis config/config_fpga_p2_euroc.yaml (T_SC), open_vins config/euroc_mav/
#: kalibr_imucam_chain.yaml (T_imu_cam), VINS-Fusion config/euroc/euroc_stereo_imu_config.yaml
#: (body_T_cam0): it is EuRoC's sensor.yaml T_BS, camera -> body (IMU).
EUROC_T_IMU_CAM0 = np.array(
    [
        [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975],
        [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768],
        [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
#: basalt data/euroc_ds_calib.json, T_imu_cam[0] (basalt's own calibration of the same rig)
BASALT_EUROC_CAM0 = {
    "px": -0.016774788924641534,
    "py": -0.068938940687127,
    "pz": 0.005139123188382424,
    "qx": -0.007239825785317818,
    "qy": 0.007541278561558601,
    "qz": 0.7017845426564943,
    "qw": 0.7123125505904486,
}

KALIBR_TEXT = """cam0:
  T_cam_imu:
{rows}
  cam_overlaps: [1]
  camera_model: pinhole
  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
  distortion_model: radtan
  intrinsics: [458.654, 457.296, 367.215, 248.375]
  resolution: [752, 480]
  rostopic: /cam0/image_raw
  timeshift_cam_imu: 0.00125
cam1:
  T_cam_imu:
{rows1}
  T_cn_cnm1:
{rows_cc}
  camera_model: pinhole
  intrinsics: [457.587, 456.134, 379.999, 255.238]
  resolution: [752, 480]
  rostopic: /cam1/image_raw
  timeshift_cam_imu: 0.00125
"""


def _rows(T: np.ndarray) -> str:
    return "\n".join("  - [" + ", ".join(repr(float(x)) for x in r) + "]" for r in T)


#: a generic extrinsic (large rotation, 30 cm lever arm) for the per-system tests
T_CAM_IMU = se3.exp(np.array([1.1, -0.4, 2.0, 0.3, -0.12, 0.05]))
P_IMU = np.array([0.7, -1.3, 4.2])  # a test point in IMU coordinates
P_CAM = T_CAM_IMU[:3, :3] @ P_IMU + T_CAM_IMU[:3, 3]  # where Kalibr's T_cam_imu puts it


@pytest.fixture
def kalibr_file(tmp_path: Path) -> Path:
    T1 = se3.exp(np.array([0.01, 0.02, -0.01, -0.11, 0.0, 0.001])) @ T_CAM_IMU
    T_cc = T1 @ se3.inverse(T_CAM_IMU)
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text(KALIBR_TEXT.format(rows=_rows(T_CAM_IMU), rows1=_rows(T1), rows_cc=_rows(T_cc)))
    return path


def _export(system: str, kalibr_file: Path) -> np.ndarray:
    ext = export_extrinsic(read_extrinsic(kalibr_file), system)
    return np.asarray(ext.transform.T)


def _h(p: np.ndarray) -> np.ndarray:
    return np.append(p, 1.0)


# ----------------------------------------------------------------------------- per-system use
def test_use_kalibr(kalibr_file: Path) -> None:
    """kalibr IccSensors.py addCameraErrorTerms: T_c_w = T_cN_b * T_b_w (b = IMU)."""
    T_cN_b = _export("kalibr", kalibr_file)
    T_w_b = se3.exp(np.array([0.3, 0.2, -1.0, 5.0, 1.0, 2.0]))
    p_w = T_w_b[:3, :3] @ P_IMU + T_w_b[:3, 3]
    T_c_w = T_cN_b @ se3.inverse(T_w_b)
    np.testing.assert_allclose((T_c_w @ _h(p_w))[:3], P_CAM, atol=1e-12)


def test_use_okvis(kalibr_file: Path) -> None:
    """okvis ReprojectionError.hpp: C_CS = C_SC^T, T_CS = [C_CS, -C_CS t_SC_S], hp_C = T_CS hp_S."""
    T_SC = _export("okvis", kalibr_file)
    C_SC, t_SC_S = T_SC[:3, :3], T_SC[:3, 3]
    T_CS = np.eye(4)
    T_CS[:3, :3] = C_SC.T
    T_CS[:3, 3] = -C_SC.T @ t_SC_S
    np.testing.assert_allclose((T_CS @ _h(P_IMU))[:3], P_CAM, atol=1e-12)


def test_use_orbslam3(kalibr_file: Path) -> None:
    """ORB_SLAM3 ImuTypes.cc Calib::Set: Tcb = [Rbc^T, -Rbc^T tbc]; Frame.cc: Tcw = Tcb * Tbw."""
    Tbc = _export("orbslam3", kalibr_file)
    Tcb = np.eye(4)
    Tcb[:3, :3] = Tbc[:3, :3].T
    Tcb[:3, 3] = -Tbc[:3, :3].T @ Tbc[:3, 3]
    Twb = se3.exp(np.array([-0.2, 0.1, 0.5, 1.0, -2.0, 0.3]))
    Tcw = Tcb @ se3.inverse(Twb)
    p_w = Twb[:3, :3] @ P_IMU + Twb[:3, 3]
    np.testing.assert_allclose((Tcw @ _h(p_w))[:3], P_CAM, atol=1e-12)


def test_use_openvins(kalibr_file: Path) -> None:
    """open_vins VioManagerOptions.h: T_CtoI = T_imu_cam; q(R_CtoI^T), p_IinC = -R_CtoI^T p_CinI;
    UpdaterHelper.cpp: p_FinC = R_ItoC p_FinI + p_IinC."""
    T_CtoI = _export("openvins", kalibr_file)
    R_ItoC = T_CtoI[:3, :3].T
    p_IinC = -T_CtoI[:3, :3].T @ T_CtoI[:3, 3]
    np.testing.assert_allclose(R_ItoC @ P_IMU + p_IinC, P_CAM, atol=1e-12)


def test_use_basalt(kalibr_file: Path) -> None:
    """basalt poses_linearize.h: T_w_c = T_w_i * T_i_c; T_c_w = T_w_c^-1; JSON px..qw (xyzw)."""
    ext = export_extrinsic(read_extrinsic(kalibr_file), "basalt")
    p = ext.extra["pose"]
    R = Rotation.from_quat([p["qx"], p["qy"], p["qz"], p["qw"]]).as_matrix()  # Eigen xyzw
    T_i_c = np.eye(4)
    T_i_c[:3, :3], T_i_c[:3, 3] = R, [p["px"], p["py"], p["pz"]]
    T_w_i = se3.exp(np.array([0.4, 0.0, -0.3, 2.0, 2.0, 1.0]))
    T_c_w = se3.inverse(T_w_i @ T_i_c)
    p_w = T_w_i[:3, :3] @ P_IMU + T_w_i[:3, 3]
    np.testing.assert_allclose((T_c_w @ _h(p_w))[:3], P_CAM, atol=1e-12)


def test_use_vins_fusion(kalibr_file: Path) -> None:
    """VINS-Fusion parameters.cpp: RIC, TIC = blocks of body_T_cam0;
    projectionTwoFrameOneCamFactor.cpp: pts_camera_j = qic.inverse() * (pts_imu_j - tic)."""
    body_T_cam0 = _export("vins_fusion", kalibr_file)
    ric, tic = body_T_cam0[:3, :3], body_T_cam0[:3, 3]
    np.testing.assert_allclose(ric.T @ (P_IMU - tic), P_CAM, atol=1e-12)


def test_use_opencv(kalibr_file: Path) -> None:
    """OpenCV projectPoints: x_cam = Rodrigues(rvec) X + tvec, then the pinhole projection."""
    cv2 = pytest.importorskip("cv2")
    ext = export_extrinsic(read_extrinsic(kalibr_file), "opencv")
    rvec, tvec = np.array(ext.extra["rvec"]), np.array(ext.extra["tvec"])
    R, _ = cv2.Rodrigues(rvec)
    np.testing.assert_allclose(R @ P_IMU + tvec, P_CAM, atol=1e-12)
    K = np.array([[400.0, 0, 320], [0, 400.0, 240], [0, 0, 1]])
    uv, _ = cv2.projectPoints(P_IMU[None], rvec, tvec, K, None)
    np.testing.assert_allclose(uv.ravel(), (K @ P_CAM)[:2] / P_CAM[2], atol=1e-9)


def test_use_liosam() -> None:
    """LIO-SAM utility.h imuConverter: acc = extRot * acc; q_final = q_from * extQRPY with
    extQRPY = Quaterniond(extRPY).inverse(); imuPreintegration.cpp: imuPose =
    lidarPose.compose(Pose3(I, extTrans))."""
    T_lidar_imu = se3.exp(np.array([0.0, np.pi, 0.0, 0.1, -0.05, 0.2]))
    R_imu_orient = so3.exp(np.array([0.0, 0.0, np.pi / 2]))  # 9-axis IMU's orientation frame
    p = to_liosam(Transform(T_lidar_imu, "lidar", "imu"), R_imu_orient)
    extRot = np.reshape(p["extrinsicRot"], (3, 3))  # Eigen::Map<RowMajor>
    extRPY = np.reshape(p["extrinsicRPY"], (3, 3))
    extTrans = np.array(p["extrinsicTrans"])
    # a known attitude and a gravity reading in the IMU frame
    R_w_imu = so3.exp(np.array([0.1, -0.2, 0.7]))
    acc_imu = R_w_imu.T @ np.array([0.0, 0.0, 9.81])
    R_w_lidar = R_w_imu @ T_lidar_imu[:3, :3].T
    np.testing.assert_allclose(extRot @ acc_imu, R_w_lidar.T @ [0, 0, 9.81], atol=1e-12)
    q_from = Rotation.from_matrix(R_w_imu @ R_imu_orient)  # what the IMU reports
    q_final = q_from * Rotation.from_matrix(extRPY).inv()
    np.testing.assert_allclose(q_final.as_matrix(), R_w_lidar, atol=1e-12)
    T_w_lidar = np.eye(4)
    T_w_lidar[:3, :3], T_w_lidar[:3, 3] = R_w_lidar, [3.0, 1.0, 0.5]
    lidar2Imu = np.eye(4)
    lidar2Imu[:3, 3] = extTrans
    imu_pos = (T_w_lidar @ lidar2Imu)[:3, 3]
    np.testing.assert_allclose(imu_pos, (T_w_lidar @ T_lidar_imu)[:3, 3], atol=1e-12)
    back, R_io = from_liosam(p["extrinsicRot"], p["extrinsicRPY"], p["extrinsicTrans"])
    np.testing.assert_allclose(back.T, T_lidar_imu, atol=1e-12)
    np.testing.assert_allclose(R_io, R_imu_orient, atol=1e-12)


# ----------------------------------------------------------------------------- real configs
def test_euroc_numbers_as_the_systems_ship_them(tmp_path: Path) -> None:
    T_cam_imu = se3.inverse(EUROC_T_IMU_CAM0)
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text("cam0:\n  T_cam_imu:\n" + _rows(T_cam_imu) + "\n")
    tf = read_extrinsic(path)
    for system in ("okvis", "openvins", "vins_fusion", "orbslam3"):
        np.testing.assert_allclose(
            export_extrinsic(tf, system).transform.T, EUROC_T_IMU_CAM0, atol=1e-12
        )
    # basalt ships its own calibration of the rig: close to T_imu_cam, far from the inverse
    p = export_extrinsic(tf, "basalt").extra["pose"]
    ours = np.array([p[k] for k in ("px", "py", "pz")])
    theirs = np.array([BASALT_EUROC_CAM0[k] for k in ("px", "py", "pz")])
    assert np.linalg.norm(ours - theirs) < 0.02
    q = [p[k] for k in ("qx", "qy", "qz", "qw")]
    q_b = [BASALT_EUROC_CAM0[k] for k in ("qx", "qy", "qz", "qw")]
    angle = (Rotation.from_quat(q).inv() * Rotation.from_quat(q_b)).magnitude()
    assert np.rad2deg(angle) < 1.0
    # the OpenVINS fallback: a T_cam_imu under cam0 is read and inverted (opencv_yaml_parse.h)
    assert calibration.detect_file_system(path) == "kalibr"
    np.testing.assert_allclose(read_extrinsic(path, system="openvins").T, T_cam_imu, atol=1e-12)


# ----------------------------------------------------------------------------- files
def test_kalibr_round_trip_bit_exact(kalibr_file: Path, tmp_path: Path) -> None:
    chain = read_kalibr(kalibr_file)
    cam0, cam1 = chain.cameras
    assert cam0.T_cam_imu is not None and cam0.T_cam_imu.name == "T_cam0_imu0"
    assert cam1.T_cn_cnm1 is not None and cam1.T_cn_cnm1.name == "T_cam1_cam0"
    assert cam0.timeshift_cam_imu == 0.00125
    assert cam0.fields["intrinsics"] == [458.654, 457.296, 367.215, 248.375]
    out = tmp_path / "out.yaml"
    write_kalibr(out, chain)
    again = read_kalibr(out)
    for a, b in zip(chain.cameras, again.cameras, strict=True):
        assert a.name == b.name and a.fields == b.fields
        assert a.timeshift_cam_imu == b.timeshift_cam_imu
        assert a.T_cam_imu is not None and b.T_cam_imu is not None
        assert np.array_equal(a.T_cam_imu.T, b.T_cam_imu.T)
    assert again.cameras[1].T_cn_cnm1 is not None
    assert np.array_equal(again.cameras[1].T_cn_cnm1.T, cam1.T_cn_cnm1.T)
    # the tree: cam1 -> cam0 through the IMU equals T_cn_cnm1
    T = chain.tree().lookup("cam1", "cam0").T
    np.testing.assert_allclose(T, cam1.T_cn_cnm1.T, atol=1e-12)


@pytest.mark.parametrize("system", system_names())
def test_snippet_reads_back(system: str, kalibr_file: Path, tmp_path: Path) -> None:
    tf = read_extrinsic(kalibr_file)
    ext = export_extrinsic(tf, system)
    text = format_parameter(ext)
    path = tmp_path / ("calib.json" if system == "basalt" else "calib.yaml")
    if system == "okvis":  # the parameter sits in a cameras list item of the config
        text = "%YAML:1.0\ncameras:\n     - {" + text.strip() + "}\n"
    path.write_text(text)
    assert calibration.detect_file_system(path) == system
    back = read_extrinsic(path)
    tol = 1e-6 if system == "orbslam3" else 1e-15  # dt: f is float32 in ORB-SLAM3 itself
    np.testing.assert_allclose(back.T, tf.T, atol=tol)
    assert (back.target_frame, back.source_frame) == ("cam0", "imu0")


@pytest.mark.parametrize("system", ["orbslam3", "vins_fusion", "openvins", "okvis"])
def test_snippet_read_by_opencv_filestorage(system: str, kalibr_file: Path, tmp_path: Path) -> None:
    """The systems parse their configs with cv::FileStorage: read our snippet the same way."""
    cv2 = pytest.importorskip("cv2")
    ext = export_extrinsic(read_extrinsic(kalibr_file), system)
    text = format_parameter(ext)
    if system == "okvis":
        text = "%YAML:1.0\ncameras:\n     - {" + text.strip() + "}\n"
    path = tmp_path / "calib.yaml"
    path.write_text(text)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if system in ("orbslam3", "vins_fusion"):
        key = "IMU.T_b_c1" if system == "orbslam3" else "body_T_cam0"
        M = fs.getNode(key).mat()
        assert M.dtype == (np.float32 if system == "orbslam3" else np.float64)
    elif system == "openvins":  # opencv_yaml_parse.h: file_node[name][r][c]
        n = fs.getNode("cam0").getNode("T_imu_cam")
        M = np.array([[n.at(r).at(c).real() for c in range(4)] for r in range(4)])
    else:  # VioParametersReader.cpp: T_SC_node[0..15], row-major
        n = fs.getNode("cameras").at(0).getNode("T_SC")
        M = np.array([n.at(i).real() for i in range(16)]).reshape(4, 4)
    fs.release()
    np.testing.assert_allclose(M, ext.transform.T, atol=1e-6)


def test_rvec_tvec_matches_cv2() -> None:
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(9)
    rvec, tvec = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    tf = from_rvec_tvec(rvec, tvec)
    assert tf.name == "T_camera_world"
    for i in range(5):
        np.testing.assert_allclose(tf.T[i, :3, :3], cv2.Rodrigues(rvec[i])[0], atol=1e-12)
    r2, t2 = to_rvec_tvec(tf[0])
    np.testing.assert_allclose(cv2.Rodrigues(r2)[0], cv2.Rodrigues(rvec[0])[0], atol=1e-12)
    np.testing.assert_array_equal(t2, tvec[0])


# ----------------------------------------------------------------------------- bad input
def test_non_rigid_T_cam_imu_names_file_and_field(tmp_path: Path) -> None:
    T = T_CAM_IMU.copy()
    T[:3, :3] *= 1.01  # a scaled rotation
    path = tmp_path / "bad-camchain-imucam.yaml"
    path.write_text("cam0:\n  T_cam_imu:\n" + _rows(T) + "\n")
    with pytest.raises(ValueError) as exc:
        read_kalibr(path)
    msg = str(exc.value)
    assert str(path) in msg and "cam0.T_cam_imu" in msg and "not a rotation" in msg
    assert "\n" not in msg
    T = T_CAM_IMU.copy()
    T[3] = [0, 0, 0.1, 1]
    path.write_text("cam0:\n  T_cam_imu:\n" + _rows(T) + "\n")
    with pytest.raises(ValueError, match="bottom row"):
        read_kalibr(path)
    path.write_text("cam0:\n  T_cam_imu: [[1, 0, 0], [0, 1, 0]]\n")
    with pytest.raises(ValueError, match=r"cam0\.T_cam_imu: expected 4x4"):
        read_kalibr(path)
    path.write_text("cam0:\n  T_cam_imu: [[1, 0, 0, a]]\n")
    with pytest.raises(ValueError, match=r"cam0\.T_cam_imu"):
        read_kalibr(path)
    path.write_text("cam0:\n  T_cam_imu: [1, 2\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        read_kalibr(path)


def test_printed_precision_sets_the_tolerance(tmp_path: Path) -> None:
    """Numbers printed with 7 digits (as in ORB-SLAM3's examples) are accepted, 2 digits not."""
    R = so3.exp(np.array([0.3, -1.0, 0.5]))
    for digits, ok in ((7, True), (2, False)):
        T = np.eye(4)
        T[:3, :3] = np.round(R, digits)
        path = tmp_path / f"p{digits}.yaml"
        path.write_text("cam0:\n  T_cam_imu:\n" + _rows(T) + "\n")
        if ok:
            read_kalibr(path)
        else:
            with pytest.raises(ValueError, match="not a rotation"):
                read_kalibr(path)


def test_unknown_system_and_camera(kalibr_file: Path, tmp_path: Path) -> None:
    tf = read_extrinsic(kalibr_file)
    with pytest.raises(ValueError, match="unknown system 'okvs'; did you mean 'okvis'"):
        export_extrinsic(tf, "okvs")
    with pytest.raises(ValueError, match="no camera 'cam5'"):
        read_extrinsic(kalibr_file, camera="cam5")
    path = tmp_path / "x.yaml"
    path.write_text("foo: 1\n")
    with pytest.raises(ValueError, match="cannot tell which system"):
        read_extrinsic(path)
    path.write_text(json.dumps({"value0": {"T_imu_cam": [{"px": 0.0}]}}))
    with pytest.raises(ValueError, match=r"missing key 'T_imu_cam\[0\]\.py'"):
        read_extrinsic(path)


def test_missing_pyyaml_is_one_clear_error(
    kalibr_file: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "yaml", None)
    with pytest.raises(ImportError, match=r"pip install \"\.\[calib\]\""):
        read_kalibr(kalibr_file)


def test_kalibr_layout_vs_opencv_filestorage(kalibr_file: Path, tmp_path: Path) -> None:
    """Kalibr's own YAML layout is rejected by OpenCV's parser; style="opencv" is read by it."""
    cv2 = pytest.importorskip("cv2")
    chain = read_kalibr(kalibr_file)
    plain, ocv = tmp_path / "kalibr.yaml", tmp_path / "opencv.yaml"
    write_kalibr(plain, chain)
    write_kalibr(ocv, chain, style="opencv")
    with pytest.raises((cv2.error, SystemError)):
        cv2.FileStorage(str(plain), cv2.FILE_STORAGE_READ)
    fs = cv2.FileStorage(str(ocv), cv2.FILE_STORAGE_READ)
    n = fs.getNode("cam0").getNode("T_cam_imu")
    M = np.array([[n.at(r).at(c).real() for c in range(4)] for r in range(4)])
    fs.release()
    assert np.array_equal(M, chain.cameras[0].T_cam_imu.T)  # type: ignore[union-attr]
    again = read_kalibr(ocv)
    assert np.array_equal(again.cameras[1].T_cam_imu.T, chain.cameras[1].T_cam_imu.T)  # type: ignore[union-attr]


@pytest.mark.parametrize("system", ["kalibr", "openvins", "basalt", "vins_fusion"])
def test_time_offset_used_as_the_system_uses_it(
    system: str, kalibr_file: Path, tmp_path: Path
) -> None:
    """t_imu = t_cam + shift in every system that keeps one, each with its own key and unit:
    kalibr IccSensors.py (t_imu = t_cam + timeshiftCamToImuPrior); open_vins VioManager.cpp
    (timestamp + _calib_dt_CAMtoIMU); basalt spline_linearize.h (timestamp_ns +
    cam_time_offset_ns); VINS-Fusion estimator.cpp (curTime = feature.first + td)."""
    shift = calibration.read_timeshift(kalibr_file)
    assert shift == 0.00125
    ext = export_extrinsic(read_extrinsic(kalibr_file), system, timeshift_cam_imu=shift)
    t_cam = 1403636580.8385556
    if system == "basalt":
        t_cam_ns = 1403636580838555648
        t_imu = (t_cam_ns + ext.extra["cam_time_offset_ns"]) * 1e-9
        assert isinstance(ext.extra["cam_time_offset_ns"], int)
        assert t_imu == pytest.approx(t_cam_ns * 1e-9 + shift, abs=1e-9)
    else:
        key = "td" if system == "vins_fusion" else "timeshift_cam_imu"
        assert t_cam + ext.extra[key] == t_cam + shift
    # the snippet carries it and reads back
    path = tmp_path / ("c.json" if system == "basalt" else "c.yaml")
    path.write_text(format_parameter(ext))
    assert calibration.read_timeshift(path) == pytest.approx(shift, abs=1e-12)
    # systems without one: nothing is invented
    for other in ("okvis", "orbslam3", "opencv"):
        e = export_extrinsic(read_extrinsic(kalibr_file), other, timeshift_cam_imu=shift)
        assert not {"td", "timeshift_cam_imu", "cam_time_offset_ns"} & set(e.extra)
