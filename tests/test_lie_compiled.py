"""The compiled SO(3)/SE(3) kernels (``liebridge/lie/_lie_ext.c``) against the numpy kernels.

``so3.exp/log`` and ``se3.exp/log/adjoint`` run as they are (compiled where built) and with
``liebridge.lie._compiled._lie_ext`` set to None (the numpy kernels, the reference): outputs agree
to a few ulps at every edge angle (0, tiny, around the series threshold, near and exactly π) and
30 m translations, over batch shapes; bad input gets the same error text; nothing is mutated.
The kernels' accuracy against GTSAM, Pinocchio and mpmath is tested in ``test_lie_so3.py`` and
``test_lie_se3.py``, which run through the compiled path where it is built.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from _strategies import EDGE_ANGLES, PI_AXES, assemble, pi_rotations, rotation_from_rotvec, twists
from hypothesis import given, settings
from hypothesis import strategies as st

from liebridge.lie import _compiled, se3, so3

AXES = [np.array(a) for a in PI_AXES]


def _numpy(fn: Callable[[], Any]) -> Any:
    ext = _compiled._lie_ext
    _compiled._lie_ext = None
    try:
        return fn()
    finally:
        _compiled._lie_ext = ext


def _close(a: np.ndarray, b: np.ndarray, tol: float = 4e-15) -> None:
    """Agree to ``tol`` relative to the larger of 1 and the entries' scale (a few ulps)."""
    assert a.shape == b.shape and a.dtype == b.dtype == np.float64
    scale = max(1.0, float(np.abs(b).max(initial=0.0)))
    assert float(np.abs(a - b).max(initial=0.0)) <= tol * scale


def _both(fn: Callable[[], Any], tol: float = 4e-15) -> None:
    _close(fn(), _numpy(fn), tol)


def _twists() -> np.ndarray:
    rng = np.random.default_rng(11)
    out = []
    for angle in EDGE_ANGLES:
        for u in AXES[:4]:
            for norm in (0.0, 1.0, 30.0):
                v = rng.normal(size=3)
                out.append(np.concatenate([angle * u, norm * v / np.linalg.norm(v)]))
    return np.array(out)


XI = _twists()


def _poses() -> np.ndarray:
    Rs = np.concatenate([rotation_from_rotvec(XI[:, :3]), pi_rotations()])
    rng = np.random.default_rng(12)
    t = rng.normal(size=(len(Rs), 3)) * rng.choice([0.0, 1.0, 30.0], size=(len(Rs), 1))
    return assemble(Rs, t)


T = _poses()


def test_compiled_kernels_are_built_where_ci_requires_it() -> None:
    """.ci/run sets LIEBRIDGE_REQUIRE_COMPILED=1: there a silently skipped build is a failure."""
    if os.environ.get("LIEBRIDGE_REQUIRE_COMPILED") == "1":
        assert _compiled.COMPILED


@pytest.mark.skipif(not _compiled.COMPILED, reason="compiled kernels not built")
def test_the_compiled_pass_is_the_one_taken() -> None:
    for op, x in (
        (_compiled.SO3_EXP, XI[:, :3].copy()),
        (_compiled.SO3_LOG, T[:, :3, :3].copy()),
        (_compiled.SE3_EXP, XI),
        (_compiled.SE3_LOG, T),
        (_compiled.SE3_ADJOINT, T),
    ):
        assert _compiled.run(op, x) is not None


def test_edge_angles_agree_with_numpy() -> None:
    w, R = XI[:, :3].copy(), T[:, :3, :3].copy()
    _both(lambda: so3.exp(w))
    _both(lambda: se3.exp(XI))
    _both(lambda: se3.adjoint(T))
    # log: near π the axis is read from R's symmetric part; both kernels do the same arithmetic
    _both(lambda: so3.log(R), 1e-14)
    _both(lambda: se3.log(T), 1e-14)


@pytest.mark.parametrize("shape", [(), (1,), (5,), (2, 3), (0,)])
def test_batch_shapes(shape: tuple[int, ...]) -> None:
    m = int(np.prod(shape))
    xi = XI[7 : 7 + m].reshape((*shape, 6))
    Tm = T[3 : 3 + m].reshape((*shape, 4, 4))
    w = np.ascontiguousarray(xi[..., :3])
    R = np.ascontiguousarray(Tm[..., :3, :3])
    for fn in (
        lambda: so3.exp(w),
        lambda: so3.log(R),
        lambda: se3.exp(xi),
        lambda: se3.log(Tm),
        lambda: se3.adjoint(Tm),
    ):
        a = fn()
        b = _numpy(fn)
        assert a.shape == b.shape
        _close(a, b, 1e-14)


@settings(max_examples=40, deadline=None)
@given(st.lists(twists(), min_size=1, max_size=6))
def test_random_twists_agree_with_numpy(xs: list[np.ndarray]) -> None:
    xi = np.array(xs)
    _both(lambda: se3.exp(xi))
    Tx = _numpy(lambda: se3.exp(xi))
    _both(lambda: se3.log(Tx), 1e-14)
    _both(lambda: se3.adjoint(Tx))


def _errors(fn: Callable[[], Any]) -> tuple[str, str]:
    msgs = []
    for run in (fn, lambda: _numpy(fn)):
        with pytest.raises((ValueError, TypeError)) as exc:
            run()
        msgs.append(f"{type(exc.value).__name__}: {exc.value}")
    return msgs[0], msgs[1]


def test_bad_input_gives_the_same_error() -> None:
    w = XI[:6, :3].copy()
    w[4, 1] = np.nan
    xi = XI[:6].copy()
    xi[2, 0] = 1e13  # rotation part beyond MAX_ANGLE
    Tb = T[:6].copy()
    Tb[3, :3, :3] *= 1.001
    Tc = T[:6].copy()
    Tc[1, 3, 2] = 0.5
    Rd = -T[:6, :3, :3]  # reflections
    cases = [
        lambda: so3.exp(w),
        lambda: se3.exp(xi),
        lambda: se3.log(Tb),
        lambda: se3.adjoint(Tc),
        lambda: so3.log(Rd),
        lambda: so3.log(Tb[:, :3, :3].copy()),
        lambda: se3.exp(np.full((2, 6), np.inf)),
        lambda: se3.log(np.ones((4, 3))),
    ]
    for fn in cases:
        a, b = _errors(fn)
        assert a == b
    assert "batch index (3,)" in _errors(lambda: se3.log(Tb))[0]


def test_valid_input_the_certificate_does_not_accept() -> None:
    """Rotations off by less than ROTATION_TOL: Frobenius certificate may refuse, numpy accepts."""
    Tm = T[:6].copy()
    Tm[:, :3, :3] *= 1.0 + 3e-7
    _both(lambda: se3.log(Tm), 1e-14)
    _both(lambda: se3.adjoint(Tm))


def test_inputs_are_not_mutated_and_outputs_are_new() -> None:
    xi, Tm = XI.copy(), T.copy()
    before = (xi.tobytes(), Tm.tobytes())
    outs = [se3.exp(xi), se3.log(Tm), se3.adjoint(Tm), so3.exp(xi[:, :3].copy())]
    assert (xi.tobytes(), Tm.tobytes()) == before
    for o in outs:
        assert not np.shares_memory(o, xi) and not np.shares_memory(o, Tm)
    ro = Tm.copy()
    ro.flags.writeable = False
    _both(lambda: se3.log(ro), 1e-14)
    _both(lambda: se3.exp(xi.tolist()))  # lists go through numpy
    _both(lambda: se3.log(np.stack([Tm, Tm], axis=1)[:, 0]), 1e-14)  # a strided view


@pytest.mark.skipif(not _compiled.COMPILED, reason="compiled kernels not built")
def test_vectorized_trig_sweep_matches_numpy() -> None:
    """The polynomial sin/cos/atan2 of the chunked passes against libm through numpy.

    Dense angles over [0, 2.6 π] (every quadrant of the half angle, across FAST_MAX and
    SMALL_ANGLE, chunk boundaries: the batch is not a multiple of 256), random axes.
    """
    rng = np.random.default_rng(5)
    n = 20_011
    theta = np.concatenate([np.linspace(0.0, 2.6 * np.pi, n - 11), np.pi - 10.0 ** -np.arange(11)])
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    xi = np.concatenate([theta[:, None] * u, 30.0 * rng.normal(size=(n, 3))], axis=1)
    w = np.ascontiguousarray(xi[:, :3])
    _both(lambda: so3.exp(w), 2e-15)
    _both(lambda: se3.exp(xi), 2e-15)
    T = _numpy(lambda: se3.exp(xi))
    R = np.ascontiguousarray(T[:, :3, :3])
    _both(lambda: so3.log(R), 2e-15)
    _both(lambda: se3.log(T), 2e-15)


@pytest.mark.parametrize("where", [0, 255, 256, 700, 999])
def test_bad_element_in_any_chunk_is_refused(where: int) -> None:
    """The chunked passes (256 elements a chunk) certify every element: one bad element at a chunk
    edge or in the tail gets numpy's error naming its index (the same text), whatever the kind."""
    rng = np.random.default_rng(where)
    xi = np.concatenate([rng.normal(size=(1000, 3)), 30.0 * rng.normal(size=(1000, 3))], axis=1)
    Tm = _numpy(lambda: se3.exp(xi))
    R = np.ascontiguousarray(Tm[:, :3, :3])

    def bad(a: np.ndarray, index: tuple[int, ...], value: float) -> np.ndarray:
        b = a.copy()
        b[(where, *index)] = value
        return b

    cases = [
        lambda: so3.exp(bad(xi[:, :3].copy(), (1,), np.nan)),
        lambda: se3.exp(bad(xi, (4,), np.inf)),  # the translation part
        lambda: se3.exp(bad(xi, (2,), 2e12)),
        lambda: so3.log(bad(R, (1, 2), np.nan)),
        lambda: so3.log(-R[:] if where == 0 else bad(R, (0, 0), -R[where, 0, 0])),
        lambda: se3.log(bad(Tm, (3, 1), 1e-9)),  # bottom row
        lambda: se3.log(bad(Tm, (1, 3), np.inf)),  # translation
        lambda: se3.log(bad(Tm, (2, 2), 1.01 * Tm[where, 2, 2])),
        lambda: se3.adjoint(bad(Tm, (0, 3), np.nan)),
    ]
    for fn in cases:
        a, b = _errors(fn)
        assert a == b
        assert f"({where},)" in a
