"""Learned-SLAM libraries run here: presets, what detection names, their objects in and out.

Beside ``tests/test_presets_run.py`` (which runs every library's update and difference against
its preset through :data:`liebridge.conventions.verification.CHECKS`, lietorch and DPVO included):
here the facts that harness does not reach — PyPose's and Theseus's own losses against the exact
composition (a 50-digit reference, ``tests/_mp_reference.py``), kornia's storage and product,
detection without a preference, and the objects of PyPose, Theseus, kornia and jaxlie read as
matrices and built from them, their storage orders checked number by number.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

from liebridge import interop
from liebridge.conventions import detect_convention, get, matching_presets
from liebridge.lie import quaternion, se3

mp_ref = pytest.importorskip("_mp_reference")
torch = pytest.importorskip("torch")


def _lib(name: str):  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pytest.importorskip(name)


def _np(x) -> np.ndarray:  # type: ignore[no-untyped-def]
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    return np.asarray(x, dtype=np.float64)


@contextlib.contextmanager
def _x64(jax):  # type: ignore[no-untyped-def]
    old = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", old)


def _axis(rng: np.random.Generator) -> np.ndarray:
    a = rng.normal(size=3)
    return a / np.linalg.norm(a)


#: Poses at rotation angles 0, 1e-9, generic and near/at π (and a 30 m translation).
def _poses() -> np.ndarray:
    rng = np.random.default_rng(11)
    out = []
    for th in (0.0, 1e-9, 0.7, 2.5, np.pi - 1e-7, np.pi):
        t = rng.normal(size=3) * (30.0 if th == 0.7 else 1.0)
        out.append(se3.exp(np.r_[th * _axis(rng), t]))
    return np.stack(out)


# --------------------------------------------------------------------------- library accuracy
def test_pypose_exp_loses_1e_9_at_tiny_angles_where_the_preset_is_exact() -> None:
    """PyPose's ``se3.Exp`` cuts ``V(φ)`` to ``I`` below its threshold: ~|v|·|φ| off at 1e-9."""
    pp = _lib("pypose")
    rng = np.random.default_rng(0)
    conv = get("pypose")
    worst_lib = worst_pre = 0.0
    for _ in range(5):
        d = np.r_[rng.normal(size=3) * 3.0, 1e-9 * _axis(rng)]  # (τ, φ)
        exact = mp_ref.retract(conv, "se3", np.eye(4), d)  # Exp(d)·I at 50 digits
        lib = _np(pp.se3(torch.tensor(d, dtype=torch.float64)).Exp().matrix())
        worst_lib = max(worst_lib, float(np.abs(lib - exact).max()))
        worst_pre = max(worst_pre, float(np.abs(conv.retract(np.eye(4), d) - exact).max()))
    assert worst_pre < 1e-15
    assert 1e-11 < worst_lib < 5e-9, worst_lib  # measured ≈ 1e-9 with |τ| ≈ 5 (pypose 0.9.5)


def test_theseus_exp_map_loses_1e_7_near_1e_3_where_the_preset_is_exact() -> None:
    """Theseus's ``SE3.exp_map`` switches to a short series at small angles: ~1e-7 at 1e-3."""
    th = _lib("theseus")
    rng = np.random.default_rng(1)
    conv = get("theseus")
    worst_lib = worst_pre = 0.0
    for _ in range(5):
        d = np.r_[rng.normal(size=3), 1e-3 * _axis(rng)]  # (v, ω)
        exact = mp_ref.retract(conv, "se3", np.eye(4), d)
        lib = _np(th.SE3.exp_map(torch.tensor(d[None], dtype=torch.float64)).to_matrix())[0]
        worst_lib = max(worst_lib, float(np.abs(lib - exact).max()))
        worst_pre = max(worst_pre, float(np.abs(conv.retract(np.eye(4), d) - exact).max()))
    assert worst_pre < 1e-15
    assert 1e-9 < worst_lib < 1e-6, worst_lib  # measured ≈ 1-2e-7 (theseus-ai 0.2.3)


# --------------------------------------------------------------------------- kornia
def test_kornia_stores_wxyz_multiplies_matrices_and_orders_the_tangent_v_omega() -> None:
    lg = _lib("kornia.geometry.liegroup")
    rng = np.random.default_rng(2)
    A, B = _poses()[2], _poses()[3]
    a = lg.Se3.from_matrix(torch.tensor(A))
    b = lg.Se3.from_matrix(torch.tensor(B))
    q = _np(a.r.q.data)
    want = quaternion.from_matrix(A[:3, :3], order="wxyz")
    assert min(np.abs(q - want).max(), np.abs(q + want).max()) < 1e-12  # (w, x, y, z)
    assert np.abs(_np(a.t) - A[:3, 3]).max() < 1e-12
    assert np.abs(_np((a * b).matrix()) - A @ B).max() < 1e-12  # a * b is the matrix product
    v = np.r_[rng.normal(size=3), 0.8 * _axis(rng)]  # (υ, ω) in kornia's exp
    E = _np(lg.Se3.exp(torch.tensor(v)).matrix())
    P = np.zeros((6, 6))
    P[:3, 3:] = P[3:, :3] = np.eye(3)
    assert np.abs(E - se3.exp(P @ v)).max() < 1e-12
    assert np.abs(E - se3.exp(v)).max() > 1e-2  # not (ω, v)


def test_kornia_preset_says_the_side_is_the_users_choice() -> None:
    assert "user's choice" in get("kornia").notes
    for name in ("lietorch", "dpvo", "kornia", "pypose"):
        assert "False" in get(name).notes  # each names the tempting false identity


# --------------------------------------------------------------------------- detection
def _pypose_retract(pp):  # type: ignore[no-untyped-def]
    def retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
        G = pp.mat2SE3(torch.tensor(X), check=False)
        return _np(G.Retr(pp.se3(torch.tensor(d))).matrix())

    return retract


def test_detect_names_pypose_and_lietorch_shares_its_fields() -> None:
    pp = _lib("pypose")
    found = detect_convention(_pypose_retract(pp))
    assert found.name == "pypose"
    assert get("lietorch") in matching_presets(found)
    assert detect_convention(_pypose_retract(pp), prefer="lietorch").name == "lietorch"


def test_detect_names_dpvo_from_the_update_of_a_stored_world_to_camera_pose() -> None:
    """DPVO's update: lietorch's (PyPose's) ``Exp(a)·T_cam_world``, read on ``T_world_cam``."""
    pp = _lib("pypose")
    lib = _pypose_retract(pp)
    found = detect_convention(lambda T, a: np.linalg.inv(lib(np.linalg.inv(T), a)))
    assert found.name == "dpvo" and found.stores == "inverse"
    assert get("droid_slam") is found


def test_detect_names_theseus_from_its_retract() -> None:
    th = _lib("theseus")

    def retract(X: np.ndarray, d: np.ndarray) -> np.ndarray:
        G = th.SE3(tensor=torch.tensor(X[None, :3, :]))
        return _np(G.retract(torch.tensor(d[None])).to_matrix())[0]

    assert detect_convention(retract, prefer="theseus").name == "theseus"
    found = detect_convention(retract)  # Sophus, manif, ... have the same retraction
    assert get("theseus") in matching_presets(found)


# --------------------------------------------------------------------------- objects in and out
BATCHES = [(), (6,), (2, 3)]


def _batch(shape: tuple[int, ...]) -> np.ndarray:
    P = _poses()
    return P[0] if shape == () else P.reshape(*shape, 4, 4) if shape == (2, 3) else P


def _close_q(q: np.ndarray, want: np.ndarray) -> float:
    return float(np.minimum(np.abs(q - want).max(-1), np.abs(q + want).max(-1)).max())


@pytest.mark.parametrize("shape", BATCHES, ids=str)
def test_pypose_lietensor_round_trip_and_storage(shape: tuple[int, ...]) -> None:
    pp = _lib("pypose")
    T = _batch(shape)
    obj = interop.to_library(T, like="pypose")
    assert type(obj).__name__ == "LieTensor" and obj.shape == (*shape, 7)
    data = _np(obj.tensor())
    assert np.abs(data[..., :3] - T[..., :3, 3]).max() < 1e-12  # [tx, ty, tz, ...]
    assert _close_q(data[..., 3:], quaternion.from_matrix(T[..., :3, :3], order="xyzw")) < 1e-9
    M = interop.as_pose_matrix(obj)
    assert isinstance(M, torch.Tensor) and type(M) is torch.Tensor and M.dtype == torch.float64
    assert np.abs(_np(M) - T).max() < 1e-9
    assert type(interop.to_library(T, like=pp.identity_SE3())).__name__ == "LieTensor"
    R = interop.to_library(T[..., :3, :3], like="pypose")
    assert np.abs(_np(interop.as_pose_matrix(R)) - T[..., :3, :3]).max() < 1e-9


@pytest.mark.parametrize("shape", BATCHES, ids=str)
def test_theseus_round_trip_and_storage(shape: tuple[int, ...]) -> None:
    th = _lib("theseus")
    T = _batch(shape)
    flat = T.reshape(-1, 4, 4)
    obj = interop.to_library(T, like=th.SE3)
    assert isinstance(obj, th.SE3) and tuple(obj.tensor.shape) == (len(flat), 3, 4)
    assert np.abs(_np(obj.tensor) - flat[:, :3, :]).max() == 0.0  # (B, 3, 4) [R | t]
    xyzq = _np(obj.to_x_y_z_quaternion())  # [x, y, z, qw, qx, qy, qz]
    assert np.abs(xyzq[:, :3] - flat[:, :3, 3]).max() < 1e-12
    # Theseus's own quaternion: w from sqrt(1 + trace) loses ~1e-8 near π (1.2e-8 at π − 1e-7)
    assert _close_q(xyzq[:, 3:], quaternion.from_matrix(flat[:, :3, :3], order="wxyz")) < 5e-8
    assert np.abs(_np(interop.as_pose_matrix(obj)) - flat).max() < 1e-12
    R = interop.to_library(T[..., :3, :3], like="theseus")
    assert isinstance(R, th.SO3)
    assert np.abs(_np(interop.as_pose_matrix(R)) - flat[:, :3, :3]).max() < 1e-12


@pytest.mark.parametrize("shape", BATCHES, ids=str)
def test_kornia_round_trip_and_storage(shape: tuple[int, ...]) -> None:
    lg = _lib("kornia.geometry.liegroup")
    T = _batch(shape)
    obj = interop.to_library(T, like="kornia")
    assert isinstance(obj, lg.Se3)
    assert _close_q(_np(obj.r.q.data), quaternion.from_matrix(T[..., :3, :3], order="wxyz")) < 1e-9
    assert np.abs(_np(obj.t) - T[..., :3, 3]).max() < 1e-12
    assert np.abs(_np(interop.as_pose_matrix(obj)) - T).max() < 1e-9
    same = interop.to_library(T, like=obj)
    assert isinstance(same, lg.Se3)
    R = interop.to_library(T[..., :3, :3], like=lg.So3)
    assert np.abs(_np(interop.as_pose_matrix(R)) - T[..., :3, :3]).max() < 1e-9


@pytest.mark.parametrize("shape", BATCHES, ids=str)
def test_jaxlie_round_trip_and_storage(shape: tuple[int, ...]) -> None:
    jaxlie = _lib("jaxlie")
    import jax

    T = _batch(shape)
    with _x64(jax):  # JAX holds float32 unless x64 is on
        obj = interop.to_library(T, like="jaxlie")
        assert isinstance(obj, jaxlie.SE3)
        v = _np(obj.wxyz_xyz)  # [qw, qx, qy, qz, x, y, z]
        assert np.abs(v[..., 4:] - T[..., :3, 3]).max() < 1e-12
        assert _close_q(v[..., :4], quaternion.from_matrix(T[..., :3, :3], order="wxyz")) < 1e-9
        assert np.abs(_np(interop.as_pose_matrix(obj)) - T).max() < 1e-9
        R = interop.to_library(T[..., :3, :3], like=jaxlie.SO3.identity())
        assert isinstance(R, jaxlie.SO3)
        assert np.abs(_np(interop.as_pose_matrix(R)) - T[..., :3, :3]).max() < 1e-9


def test_torch_graph_device_and_dtype_survive_the_round_trip() -> None:
    _lib("pypose")
    T = torch.tensor(_poses()[2], requires_grad=True)
    obj = interop.to_library(T, like="pypose")
    M = interop.as_pose_matrix(obj)
    assert M.requires_grad and M.device == T.device and M.dtype == T.dtype
    M[:3, 3].sum().backward()
    assert T.grad is not None and np.abs(_np(T.grad)[:3, 3] - 1.0).max() < 1e-12
    T32 = torch.tensor(_poses()[2], dtype=torch.float32)
    assert interop.as_pose_matrix(interop.to_library(T32, like="kornia")).dtype == torch.float32


def test_library_objects_are_recognised_without_importing_the_libraries() -> None:
    code = (
        "import sys, numpy as np; from liebridge import interop; "
        "x = interop.as_pose_matrix(np.eye(4)); "
        "print(x.shape, any(m in sys.modules for m in ('torch', 'jax', 'pypose', 'kornia')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["(4,", "4)", "False"], out.stdout + out.stderr


def test_bad_objects_and_names_get_clear_errors() -> None:
    pp = _lib("pypose")
    with pytest.raises(TypeError, match=r"T_wb: a pypose LieTensor of type 'se3'.*Exp"):
        interop.as_pose_matrix(pp.se3(torch.zeros(6, dtype=torch.float64)), "T_wb")
    with pytest.raises(ValueError, match="like: unknown library 'pypse'"):
        interop.to_library(np.eye(4), like="pypse")
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(ValueError, match="T"):
        interop.to_library(np.stack([np.eye(4), bad]), like="pypose")
    assert interop.as_pose_matrix([1.0, 2.0]) == [1.0, 2.0]  # not an object: unchanged


def test_the_tensors_page_section_runs() -> None:
    """The python block of docs/tensors.md's learned-SLAM section runs (PyPose installed)."""
    _lib("pypose")
    from pathlib import Path

    page = Path(__file__).resolve().parents[1] / "docs" / "tensors.md"
    text = page.read_text(encoding="utf-8")
    section = text.split("## Learned-SLAM presets and library objects", 1)[1].split("\n## ", 1)[0]
    blocks = [b.split("```", 1)[0] for b in section.split("```python\n")[1:]]
    assert blocks
    for k, code in enumerate(blocks):
        exec(compile(code, f"tensors.md[block {k}]", "exec"), {"__name__": "tensors_md"})


@pytest.mark.parametrize("lib", ["pypose", "theseus", "kornia"])
def test_object_matrices_go_on_into_liebridge_with_their_graph(lib: str) -> None:
    """``as_pose_matrix`` of a torch library's object feeds liebridge's functions on torch."""
    _lib({"kornia": "kornia.geometry.liegroup"}.get(lib, lib))
    pytest.importorskip("array_api_compat")
    import liebridge as lb

    T = _poses()[2]
    Tt = torch.tensor(T, requires_grad=True)
    M = interop.as_pose_matrix(interop.to_library(Tt, like=lib))
    M = M.reshape(4, 4) if lib == "theseus" else M  # Theseus: always a batch
    xi = lb.lie.se3.log(M)
    assert isinstance(xi, torch.Tensor)
    assert np.abs(_np(xi) - lb.lie.se3.log(T)).max() < 1e-9
    cov = lb.convert_covariance(torch.eye(6, dtype=torch.float64) * 1e-4, M, "dpvo", "gtsam")
    assert (
        np.abs(_np(cov) - lb.convert_covariance(np.eye(6) * 1e-4, T, "dpvo", "gtsam")).max() < 1e-15
    )
    xi.sum().backward()
    assert Tt.grad is not None and np.isfinite(_np(Tt.grad)).all()
