"""Bad input: a 3×3 with unit columns that is not a rotation, at every public entry point.

A matrix whose columns all have norm 1 passes a column-norm check but is not orthonormal (here
columns 0 and 1 meet at 45°). Every function that takes a rotation or a pose must refuse it with
the argument, the batch index and the size of the violation (a mutation that checked only the
column norms was caught by one kernel test alone).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions import get
from liebridge.io import poses
from liebridge.lie import se3, so3

SKEWED = np.column_stack([[1.0, 0.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5), 0.0], [0.0, 0.0, 1.0]])
assert np.allclose(np.linalg.norm(SKEWED, axis=0), 1.0)


def _rotations() -> np.ndarray:
    R = np.broadcast_to(np.eye(3), (3, 3, 3)).copy()
    R[1] = SKEWED
    return R


def _poses() -> np.ndarray:
    T = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()
    T[1, :3, :3] = SKEWED
    T[:, :3, 3] = [1.0, 2.0, 3.0]
    return T


CALLS: dict[str, Callable[[], Any]] = {
    "so3.log": lambda: so3.log(_rotations()),
    "so3.adjoint": lambda: so3.adjoint(_rotations()),
    "se3.log": lambda: se3.log(_poses()),
    "se3.inverse": lambda: se3.inverse(_poses()),
    "se3.adjoint": lambda: se3.adjoint(_poses()),
    "tangent_map(rotation)": lambda: lb.tangent_map(_rotations(), "gtsam", "sophus"),
    "tangent_map(pose)": lambda: lb.tangent_map(_poses(), "gtsam", "ros"),
    "convert_covariance": lambda: lb.convert_covariance(np.eye(6), _poses(), "gtsam", "g2o"),
    "Convention.retract": lambda: get("sophus").retract(_poses(), np.zeros(6)),
    "Convention.local": lambda: get("ros").local(_poses(), _poses()),
    "poses.from_matrix": lambda: poses.from_matrix(_poses(), layout="xyz_qxyzw"),
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_unit_columns_that_are_not_orthogonal_are_refused(name: str) -> None:
    with pytest.raises(ValueError, match=r"batch index \(1,\)") as info:
        CALLS[name]()
    msg = str(info.value)
    assert "orthonormal" in msg or "rotation" in msg, msg
    assert any(ch.isdigit() for ch in msg.split("batch index")[-1]), msg  # the violation's size


SINGLE: dict[str, Callable[[], Any]] = {
    "so3.log": lambda: so3.log(SKEWED),
    "se3.log": lambda: se3.log(_poses()[1]),
    "tangent_map": lambda: lb.tangent_map(_poses()[1], "gtsam", "sophus"),
    "Convention.retract(rotation)": lambda: get("gtsam").retract(SKEWED, np.zeros(3)),
}


@pytest.mark.parametrize("name", sorted(SINGLE))
def test_one_skewed_matrix_is_refused_by_the_single_element_fast_path(name: str) -> None:
    """The one-element path certifies a rotation without numpy; it must refuse the same input."""
    with pytest.raises(ValueError, match=r"batch index \(\)"):
        SINGLE[name]()
