"""dcs_torchrl.render.warp: what its users see of Warp (the frames: tests/test_batched.py)."""
import os
import subprocess
import sys

import pytest

pytest.importorskip("mujoco_warp")

RENDER_ON_THE_CPU = """
import dcs_torchrl as dcs
env = dcs.make_env("cartpole", "swingup", num_envs=1, backend="warp", height=8, width=8, seed=0)
env.rollout(1)
print("rendered")
"""


def test_the_cpu_is_rendered_on_without_a_cuda_driver_warning():
    """Warp probes for an NVIDIA driver at its start whatever the device; where there is none, asking
    for the CPU prints nothing about it (on a machine with a driver this holds trivially)."""
    done = subprocess.run([sys.executable, "-c", RENDER_ON_THE_CPU], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert done.returncode == 0 and "rendered" in done.stdout, done.stderr
    assert "CUDA driver" not in done.stderr and "Warp CUDA warning" not in done.stderr, done.stderr
