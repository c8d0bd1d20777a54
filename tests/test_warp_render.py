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


@pytest.fixture
def warp_cpu():
    """Warp's CPU device, and the process's default device put back after the test."""
    from dcs_torchrl.render.warp import import_warp

    wp, _ = import_warp("cpu")
    cpu = wp.get_device("cpu")
    before = cpu.runtime.default_device
    yield cpu
    cpu.runtime.default_device = before


def test_the_default_device_stays_while_any_render_runs_and_comes_back_after_the_last(warp_cpu):
    """Two render threads leave in the order they did not enter (wp.ScopedDevice would put the former
    default back under the one still rendering, and MuJoCo Warp launch there)."""
    from dcs_torchrl.render.warp import _DefaultDevice

    runtime, former = warp_cpu.runtime, object()
    runtime.default_device = former
    scopes = _DefaultDevice()
    first, second = scopes.scope(warp_cpu), scopes.scope(warp_cpu)
    first.__enter__()
    second.__enter__()
    assert runtime.default_device is warp_cpu
    first.__exit__(None, None, None)
    assert runtime.default_device is warp_cpu  # the second still renders
    second.__exit__(None, None, None)
    assert runtime.default_device is former


def test_a_block_for_another_device_waits_for_the_renders_on_the_first(warp_cpu):
    import threading
    import types

    from dcs_torchrl.render.warp import _DefaultDevice

    other = types.SimpleNamespace(runtime=warp_cpu.runtime, is_cuda=False)  # a second device, as a GPU box has
    scopes, entered, seen = _DefaultDevice(), threading.Event(), []

    def render_on_other():
        with scopes.scope(other):
            seen.append(warp_cpu.runtime.default_device)
            entered.set()

    with scopes.scope(warp_cpu):
        thread = threading.Thread(target=render_on_other)
        thread.start()
        assert not entered.wait(0.5) and warp_cpu.runtime.default_device is warp_cpu
    assert entered.wait(10)
    thread.join(10)
    assert seen == [other]


def test_renders_set_the_default_device_through_the_counted_scope_only(monkeypatch, warp_cpu):
    import warp

    import dcs_torchrl as dcs
    from dcs_torchrl.render import warp as warp_render

    def unshared(*args, **kwargs):
        raise AssertionError("wp.ScopedDevice in a render: threads rendering at once restore it under each other")

    entered = []
    scope = warp_render.DEFAULT_DEVICE.scope
    monkeypatch.setattr(warp, "ScopedDevice", unshared)
    monkeypatch.setattr(warp_render.DEFAULT_DEVICE, "scope", lambda device: entered.append(device.alias) or scope(device))
    env = dcs.make_env("cartpole", "swingup", num_envs=4, backend="warp", height=8, width=8, seed=0)
    parts = len(env.base_env.renderers) if hasattr(env, "base_env") else len(env.renderers)
    env.rollout(2)
    env.close()
    assert parts > 1 and entered.count("cpu") == parts + 3 * parts  # each part's set-up, its render at the reset and 2 steps
