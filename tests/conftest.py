"""Shared fixtures: real dm_control physics, real EGL rendering, small generated videos."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")
if os.environ.get("PYTEST_XDIST_WORKER"):  # one of several test processes on this machine's cores
    # torch's OpenMP threads wait spinning: two processes of two threads each on two cores slow each
    # other many times over. One thread each, in the tests' own processes and in those they start.
    os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(0)
