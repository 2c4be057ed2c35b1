"""Kalibr's camera–IMU calibration, exported to every VIO system, checked on a point.

Writes a Kalibr ``camchain-imucam.yaml`` for the EuRoC MAV rig (cam0, cam1; the EuRoC ``T_BS``
that OKVIS, OpenVINS and VINS-Fusion ship in their configs, inverted into Kalibr's
``T_cam_imu``), reads it back with :func:`liebridge.frames.read_kalibr`, and for each system
prints the parameter name, the direction in words and the snippet to paste into its config.
Then it checks the one thing that matters: a landmark seen by the IMU-frame lands at the same
camera coordinates whichever system's parameter is used, each in that system's own way.
Last, the TF tree answers ``T_cam1_cam0`` and the body frame is re-expressed FLU → FRD.

Run: ``python examples/kalibr_to_vio.py [--out DIR]`` (no plot; prints only).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from liebridge.frames import (
    KalibrCamchain,
    KalibrCamera,
    Transform,
    axes_transform,
    export_extrinsic,
    format_parameter,
    read_kalibr,
    system_names,
    write_kalibr,
)
from liebridge.lie import se3

# EuRoC MAV sensor.yaml T_BS of cam0 and cam1 (camera -> body/IMU)
T_IMU_CAM0 = np.array(
    [
        [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975],
        [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768],
        [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
T_IMU_CAM1 = np.array(
    [
        [0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556],
        [0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024],
        [-0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038],
        [0.0, 0.0, 0.0, 1.0],
    ]
)


def map_point(system: str, T: np.ndarray, p_imu: np.ndarray) -> np.ndarray:
    """Camera coordinates of ``p_imu`` computed as ``system`` uses its parameter ``T``."""
    if system in ("kalibr", "opencv"):  # p_cam = T_cam_imu p_imu
        return T[:3, :3] @ p_imu + T[:3, 3]
    # every other system stores T_imu_cam and inverts it: p_cam = Rᵀ (p_imu − t)
    return T[:3, :3].T @ (p_imu - T[:3, 3])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="directory for the YAML written (default: temp)")
    args = ap.parse_args()
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="kalibr_to_vio_"))
    out.mkdir(parents=True, exist_ok=True)

    # a Kalibr camchain-imucam.yaml, written as Kalibr writes it
    T0 = Transform(se3.inverse(T_IMU_CAM0), "cam0", "imu0")
    T1 = Transform(se3.inverse(T_IMU_CAM1), "cam1", "imu0")
    chain = KalibrCamchain(
        (
            KalibrCamera("cam0", T0, None, 0.0, {"rostopic": "/cam0/image_raw"}),
            KalibrCamera("cam1", T1, T1 @ T0.inverse(), 0.0, {"rostopic": "/cam1/image_raw"}),
        )
    )
    path = out / "camchain-imucam.yaml"
    write_kalibr(path, chain)
    chain = read_kalibr(path)
    T_cam_imu = chain.camera("cam0").T_cam_imu
    assert T_cam_imu is not None
    print(f"read {path}: {T_cam_imu.describe()}")

    p_imu = np.array([0.5, -0.2, 3.0])  # a landmark, in IMU coordinates
    p_cam = T_cam_imu.apply(p_imu)
    worst = 0.0
    for system in system_names():
        ext = export_extrinsic(T_cam_imu, system)
        print(f"\n== {system}: {ext.parameter}")
        print(ext.direction)
        print(format_parameter(ext).rstrip())
        worst = max(worst, float(np.abs(map_point(system, ext.transform.T, p_imu) - p_cam).max()))
    print(f"\nlandmark in cam0 by every system's own use: max difference {worst:.1e} m")

    T_c1_c0 = chain.tree().lookup("cam1", "cam0")
    print(f"stereo baseline |t| of {T_c1_c0.name}: {np.linalg.norm(T_c1_c0.t):.4f} m")
    # the IMU frame as FRD instead of its FLU-like axes: compose with a constant frame
    T_cam_imufrd = T_cam_imu @ axes_transform("FLU", "FRD", "imu0", "imu0_frd")
    print(f"{T_cam_imufrd.name}: maps FRD IMU coordinates to cam0")
    return 0 if worst < 1e-12 else 1


if __name__ == "__main__":
    raise SystemExit(main())
