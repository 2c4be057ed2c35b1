import subprocess
import sys

import liebridge


def test_version_command() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "--version"], capture_output=True, text=True
    )
    assert out.returncode == 0
    assert liebridge.__version__ in out.stdout


def test_demo_command_agrees_with_gtsam() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "liebridge.cli", "demo"], capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    err = float(out.stdout.split("max |diff| = ")[1].split()[0])
    assert err < 1e-12
