"""The Gymnasium env (dcs_torchrl/gym_env.py): make_env's frames, Gymnasium's checker, vector envs.

Real dm_control physics and EGL rendering throughout; every comparison with ``make_env`` is
exact (the adapter hands over the TorchRL env's own tensors).
"""
import re
import sys
import textwrap
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch
from dcs_test_utils import PAPER_TASKS
from dm_control import suite
from gymnasium.utils.env_checker import check_env
from tensordict import TensorDict

import dcs_torchrl as dcs
from dcs_torchrl import gym_env
from dcs_torchrl._compat.private_api import control_timestep
from dcs_torchrl.gym_env import DistractingControlEnv, env_id

# The cameras of dog fetch track a target (make_env refuses them); its fixed camera.
TASK_SETTINGS = {("dog", "fetch"): {"camera_id": 2}}


def _actions(space, n, seed):
    rng = np.random.default_rng(seed)
    return [rng.uniform(space.low, space.high).astype(space.dtype) for _ in range(n)]


def _torchrl_step(env, action):
    td = env.step(TensorDict({"action": torch.as_tensor(action)}, batch_size=()))["next"]
    return td["pixels"].numpy(), float(td["reward"]), bool(td["terminated"]), bool(td["truncated"])


def _gymnasium_warnings(caught):
    return [str(w.message) for w in caught if "WARN:" in str(w.message)]


# ------------------------------------------------------------------ registration
def test_every_task_and_benchmark_is_registered():
    ids = gym_env.register_envs()
    count = len(gymnasium.registry)
    assert gym_env.register_envs() == ids and len(gymnasium.registry) == count  # idempotent
    expected = {env_id(d, t, b, dyn) for d, t in suite.ALL_TASKS for b in dcs.BENCHMARKS for dyn in (False, True)}
    assert set(ids) == expected and expected <= set(gymnasium.registry)
    for domain, task in PAPER_TASKS:
        assert f"dcs/{domain}-{task}-medium-dynamic-v0" in gymnasium.registry
    spec = gymnasium.spec("dcs/ball_in_cup-catch-easy-dynamic-v0")
    assert spec.kwargs == {"domain": "ball_in_cup", "task": "catch", "benchmark": "easy", "dynamic": True,
                           "registered_id": "dcs/ball_in_cup-catch-easy-dynamic-v0"}
    assert spec.max_episode_steps is None  # the env truncates at dm_control's time limit itself


# --------------------------------------------------------------- same pixels
@pytest.mark.parametrize("dynamic", [False, True], ids=["static", "dynamic"])
def test_frames_equal_make_env_across_resets(dynamic):
    """Seed, 20 steps to the time limit (action repeat 50), the reset after it, 6 steps, a reseed
    mid-episode and 4 steps: every frame, reward and flag equals make_env's."""
    settings = dict(benchmark="medium", dynamic=dynamic, action_repeat=50)
    ours = DistractingControlEnv("cartpole", "swingup", **settings)
    theirs = dcs.make_env("cartpole", "swingup", seed=7, **settings)
    obs, info = ours.reset(seed=7)
    assert info == {} and np.array_equal(obs, theirs.reset()["pixels"].numpy())
    seen_end = False
    for i, action in enumerate(_actions(ours.action_space, 30, seed=0)):
        if i == 26:  # reseed mid-episode: as make_env(seed=11) would start
            theirs.set_seed(11)
            obs = ours.reset(seed=11)[0]
            assert np.array_equal(obs, theirs.reset()["pixels"].numpy()), "after reset(seed=11)"
        obs, reward, terminated, truncated, _ = ours.step(action)
        frame, reward_ref, terminated_ref, truncated_ref = _torchrl_step(theirs, action)
        assert np.array_equal(obs, frame), f"step {i}"
        assert (reward, terminated, truncated) == (reward_ref, terminated_ref, truncated_ref), f"step {i}"
        assert not terminated
        if truncated:  # the time limit: both start the next episode without a seed
            assert i == 19
            seen_end = True
            assert np.array_equal(ours.reset()[0], theirs.reset()["pixels"].numpy()), "after the time limit"
    assert seen_end
    # a seed given at construction is make_env's seed
    again = DistractingControlEnv("cartpole", "swingup", seed=7, **settings)
    assert np.array_equal(again.reset()[0], DistractingControlEnv("cartpole", "swingup", **settings).reset(seed=7)[0])
    for env in (ours, theirs, again):
        env.close()


def test_time_limit_is_truncation_not_termination():
    """cartpole swingup: 1000 control steps at action repeat 8 = 125 agent steps, then truncated."""
    ours = gymnasium.make("dcs/cartpole-swingup-none-v0")
    theirs = dcs.make_env("cartpole", "swingup", seed=3)
    ours.reset(seed=3)
    theirs.reset()
    action = np.zeros(1)
    for step in range(1, 126):
        obs, reward, terminated, truncated, _ = ours.step(action)
        _, _, terminated_ref, truncated_ref = _torchrl_step(theirs, action)
        assert (terminated, truncated) == (terminated_ref, truncated_ref) == (False, step == 125), step
        assert type(terminated) is bool and type(truncated) is bool and type(reward) is float
    with pytest.raises(gymnasium.error.ResetNeeded, match="reset"):
        ours.unwrapped.step(action)
    assert ours.reset()[0].shape == (84, 84, 3)
    ours.close()
    theirs.close()


# ------------------------------------------------------- Gymnasium's checker
def _checked_tasks():
    """Every task make_env accepts: the paper's six and the first task of every other domain on every
    run (~1 s each), the others of those domains (same models, other rewards) marked slow."""
    first = {}
    for domain, task in suite.ALL_TASKS:
        first.setdefault(domain, (domain, task))
    every_run = set(PAPER_TASKS) | set(first.values())
    return [pytest.param(d, t, id=f"{d}-{t}", marks=() if (d, t) in every_run else pytest.mark.slow)
            for d, t in suite.ALL_TASKS]


@pytest.mark.parametrize("domain, task", _checked_tasks())
def test_gymnasium_check_env_passes_medium(domain, task):
    env = gymnasium.make(env_id(domain, task, "medium"), **TASK_SETTINGS.get((domain, task), {}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    space = env.action_space
    env.close()
    found = _gymnasium_warnings(caught)
    # the action space is the task's own: Gymnasium's checker notes bounds other than [-1, 1] (lqr's are
    # +-1e10, quadruped's reach 1.1), as it would for dm_control itself
    if np.all(space.low == -1) and np.all(space.high == 1):
        assert found == []
    else:
        assert len(found) == 1 and "action space" in found[0] and "normali" in found[0], found


def test_dict_observation_is_make_envs_state_and_distractions():
    ours = DistractingControlEnv("walker", "walk", benchmark="medium", dynamic=True, obs_type="dict",
                                 expose_distractions=True, render_mode="rgb_array")
    theirs = dcs.make_env("walker", "walk", benchmark="medium", dynamic=True, seed=2, pixels_only=False,
                          expose_distractions=True)
    space = ours.observation_space
    assert set(space) == {"pixels", "state", "distractions"}
    assert set(space["distractions"]) == {"camera", "color", "background"}
    obs, _ = ours.reset(seed=2)
    td = theirs.reset()
    for action in [None, *_actions(ours.action_space, 3, seed=1)]:
        if action is not None:
            obs = ours.step(action)[0]
            td = theirs.step(TensorDict({"action": torch.as_tensor(action)}, batch_size=()))["next"]
        assert obs in space
        state = np.concatenate([td[k].numpy().reshape(-1) for k in theirs.base_env.observation_spec.keys()])
        assert obs["state"].dtype == np.float64 and np.array_equal(obs["state"], state)
        assert np.array_equal(obs["pixels"], td["pixels"].numpy())
        for name in ("camera", "color", "background"):
            assert np.array_equal(obs["distractions"][name], td["distractions", name].numpy()), name
        rendered = ours.render()
        assert np.array_equal(rendered, obs["pixels"]) and rendered is not obs["pixels"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(ours)
    # only the unbounded state and distraction boxes, and no spec (built directly) to remake it from
    assert all("infinity" in m or "not having a spec" in m for m in _gymnasium_warnings(caught))
    ours.close()
    theirs.close()
    plain = DistractingControlEnv("cartpole", "swingup", obs_type="dict")
    assert set(plain.observation_space) == {"pixels", "state"} and plain.observation_space["state"].shape == (5,)
    plain.close()


def test_render_modes_and_render_fps():
    env = gymnasium.make("dcs/finger-spin-easy-v0", render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    assert np.array_equal(env.render(), obs)
    obs = env.step(env.action_space.sample())[0]
    assert np.array_equal(env.render(), obs)
    base = env.unwrapped.torchrl_env.base_env
    # 20 ms control steps, action repeat 2
    assert env.unwrapped.metadata["render_fps"] == 1 / (control_timestep(base) * 2) == pytest.approx(25.0)
    env.close()
    env.close()  # twice is harmless (Gymnasium's checker asks it)
    quiet = DistractingControlEnv("finger", "spin")
    quiet.reset(seed=0)
    assert quiet.render() is None
    quiet.close()
    with pytest.raises(ValueError, match=r"render_mode 'human'; choose one of \[None, 'rgb_array'\]"):
        DistractingControlEnv("finger", "spin", render_mode="human")
    collected = gymnasium.make("dcs/finger-spin-none-v0", render_mode="rgb_array_list")  # Gymnasium's wrapper
    collected.reset(seed=0)
    collected.step(collected.action_space.sample())
    assert [frame.shape for frame in collected.render()] == [(84, 84, 3)] * 2
    collected.close()


def test_settings_pass_through_to_make_env():
    env = gymnasium.make("dcs/reacher-easy-medium-v0", height=48, width=64, camera_scale=0.0, render_profile="fast")
    obs, _ = env.reset(seed=1)
    assert obs.shape == (48, 64, 3) and env.observation_space.shape == (48, 64, 3)
    assert env.unwrapped.torchrl_env.transform[0].scale == 0.0
    env.close()


def test_frame_stack_on_the_gymnasium_side_is_the_recipes_stack():
    """docs/gymnasium.md's stack: FrameStackObservation(3), then channels first, equals pixel_env's."""
    from gymnasium.spaces import Box
    from gymnasium.wrappers import FrameStackObservation, TransformObservation

    from dcs_torchrl.training.envs import pixel_env

    ours = TransformObservation(
        FrameStackObservation(gymnasium.make("dcs/cartpole-swingup-medium-dynamic-v0"), stack_size=3),
        lambda stack: stack.transpose(0, 3, 1, 2).reshape(9, 84, 84), Box(0, 255, (9, 84, 84), np.uint8))
    theirs = pixel_env(dcs.resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True),
                       frame_stack=3, image_size=84, render_profile="default", seed=4)
    obs, _ = ours.reset(seed=4)
    td = theirs.reset()
    assert np.array_equal(obs, td["pixels"].numpy())
    for action in _actions(ours.action_space, 4, seed=2):
        obs = ours.step(action)[0]
        td = theirs.step(td.set("action", torch.as_tensor(action)))["next"]
        assert np.array_equal(obs, td["pixels"].numpy())
    ours.close()
    theirs.close()


def test_action_space_is_float32_with_the_tasks_bounds():
    """Stable-Baselines3 warns at every check_env on a float64 action space; the bounds stay the task's."""
    for domain, task in [("cartpole", "swingup"), ("quadruped", "walk")]:
        ours = DistractingControlEnv(domain, task)
        spec = ours.torchrl_env.action_spec
        space = ours.action_space
        assert space.dtype == np.float32 and space.shape == tuple(spec.shape)
        np.testing.assert_array_equal(space.low, spec.space.low.numpy().astype(np.float32))
        np.testing.assert_array_equal(space.high, spec.space.high.numpy().astype(np.float32))
        assert space.sample().dtype == np.float32 and space.sample() in space
        ours.close()
    # a float64 action reaches the physics unrounded: the same frames as make_env's for that action
    ours = DistractingControlEnv("cartpole", "swingup", seed=1)
    theirs = dcs.make_env("cartpole", "swingup", seed=1)
    ours.reset()
    theirs.reset()
    action = np.array([0.1234567890123], dtype=np.float64)
    assert np.array_equal(ours.step(action)[0], _torchrl_step(theirs, action)[0])
    ours.close()
    theirs.close()


def test_flat_dict_layout_is_the_nested_one_on_one_level():
    settings = dict(benchmark="medium", dynamic=True, obs_type="dict", expose_distractions=True)
    nested = DistractingControlEnv("cartpole", "swingup", **settings)
    flat = DistractingControlEnv("cartpole", "swingup", dict_layout="flat", **settings)
    keys = {"pixels", "state", "distractions/camera", "distractions/color", "distractions/background"}
    assert set(flat.observation_space) == keys
    assert all(isinstance(space, gymnasium.spaces.Box) for space in flat.observation_space.values())  # what SB3 takes
    for name in ("camera", "color", "background"):
        assert flat.observation_space[f"distractions/{name}"] == nested.observation_space["distractions"][name]
    a, _ = nested.reset(seed=5)
    b, _ = flat.reset(seed=5)
    for action in [None, *_actions(flat.action_space, 2, seed=3)]:
        if action is not None:
            a, b = nested.step(action)[0], flat.step(action)[0]
        assert set(b) == keys and b in flat.observation_space
        assert np.array_equal(a["pixels"], b["pixels"]) and np.array_equal(a["state"], b["state"])
        for name in ("camera", "color", "background"):
            assert np.array_equal(a["distractions"][name], b[f"distractions/{name}"]), name
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(flat)
    assert all("infinity" in m or "not having a spec" in m for m in _gymnasium_warnings(caught))
    nested.close()
    flat.close()
    made = gymnasium.make("dcs/cartpole-swingup-easy-v0", obs_type="dict", expose_distractions=True, dict_layout="flat")
    assert "distractions/camera" in made.observation_space.spaces
    made.close()
    with pytest.raises(ValueError, match=r"unknown dict_layout 'flattened'; choose one of \['nested', 'flat'\]"):
        DistractingControlEnv("cartpole", "swingup", obs_type="dict", dict_layout="flattened")
    with pytest.raises(ValueError, match="lays out a Dict observation: pass obs_type='dict' too"):
        DistractingControlEnv("cartpole", "swingup", dict_layout="flat")


def test_step_and_reset_after_close_raise():
    env = gymnasium.make("dcs/cartpole-swingup-none-v0")
    env.reset(seed=0)
    env.close()
    with pytest.raises(gymnasium.error.ClosedEnvironmentError, match=r"step\(\) after close\(\)"):
        env.unwrapped.step(np.zeros(1, np.float32))
    with pytest.raises(gymnasium.error.ClosedEnvironmentError, match=r"reset\(\) after close\(\): .* make a new env"):
        env.unwrapped.reset(seed=0)
    env.close()  # still harmless


def _doc_block(marker: str) -> str:
    """The python block of docs/gymnasium.md that holds ``marker``."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "gymnasium.md").read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL) if marker in b]
    assert len(blocks) == 1, marker
    return textwrap.dedent(blocks[0])  # a block inside a list item is indented


def test_the_docs_channel_stack_is_an_image_of_the_last_frames():
    """docs/gymnasium.md's stack for Stable-Baselines3's CnnPolicy (a 4-D FrameStackObservation is refused
    there): k frames on the channel axis, (84, 84, 3k) uint8, oldest first."""
    scope: dict = {}
    exec(_doc_block("def stack_on_channels"), scope)  # noqa: S102  (the page's own code)
    env = scope["env"]
    assert env.observation_space == gymnasium.spaces.Box(0, 255, (84, 84, 9), np.uint8)
    single = gymnasium.make("dcs/cartpole-swingup-medium-v0")
    frames = [single.reset(seed=0)[0]] * 3
    obs, _ = env.reset(seed=0)
    assert np.array_equal(obs, np.concatenate(frames, axis=-1))
    for action in _actions(env.action_space, 3, seed=4):
        obs = env.step(action)[0]
        frames = frames[1:] + [single.step(action)[0]]
        assert obs in env.observation_space and np.array_equal(obs, np.concatenate(frames, axis=-1))
    env.close()
    single.close()


# ----------------------------------------------------------------- bad input
def test_bad_input_names_the_fix():
    with pytest.raises(ValueError, match=r"obs_type 'state'; choose one of \['pixels', 'dict'\]"):
        DistractingControlEnv("cartpole", "swingup", obs_type="state")
    with pytest.raises(ValueError, match=r"unknown env setting\(s\) \['camera_scael'\]: choose among .*'camera_scale'"):
        DistractingControlEnv("cartpole", "swingup", camera_scael=0.1)
    with pytest.raises(ValueError, match="obs_type decides it"):
        DistractingControlEnv("cartpole", "swingup", pixels_only=False)
    with pytest.raises(ValueError, match="pass obs_type='dict' too"):
        DistractingControlEnv("cartpole", "swingup", expose_distractions=True)
    with pytest.raises(ValueError, match="unknown benchmark 'medum'; choose one of"):  # make_env's validation
        DistractingControlEnv("cartpole", "swingup", benchmark="medum")
    with pytest.raises(ValueError, match="unknown task 'swing' of domain 'cartpole'; choose one of"):
        DistractingControlEnv("cartpole", "swing")
    with pytest.raises(gymnasium.error.NameNotFound, match="Did you mean: `cartpole-swingup-medium`"):
        gymnasium.make("dcs/cartpole-swingup-medum-v0")
    with pytest.raises(ValueError, match=r"keywords for another preset \('dcs/cartpole-swingup-easy-v0'\): make that id"):
        gymnasium.make("dcs/cartpole-swingup-medium-v0", benchmark="easy")
    with pytest.raises(ValueError, match="keywords for another preset"):
        gymnasium.make("dcs/cartpole-swingup-medium-dynamic-v0", dynamic=False)
    with pytest.raises(ValueError, match=r"benchmark='extreme', which is no benchmark of the suite; choose one of "
                                         r"\['none', 'easy', 'medium', 'blind', 'hard'\]") as refused:
        gymnasium.make("dcs/cartpole-swingup-medium-v0", benchmark="extreme")
    assert "make that id" not in str(refused.value)  # no id that does not exist
    with pytest.raises(ValueError, match="no dm_control suite task"):
        gymnasium.make("dcs/cartpole-swingup-medium-v0", task="swing")
    gymnasium.make("dcs/cartpole-swingup-medium-dynamic-v0", dynamic=True, camera_scale=0.3).close()  # agrees, overrides
    env = DistractingControlEnv("cartpole", "swingup")
    with pytest.raises(gymnasium.error.ResetNeeded, match=r"call reset\(\) before step\(\)"):
        env.step(np.zeros(1))
    with pytest.raises(ValueError, match="seed must be a non-negative integer below 2\\*\\*32"):
        env.reset(seed=-1)
    with pytest.raises(ValueError, match="reset takes no options"):
        env.reset(options={"init": 1})
    env.reset(seed=np.int64(4), options={})
    with pytest.raises(ValueError, match=r"action must have shape \(1,\)"):
        env.step(np.zeros(2))
    env.close()


def test_missing_gymnasium_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "gymnasium", None)
    monkeypatch.delitem(sys.modules, "dcs_torchrl.gym_env")
    with pytest.raises(ModuleNotFoundError, match=r'pip install "dcs-torchrl\[gym\]"'):
        import dcs_torchrl.gym_env  # noqa: F401


# --------------------------------------------------------------- vector envs
def _single_frames(seed, actions, name):
    env = gymnasium.make(name)
    frames = [env.reset(seed=seed)[0]] + [env.step(a)[0] for a in actions]
    env.close()
    return np.stack(frames)


def test_sync_vector_env_each_sub_env_its_own_seed():
    name = "dcs/cartpole-swingup-medium-dynamic-v0"
    envs = gymnasium.vector.SyncVectorEnv([lambda: gymnasium.make(name) for _ in range(2)])
    actions = _actions(envs.single_action_space, 3, seed=5)
    frames = [envs.reset(seed=[3, 9])[0]] + [envs.step(np.stack([a, a]))[0] for a in actions]
    envs.close()
    frames = np.stack(frames, axis=1)  # [env, time, H, W, 3]
    assert not np.array_equal(frames[0], frames[1])
    assert np.array_equal(frames[0], _single_frames(3, actions, name))
    assert np.array_equal(frames[1], _single_frames(9, actions, name))


def test_async_vector_env_spawn_each_sub_env_its_own_seed():
    """Workers are spawned (EGL contexts do not survive fork); the module-qualified id registers the
    ids in each worker. ``reset(seed=5)`` gives the sub-envs seeds 5 and 6."""
    name = "dcs/ball_in_cup-catch-medium-dynamic-v0"
    envs = gymnasium.make_vec(f"dcs_torchrl.gym_env:{name}", num_envs=2, vectorization_mode="async",
                              vector_kwargs={"context": "spawn"})
    actions = _actions(envs.single_action_space, 2, seed=6)
    frames = [envs.reset(seed=5)[0]] + [envs.step(np.stack([a, a]))[0] for a in actions]
    envs.close()
    frames = np.stack(frames, axis=1)
    assert np.array_equal(frames[0], _single_frames(5, actions, name))
    assert np.array_equal(frames[1], _single_frames(6, actions, name))
