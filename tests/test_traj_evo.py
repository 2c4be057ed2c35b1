"""APE/RPE against evo itself (installed from PyPI): same statistics to 1e-9 on the same inputs.

Trajectories: GTSAM's shipped sphere2500 poses with noise, in another world frame, scaled,
with jittered stamps and half the poses (tests/_traj_data.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from _traj_data import noisy_pair
from hypothesis import given
from hypothesis import strategies as st

from liebridge import traj
from liebridge.io import trajfile

evo = pytest.importorskip("evo")
from evo.core import metrics as em  # noqa: E402
from evo.core import sync  # noqa: E402
from evo.core.units import Unit  # noqa: E402
from evo.tools import file_interface  # noqa: E402

STATS = ("rmse", "mean", "median", "std", "min", "max")
RELATIONS = {
    "trans_part": em.PoseRelation.translation_part,
    "rot_part": em.PoseRelation.rotation_part,
    "full": em.PoseRelation.full_transformation,
    "angle_deg": em.PoseRelation.rotation_angle_deg,
    "angle_rad": em.PoseRelation.rotation_angle_rad,
    "point_distance": em.PoseRelation.point_distance,
}


def _close(ours: dict, theirs: dict) -> None:
    for k in STATS:
        assert ours[k] == pytest.approx(float(theirs[k]), rel=1e-9, abs=1e-9), k


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("evo")
    t_ref, T_ref, t_est, T_est = noisy_pair(n=800, scale=1.3)
    trajfile.write_trajectory(d / "ref.txt", t_ref, T_ref)
    trajfile.write_trajectory(d / "est.txt", t_est, T_est)
    return d / "ref.txt", d / "est.txt"


def _evo_pair(files, kind):
    r = file_interface.read_tum_trajectory_file(str(files[0]))
    e = file_interface.read_tum_trajectory_file(str(files[1]))
    r, e = sync.associate_trajectories(r, e)
    if kind != "none":
        e.align(r, correct_scale=(kind == "sim3"))
    return r, e


def _ours(files, kind):
    t_ref, T_ref = trajfile.read_trajectory(files[0])
    t_est, T_est = trajfile.read_trajectory(files[1])
    i_ref, i_est = traj.associate(t_ref, t_est)
    A = traj.align(T_ref[i_ref], T_est[i_est], kind)
    return T_ref[i_ref], A.apply(T_est[i_est]), A


@pytest.mark.parametrize("kind", ["none", "se3", "sim3"])
@pytest.mark.parametrize("relation", list(RELATIONS))
def test_ape_matches_evo(files, kind, relation):
    r, e = _evo_pair(files, kind)
    m = em.APE(RELATIONS[relation])
    m.process_data((r, e))
    Tr, Te, _ = _ours(files, kind)
    assert len(Tr) == r.num_poses
    _close(traj.statistics(traj.ape(Tr, Te, relation)).as_dict(), m.get_all_statistics())


@pytest.mark.parametrize("kind", ["se3", "sim3"])
def test_alignment_matches_evo(files, kind):
    r = file_interface.read_tum_trajectory_file(str(files[0]))
    e = file_interface.read_tum_trajectory_file(str(files[1]))
    r, e = sync.associate_trajectories(r, e)
    R, t, s = e.align(r, correct_scale=(kind == "sim3"))
    _, _, A = _ours(files, kind)
    np.testing.assert_allclose(A.R_ref_est, R, atol=1e-12)
    np.testing.assert_allclose(A.t_ref_est, t, atol=1e-9)
    assert A.scale == pytest.approx(s, rel=1e-12)


RPE_CASES = [
    (1, "frames", False),
    (7, "frames", False),
    (5, "frames", True),
    (3.0, "m", False),
    (2.0, "m", True),
    (10.0, "m", False),
]


@pytest.mark.parametrize(("delta", "unit", "all_pairs"), RPE_CASES)
@pytest.mark.parametrize("relation", ["trans_part", "angle_deg", "full", "point_distance"])
@pytest.mark.parametrize("kind", ["se3", "sim3"])
def test_rpe_matches_evo(files, kind, relation, delta, unit, all_pairs):
    r, e = _evo_pair(files, kind)
    m = em.RPE(
        RELATIONS[relation],
        delta,
        Unit.frames if unit == "frames" else Unit.meters,
        all_pairs=all_pairs,
    )
    m.process_data((r, e))
    Tr, Te, _ = _ours(files, kind)
    err, pairs = traj.rpe(Tr, Te, delta, unit, relation, all_pairs=all_pairs)
    assert [int(j) for j in pairs[:, 1]] == list(m.delta_ids)
    _close(traj.statistics(err).as_dict(), m.get_all_statistics())


def test_association_matches_evo_both_ways():
    rng = np.random.default_rng(3)
    a = np.cumsum(rng.uniform(0.001, 0.03, 500))
    b = np.cumsum(rng.uniform(0.001, 0.05, 300)) + 0.2
    for x, y, off in [(a, b, 0.0), (b, a, 0.0), (a, b, 0.013), (b, a, -0.02), (a, a[::3], 0.0)]:
        i1, i2 = sync.matching_time_indices(
            x if len(y) > len(x) else y,
            y if len(y) > len(x) else x,
            0.01,
            off if len(y) > len(x) else -off,
        )
        ours = traj.associate(x, y, offset=off)
        expected = (i1, i2) if len(y) > len(x) else (i2, i1)
        assert ours[0].tolist() == list(expected[0])
        assert ours[1].tolist() == list(expected[1])


def test_cli_json_matches_evo(files, capsys):
    import json

    from liebridge.cli import main

    assert (
        main(["traj", "ape", str(files[0]), str(files[1]), "--align", "sim3", "--format", "json"])
        == 0
    )
    out = capsys.readouterr().out
    res = json.loads(out)
    r, e = _evo_pair(files, "sim3")
    m = em.APE(em.PoseRelation.translation_part)
    m.process_data((r, e))
    _close(res, m.get_all_statistics())
    assert (
        main(
            [
                "traj",
                "rpe",
                str(files[0]),
                str(files[1]),
                "--align",
                "se3",
                "--delta",
                "4",
                "--unit",
                "frames",
                "--format",
                "json",
            ]
        )
        == 0
    )
    res = json.loads(capsys.readouterr().out)
    r, e = _evo_pair(files, "se3")
    m = em.RPE(em.PoseRelation.translation_part, 4, Unit.frames)
    m.process_data((r, e))
    _close(res, m.get_all_statistics())


def test_lerp_slerp_matches_evo_interpolate(files):
    from scipy.spatial.transform import Rotation

    r = file_interface.read_tum_trajectory_file(str(files[0]))
    t_ref, T_ref = trajfile.read_trajectory(files[0])
    rng = np.random.default_rng(7)
    tq = np.sort(rng.uniform(t_ref[0], t_ref[-1], 300))
    ours = traj.interpolate_poses(tq, t_ref, T_ref, "lerp_slerp")
    theirs = r.interpolate(tq)
    np.testing.assert_allclose(ours[:, :3, 3], theirs.positions_xyz, atol=1e-9)
    q = theirs.orientations_quat_wxyz
    R = Rotation.from_quat(np.roll(q, -1, axis=1)).as_matrix()
    np.testing.assert_allclose(ours[:, :3, :3], R, atol=1e-9)


@given(
    seed=st.integers(0, 2**31 - 1),
    n1=st.integers(1, 60),
    n2=st.integers(1, 60),
    step=st.sampled_from([0.005, 0.01, 0.02]),
    max_diff=st.sampled_from([0.0, 0.005, 0.01, 0.02]),
    offset=st.sampled_from([0.0, 0.01, -0.013, 0.5]),
)
def test_association_matches_evo_random(seed, n1, n2, step, max_diff, offset):
    """Random stamps on a coarse grid (so exact ties happen) against evo's own matcher."""
    rng = np.random.default_rng(seed)
    a = np.unique(np.round(rng.uniform(0, n1 * step * 2, n1) / 0.005) * 0.005)
    b = np.unique(np.round(rng.uniform(0, n2 * step * 2, n2) / 0.005) * 0.005)
    second_longer = len(b) > len(a)
    short, long = (a, b) if second_longer else (b, a)
    i_s, i_l = sync.matching_time_indices(
        short, long, max_diff, offset if second_longer else -offset
    )
    exp_ref, exp_est = (i_s, i_l) if second_longer else (i_l, i_s)
    if not i_s:
        with pytest.raises(ValueError, match="no overlapping timestamps"):
            traj.associate(a, b, max_diff=max_diff, offset=offset)
        return
    i_ref, i_est = traj.associate(a, b, max_diff=max_diff, offset=offset)
    assert i_ref.tolist() == list(exp_ref)
    assert i_est.tolist() == list(exp_est)


@pytest.mark.parametrize("swap", [False, True])
def test_interpolation_sync_matches_evo(files, capsys, swap):
    """``--interpolate lerp_slerp`` is evo's ``SyncMethod.interpolation`` (either side longer)."""
    import json

    from evo.core.sync_method import SyncMethod

    from liebridge.cli import main

    ref, est = (files[1], files[0]) if swap else files
    r = file_interface.read_tum_trajectory_file(str(ref))
    e = file_interface.read_tum_trajectory_file(str(est))
    r, e = sync.associate_trajectories(r, e, sync_method=SyncMethod.interpolation, offset_2=0.003)
    e.align(r, correct_scale=True)
    m = em.APE(em.PoseRelation.full_transformation)
    m.process_data((r, e))
    assert (
        main(
            [
                "traj",
                "ape",
                str(ref),
                str(est),
                "--align",
                "sim3",
                "--interpolate",
                "lerp_slerp",
                "--offset",
                "0.003",
                "-r",
                "full",
                "--format",
                "json",
            ]
        )
        == 0
    )
    res = json.loads(capsys.readouterr().out)
    assert res["resampled"] == ("est" if swap else "ref")  # the longer one (REF has 800 poses)
    _close(res, m.get_all_statistics())
