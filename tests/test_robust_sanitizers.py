"""The compiled IMU kernel under AddressSanitizer and UBSan.

An instrumented copy of ``liebridge/imu/_imu_ext.c`` is built into ``tmp_path`` with
``-fsanitize=address,undefined -fno-sanitize-recover=all`` (any report aborts) and exercised in a
subprocess that preloads ``libasan`` (Python itself is not instrumented): through the library on
aligned and misaligned float64 views (the Python side must hand over aligned copies), and called
directly with misaligned buffers (the kernel must refuse them, not read through them). Skipped
when no C compiler or no ``libasan`` is there.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import liebridge.imu

SOURCE = Path(liebridge.imu.__file__).parent / "_imu_ext.c"

SCRIPT = r"""
import importlib.util, sys
import numpy as np
spec = importlib.util.spec_from_file_location("_imu_ext", sys.argv[1])
ext = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ext)

import gtsam
from liebridge.imu import kernel, preintegrate

p = gtsam.PreintegrationParams.MakeSharedU(9.81)
p.setAccelerometerCovariance(1e-3 * np.eye(3))
p.setGyroscopeCovariance(1e-4 * np.eye(3))
p.setIntegrationCovariance(1e-8 * np.eye(3))
rng = np.random.default_rng(0)
n = 300
acc = rng.normal(size=(n, 3)) + [0.0, 0.0, 9.81]
gyro = 0.3 * rng.normal(size=(n, 3))
dt = np.full(n, 0.005)
bias = np.array([0.01, -0.02, 0.03, 1e-3, -2e-3, 3e-3])

def misaligned(x):
    raw = np.zeros(x.nbytes + 1, dtype=np.uint8)
    view = raw[1:].view(np.float64).reshape(x.shape)
    view[...] = x
    assert not view.flags.aligned
    return view

kernel._imu_ext = None
ref = preintegrate(acc, gyro, dt, bias=bias, params=p)          # the numpy kernel
class Counting:
    calls = 0

    def block_sums(self, *a):
        Counting.calls += 1
        return ext.block_sums(*a)

from liebridge.imu.inputs import read_params
kernel._imu_ext = Counting()
assert kernel.compiled_applies(read_params(p))
for make in (lambda x: x, misaligned):
    got = preintegrate(make(acc), make(gyro), make(dt), bias=make(bias), params=p)
    np.testing.assert_allclose(got.covariance, ref.covariance, rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(got.delta_p, ref.delta_p, rtol=1e-12, atol=1e-15)

assert Counting.calls >= 2, Counting.calls

# direct calls: misaligned buffers are refused (a ValueError), never read
coef = kernel._COEF
args = [acc, gyro, dt, bias, True, np.eye(3), coef, coef.shape[1], 1e-6,
        np.zeros((n, 21)), np.zeros(kernel._C_N_OUT)]
ext.block_sums(*args)
for k in (0, 1, 2, 3, 5, 9, 10):
    bad = list(args)
    bad[k] = misaligned(np.asarray(args[k], dtype=np.float64))
    try:
        ext.block_sums(*bad)
    except ValueError as exc:
        assert "aligned" in str(exc), exc
    else:
        raise AssertionError(f"argument {k}: a misaligned buffer was accepted")
# the window and combined kernels: valid calls, and bad windows refused before any read
starts = np.array([0, 50, 51, 200], dtype=np.int64)
wargs = [acc, gyro, dt, starts, np.tile(bias, (4, 1)), False, np.eye(3), coef, coef.shape[1],
         1e-6, np.zeros((149, 21)), np.zeros((4, kernel._C_N_OUT))]
ext.window_sums(*wargs)
for k, bad_value in ((3, np.array([0, 50, 50], dtype=np.int64)),
                     (3, np.array([0, 400], dtype=np.int64)),
                     (10, np.zeros((148, 21))),
                     (4, np.zeros((3, 6)))):
    bad = list(wargs)
    bad[k] = bad_value
    if k == 3:
        bad[4] = np.zeros((len(bad_value), 6))
        bad[11] = np.zeros((len(bad_value), kernel._C_N_OUT))
    try:
        ext.window_sums(*bad)
    except ValueError:
        pass
    else:
        raise AssertionError(f"window_sums argument {k}: accepted {bad_value.shape}")
kernel._imu_ext = ext
from liebridge.imu import preintegrate_combined, preintegrate_windows
w = preintegrate_windows(acc, gyro, dt, starts, bias=bias, params=p)
np.testing.assert_allclose(w[2].covariance, preintegrate(acc[51:200], gyro[51:200], dt[51:200],
                           bias=bias, params=p).covariance, rtol=1e-9, atol=1e-18)
cp = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
c1 = preintegrate_combined(acc, gyro, dt, bias=bias, params=cp)
c2 = preintegrate_combined(acc, gyro, dt, bias=bias, params=cp, compiled=False)
np.testing.assert_allclose(c1.covariance, c2.covariance, rtol=1e-9, atol=1e-15)
out = np.zeros(289)
try:
    ext.combined_integrate(acc, gyro, dt, bias, np.zeros(80), out)
except ValueError:
    pass
else:
    raise AssertionError("combined_integrate: a short covariance buffer was accepted")
print("sanitized kernel: ok")
"""


def _compiler() -> str | None:
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


@pytest.mark.skipif(sys.platform != "linux", reason="LD_PRELOAD of libasan: Linux only")
def test_class12_compiled_kernel_is_clean_under_asan_and_ubsan(tmp_path: Path) -> None:
    cc = _compiler()
    if cc is None:
        pytest.skip("no C compiler")
    libasan = subprocess.run(
        [cc, "-print-file-name=libasan.so"], capture_output=True, text=True
    ).stdout.strip()
    if not libasan or not os.path.isabs(libasan) or not os.path.exists(libasan):
        pytest.skip("libasan not found")
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    so = tmp_path / f"_imu_ext{suffix}"
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
            str(SOURCE),
            "-o",
            str(so),
        ],
        capture_output=True,
        text=True,
    )
    if build.returncode != 0:
        pytest.skip(f"sanitizer build failed: {build.stderr.strip()[:300]}")
    env = dict(os.environ)
    env["LD_PRELOAD"] = libasan
    env["ASAN_OPTIONS"] = "detect_leaks=0:abort_on_error=0:exitcode=86"
    env["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1:exitcode=87"
    root = str(Path(liebridge.imu.__file__).parents[2])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    run = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(so)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    report = run.stdout + run.stderr
    assert run.returncode == 0, report[-3000:]
    assert "runtime error" not in report and "AddressSanitizer" not in report, report[-3000:]
    assert "sanitized kernel: ok" in run.stdout
