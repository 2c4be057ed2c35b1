"""One harness for every registered chart: the properties each chart kind must have.

Over every name in the registry (single-group conventions of every group, bundles, navigation
charts and the charts a user registered, ``tests/test_extending.py``): the round trip
``local(X, retract(X, d)) == d``, ``from_canonical·to_canonical == I``, ``to_canonical`` and
``local_jacobian`` against central differences through the chart's own retraction and GTSAM's
chart of the group, batching, and no mutation of the inputs. Elements are each group record's
probe (bundles: their blocks' probes).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from liebridge import check, conventions, lie
from liebridge.conventions import Bundle, Chart, Convention, NavChart, Sphere, Vector

pytestmark = pytest.mark.filterwarnings("error")


def _charts() -> list[str]:
    import test_extending  # noqa: F401  (registers the user's groups and conventions first)

    return conventions.names()


def _block_element(b: Any) -> np.ndarray:
    if isinstance(b, Vector):
        return np.linspace(0.1, 0.3, b.n)
    if isinstance(b, Sphere):
        return b.length * np.array([0.36, -0.48, 0.8])
    if isinstance(b, NavChart):
        return lie.se23.GROUP.probe
    return b.record.probe


def probe(c: Chart) -> np.ndarray:
    """A generic element of ``c`` (a bundle's: its blocks' probes)."""
    if isinstance(c, Bundle):
        return c.assemble(**{n: _block_element(b) for n, b in c.blocks})
    if isinstance(c, NavChart):
        return lie.se23.GROUP.probe
    assert isinstance(c, Convention)
    return c.record.probe


def _canonical(c: Chart) -> Chart:
    """GTSAM's chart of ``c``'s group: right, canonical order, the group's exponential.

    A bundle's: its blocks' (a vector's is ``b + d``, a sphere's GTSAM's ``Unit3`` chart).
    """
    if isinstance(c, Bundle):  # the blocks' canonical charts, concatenated
        return Bundle.of(
            "canonical",
            [
                (
                    n,
                    b
                    if isinstance(b, Vector)
                    else Sphere(b.length)
                    if isinstance(b, Sphere)
                    else _canonical(b),
                )
                for n, b in c.blocks
            ],
        )
    g = c.record
    return Convention(
        "canonical", "right", g.canonical_order, g.coupled_chart, "exp", "wxyz", group=g.name
    )  # type: ignore[arg-type]


NAMES = _charts()


def test_every_chart_kind_is_in_the_registry() -> None:
    kinds = {type(conventions.get(n)) for n in NAMES}
    assert {Convention, Bundle, NavChart} <= kinds
    groups = {conventions.get(n).group for n in NAMES}
    assert {"so2", "se2", "se3", "sim3", "se23", "t3", "planar"} <= groups


@pytest.mark.parametrize("name", NAMES)
def test_round_trip_and_inverse_maps(name: str) -> None:
    c = conventions.get(name)
    X = probe(c)
    n = c.dim(X)
    rng = np.random.default_rng(len(name))
    d = rng.uniform(-0.2, 0.2, size=(4, n))
    if c.embed is not None:  # only the group's coordinates move the element
        keep = np.zeros(n, dtype=bool)
        keep[list(c.embed.index)] = True
        d[:, ~keep] = 0.0
    Y = c.retract(X, d)
    np.testing.assert_allclose(c.local(X, Y), d, atol=1e-9)
    M, Minv = c.to_canonical(X), c.from_canonical(X)
    k = M.shape[-2]
    np.testing.assert_allclose(M @ Minv, np.eye(k), atol=1e-10)


@pytest.mark.parametrize("name", NAMES)
def test_first_order_maps_against_finite_differences(name: str) -> None:
    c = conventions.get(name)
    X = probe(c)
    ref = _canonical(c)
    num = check.numerical_jacobian(lambda Y: ref.local(X, Y), X, retract=c.retract, dim=c.dim(X))
    scale = 1.0 + np.abs(num).max()
    np.testing.assert_allclose(c.to_canonical(X), num, atol=1e-7 * scale)


@pytest.mark.parametrize("name", NAMES)
def test_local_jacobian_against_finite_differences(name: str) -> None:
    c = conventions.get(name)
    X = probe(c)
    n = c.dim(X)
    d = np.full(n, 0.15)
    if c.embed is not None:
        d = np.zeros(n)
        d[list(c.embed.index)] = 0.15
    Y = c.retract(X, d)
    num = check.numerical_jacobian(lambda Z: c.local(X, Z), Y, retract=c.retract, dim=n)
    scale = 1.0 + np.abs(num).max()
    J = c.local_jacobian(X, Y)
    if c.embed is not None:  # the coordinates outside the group are not a direction of it
        idx = list(c.embed.index)
        J, num = J[np.ix_(idx, idx)], num[np.ix_(idx, idx)]
    np.testing.assert_allclose(J, num, atol=1e-6 * scale)


@pytest.mark.parametrize("name", NAMES)
def test_batched_equals_one_by_one_and_inputs_are_not_mutated(name: str) -> None:
    c = conventions.get(name)
    X = np.stack([probe(c)] * 3)
    n = c.dim(X[0])
    d = np.random.default_rng(1).uniform(-0.1, 0.1, size=(3, n))
    X.setflags(write=False)
    d.setflags(write=False)
    Y = c.retract(X, d)
    for k in range(3):
        np.testing.assert_allclose(Y[k], c.retract(X[k], d[k]), atol=1e-14)
    np.testing.assert_allclose(c.to_canonical(X)[1], c.to_canonical(X[1]), atol=1e-14)


# --------------------------------------------------------------------------- one engine
FAST = [
    n
    for n in NAMES
    if isinstance(conventions.get(n), Convention)
    and conventions.get(n)._engine.rotations_3d
    and not conventions.get(n).is_euler
]


@pytest.mark.parametrize("name", FAST)
@pytest.mark.parametrize("rotation_only", [False, True], ids=["pose", "rotation"])
def test_se3_fast_implementation_equals_the_record_driven_engine(
    name: str, rotation_only: bool
) -> None:
    """SE(3)/SO(3)'s registered fast maps are the record-driven formulas, evaluated faster."""
    from liebridge.conventions.engine import RECORD_ENGINE

    c = conventions.get(name)
    assert isinstance(c, Convention)
    g = lie.so3.GROUP if rotation_only or not c.record.cols else lie.se3.GROUP
    c = conventions.Convention(
        c.name, c.side, c.order, c.chart, c.rotation, c.quat_order, group=g.name
    )
    fast = c._engine
    assert fast is not RECORD_ENGINE
    rng = np.random.default_rng(7)
    X = g.exp(rng.uniform(-1.0, 1.0, size=(5, g.dim)) * [2.0] * g.dim)
    Y = g.exp(rng.uniform(-1.0, 1.0, size=(5, g.dim)))
    d = rng.uniform(-0.3, 0.3, size=(5, g.dim))
    for op, args in (
        ("retract", (X, d)),
        ("local", (X, Y)),
        ("local_jacobian", (X, Y)),
        ("to_canonical", (X,)),
        ("from_canonical", (X,)),
    ):
        a = getattr(fast, op)(c, *args)
        b = getattr(RECORD_ENGINE, op)(c, *args)
        np.testing.assert_allclose(a, b, atol=1e-12, err_msg=f"{name}.{op}")


@pytest.mark.parametrize("name", NAMES)
def test_every_chart_pickles_for_worker_processes(name: str) -> None:
    """A process pool or a Dask worker receives charts by pickle: equal, and they still work."""
    import pickle

    c = conventions.get(name)
    c2 = pickle.loads(pickle.dumps(c))
    assert c2 == c and c2._engine is c._engine
    X = probe(c)
    d = np.full(c.dim(X), 0.1)
    if c.embed is not None:
        d = np.zeros(c.dim(X))
        d[list(c.embed.index)] = 0.1
    np.testing.assert_allclose(c2.retract(X, d), c.retract(X, d), atol=0)
