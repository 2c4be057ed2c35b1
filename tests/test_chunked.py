"""The unscented covariance conversion runs in bounded memory (chunks).

Chunked results equal unchunked ones (same arithmetic per element; tolerance only for BLAS
blocking), peak memory does not grow with the batch, and a bad element is named by its index in
the caller's batch, not in the chunk.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import liebridge as lb
from liebridge.conventions.convert import UNSCENTED_CHUNK
from liebridge.lie import se3


def _batch(shape: tuple[int, ...], seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(*shape, 6, 6)) * 0.2
    cov = A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(6)
    X = se3.exp(rng.normal(size=(*shape, 6)) * np.array([1, 1, 1, 30, 30, 30]))
    return cov, X


@pytest.mark.parametrize("shape", [(7,), (3, 5), (2, 2, 3)])
@pytest.mark.parametrize("chunk", [1, 2, 4, 1000])
@pytest.mark.parametrize(("src", "dst"), [("gtsam", "ros"), ("sophus", "g2o"), ("barfoot", "ros")])
def test_chunked_equals_unchunked(shape: tuple[int, ...], chunk: int, src: str, dst: str) -> None:
    cov, X = _batch(shape)
    whole = lb.convert_covariance(cov, X, src, dst, method="unscented", chunk_size=10**6)
    parts = lb.convert_covariance(cov, X, src, dst, method="unscented", chunk_size=chunk)
    assert parts.shape == (*shape, 6, 6)
    np.testing.assert_allclose(parts, whole, rtol=1e-13, atol=1e-15)
    # and each element equals its own single-element call
    flat = parts.reshape(-1, 6, 6)
    for k in (0, flat.shape[0] - 1):
        i = np.unravel_index(k, shape)
        one = lb.convert_covariance(cov[i], X[i], src, dst, method="unscented")
        np.testing.assert_allclose(flat[k], one, rtol=1e-13, atol=1e-15)


def test_rotation_chunk_equals_unchunked() -> None:
    rng = np.random.default_rng(1)
    A = rng.normal(size=(9, 3, 3)) * 0.3
    cov = A @ np.swapaxes(A, -1, -2)
    R = se3.exp(np.concatenate([rng.normal(size=(9, 3)), np.zeros((9, 3))], axis=-1))[..., :3, :3]
    whole = lb.convert_covariance(cov, R, "gtsam", "ros", method="unscented")
    parts = lb.convert_covariance(cov, R, "gtsam", "ros", method="unscented", chunk_size=2)
    np.testing.assert_allclose(parts, whole, rtol=1e-13, atol=1e-15)


def test_peak_memory_does_not_grow_with_the_batch() -> None:
    chunk = 64
    peaks = []
    for n in (4 * chunk, 16 * chunk):
        cov, X = _batch((n,))
        tracemalloc.start()
        lb.convert_covariance(cov, X, "gtsam", "ros", method="unscented", chunk_size=chunk)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    io_growth = 12 * chunk * 36 * 8 * 2  # the larger batch's extra output (and its copy)
    assert peaks[1] < peaks[0] + io_growth  # not 4x: the in-flight part is per chunk


def test_default_chunk_is_bounded() -> None:
    assert 256 <= UNSCENTED_CHUNK <= 65536


@pytest.mark.parametrize("chunk", [1, 2, None])
def test_bad_element_named_by_its_index_in_the_callers_batch(chunk: int | None) -> None:
    cov, X = _batch((2, 3))
    cov[1, 1] = np.eye(6) * 1e26  # sigma points beyond the representable rotation angle
    with pytest.raises(
        ValueError, match=r"cov \(its sigma points\).* at batch index \(1, 1, \d+\)"
    ):
        lb.convert_covariance(cov, X, "gtsam", "ros", method="unscented", chunk_size=chunk)


@pytest.mark.parametrize(
    ("chunk", "err"), [(0, ValueError), (-3, ValueError), (2.5, TypeError), (True, TypeError)]
)
def test_bad_chunk_size(chunk: object, err: type[Exception]) -> None:
    cov, X = _batch((2,))
    with pytest.raises(err, match="chunk_size"):
        lb.convert_covariance(cov, X, "gtsam", "ros", method="unscented", chunk_size=chunk)  # type: ignore[arg-type]


def test_embedding_destination_and_empty_batch() -> None:
    # g2o's SE(2) (3 coordinates) to ROS's 6x6 message embedding: dst's dimension, not src's
    rng = np.random.default_rng(2)
    A = rng.normal(size=(5, 3, 3)) * 0.1
    cov = A @ np.swapaxes(A, -1, -2)
    X = np.broadcast_to(np.eye(3), (5, 3, 3))
    whole = lb.convert_covariance(cov, X, "g2o_se2", "ros_pose2", method="unscented")
    parts = lb.convert_covariance(cov, X, "g2o_se2", "ros_pose2", method="unscented", chunk_size=2)
    assert whole.shape == (5, 6, 6)
    np.testing.assert_allclose(parts, whole, rtol=1e-13, atol=1e-15)
    empty = lb.convert_covariance(
        np.zeros((0, 6, 6)), np.zeros((0, 4, 4)), "gtsam", "ros", method="unscented"
    )
    assert empty.shape == (0, 6, 6)
