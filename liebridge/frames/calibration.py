"""Calibration files: Kalibr's camchain-imucam.yaml, and the camera–IMU extrinsic of VIO systems.

The same extrinsic has a different name **and direction** in every system. Kalibr's
``T_cam_imu`` maps IMU coordinates to camera coordinates (``p_cam = T_cam_imu p_imu``); OKVIS,
ORB-SLAM3, OpenVINS, Basalt and VINS-Fusion all store the inverse, ``T_imu_cam``, each under its
own name; OpenCV's ``rvec, tvec`` map "world" (here: the IMU frame) coordinates to the camera.
Every row of :data:`SYSTEMS` was read in the system's source (file cited on the row) and is
tested by reproducing the system's own use of the parameter on a test point
(``tests/test_frames_calibration.py``):

============  ==================  ===========  =====================================================
system        parameter           holds        the system's use (source)
============  ==================  ===========  =====================================================
kalibr        ``T_cam_imu``       T_cam_imu    ``T_c_w = T_cN_b * T_b_w`` (kalibr
                                               ``IccSensors.py`` ``addCameraErrorTerms``);
                                               written by ``ConfigReader.py``
                                               ``setExtrinsicsImuToCam``
okvis         ``T_SC``            T_imu_cam    ``hp_C = T_CS * hp_S`` with ``T_CS = T_SC⁻¹`` (okvis
                                               ``ReprojectionError.hpp``); 16 numbers row-major
                                               (``VioParametersReader.cpp``)
orbslam3      ``IMU.T_b_c1``      T_imu_cam    ``Tcb = Tbc⁻¹`` (``ImuTypes.cc`` ``Calib::Set``),
                                               ``mTcw = mImuCalib.mTcb * Tbw`` (``Frame.cc``);
                                               read from ``IMU.T_b_c1`` (``Settings.cc``
                                               ``readIMU``) with ``at<float>``: ``dt: f``
openvins      ``T_imu_cam``       T_imu_cam    parsed into ``T_CtoI`` (``VioManagerOptions.h``),
                                               ``R_ItoC = R_CtoIᵀ``, ``p_IinC = −R_CtoIᵀ p_CinI``,
                                               ``p_FinC = R_ItoC p_FinI + p_IinC``
                                               (``UpdaterHelper.cpp``); a missing ``T_imu_cam``
                                               falls back to an inverted ``T_cam_imu``
                                               (``opencv_yaml_parse.h``)
basalt        ``T_imu_cam``       T_imu_cam    ``T_w_c = T_w_i * calib.T_i_c`` (basalt
                                               ``poses_linearize.h``); JSON ``T_imu_cam`` =
                                               ``Calibration::T_i_c`` (basalt-headers
                                               ``headers_serialization.h``), ``{px..pz, qx..qw}``
vins_fusion   ``body_T_cam0``     T_imu_cam    ``RIC, TIC`` = its blocks (``parameters.cpp``),
                                               ``pts_camera = qic⁻¹ (pts_imu − tic)``
                                               (``projectionTwoFrameOneCamFactor.cpp``)
opencv        ``rvec, tvec``      T_cam_imu    ``x_cam = Rodrigues(rvec) X + tvec`` (OpenCV
                                               ``solvePnP``/``projectPoints``), the IMU frame
                                               playing OpenCV's "world"
============  ==================  ===========  =====================================================

Versions read: kalibr 1f60227 (2024-03), okvis f0c9ba4 (2020-07), ORB_SLAM3 master (2021-2022),
open_vins 6948812 (2025-11), basalt 0f3b2b5 (2026-03), VINS-Fusion be55a93 (2021-07), LIO-SAM
0be1fbe (2023-04).

Kalibr's ``timeshift_cam_imu`` is ``t_imu = t_cam + timeshift_cam_imu`` (kalibr
``IccSensors.py``: "t_imu = t_cam + timeshiftCamToImuPrior"). ``T_cn_cnm1`` maps camera n−1
coordinates to camera n. The time offset goes to the systems that keep one, same meaning,
their own key and unit (:data:`TIME_OFFSETS`): OpenVINS ``timeshift_cam_imu``, VINS-Fusion
``td``, Basalt ``cam_time_offset_ns``.

Second cameras (``camera="cam1"``): Kalibr and OpenVINS ``cam1``, VINS-Fusion ``body_T_cam1``;
ORB-SLAM3 ``Stereo.T_c1_c2`` = ``T_cam0_cam1`` (camera-2 coordinates to camera 1's: ORB_SLAM3
``src/Settings.cc`` reads it into ``Tlr_`` and gives ``Tlr_.inverse()`` to ``cv::stereoRectify``
as the first-to-second camera motion, :data:`ORBSLAM3_STEREO`); OKVIS and Basalt keep one list,
entry N being camera N, so their snippet for camera N is the whole list up to it.

YAML needs PyYAML (the ``calib`` extra), imported only when a file is read or written. Files in
OpenCV's dialect (``%YAML:1.0``, ``!!opencv-matrix`` nodes, ``Key:value`` and ``data:[...]``
without a space after the colon, as ORB-SLAM3, VINS-Fusion, OpenVINS and OKVIS use) are read as
``cv2.FileStorage`` reads them, and :func:`format_parameter` writes each system's parameter in
that system's own syntax (both checked against OpenCV's ``FileStorage`` in the tests). A key a
system's file lacks is one ``ValueError`` naming the file and the key (:data:`REQUIRED_KEYS`).
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .. import _validate as validate
from .._validate import FloatArray
from ..io import poses as pose_io
from ..io.atomic import atomic_write
from ..lie import unchecked as U
from .transform import Transform, frame_name
from .tree import TransformTree

__all__ = [
    "ORBSLAM3_STEREO",
    "REQUIRED_KEYS",
    "SYSTEMS",
    "TIME_OFFSETS",
    "CalibrationFile",
    "ExtrinsicFormat",
    "KalibrCamchain",
    "KalibrCamera",
    "OrbSlam3PrecisionWarning",
    "SystemExtrinsic",
    "detect_file_system",
    "detect_system",
    "export_extrinsic",
    "format_parameter",
    "from_liosam",
    "from_rvec_tvec",
    "read_extrinsic",
    "read_kalibr",
    "read_timeshift",
    "system_format",
    "system_names",
    "to_liosam",
    "to_rvec_tvec",
    "write_kalibr",
]

PathLike = str | Path
Holds = Literal["T_cam_imu", "T_imu_cam", "T_cam0_cam1"]


# ----------------------------------------------------------------------------- the systems
@dataclass(frozen=True)
class ExtrinsicFormat:
    """How one system names, orients and stores the camera–IMU extrinsic.

    ``holds`` is the direction in liebridge's naming: ``"T_cam_imu"`` maps IMU coordinates to
    camera coordinates, ``"T_imu_cam"`` camera coordinates to IMU coordinates,
    ``"T_cam0_cam1"`` (ORB-SLAM3's ``Stereo.T_c1_c2``, :data:`ORBSLAM3_STEREO`) the second
    camera's coordinates to the first's.
    """

    system: str
    parameter: str
    holds: Holds
    storage: str
    use: str
    source: str
    own_frames: tuple[str, str]  # the system's own names for (camera, imu)


SYSTEMS: dict[str, ExtrinsicFormat] = {
    f.system: f
    for f in (
        ExtrinsicFormat(
            "kalibr",
            "T_cam_imu",
            "T_cam_imu",
            "4x4 rows (YAML list of lists) under camN",
            "p_cam = T_cam_imu p_imu (T_c_w = T_cN_b * T_b_w)",
            "ethz-asl/kalibr aslam_offline_calibration/kalibr/python/kalibr_imu_camera_calibration/"
            "IccSensors.py (addCameraErrorTerms); kalibr_common/ConfigReader.py",
            ("cam", "imu"),
        ),
        ExtrinsicFormat(
            "okvis",
            "T_SC",
            "T_imu_cam",
            "16 numbers, row-major, in a cameras list item",
            "hp_C = T_CS hp_S with T_CS = T_SC^-1 (S = sensor/IMU, C = camera)",
            "ethz-asl/okvis okvis_ceres/include/okvis/ceres/implementation/ReprojectionError.hpp; "
            "okvis_common/src/VioParametersReader.cpp",
            ("C", "S"),
        ),
        ExtrinsicFormat(
            "orbslam3",
            "IMU.T_b_c1",
            "T_imu_cam",
            "!!opencv-matrix 4x4, dt: f (read with cv::Mat::at<float>)",
            "Tcb = Tbc^-1, Tcw = Tcb * Tbw (b = body/IMU, c1 = first camera)",
            "UZ-SLAMLab/ORB_SLAM3 src/Settings.cc (readIMU), src/ImuTypes.cc (Calib::Set), "
            "src/Frame.cc (SetImuPoseVelocity)",
            ("c1", "b"),
        ),
        ExtrinsicFormat(
            "openvins",
            "T_imu_cam",
            "T_imu_cam",
            "4x4 rows (YAML list of lists) under camN (kalibr_imucam_chain.yaml)",
            "T_CtoI = T_imu_cam; p_FinC = R_ItoC p_FinI + p_IinC with R_ItoC = R_CtoI^T, "
            "p_IinC = -R_CtoI^T p_CinI",
            "rpng/open_vins ov_msckf/src/core/VioManagerOptions.h; "
            "ov_msckf/src/update/UpdaterHelper.cpp; ov_core/src/utils/opencv_yaml_parse.h",
            ("C", "I"),
        ),
        ExtrinsicFormat(
            "basalt",
            "T_imu_cam",
            "T_imu_cam",
            'JSON list of {"px","py","pz","qx","qy","qz","qw"} (Calibration::T_i_c)',
            "T_w_c = T_w_i * T_i_c",
            "VladyslavUsenko/basalt include/basalt/optimization/poses_linearize.h; "
            "basalt-headers include/basalt/serialization/headers_serialization.h",
            ("c", "i"),
        ),
        ExtrinsicFormat(
            "vins_fusion",
            "body_T_cam0",
            "T_imu_cam",
            "!!opencv-matrix 4x4, dt: d",
            "pts_imu = ric pts_camera + tic; pts_camera = ric^-1 (pts_imu - tic)",
            "HKUST-Aerial-Robotics/VINS-Fusion vins_estimator/src/estimator/parameters.cpp; "
            "vins_estimator/src/factor/projectionTwoFrameOneCamFactor.cpp",
            ("cam0", "body"),
        ),
        ExtrinsicFormat(
            "opencv",
            "rvec, tvec",
            "T_cam_imu",
            "rotation vector (Rodrigues) and translation, world (here: IMU) -> camera",
            "x_cam = R(rvec) X + tvec (cv::solvePnP, cv::projectPoints)",
            "OpenCV calib3d documentation (solvePnP, projectPoints, Rodrigues)",
            ("camera", "world"),
        ),
    )
}


#: ORB-SLAM3's second camera: ``Stereo.T_c1_c2`` (what :func:`export_extrinsic` gives for
#: ``cam1``), its storage, its use and the source read.
ORBSLAM3_STEREO = ExtrinsicFormat(
    "orbslam3",
    "Stereo.T_c1_c2",
    "T_cam0_cam1",  # not a camera–IMU matrix: camera-2 coordinates to camera 1's
    "!!opencv-matrix 4x4, dt: f, beside IMU.T_b_c1 (the first camera's)",
    "Tlr = T_c1_c2 (p_c1 = Tlr p_c2); cv::stereoRectify gets R12, t12 = Tlr^-1 (first camera "
    "to second); baseline b = |t_lr|; hence T_b_c2 = T_b_c1 * T_c1_c2",
    "UZ-SLAMLab/ORB_SLAM3 src/Settings.cc (readCamera2, precomputeRectificationMaps)",
    ("c2", "c1"),
)


def system_names() -> tuple[str, ...]:
    """Names accepted by :func:`export_extrinsic` and ``--to-system``/``--from-system``."""
    return tuple(SYSTEMS)


def system_format(name: Any, what: str = "system") -> ExtrinsicFormat:
    """Return the :class:`ExtrinsicFormat` of ``name`` (an unknown name raises naming ``what``)."""
    if not isinstance(name, str):
        raise TypeError(f"{what}: expected a system name (str), got {type(name).__name__}")
    key = name.strip().lower().replace("-", "_")
    key = {"orb_slam3": "orbslam3", "vins": "vins_fusion", "vinsfusion": "vins_fusion"}.get(
        key, key
    )
    if key in SYSTEMS:
        return SYSTEMS[key]
    import difflib

    close = difflib.get_close_matches(key, list(SYSTEMS), n=2, cutoff=0.5)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    raise ValueError(f"{what}: unknown system {name!r}{hint} (known: {', '.join(SYSTEMS)})")


@dataclass(frozen=True)
class SystemExtrinsic:
    """The camera–IMU extrinsic of one camera as one system stores it.

    Attributes
    ----------
    system, parameter : str
        The system and the name its configuration uses for this camera's matrix
        (``body_T_cam1`` for VINS-Fusion's second camera, ``Stereo.T_c1_c2`` for ORB-SLAM3's,
        ``T_imu_cam[1]`` for Basalt's, ``cameras[1].T_SC`` for OKVIS's).
    transform : Transform
        The stored matrix with its frames: ``T`` maps ``source_frame`` to ``target_frame``.
    direction : str
        The direction in words.
    extra : dict
        System-specific forms (``rvec``/``tvec`` for OpenCV, the JSON pose for Basalt).
    camera : str
        Which camera of the rig (``"cam0"``, ``"cam1"``...); :func:`format_parameter` labels the
        snippet with it.
    rig : tuple of Transform
        The earlier cameras' matrices as the system stores them, where the system's snippet for
        this camera holds them too: OKVIS's ``cameras`` and Basalt's ``T_imu_cam`` lists
        (``T_imu_cam0``...), ORB-SLAM3's ``IMU.T_b_c1`` beside ``Stereo.T_c1_c2``. Empty for
        camera 0 and for the systems that keep one entry per camera.
    """

    system: str
    parameter: str
    transform: Transform
    direction: str
    extra: Mapping[str, Any] = field(default_factory=dict)
    camera: str = "cam0"
    rig: tuple[Transform, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict: ``system``, ``parameter``, ``T`` (rows), frames, direction."""
        tf = self.transform
        return {
            "system": self.system,
            "parameter": self.parameter,
            "T": (np.asarray(tf.T) + 0.0).tolist(),
            "target_frame": tf.target_frame,
            "source_frame": tf.source_frame,
            "direction": self.direction,
            "camera": self.camera,
            **{
                k: (np.asarray(val).tolist() if isinstance(val, np.ndarray) else val)
                for k, val in self.extra.items()
            },
        }


#: Where each system keeps the camera–IMU time offset, all meaning ``t_imu = t_cam + offset``:
#: (key, unit scale from seconds, source). OKVIS (``imageDelay`` is read but not used in
#: ethz-asl/okvis), ORB-SLAM3 and OpenCV have none.
TIME_OFFSETS: dict[str, tuple[str, float, str]] = {
    "kalibr": (
        "timeshift_cam_imu",
        1.0,
        "kalibr IccSensors.py: t_imu = t_cam + timeshiftCamToImuPrior",
    ),
    "openvins": (
        "timeshift_cam_imu",
        1.0,
        "open_vins VioManagerOptions.h reads it into calib_camimu_dt; VioManager.cpp uses "
        "timestamp + _calib_dt_CAMtoIMU as IMU time",
    ),
    "basalt": (
        "cam_time_offset_ns",
        1e9,
        "basalt spline_linearize.h: time_ns = acd.timestamp_ns + calibration->cam_time_offset_ns",
    ),
    "vins_fusion": (
        "td",
        1.0,
        "VINS-Fusion estimator.cpp: curTime = feature.first + td (config: 'readed image clock "
        "+ td = real image clock (IMU clock)')",
    ),
}


def export_extrinsic(
    T_cam_imu: Transform,
    system: str,
    *,
    timeshift_cam_imu: float | None = None,
    camera: str | None = None,
    earlier_cameras: Sequence[Transform] = (),
) -> SystemExtrinsic:
    """Express the camera–IMU extrinsic ``T_cam_imu`` in ``system``'s convention.

    Parameters
    ----------
    T_cam_imu : Transform
        Maps IMU coordinates to camera coordinates: ``target_frame`` is the camera,
        ``source_frame`` the IMU (as Kalibr's ``T_cam_imu``). A covariance is carried along.
    system : str
        One of :func:`system_names`.
    timeshift_cam_imu : float, optional
        Kalibr's time offset (``t_imu = t_cam + timeshift_cam_imu``, seconds); exported under the
        system's own key and unit (:data:`TIME_OFFSETS`) in ``extra`` and the snippet.
    camera : str, optional
        Which camera of the rig this is, ``"cam0"``, ``"cam1"``...; by default
        ``T_cam_imu.target_frame`` when it is such a name, else ``"cam0"``. It picks the
        parameter: VINS-Fusion ``body_T_camN``; ORB-SLAM3 ``IMU.T_b_c1`` for ``cam0`` and, for
        ``cam1``, ``Stereo.T_c1_c2`` = ``T_cam0_cam1`` (maps camera-2 coordinates to camera 1's:
        ORB-SLAM3 ``src/Settings.cc`` reads it as ``Tlr`` and hands ``Tlr⁻¹`` to
        ``cv::stereoRectify`` as the first-to-second camera motion); OKVIS ``cameras[N].T_SC``
        and Basalt ``T_imu_cam[N]``, items of one list.
    earlier_cameras : sequence of Transform
        ``T_cam_imu`` of ``cam0`` … ``cam(N−1)``, in order (same IMU frame). Needed for camera
        ``N ≥ 1`` where the system stores it relative to the first camera (ORB-SLAM3) or in a
        list with the earlier ones (OKVIS, Basalt): a snippet with camera 1 alone would be read
        as camera 0.

    Returns
    -------
    SystemExtrinsic
        Its ``transform`` is ``T_cam_imu`` or its inverse, as the system stores it (for
        ORB-SLAM3's second camera: ``T_cam0_cam1``).

    Raises
    ------
    ValueError
        An unknown system or camera name, a batch, ``earlier_cameras`` missing where the system
        needs them (naming what it stores), of the wrong length or with another IMU frame, or a
        third camera for ORB-SLAM3 (it keeps two).
    """
    fmt = system_format(system)
    if not isinstance(T_cam_imu, Transform):
        raise TypeError(f"T_cam_imu: expected a Transform, got {type(T_cam_imu).__name__}")
    if T_cam_imu.batch_shape:
        raise ValueError(f"T_cam_imu: expected one transform, got a batch {T_cam_imu.batch_shape}")
    if camera is None:
        camera = T_cam_imu.target_frame
        camera = camera if re.fullmatch(r"cam\d+", camera) else "cam0"
    m = re.fullmatch(r"cam(\d+)", camera) if isinstance(camera, str) else None
    if m is None:
        raise ValueError(f"camera: expected cam0, cam1, ..., got {camera!r}")
    idx = int(m.group(1))
    earlier = _earlier_cameras(earlier_cameras, T_cam_imu, idx)
    needs = idx > 0 and fmt.system in ("okvis", "orbslam3", "basalt")
    if fmt.system == "orbslam3" and idx > 1:
        raise ValueError(
            f"camera: ORB-SLAM3 keeps two cameras (IMU.T_b_c1, Stereo.T_c1_c2); no {camera}"
        )
    if needs and len(earlier) != idx:
        how = {
            "orbslam3": "as Stereo.T_c1_c2, relative to the first camera",
            "okvis": "as an item of its cameras list, after the earlier cameras",
            "basalt": "as an entry of its T_imu_cam list, after the earlier cameras",
        }[fmt.system]
        raise ValueError(
            f"earlier_cameras: {fmt.system} stores {camera} {how}; pass the T_cam_imu of "
            f"cam0 … cam{idx - 1} ({idx} transform(s), got {len(earlier)})"
        )
    cam_own, imu_own = fmt.own_frames
    own: dict[str, str] = {T_cam_imu.target_frame: cam_own, T_cam_imu.source_frame: imu_own}
    parameter = fmt.parameter
    rig: tuple[Transform, ...] = ()
    if fmt.system == "orbslam3" and idx == 1:
        tf = earlier[0] @ T_cam_imu.inverse()  # T_c1_c2 = T_cam0_imu · T_imu_cam1
        parameter = "Stereo.T_c1_c2"
        own = {earlier[0].target_frame: "c1", T_cam_imu.target_frame: "c2"}
        rig = (earlier[0].inverse(),)
    else:
        tf = T_cam_imu if fmt.holds == "T_cam_imu" else T_cam_imu.inverse()
        if fmt.system == "vins_fusion":
            parameter = f"body_T_cam{idx}"
            own[T_cam_imu.target_frame] = f"cam{idx}"
        elif needs:  # okvis, basalt: the list up to this camera
            parameter = f"cameras[{idx}].T_SC" if fmt.system == "okvis" else f"T_imu_cam[{idx}]"
            rig = tuple(e.inverse() for e in earlier)
    direction = (
        f"{parameter} maps {tf.source_frame} coordinates to {tf.target_frame} coordinates "
        f"(p_{tf.target_frame} = R p_{tf.source_frame} + t; {fmt.system} calls the frames "
        f"{own[tf.target_frame]} = {tf.target_frame}, {own[tf.source_frame]} = "
        f"{tf.source_frame}); it is the pose of {tf.source_frame} in {tf.target_frame}"
    )
    extra: dict[str, Any] = {}
    if fmt.system == "opencv":
        rvec, tvec = to_rvec_tvec(tf)
        extra = {"rvec": rvec.tolist(), "tvec": tvec.tolist()}
    elif fmt.system == "basalt":
        extra = {"pose": _basalt_pose(tf.T)}
    if timeshift_cam_imu is not None:
        shift = _time_offset(timeshift_cam_imu, "timeshift_cam_imu")
        if fmt.system in TIME_OFFSETS:
            key, scale, _ = TIME_OFFSETS[fmt.system]
            extra[key] = round(shift * scale) if scale != 1.0 else shift
    return SystemExtrinsic(fmt.system, parameter, tf, direction, extra, camera, rig)


def _earlier_cameras(earlier_cameras: Any, T_cam_imu: Transform, idx: int) -> tuple[Transform, ...]:
    """Check ``earlier_cameras``: single Transforms from the IMU frame of ``T_cam_imu``."""
    if isinstance(earlier_cameras, Transform) or not isinstance(earlier_cameras, Sequence):
        raise TypeError(
            "earlier_cameras: expected a sequence of Transforms (T_cam_imu of cam0 … camN−1), "
            f"got {type(earlier_cameras).__name__}"
        )
    out = tuple(earlier_cameras)
    if out and len(out) != idx:
        raise ValueError(
            f"earlier_cameras: expected the T_cam_imu of cam0 … cam{idx - 1} ({idx} "
            f"transform(s)) for cam{idx}, got {len(out)}"
        )
    for k, e in enumerate(out):
        if not isinstance(e, Transform):
            raise TypeError(f"earlier_cameras[{k}]: expected a Transform, got {type(e).__name__}")
        if e.batch_shape:
            raise ValueError(f"earlier_cameras[{k}]: expected one transform, got a batch")
        if e.source_frame != T_cam_imu.source_frame:
            raise ValueError(
                f"earlier_cameras[{k}]: maps from {e.source_frame!r}, but T_cam_imu maps from "
                f"{T_cam_imu.source_frame!r}: both must be T_cam_imu of the same IMU"
            )
    return out


#: Largest camera–IMU time offset accepted, seconds: it must fit in int64 nanoseconds (Basalt's
#: ``cam_time_offset_ns``); a real offset is milliseconds.
MAX_TIME_OFFSET = 9.2e9


def _time_offset(value: Any, where: str, scale: float = 1.0) -> float:
    """Return a time offset read from a file (in units of ``1/scale`` s) as finite seconds.

    A ``ValueError`` names ``where`` for a value that is not a number, beyond float64 (``1``
    and 400 zeros), or beyond :data:`MAX_TIME_OFFSET`.
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{where}: expected a number, got {value!r}")
    try:
        seconds = float(value) / scale
    except OverflowError:
        raise ValueError(f"{where}: {str(value)[:20]}… is beyond float64") from None
    if not np.isfinite(seconds):
        raise ValueError(f"{where}: expected a finite number, got {value!r}")
    if abs(seconds) > MAX_TIME_OFFSET:
        raise ValueError(
            f"{where}: a time offset of {seconds:.6g} s is beyond ±{MAX_TIME_OFFSET:g} s "
            "(int64 nanoseconds); a camera–IMU offset is a fraction of a second"
        )
    return seconds


def _basalt_pose(T: FloatArray) -> dict[str, float]:
    x = pose_io.from_matrix(T, layout="xyz_qxyzw")
    return dict(zip(("px", "py", "pz", "qx", "qy", "qz", "qw"), map(float, x), strict=True))


# ----------------------------------------------------------------------------- OpenCV rvec, tvec
def from_rvec_tvec(
    rvec: Any, tvec: Any, *, target_frame: str = "camera", source_frame: str = "world"
) -> Transform:
    """OpenCV's ``rvec, tvec`` (``(..., 3)`` each) as ``T_camera_world``.

    ``x_cam = R(rvec) X_world + tvec`` with ``R(rvec)`` Rodrigues' rotation of the rotation
    vector ``rvec`` (OpenCV ``solvePnP`` returns the pose of the world in the camera). GTSAM
    prefers the camera's pose in the world, ``T_world_camera``: take :meth:`Transform.inverse`.
    """
    r = validate.tangent(rvec, "rvec", 3)
    tv = validate.vector(tvec, "tvec", 3)
    shape = validate.batch_shape(("rvec", r.shape[:-1]), ("tvec", tv.shape[:-1]))
    R = U.so3_exp(np.broadcast_to(r, (*shape, 3)))
    return Transform(
        U.se3_assemble(R, np.broadcast_to(tv, (*shape, 3))), target_frame, source_frame
    )


def to_rvec_tvec(T_camera_world: Transform) -> tuple[FloatArray, FloatArray]:
    """Inverse of :func:`from_rvec_tvec`: ``(rvec, tvec)``, ``‖rvec‖ ∈ [0, π]``."""
    if not isinstance(T_camera_world, Transform):
        raise TypeError(
            f"T_camera_world: expected a Transform, got {type(T_camera_world).__name__}"
        )
    return U.so3_log(T_camera_world.R), np.array(T_camera_world.t)


# ----------------------------------------------------------------------------- LIO-SAM
def to_liosam(T_lidar_imu: Transform, R_imu_orient: Any = None) -> dict[str, list[float]]:
    """LIO-SAM's ``extrinsicRot``, ``extrinsicRPY``, ``extrinsicTrans`` from ``T_lidar_imu``.

    What LIO-SAM does with them (TixiaoShan/LIO-SAM ``include/utility.h`` ``imuConverter``,
    ``src/imuPreintegration.cpp``, 0be1fbe):

    * ``extrinsicRot`` (9 numbers, row-major) **rotates IMU vectors** into the lidar frame:
      ``acc = extRot * acc``, ``gyr = extRot * gyr`` — it is ``R_lidar_imu``;
    * ``extrinsicRPY`` is for the 9-axis IMU's **orientation output**, whose frame may differ
      from its accelerometer frame: ``q_final = q_from * extQRPY`` with
      ``extQRPY = Quaterniond(extRPY).inverse()``, so ``extRPY = R_lidar_orient`` where
      ``q_from = q_world_orient``; with ``R_imu_orient`` (``R_imu_orient`` maps the orientation
      frame to the IMU frame; default identity) it is ``R_lidar_imu · R_imu_orient``;
    * ``extrinsicTrans`` is the IMU's position in the lidar frame: ``lidar2Imu =
      Pose3(I, extTrans)``, ``imuPose = lidarPose.compose(lidar2Imu)`` — the translation of
      ``T_lidar_imu``. The params.yaml comment "T_lb (lidar -> imu)" names the same matrix.

    Returns
    -------
    dict
        ``{"extrinsicRot": [9], "extrinsicRPY": [9], "extrinsicTrans": [3]}`` (lists of floats).
    """
    if not isinstance(T_lidar_imu, Transform):
        raise TypeError(f"T_lidar_imu: expected a Transform, got {type(T_lidar_imu).__name__}")
    R_li = np.asarray(T_lidar_imu.R)
    R_io = np.eye(3) if R_imu_orient is None else validate.rotation(R_imu_orient, "R_imu_orient")
    return {
        "extrinsicRot": R_li.ravel().tolist(),
        "extrinsicRPY": (R_li @ R_io).ravel().tolist(),
        "extrinsicTrans": np.asarray(T_lidar_imu.t).tolist(),
    }


def from_liosam(
    extrinsicRot: Any,
    extrinsicRPY: Any,
    extrinsicTrans: Any,
    *,
    lidar_frame: str = "lidar",
    imu_frame: str = "imu",
) -> tuple[Transform, FloatArray]:
    """Inverse of :func:`to_liosam`: ``(T_lidar_imu, R_imu_orient)``.

    Each argument is LIO-SAM's list (9, 9 and 3 numbers, row-major); a non-rotation raises
    naming the parameter.
    """
    R = validate.rotation(
        np.reshape(validate.vector(extrinsicRot, "extrinsicRot", 9), (3, 3)), "extrinsicRot"
    )
    Rp = validate.rotation(
        np.reshape(validate.vector(extrinsicRPY, "extrinsicRPY", 9), (3, 3)), "extrinsicRPY"
    )
    t = validate.vector(extrinsicTrans, "extrinsicTrans", 3)
    return Transform(U.se3_assemble(R, t), lidar_frame, imu_frame), np.asarray(R.T @ Rp)


# ----------------------------------------------------------------------------- YAML
def _yaml() -> Any:
    try:
        import yaml
    except ImportError:
        raise ImportError(
            "reading and writing calibration YAML needs PyYAML, an optional extra: "
            'pip install ".[calib]" (from the checkout)'
        ) from None
    return yaml


_OPENCV_TAG = "tag:yaml.org,2002:opencv-matrix"


class _OpenCVMatrix(dict[str, Any]):
    """An ``!!opencv-matrix`` node (rows, cols, dt, data) as read."""


#: Deepest nesting of mappings and sequences a calibration file may have (real files: < 6).
YAML_MAX_DEPTH = 64
#: Largest number of values that aliases (``*anchor``) may add to a file's parsed size beyond
#: the file's own values: a few shared blocks are fine, a "billion laughs" expansion is not.
YAML_MAX_ALIAS_EXPANSION = 100_000


def _loader() -> Any:
    yaml = _yaml()
    base = getattr(yaml, "CSafeLoader", None) or yaml.SafeLoader  # libyaml's parser when present

    class Loader(base):  # type: ignore[misc,valid-type]
        pass

    def construct(loader: Any, node: Any) -> _OpenCVMatrix:
        return _OpenCVMatrix(loader.construct_mapping(node, deep=True))

    Loader.add_constructor(_OPENCV_TAG, construct)
    return Loader


def _check_yaml_shape(yaml: Any, text: str, path: PathLike, loader: Any) -> None:
    """Refuse a document too deep, self-referential, or expanded too much by its aliases.

    The limits: :data:`YAML_MAX_DEPTH` levels of nesting; :data:`YAML_MAX_ALIAS_EXPANSION`
    values added by aliases; no alias to an anchor still open (a structure that holds itself).
    One pass over the parser's events (iterative: no recursion, whatever the depth), before the
    recursive composer and constructor see the document. Each collection's expanded size is
    counted as it closes; an alias adds its anchor's size.
    """
    ev = yaml.events
    sizes: dict[str, int] = {}  # anchor → expanded size, once closed
    open_anchors: list[str | None] = []
    counts: list[int] = [0]  # expanded size of each open collection
    extra = 0  # values added by aliases
    for e in yaml.parse(text, Loader=loader):
        if isinstance(e, ev.ScalarEvent):
            counts[-1] += 1
            if e.anchor is not None:
                sizes[e.anchor] = 1
        elif isinstance(e, ev.CollectionStartEvent):
            if len(counts) > YAML_MAX_DEPTH:
                raise ValueError(
                    f"{path}: nested more than {YAML_MAX_DEPTH} levels deep (at line "
                    f"{e.start_mark.line + 1}); no calibration file is"
                )
            counts.append(1)
            open_anchors.append(e.anchor)
        elif isinstance(e, ev.CollectionEndEvent):
            size = counts.pop()
            anchor = open_anchors.pop()
            counts[-1] += size
            if anchor is not None:
                sizes[anchor] = size
        elif isinstance(e, ev.AliasEvent):
            alias_size = sizes.get(e.anchor)
            if alias_size is None:
                if e.anchor in open_anchors:
                    raise ValueError(
                        f"{path}: the alias *{e.anchor} refers to its own anchor (a "
                        "self-referential structure, which no calibration value is)"
                    )
                continue  # undefined: the composer reports it
            counts[-1] += alias_size
            extra += alias_size
            if extra > YAML_MAX_ALIAS_EXPANSION:
                raise ValueError(
                    f"{path}: its aliases expand it by more than {YAML_MAX_ALIAS_EXPANSION} "
                    f"values (at line {e.start_mark.line + 1}; an alias bomb?); refusing to "
                    "expand it"
                )


#: OpenCV's YAML header: ``%YAML:1.0`` (what ``cv::FileStorage`` writes) or ``%YAML 1.0``.
_OPENCV_HEADER = re.compile(r"\A(\s*)%YAML(:\s*|\s+)(\d+\.\d+)[^\n]*(\n|\Z)")
#: A block-mapping key at the start of a line with its value right after the colon
#: (``Viewer.PointSize:2``, ``data:[...]``): OpenCV's parser takes it, YAML needs a space.
_OPENCV_TIGHT_KEY = re.compile(r"^([ \t]*(?:-[ \t]+)?[A-Za-z_][\w.\-]*):(?=[^\s:/])", re.M)


def _opencv_dialect(text: str) -> str:
    """Rewrite OpenCV's YAML dialect into YAML that PyYAML parses, keeping line numbers.

    ``cv::FileStorage`` files (ORB-SLAM3's, VINS-Fusion's, OKVIS's and OpenVINS's configs)
    start with ``%YAML:1.0`` — a directive PyYAML rejects, replaced here by a comment line — and
    OpenCV's own parser also takes ``Key:value`` and ``data:[...]`` without the space after the
    colon that YAML requires (ORB-SLAM3's ``Examples/Stereo-Inertial/EuRoC.yaml`` has
    ``Viewer.PointSize:2`` and ``data:[...]``). In a file with OpenCV's header, a key at the
    start of a line (letters, digits, ``_``, ``.``, ``-``) directly followed by its value gets
    that space. ``!!opencv-matrix`` nodes are read by the loader (:func:`_loader`).
    A file without the header is read as plain YAML.
    """
    m = _OPENCV_HEADER.match(text)
    if m is None:
        return text
    text = f"{m.group(1)}# {text[len(m.group(1)) : m.end()]}" + text[m.end() :]
    if m.group(3) == "1.0" or ":" in m.group(2):  # OpenCV's own header, not YAML 1.1/1.2
        text = _OPENCV_TIGHT_KEY.sub(r"\1: ", text)
    return text


def _load_text(text: str, path: PathLike) -> Any:
    """YAML (plain or OpenCV's dialect) or JSON text → Python objects; errors name the file.

    The one loader of every calibration reader: a safe loader (no Python objects), with the
    depth and alias limits of :func:`_check_yaml_shape`; JSON nested too deep is refused too.
    """
    stripped = text.lstrip()
    if stripped.startswith("{") and '"' in stripped[:200]:
        try:
            return json.loads(text)
        except json.JSONDecodeError:
            pass  # YAML flow mappings also start with "{"
        except RecursionError:
            raise ValueError(f"{path}: JSON nested too deep for a calibration file") from None
    yaml = _yaml()
    text = _opencv_dialect(text)
    loader = _loader()
    try:
        _check_yaml_shape(yaml, text, path, loader)
        return yaml.load(text, Loader=loader)  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        msg = " ".join(str(exc).split())
        raise ValueError(f"{path}: not valid YAML: {msg}") from None


def _read(path: PathLike | CalibrationFile) -> Any:
    if isinstance(path, CalibrationFile):
        return path.data
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (UTF-8)") from None
    return _load_text(text, path)


@dataclass(frozen=True, eq=False)
class CalibrationFile:
    """A calibration file parsed once, to hand to several readers without parsing it again.

    :func:`read_kalibr`, :func:`read_extrinsic`, :func:`read_timeshift` and
    :func:`detect_file_system` take it in place of a path (a 20 MB file costs one parse, not
    one per reader). Build it with :meth:`read`; treat :attr:`data` as read-only.

    Attributes
    ----------
    path : Path
        The file, named in every error.
    data : object
        The parsed YAML/JSON (dicts, lists, numbers, strings), through the one loader of this
        module (safe, with depth and alias limits).
    """

    path: Path
    data: Any

    @classmethod
    def read(cls, path: PathLike) -> CalibrationFile:
        """Parse ``path`` (YAML, OpenCV's YAML dialect or JSON) once."""
        return cls(Path(path), _read(path))

    def __str__(self) -> str:
        return str(self.path)

    @property
    def system(self) -> str | None:
        """:func:`detect_system` of the data (None if no system's keys are found)."""
        return detect_system(self.data)


def _matrix(value: Any, where: str, shape: tuple[int, ...]) -> FloatArray:
    """Read a numeric matrix from a list of lists, a flat list or an ``!!opencv-matrix``."""
    if isinstance(value, _OpenCVMatrix):
        for key in ("rows", "cols", "dt", "data"):  # cv::FileStorage asserts each of them
            if key not in value:
                raise ValueError(
                    f"{where}: missing key {key!r} in the !!opencv-matrix (OpenCV needs rows, "
                    "cols, dt and data)"
                )
        rows, cols, data = value["rows"], value["cols"], value["data"]
        for key, n in (("rows", rows), ("cols", cols)):
            if isinstance(n, bool) or not isinstance(n, int) or n < 0:
                raise ValueError(f"{where}: !!opencv-matrix {key}: expected a count, got {n!r}")
        if not isinstance(data, list) or len(data) != rows * cols:
            n = len(data) if isinstance(data, list) else "no list of"
            raise ValueError(f"{where}: !!opencv-matrix {rows}x{cols} with {n} data values")
        value = [data[i * cols : (i + 1) * cols] for i in range(rows)]
    try:
        arr = validate.as_float_array(value, where)
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    if arr.size == int(np.prod(shape)) and arr.ndim <= 2:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise ValueError(f"{where}: expected {'x'.join(map(str, shape))} numbers, got {arr.shape}")
    validate.check_finite(arr, where)
    return arr


def _pose(value: Any, where: str) -> tuple[FloatArray, float]:
    """Read a rigid 4x4 from a file and the rotation tolerance its printed precision allows.

    The tolerance goes on with the matrix into the :class:`Transform` built from it, so a file
    printed with 4 decimals is validated at its own precision once, not refused at 1e-6 later.
    """
    T = _matrix(value, where, (4, 4))
    fields = [repr(float(x)) for x in T[:3, :3].ravel()]
    tol = pose_io.text_rotation_tol(fields)
    try:
        return validate.pose(T, where, tol), tol
    except ValueError as exc:
        raise ValueError(f"{exc} (a rigid transform is required)") from None


# ----------------------------------------------------------------------------- Kalibr
@dataclass(frozen=True)
class KalibrCamera:
    """One ``camN`` entry of a Kalibr camchain(-imucam) file.

    Attributes
    ----------
    name : str
        ``"cam0"``, ``"cam1"``, ...
    T_cam_imu : Transform or None
        Maps IMU coordinates to this camera's (``target_frame`` = ``name``).
    T_cn_cnm1 : Transform or None
        Maps the previous camera's coordinates to this camera's.
    timeshift_cam_imu : float or None
        ``t_imu = t_cam + timeshift_cam_imu`` (seconds).
    fields : dict
        Every other key as read (intrinsics, distortion, resolution, rostopic...), written back
        unchanged.
    """

    name: str
    T_cam_imu: Transform | None = None
    T_cn_cnm1: Transform | None = None
    timeshift_cam_imu: float | None = None
    fields: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class KalibrCamchain:
    """A Kalibr ``camchain-imucam.yaml`` (or ``camchain.yaml``): cameras in file order."""

    cameras: tuple[KalibrCamera, ...]
    imu_frame: str = "imu0"

    def camera(self, name: str) -> KalibrCamera:
        """Return the camera called ``name``; raise naming the cameras present."""
        for c in self.cameras:
            if c.name == name:
                return c
        have = ", ".join(c.name for c in self.cameras) or "(none)"
        raise ValueError(f"camera: no camera {name!r} in the chain (cameras: {have})")

    def tree(self) -> TransformTree:
        """Build a TransformTree of the IMU and cameras (``T_cam_imu``, else ``T_cn_cnm1``)."""
        tree = TransformTree()
        for c in self.cameras:
            if c.T_cam_imu is not None:
                tree.add(c.T_cam_imu)
        for c in self.cameras:
            if c.T_cn_cnm1 is not None and c.T_cam_imu is None:
                tree.add(c.T_cn_cnm1)
        return tree


def read_kalibr(path: PathLike | CalibrationFile, *, imu_frame: str = "imu0") -> KalibrCamchain:
    """Read a Kalibr camchain(-imucam) YAML file.

    Every ``T_cam_imu`` / ``T_cn_cnm1`` must be a rigid 4×4 (rotation orthonormal within the
    precision the numbers were printed with, bottom row ``[0, 0, 0, 1]``); otherwise a
    ``ValueError`` names the file, the camera and the field. The matrices are returned as
    written, never projected.
    """
    frame_name(imu_frame, "imu_frame")
    data = _read(path)
    if not isinstance(data, dict) or not data:
        raise ValueError(f"{path}: expected a mapping of cameras (cam0, cam1, ...)")
    cams: list[KalibrCamera] = []
    names = list(data)
    for i, name in enumerate(names):
        entry = data[name]
        if not isinstance(name, str) or not isinstance(entry, dict):
            raise ValueError(f"{path}: {name!r} is not a camera entry (a mapping under camN)")
        rest = {k: val for k, val in entry.items() if k not in _KALIBR_FIELDS}
        T_ci = T_cc = None
        if "T_cam_imu" in entry:
            T, tol = _pose(entry["T_cam_imu"], f"{path}: {name}.T_cam_imu")
            T_ci = Transform(T, name, imu_frame, tol=tol)
        if "T_cn_cnm1" in entry:
            if i == 0:
                raise ValueError(f"{path}: {name}.T_cn_cnm1 on the first camera (no previous)")
            T, tol = _pose(entry["T_cn_cnm1"], f"{path}: {name}.T_cn_cnm1")
            T_cc = Transform(T, name, str(names[i - 1]), tol=tol)
        shift = entry.get("timeshift_cam_imu")
        if shift is not None:
            shift = _time_offset(shift, f"{path}: {name}.timeshift_cam_imu")
        cams.append(KalibrCamera(name, T_ci, T_cc, shift, rest))
    return KalibrCamchain(tuple(cams), imu_frame)


_KALIBR_FIELDS = ("T_cam_imu", "T_cn_cnm1", "timeshift_cam_imu")


def write_kalibr(
    path: PathLike, chain: KalibrCamchain, *, style: Literal["kalibr", "opencv"] = "kalibr"
) -> None:
    """Write ``chain`` as Kalibr does (``yaml.dump``, flow-style rows, full-precision floats).

    Kalibr's own writer is ``yaml.dump(data, default_flow_style=None)``
    (``kalibr_common/ConfigReader.py`` ``writeYaml``); the numbers are written with ``repr``
    and read back bit-exact.

    ``style="opencv"`` writes the same data for readers built on OpenCV's ``cv::FileStorage``
    (OpenVINS reads its ``kalibr_imucam_chain.yaml`` that way): a ``%YAML:1.0`` header and
    sequence items indented under their key. OpenCV 5.0's YAML parser rejects Kalibr's own
    layout (items at the key's indentation: "Incorrect indentation"; measured in the tests).
    """
    if style not in ("kalibr", "opencv"):
        raise ValueError(f"style: expected 'kalibr' or 'opencv', got {style!r}")
    yaml = _yaml()
    data: dict[str, Any] = {}
    for c in chain.cameras:
        entry: dict[str, Any] = {
            k: _plain(val, f"chain: {c.name}.{k}") for k, val in c.fields.items()
        }
        if c.T_cam_imu is not None:
            entry["T_cam_imu"] = np.asarray(c.T_cam_imu.T).tolist()
        if c.T_cn_cnm1 is not None:
            entry["T_cn_cnm1"] = np.asarray(c.T_cn_cnm1.T).tolist()
        if c.timeshift_cam_imu is not None:
            entry["timeshift_cam_imu"] = float(c.timeshift_cam_imu)
        data[c.name] = entry
    if style == "kalibr":
        text = yaml.safe_dump(data, default_flow_style=None, width=2147483647)
    else:

        class Dumper(yaml.SafeDumper):  # type: ignore[name-defined]
            def increase_indent(self, flow: bool = False, indentless: bool = False) -> Any:
                return super().increase_indent(flow, False)

        text = "%YAML:1.0\n" + yaml.dump(
            data, Dumper=Dumper, default_flow_style=None, width=2147483647
        )
    with atomic_write(path, "w") as fh:  # the one helper: whole or nothing, links and FIFOs safe
        fh.write(text)


def _plain(x: Any, where: str) -> Any:
    """``x`` as plain YAML data (arrays as lists), refusing what the reader would refuse.

    Shared sub-objects stay shared (YAML anchors; no exponential expansion), a container that
    holds itself and an expansion beyond :data:`YAML_MAX_ALIAS_EXPANSION` values are refused
    with a ``ValueError`` naming the field — iteratively, so neither recursion nor time runs away.
    """
    memo: dict[int, tuple[Any, int]] = {}  # id → (plain copy, expanded size)
    on_path: set[int] = set()
    extra = 0

    def children(obj: Any) -> list[Any]:
        return list(obj.values()) if isinstance(obj, dict) else list(obj)

    root = x
    if not isinstance(root, (dict, list, tuple)):
        return _leaf(root)
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        obj, done = stack.pop()
        oid = id(obj)
        if done:
            on_path.discard(oid)
            kids = children(obj)
            plain = [memo[id(k)][0] if id(k) in memo else _leaf(k) for k in kids]
            size = 1 + sum(memo[id(k)][1] if id(k) in memo else _leaf_size(k) for k in kids)
            out: Any = dict(zip(obj.keys(), plain, strict=True)) if isinstance(obj, dict) else plain
            memo[oid] = (out, size)
            continue
        if oid in memo:
            extra += memo[oid][1]
            if extra > YAML_MAX_ALIAS_EXPANSION:
                raise ValueError(
                    f"{where}: shared sub-objects expand it by more than "
                    f"{YAML_MAX_ALIAS_EXPANSION} values; read_kalibr would refuse the file"
                )
            continue
        if oid in on_path:
            raise ValueError(f"{where}: a container holds itself (a self-referential structure)")
        if len(on_path) >= YAML_MAX_DEPTH:
            raise ValueError(f"{where}: nested more than {YAML_MAX_DEPTH} levels deep")
        on_path.add(oid)
        stack.append((obj, True))
        kids = [k for k in reversed(children(obj)) if isinstance(k, (dict, list, tuple))]
        stack.extend((k, False) for k in kids)
    return memo[id(root)][0]


def _leaf(x: Any) -> Any:
    return x.tolist() if isinstance(x, np.ndarray) else x


def _leaf_size(x: Any) -> int:
    return int(x.size) + 1 if isinstance(x, np.ndarray) else 1


# ----------------------------------------------------------------------------- other systems' files
def detect_system(data: Any) -> str | None:
    """Which system's file ``data`` (parsed YAML/JSON) looks like, or None."""
    if not isinstance(data, dict):
        return None
    if "value0" in data and isinstance(data["value0"], dict) and "T_imu_cam" in data["value0"]:
        return "basalt"
    if "T_imu_cam" in data and isinstance(data["T_imu_cam"], list) and data["T_imu_cam"]:
        if isinstance(data["T_imu_cam"][0], dict):
            return "basalt"
    if ("cameras" in data and isinstance(data["cameras"], list)) or "T_SC" in data:
        return "okvis"
    if "IMU.T_b_c1" in data or "Tbc" in data or "Stereo.T_c1_c2" in data:
        return "orbslam3"
    if any(re.fullmatch(r"body_T_cam\d+", str(k)) for k in data):
        return "vins_fusion"
    if "rvec" in data and "tvec" in data:
        return "opencv"
    cams = [val for k, val in data.items() if re.fullmatch(r"cam\d+", str(k))]
    if cams and all(isinstance(c, dict) for c in cams):
        if any("T_cam_imu" in c for c in cams):
            return "kalibr"
        if any("T_imu_cam" in c for c in cams):
            return "openvins"
    return None


def detect_file_system(path: PathLike | CalibrationFile) -> str | None:
    """:func:`detect_system` of a file (None if no system's keys are found)."""
    return detect_system(_read(path))


#: Where each system's file keeps camera N's extrinsic (what a missing-key error names).
REQUIRED_KEYS: dict[str, str] = {
    "kalibr": "camN.T_cam_imu",
    "openvins": "camN.T_imu_cam (or camN.T_cam_imu, inverted)",
    "okvis": "cameras[N].T_SC (camera 0: also a top-level T_SC)",
    "orbslam3": "IMU.T_b_c1 (camera 0; also Tbc in older files), Stereo.T_c1_c2 (camera 1)",
    "vins_fusion": "body_T_camN",
    "basalt": "T_imu_cam[N] with px, py, pz, qx, qy, qz, qw (under value0)",
    "opencv": "rvec, tvec",
}


def _missing(path: Any, key: str, system: str, note: str = "") -> ValueError:
    """Return the one error for a missing key: the file, the key, where the system keeps it."""
    more = f"; {note}" if note else ""
    return ValueError(
        f"{path}: missing key {key!r} (expected in a {system} file, which keeps camera N's "
        f"extrinsic in {REQUIRED_KEYS[system]}{more})"
    )


def read_extrinsic(
    path: PathLike | CalibrationFile,
    *,
    system: str | None = None,
    camera: str = "cam0",
    imu_frame: str = "imu0",
) -> Transform:
    """Read the camera–IMU extrinsic from ``system``'s file and return it as ``T_cam_imu``.

    Parameters
    ----------
    path : str, Path or CalibrationFile
        A Kalibr camchain-imucam.yaml, an OpenVINS kalibr_imucam_chain.yaml, an OKVIS config (or
        a top-level ``T_SC``, as :func:`format_parameter` prints it), an ORB-SLAM3 or
        VINS-Fusion settings file (OpenCV's YAML dialect), a Basalt calibration JSON, or a
        YAML/JSON with ``rvec`` and ``tvec`` (OpenCV).
    system : str, optional
        The file's system (:func:`system_names`); by default detected from its keys.
    camera : str
        ``"cam0"``, ``"cam1"``... ORB-SLAM3 keeps two cameras: ``cam0`` is ``IMU.T_b_c1``,
        ``cam1`` is ``IMU.T_b_c1 · Stereo.T_c1_c2`` (``Stereo.T_c1_c2`` maps camera-2
        coordinates to camera 1's).
    imu_frame : str
        Name of the IMU frame in the result.

    Returns
    -------
    Transform
        ``T_{camera}_{imu_frame}``: maps IMU coordinates to camera coordinates.

    Raises
    ------
    ValueError
        A key the system's file needs is missing (one line naming the file and the key, see
        :data:`REQUIRED_KEYS`), a matrix is not rigid, or the system cannot be told.
    """
    frame_name(camera, "camera")
    frame_name(imu_frame, "imu_frame")
    m = re.fullmatch(r"cam(\d+)", camera)
    if m is None:
        raise ValueError(f"camera: expected cam0, cam1, ..., got {camera!r}")
    idx = int(m.group(1))
    data = _read(path)
    name = detect_system(data) if system is None else system_format(system, "system").system
    if name is None:
        raise ValueError(
            f"{path}: cannot tell which system wrote it (no T_cam_imu, T_imu_cam, T_SC, "
            f"IMU.T_b_c1, body_T_camN, rvec/tvec found); give the system explicitly"
        )
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping at the top level for {name}")

    def need(mapping: Any, key: str, shown: str | None = None, note: str = "") -> Any:
        if not isinstance(mapping, dict) or key not in mapping:
            raise _missing(path, shown or key, name, note)
        return mapping[key]

    cams_here = ", ".join(str(k) for k in data if re.fullmatch(r"cam\d+", str(k))) or "none"
    no_camera = f"no camera {camera!r} here; cameras: {cams_here}"
    if name == "kalibr":  # the data parsed above, not the file again
        need(data, camera, note=no_camera)
        need(data[camera], "T_cam_imu", f"{camera}.T_cam_imu", "a camchain without the IMU?")
        parsed = path if isinstance(path, CalibrationFile) else CalibrationFile(Path(path), data)
        T_ci = read_kalibr(parsed, imu_frame=imu_frame).camera(camera).T_cam_imu
        assert T_ci is not None  # checked above
        return T_ci
    if name == "opencv":
        r = _matrix(need(data, "rvec"), f"{path}: rvec", (3,))
        t = _matrix(need(data, "tvec"), f"{path}: tvec", (3,))
        return from_rvec_tvec(r, t, target_frame=camera, source_frame=imu_frame)
    if name == "openvins":
        entry = need(data, camera, note=no_camera)
        where = f"{path}: {camera}.T_imu_cam"
        if isinstance(entry, dict) and "T_imu_cam" not in entry and "T_cam_imu" in entry:
            # OpenVINS falls back to an inverted T_cam_imu (opencv_yaml_parse.h)
            T, tol = _pose(entry["T_cam_imu"], f"{path}: {camera}.T_cam_imu")
            T = U.se3_inverse(T)
        else:
            T, tol = _pose(need(entry, "T_imu_cam", f"{camera}.T_imu_cam"), where)
    elif name == "okvis":
        if "cameras" not in data and "T_SC" in data:  # a bare T_SC, as format_parameter prints
            if idx != 0:
                raise _missing(path, f"cameras[{idx}].T_SC", name, "its top-level T_SC is cam0's")
            T, tol = _pose(data["T_SC"], f"{path}: T_SC")
        else:
            cams = need(data, "cameras", "cameras (or a top-level T_SC)")
            if not isinstance(cams, list):
                raise ValueError(f"{path}: cameras: expected a list of cameras")
            if idx >= len(cams):
                raise _missing(path, f"cameras[{idx}]", name, f"it has {len(cams)} camera(s)")
            where = f"{path}: cameras[{idx}].T_SC"
            T, tol = _pose(need(cams[idx], "T_SC", f"cameras[{idx}].T_SC"), where)
    elif name == "orbslam3":
        if idx > 1:
            raise ValueError(
                f"{path}: no {camera} in ORB-SLAM3 (it keeps two cameras: IMU.T_b_c1 for the "
                "first, Stereo.T_c1_c2 from the first to the second)"
            )
        key = "IMU.T_b_c1" if "IMU.T_b_c1" in data or "Tbc" not in data else "Tbc"
        T, tol = _pose(_orbslam3_float(need(data, key), path, key), f"{path}: {key}")
        if idx == 1:  # T_b_c2 = T_b_c1 · T_c1_c2 (Settings.cc reads Stereo.T_c1_c2 as Tlr)
            key = "Stereo.T_c1_c2"
            T12, tol12 = _pose(_orbslam3_float(need(data, key), path, key), f"{path}: {key}")
            T, tol = T @ T12, max(tol, tol12)
    elif name == "vins_fusion":
        key = f"body_T_cam{idx}"
        T, tol = _pose(need(data, key), f"{path}: {key}")
    else:  # basalt
        root = data["value0"] if isinstance(data.get("value0"), dict) else data
        poses = need(root, "T_imu_cam")
        if not isinstance(poses, list):
            raise ValueError(f"{path}: T_imu_cam: expected a list of poses (one per camera)")
        if idx >= len(poses):
            raise _missing(path, f"T_imu_cam[{idx}]", name, f"it has {len(poses)} camera(s)")
        p = poses[idx]
        where = f"{path}: T_imu_cam[{idx}]"
        keys = ("px", "py", "pz", "qx", "qy", "qz", "qw")
        if not isinstance(p, dict):
            raise ValueError(f"{where}: expected a mapping with keys {', '.join(keys)}")
        for k in keys:
            need(p, k, f"T_imu_cam[{idx}].{k}")
        x = _matrix([p[k] for k in keys], where, (7,))
        try:
            T = pose_io.to_matrix(x, layout="xyz_qxyzw")
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        tol = validate.ROTATION_TOL
    return Transform(T, imu_frame, camera, tol=tol).inverse()  # all of these hold T_imu_cam


class OrbSlam3PrecisionWarning(UserWarning):
    """An ORB-SLAM3 matrix that ORB-SLAM3 itself would misread (not ``dt: f``)."""


def _orbslam3_float(value: Any, path: Any, key: str) -> Any:
    """Warn when ORB-SLAM3 would misread ``key``: it takes every element with ``at<float>``.

    ORB_SLAM3 ``src/Converter.cc`` ``toSophus`` reads the matrix with ``cv::Mat::at<float>``
    whatever its type: a ``dt: d`` matrix is reinterpreted, not converted. liebridge reads the
    numbers as written and says so once, naming the file and the key.
    """
    if isinstance(value, _OpenCVMatrix) and value.get("dt", "f") != "f":
        warnings.warn(
            f"{path}: {key} is dt: {value.get('dt')}, but ORB-SLAM3 reads it with "
            "cv::Mat::at<float> (src/Converter.cc, toSophus) and would misread it; write it "
            "as dt: f (read here as written)",
            OrbSlam3PrecisionWarning,
            stacklevel=3,
        )
    return value


def read_timeshift(
    path: PathLike | CalibrationFile, *, system: str | None = None, camera: str = "cam0"
) -> float | None:
    """Kalibr's ``timeshift_cam_imu`` (seconds, ``t_imu = t_cam + shift``) from a system's file.

    Reads the system's own key and unit (:data:`TIME_OFFSETS`); None when the file has none or
    the system keeps none.
    """
    data = _read(path)
    name = detect_system(data) if system is None else system_format(system, "system").system
    if name not in TIME_OFFSETS or not isinstance(data, dict):
        return None
    key, scale, _ = TIME_OFFSETS[name]
    if name in ("kalibr", "openvins"):
        entry = data.get(camera)
        value = entry.get(key) if isinstance(entry, dict) else None
        where = f"{path}: {camera}.{key}"
    elif name == "basalt":
        root = data.get("value0", data)
        value = root.get(key) if isinstance(root, dict) else None
        where = f"{path}: {key}"
    else:
        value, where = data.get(key), f"{path}: {key}"
    if value is None:
        return None
    return _time_offset(value, where, scale)


def _num(x: float) -> str:
    return repr(float(x) + 0.0)  # + 0.0: no "-0.0" in a config file


def format_parameter(ext: SystemExtrinsic, camera: str | None = None) -> str:
    """Write the parameter in its system's own configuration syntax (a snippet to paste).

    Kalibr/OpenVINS: YAML rows under ``camN``; OKVIS: ``T_SC: [16 numbers]`` for camera 0, the
    ``cameras`` list (one ``{T_SC: [...]}`` item per camera, up to this one) for a later camera;
    ORB-SLAM3 and VINS-Fusion: OpenCV ``!!opencv-matrix`` (``dt: f`` for ORB-SLAM3, which reads
    floats; ``dt: d`` for VINS-Fusion) — ORB-SLAM3's second camera as ``IMU.T_b_c1`` and
    ``Stereo.T_c1_c2``, VINS-Fusion's as ``body_T_cam1``; Basalt: JSON, the whole ``T_imu_cam``
    list up to this camera (entry N is camera N); OpenCV: ``rvec``/``tvec`` YAML lists.
    Numbers are written with ``repr`` (they read back bit-exact, except ORB-SLAM3's float32).
    Every snippet, written to a file, is read back by :func:`read_extrinsic` with
    ``camera=ext.camera``.

    Parameters
    ----------
    ext : SystemExtrinsic
        From :func:`export_extrinsic`.
    camera : str, optional
        ``ext.camera`` (the default); another camera name is a ``ValueError`` (export with
        ``export_extrinsic(..., camera=...)``: the label and the matrix must agree).
    """
    if not isinstance(ext, SystemExtrinsic):
        raise TypeError(f"ext: expected a SystemExtrinsic, got {type(ext).__name__}")
    if camera is not None and camera != ext.camera:
        raise ValueError(
            f"camera: {camera!r}, but ext holds {ext.camera}'s {ext.parameter}; export it with "
            f"export_extrinsic(..., camera={camera!r})"
        )
    camera = ext.camera
    T = np.asarray(ext.transform.T)
    m = re.fullmatch(r"cam(\d+)", camera)
    idx = int(m.group(1)) if m else 0
    if ext.system in ("kalibr", "openvins"):
        head = "%YAML:1.0\n" if ext.system == "openvins" else ""
        body = "".join(f"    - [{r}]\n" for r in _rows_text(T))  # indented: cv::FileStorage
        if "timeshift_cam_imu" in ext.extra:
            body += f"  timeshift_cam_imu: {_num(ext.extra['timeshift_cam_imu'])}\n"
        return f"{head}{camera}:\n  {ext.parameter}:\n{body}"
    if ext.system == "okvis":
        if idx == 0:
            return f"T_SC: [{', '.join(_rows_text(T))}]\n"
        items = "".join(
            f"    - {{T_SC: [{', '.join(_rows_text(np.asarray(M)))}]}}\n"
            for M in (*(r.T for r in ext.rig), T)
        )
        return f"%YAML:1.0\ncameras:\n{items}"
    if ext.system in ("orbslam3", "vins_fusion"):
        dt = "f" if ext.system == "orbslam3" else "d"
        mats = [(r_key, r.T) for r_key, r in zip(("IMU.T_b_c1",), ext.rig, strict=False)]
        mats.append((ext.parameter, T))
        td = f"td: {_num(ext.extra['td'])}\n" if "td" in ext.extra else ""
        return "%YAML:1.0\n" + "".join(_opencv_matrix(k, M, dt) for k, M in mats) + td
    if ext.system == "basalt":
        poses = [_basalt_pose(np.asarray(r.T)) for r in ext.rig] + [_basalt_pose(T)]
        value0: dict[str, Any] = {"T_imu_cam": poses}
        if "cam_time_offset_ns" in ext.extra:
            value0["cam_time_offset_ns"] = ext.extra["cam_time_offset_ns"]
        return json.dumps({"value0": value0}, indent=4) + "\n"
    rvec, tvec = to_rvec_tvec(ext.transform)
    return (
        f"rvec: [{', '.join(_num(x) for x in rvec)}]\ntvec: [{', '.join(_num(x) for x in tvec)}]\n"
    )


def _rows_text(T: Any) -> list[str]:
    return [", ".join(_num(x) for x in row) for row in np.asarray(T)]


def _opencv_matrix(key: str, T: Any, dt: str) -> str:
    data = ",\n          ".join(_rows_text(T))
    return f"{key}: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: {dt}\n   data: [{data}]\n"
