"""The recipes' pixel env: the suite env's frames, channel-first, stacked as its docstring says."""
import pytest
import torch

from dcs_torchrl import make_env
from dcs_torchrl.envs import resolve_settings
from dcs_torchrl.training.envs import batched_pixel_env, pixel_env

STACK, SIZE, STEPS = 3, 32, 5


def _suite_frames(settings, actions, seed):
    """The suite env's own frames (CHW) at reset and after each action, same seed and settings."""
    env = make_env(settings.domain, settings.task, benchmark=settings.benchmark, dynamic=settings.dynamic,
                   height=SIZE, width=SIZE, seed=seed)
    td = env.reset()
    frames = [td["pixels"].permute(2, 0, 1)]
    for action in actions:
        td = env.step(td.set("action", action))["next"]
        frames.append(td["pixels"].permute(2, 0, 1))
    env.close()
    return frames


@pytest.mark.parametrize("dynamic", [False, True])
def test_the_stack_repeats_the_first_frame_at_reset_then_holds_the_last_frames_in_order(dynamic):
    """At a reset every frame of the stack is the first frame (DrQ's padding, not black frames);
    after k steps the stack is frames k-2, k-1, k, oldest first."""
    settings = resolve_settings("cheetah", "run", benchmark="medium", dynamic=dynamic)
    env = pixel_env(settings, frame_stack=STACK, image_size=SIZE, render_profile="default", seed=3)
    torch.manual_seed(0)
    actions = [env.action_spec.rand() for _ in range(STEPS)]
    frames = _suite_frames(settings, actions, seed=3)
    assert not torch.equal(frames[1], frames[2])  # consecutive frames differ: an order mistake shows
    td = env.reset()
    stacks = [td["pixels"]]
    for action in actions:
        td = env.step(td.set("action", action))["next"]
        stacks.append(td["pixels"])
    env.close()
    for k, stack in enumerate(stacks):
        assert stack.shape == (3 * STACK, SIZE, SIZE) and stack.dtype == torch.uint8
        expected = torch.cat([frames[max(0, j)] for j in range(k - STACK + 1, k + 1)])
        assert torch.equal(stack, expected), f"the stack after {k} steps"


def test_the_batched_recipe_env_stacks_each_sub_envs_frames_from_its_own_reset():
    """The same through the recipes' batched env (``batched_pixel_env``): the first observation is the
    first frame repeated, and a sub-env's reset after a done starts its stack anew."""
    settings = resolve_settings("cartpole", "swingup", action_repeat=250)  # 4 agent steps an episode
    env = batched_pixel_env(settings, num_workers=1, seed=0, image_size=SIZE)
    td = env.reset()
    first = td["pixels"][0]
    assert all(torch.equal(first[3 * i : 3 * i + 3], first[:3]) for i in range(STACK))
    rollout = env.rollout(6, break_when_any_done=False)
    reset_at = rollout["next", "done"][0, :, 0].nonzero().flatten()
    assert reset_at.tolist() == [3]  # the episode ends after its fourth step
    restarted = rollout["pixels"][0, 4]  # the observation the policy sees after the reset
    assert all(torch.equal(restarted[3 * i : 3 * i + 3], restarted[:3]) for i in range(STACK))
    assert not torch.equal(restarted[:3], rollout["pixels"][0, 3, -3:])  # a new episode, a new frame
    env.close()


def test_an_env_that_renders_on_another_egl_device_than_this_process_runs_in_a_worker_on_it(monkeypatch):
    """``render_device`` other than this process's device: even one env runs in a worker spawned on
    that device (here device 0, with this process pretending to render on 1), with the same frames."""
    from torchrl.envs import SerialEnv

    from dcs_torchrl import ParallelSuiteEnv

    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True)
    here = batched_pixel_env(settings, num_workers=1, seed=5, frame_stack=STACK, image_size=SIZE, render_device=0)
    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "1")  # what this process "renders on"; the worker is told 0
    there = batched_pixel_env(settings, num_workers=1, seed=5, frame_stack=STACK, image_size=SIZE, render_device=0)
    try:
        assert isinstance(here.base_env, SerialEnv)  # device 0 was this process's: no worker
        assert isinstance(there.base_env, ParallelSuiteEnv)
        torch.manual_seed(0)
        actions = [here.action_spec.rand() for _ in range(STEPS)]
        frames = []
        for env in (here, there):
            td = env.reset()
            stacks = [td["pixels"]]
            for action in actions:
                td = env.step(td.set("action", action))["next"]
                stacks.append(td["pixels"])
            frames.append(torch.stack(stacks))
        assert torch.equal(*frames)
    finally:
        here.close()
        there.close()
