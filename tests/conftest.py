import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=60,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=60, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


# ----------------------------------------------------------------------------- tensor grids
# The torch/JAX harnesses (tests/test_tensors*.py) run every parametrization locally (`pytest`:
# about 12 minutes on two cores, JAX's op-by-op compilation most of it). CI's torch/JAX step
# runs `-m "not exhaustive"`: every test function, and of each one's torch and JAX
# parametrizations a fixed sample (one in TENSOR_SAMPLE[backend], chosen by a hash of the test
# id: the same cases every run), so every test function still runs there (the few marked
# `exhaustive` by hand, torch.compile and jit repeats of what test_tensors.py runs, excepted).
TENSOR_SAMPLE = {"torch": 8, "jax": 24}


def pytest_collection_modifyitems(config, items):
    import re
    import zlib

    import pytest

    for item in items:
        if not item.nodeid.startswith("tests/test_tensors") or "[" not in item.nodeid:
            continue
        name = item.nodeid.split("::")[-1]  # the function's name and its parameters
        backend = next((b for b in TENSOR_SAMPLE if re.search(rf"(\b|_){b}(\b|_)", name)), None)
        if backend is None:
            continue
        if zlib.crc32(item.nodeid.encode()) % TENSOR_SAMPLE[backend]:
            item.add_marker(pytest.mark.exhaustive)
