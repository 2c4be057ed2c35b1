"""The compiled conversion pass and Lie kernels under AddressSanitizer and UBSan.

Instrumented copies of ``liebridge/conventions/_convert_ext.c`` and ``liebridge/lie/_lie_ext.c``
are built into ``tmp_path`` with ``-fsanitize=address,undefined -fno-sanitize-recover=all`` (any
report aborts) and exercised in a subprocess that preloads ``libasan``: through the library on
batches of every shape, bad input, misaligned and strided views and mismatched shapes (which
the kernels must refuse, -2, not read through), and compared with the numpy paths. Skipped when
no C compiler or no ``libasan`` is there (as ``test_robust_sanitizers.py`` for the IMU kernel).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import liebridge

PKG = Path(liebridge.__file__).parent
SOURCES = {
    "_convert_ext": PKG / "conventions" / "_convert_ext.c",
    "_lie_ext": PKG / "lie" / "_lie_ext.c",
}

SCRIPT = r"""
import importlib, importlib.util, sys
import numpy as np

def load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod

conv = load("_convert_ext", sys.argv[1])
lie = load("_lie_ext", sys.argv[2])
import liebridge as lb
from liebridge.lie import _compiled, se3, so3
cv = importlib.import_module("liebridge.conventions.convert")

def both(fn, set_ext, ext):
    set_ext(ext)
    a = fn()
    set_ext(None)
    b = fn()
    set_ext(ext)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max(initial=0)))

def set_conv(e):
    cv._convert_ext = e

def set_lie(e):
    _compiled._lie_ext = e

def misaligned(x):
    raw = np.zeros(x.nbytes + 1, dtype=np.uint8)
    view = raw[1:].view(np.float64).reshape(x.shape)
    view[...] = x
    assert not view.flags.aligned
    return view

rng = np.random.default_rng(0)
for shape in [(), (1,), (7,), (2, 3), (0,)]:
    m = int(np.prod(shape))
    xi = rng.normal(size=(*shape, 6))
    xi[..., :3] *= 1.2
    T = se3.exp(xi)
    A = rng.normal(size=(*shape, 6, 6))
    C = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(6)
    J = rng.normal(size=(*shape, 2, 6))
    pairs = [("gtsam", "barfoot"), ("gtsam", "ros"), ("barfoot", "pytransform3d_global")]
    for src, dst in pairs + [("ceres_pose", "sophus")]:
        both(lambda: lb.convert_covariance(C, T, src, dst), set_conv, conv)
        both(lambda: lb.convert_information(C, T, src, dst), set_conv, conv)
        both(lambda: lb.tangent_map(T, src, dst), set_conv, conv)
        both(lambda: lb.convert_jacobian(J, T, src, dst), set_conv, conv)
        Jt = np.swapaxes(J, -1, -2).copy()
        both(lambda: lb.convert_jacobian(Jt, None, src, dst, at_output=T), set_conv, conv)
        R, C3 = np.ascontiguousarray(T[..., :3, :3]), np.ascontiguousarray(C[..., :3, :3])
        both(lambda: lb.convert_covariance(C3, R, src, dst), set_conv, conv)
    w = np.ascontiguousarray(xi[..., :3])
    R = np.ascontiguousarray(T[..., :3, :3])
    both(lambda: so3.exp(w), set_lie, lie)
    both(lambda: so3.log(R), set_lie, lie)
    both(lambda: se3.exp(xi), set_lie, lie)
    both(lambda: se3.log(T), set_lie, lie)
    both(lambda: se3.adjoint(T), set_lie, lie)

# the kernels refuse what they cannot read safely: -2, nothing read or written
plan = cv._compiled_plan("gtsam", "barfoot")
T = se3.exp(rng.normal(size=(5, 6)))
C = np.broadcast_to(np.eye(6), (5, 6, 6)).copy()
out = np.empty((5, 6, 6))
assert conv.transform(1, plan, misaligned(T), C, out) == -2
assert conv.transform(1, plan, T, misaligned(C), out) == -2
assert conv.transform(1, plan, T, C, misaligned(out)) == -2
assert conv.transform(1, plan, T[:, :3, :3], C, out) == -2
assert conv.transform(1, plan, T, C[:4], out) == -2
assert conv.transform(1, plan, T, C, np.empty((5, 6, 5))) == -2
assert conv.transform(1, plan, T, C[..., ::2, :], out) == -2
assert conv.transform(1, plan, T, C.astype(np.float32), out) == -2
assert conv.transform(0, plan, T, None, np.empty((5, 3, 3))) == -2
assert conv.transform(7, plan, T, C, out) == -2
assert conv.transform(3, plan, T, np.ones((5, 70, 6)), np.empty((5, 70, 6))) == -2
bad_plan = (np.zeros(7), None, plan[2], None, plan[4])
assert conv.transform(1, bad_plan, T, C, out) == -2
assert conv.transform(1, (misaligned(plan[0]), None, plan[2], None, plan[4]), T, C, out) == -2
assert conv.transform(1, plan, T, C, out) == -1
Cb = C.copy(); Cb[3, 0, 0] = -1.0
assert conv.transform(1, plan, T, Cb, out) == 3
cf = _compiled._COEF
assert lie.kernel(3, misaligned(T), np.empty((5, 6)), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(3, T, misaligned(np.empty((5, 6))), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(3, T, np.empty((5, 7)), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(3, T, np.empty((4, 6)), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(2, T, np.empty((5, 4, 4)), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(9, T, np.empty((5, 6)), cf, 0.5, 1e-6, 1e11) == -2
assert lie.kernel(0, np.ones(3), np.empty((3, 3)), cf, 0.5, 1e-6, 1e11) == -1
assert lie.kernel(3, T, np.empty((5, 6)), cf[:2], 0.5, 1e-6, 1e11) == -2
# bad input: the same errors as numpy
for fn in (lambda: lb.convert_covariance(Cb, T, "gtsam", "barfoot"), lambda: se3.log(T * 1.01)):
    msgs = []
    for e1, e2 in ((conv, lie), (None, None)):
        cv._convert_ext, _compiled._lie_ext = e1, e2
        try:
            fn()
        except ValueError as e:
            msgs.append(str(e))
    assert len(msgs) == 2 and msgs[0] == msgs[1], msgs
print("sanitized kernels: ok")
"""


def _compiler() -> str | None:
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


@pytest.mark.skipif(sys.platform != "linux", reason="LD_PRELOAD of libasan: Linux only")
def test_compiled_conversion_and_lie_kernels_are_clean_under_asan_and_ubsan(
    tmp_path: Path,
) -> None:
    cc = _compiler()
    if cc is None:
        pytest.skip("no C compiler")
    libasan = subprocess.run(
        [cc, "-print-file-name=libasan.so"], capture_output=True, text=True
    ).stdout.strip()
    if not libasan or not os.path.isabs(libasan) or not os.path.exists(libasan):
        pytest.skip("libasan not found")
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    built = []
    for name, source in SOURCES.items():
        so = tmp_path / f"{name}{suffix}"
        build = subprocess.run(
            [
                cc,
                "-O1",
                "-g",
                "-shared",
                "-fPIC",
                "-fno-omit-frame-pointer",
                "-fsanitize=address,undefined",
                "-fno-sanitize-recover=all",
                f"-I{sysconfig.get_paths()['include']}",
                str(source),
                "-o",
                str(so),
            ],
            capture_output=True,
            text=True,
        )
        if build.returncode != 0:
            pytest.skip(f"sanitizer build failed: {build.stderr.strip()[:300]}")
        built.append(str(so))
    env = dict(os.environ)
    env["LD_PRELOAD"] = libasan
    env["ASAN_OPTIONS"] = "detect_leaks=0:abort_on_error=0:exitcode=86"
    env["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1:exitcode=87"
    root = str(PKG.parent)
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    run = subprocess.run(
        [sys.executable, "-c", SCRIPT, *built],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-4000:]
    assert "sanitized kernels: ok" in run.stdout
