"""make_env: presets as data, overrides, seeding, and TorchRL's batched envs and collectors."""
import functools

import numpy as np
import pytest
import torch
from dm_control.mujoco import engine
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.envs import DMControlEnv, ParallelEnv, SerialEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs

import dcs_torchrl as dcs
from dcs_torchrl import BENCHMARKS, TASKS, make_env, resolve_settings
from dcs_torchrl.presets import action_repeat
from dcs_test_utils import PAPER_TASKS, physics_of


def distractions(env):
    camera, color, background, render, _exclude_states = env.transform
    return camera, color, background, render


def rollout(env, steps, seed=0):
    torch.manual_seed(seed)
    return env.rollout(steps, break_when_any_done=False)


@pytest.mark.parametrize("preset_name", list(BENCHMARKS))  # not `benchmark`: pytest-benchmark's fixture name
def test_benchmark_presets(preset_name):
    preset = BENCHMARKS[preset_name]
    env = make_env("cartpole", "swingup", benchmark=preset_name)
    camera, color, background, _ = distractions(env)
    assert camera.scale == preset.camera_scale and color.scale == preset.color_scale
    assert camera.blind == preset.blind
    assert len(background.videos) == (60 if preset.num_videos is None else preset.num_videos)
    assert background.blend == 1.0
    expected_alpha = None if preset_name == "none" else 0.3
    assert background.ground_alpha == expected_alpha


def test_spec_table():
    assert {k: (v.camera_scale, v.color_scale, v.num_videos, v.blind) for k, v in BENCHMARKS.items()} == {
        "none": (0.0, 0.0, 0, False),
        "easy": (0.1, 0.1, 4, False),
        "medium": (0.2, 0.2, 8, False),
        "blind": (0.2, 0.2, 8, True),
        "hard": (0.3, 0.3, None, False),
    }
    assert dict(TASKS) == {
        ("ball_in_cup", "catch"): 4,
        ("cartpole", "swingup"): 8,
        ("cheetah", "run"): 4,
        ("finger", "spin"): 2,
        ("reacher", "easy"): 4,
        ("walker", "walk"): 2,
    }


@pytest.mark.parametrize("domain,task", PAPER_TASKS)
def test_paper_tasks(domain, task):
    env = make_env(domain, task, benchmark="easy", dynamic=True, seed=0)
    assert env.base_env.frame_skip == TASKS[domain, task]
    td = rollout(env, 4)
    assert td["next", "pixels"].shape == (4, 84, 84, 3) and td["next", "pixels"].dtype == torch.uint8
    alpha = physics_of(env).model.mat_rgba[physics_of(env).model.name2id("grid", "material"), 3]
    assert alpha == {"cheetah": 1.0, "walker": 1.0, "reacher": 0.0}.get(domain, 0.3)


def test_overrides():
    env = make_env(
        "cheetah", "run", benchmark="medium", camera_scale=0.05, color_scale=0.7, num_videos=2,
        background_blend=0.5, ground_alpha=0.9, action_repeat=3, height=32, width=48, blind=True,
    )
    camera, color, background, render = distractions(env)
    assert (camera.scale, color.scale, len(background.videos), background.blend) == (0.05, 0.7, 2, 0.5)
    assert background.ground_alpha == 0.9 and camera.blind and env.base_env.frame_skip == 3
    assert env.reset()["pixels"].shape == (32, 48, 3)


def test_resolved_settings_are_plain_data():
    settings = resolve_settings("walker", "walk", benchmark="hard", dynamic=True)
    assert settings.as_dict() == {
        "domain": "walker", "task": "walk", "benchmark": "hard", "dynamic": True,
        "camera_scale": 0.3, "color_scale": 0.3, "num_videos": 60, "background_blend": 1.0,
        "blind": False, "background_split": "train", "background_dir": None, "ground_alpha": 1.0,
        "action_repeat": 2, "camera_id": 0, "reference_blend": False, "texture_size": 256,
    }
    assert resolve_settings("walker", "walk", benchmark="hard", background_split="val").num_videos == 30
    # the settings beyond the paper are recorded where their distraction is on
    lit = resolve_settings("walker", "walk", light_scale=0.5).as_dict()
    assert lit["light_scale"] == 0.5 and "texture_scale" not in lit and "texture_dir" not in lit
    textured = resolve_settings("walker", "walk", texture_scale=0.25, texture_split="val").as_dict()
    assert (textured["texture_scale"], textured["texture_dir"], textured["texture_split"]) == (0.25, None, "val")
    assert "light_scale" not in textured


def test_expose_distractions():
    env = make_env("finger", "spin", benchmark="medium", dynamic=True, expose_distractions=True, seed=0)
    check_env_specs(env)
    td = rollout(env, 3)
    nmat = physics_of(env).model.nmat
    shapes = {k: (td["next", "distractions", k].shape, td["next", "distractions", k].dtype) for k in ("camera", "color", "background")}
    assert shapes == {
        "camera": ((3, 4), torch.float32),
        "color": ((3, nmat, 3), torch.float32),
        "background": ((3, 2), torch.int64),
    }
    quiet = make_env("finger", "spin", expose_distractions=True, seed=0).reset()
    assert quiet["distractions", "background"].tolist() == [-1, -1]


def test_seed_makes_pixels_reproducible_bit_for_bit():
    a = rollout(make_env("walker", "walk", benchmark="medium", dynamic=True, seed=5), 12)
    b = rollout(make_env("walker", "walk", benchmark="medium", dynamic=True, seed=5), 12)
    c = rollout(make_env("walker", "walk", benchmark="medium", dynamic=True, seed=6), 12)
    assert torch.equal(a["next", "pixels"], b["next", "pixels"])
    assert not torch.equal(a["next", "pixels"], c["next", "pixels"])
    later = make_env("walker", "walk", benchmark="medium", dynamic=True)
    later.set_seed(5)
    assert torch.equal(rollout(later, 12)["next", "pixels"], a["next", "pixels"])


def test_benchmark_none_is_plain_dm_control():
    env = make_env("cheetah", "run", seed=1)
    plain = TransformedEnv(DMControlEnv("cheetah", "run", from_pixels=False, frame_skip=4), dcs.RenderPixels())
    plain.set_seed(1)
    assert torch.equal(rollout(env, 5)["next", "pixels"], rollout(plain, 5)["next", "pixels"])


@pytest.mark.slow  # by default: tests/distractions/test_contract.py::test_specs_parallel (the same transforms in
# TorchRL's ParallelEnv: specs, a stream per worker) and tests/test_parallel.py (make_env in spawned workers)
def test_parallel_env_workers_get_their_own_streams():
    factory = functools.partial(make_env, "cartpole", "swingup", benchmark="medium", dynamic=True, expose_distractions=True,
                                height=32, width=32)
    env = ParallelEnv(2, factory, mp_start_method="spawn")
    env.set_seed(0)
    check_env_specs(env)
    td = rollout(env, 5)
    for key in ("camera", "color", "background"):
        assert not torch.equal(td["next", "distractions", key][0], td["next", "distractions", key][1]), key
    env.close()


def test_serial_env_and_collectors():
    factory = functools.partial(make_env, "cartpole", "swingup", benchmark="easy", dynamic=True, height=32, width=32)
    serial = SerialEnv(2, factory)
    serial.set_seed(0)
    check_env_specs(serial)
    collector = Collector(serial, None, frames_per_batch=8, total_frames=16)
    batches = [batch for batch in collector]
    assert len(batches) == 2 and batches[0]["next", "pixels"].shape[-3:] == (32, 32, 3)
    collector.shutdown()
    multi = MultiSyncCollector([factory], None, frames_per_batch=8, total_frames=16)  # one spawned worker: seconds each
    multi.set_seed(0)
    frames = sum(batch.numel() for batch in multi)
    multi.shutdown()
    assert frames == 16


def test_bad_input_names_the_fix():
    with pytest.raises(ValueError, match="unknown dm_control domain 'cheeta'; choose one of"):
        make_env("cheeta", "run")
    with pytest.raises(ValueError, match="unknown task 'walk' of domain 'cheetah'; choose one of"):
        make_env("cheetah", "walk")
    with pytest.raises(ValueError, match="unknown benchmark 'impossible'"):
        make_env("cheetah", "run", benchmark="impossible")
    with pytest.raises(ValueError, match="unknown render_profile"):
        make_env("cheetah", "run", render_profile="max")
    with pytest.raises(ValueError, match=r"scale must be in \[0, 1\]"):
        make_env("cheetah", "run", camera_scale=2.0)
    with pytest.raises(ValueError, match="action_repeat must be a positive integer"):
        make_env("cheetah", "run", action_repeat=0)
    with pytest.raises(ValueError, match="num_videos"):
        make_env("cheetah", "run", num_videos=61)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        make_env("cheetah", "run", seed=-1)


def test_env_options_have_one_source():
    """EnvOptions declares a suite env's options once: make_env's signature and docstring, the
    resolved EnvSettings and the validation follow it (the recipes' config: tests/training/test_env_config.py)."""
    import dataclasses
    import inspect

    from dcs_torchrl.envs import SCENE_OPTIONS, EnvOptions, EnvSettings

    options = dataclasses.fields(EnvOptions)
    assert [f.name for f in dataclasses.fields(EnvSettings)] == ["domain", "task", *SCENE_OPTIONS]
    assert set(SCENE_OPTIONS) < {f.name for f in options}
    parameters = inspect.signature(make_env).parameters
    assert list(parameters) == ["domain", "task", *(f.name for f in options)]
    assert all(parameters[f.name].default == f.default for f in options)
    assert all(f"        {f.name} (" in make_env.__doc__ for f in options)
    with pytest.raises(ValueError, match=r"unknown env setting\(s\) \['cam_scale'\]: choose among"):
        resolve_settings("cartpole", "swingup", cam_scale=0.1)
    with pytest.raises(ValueError, match=r"unknown env setting\(s\) \['height'\]"):  # not a scene option
        resolve_settings("cartpole", "swingup", height=64)
    with pytest.raises(TypeError, match=r"make_env\(\) got unknown keyword argument\(s\) \['cam_scale'\]: choose"):
        make_env("cartpole", "swingup", cam_scale=0.1)


def _reference_camera(domain: str) -> int:
    """The camera the authors' 2021 code renders ``domain`` from (``distracting_control/suite.py``,
    ``load``: ``render_kwargs["camera_id"] = 2 if domain_name == "quadruped" else 0``)."""
    return 2 if domain == "quadruped" else 0


def _one_task_per_domain():
    from dm_control import suite

    return list({domain: (domain, task) for domain, task in reversed(suite.ALL_TASKS)}.values())


@pytest.mark.parametrize("domain,task", _one_task_per_domain())
def test_every_domain_renders_from_the_2021_codes_camera(domain, task):
    """The frame make_env shows is the render of the 2021 code's camera, and the camera distraction
    moves that camera: for the paper's six tasks and every other domain the suite accepts."""
    camera_id = _reference_camera(domain)
    size = 32
    env = make_env(domain, task, height=size, width=size, seed=1)
    plain = TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=action_repeat(domain, task)),
                           dcs.RenderPixels(size, size, camera_id=camera_id))
    plain.set_seed(1)
    shown = env.reset()["pixels"]
    assert torch.equal(shown, plain.reset()["pixels"])
    physics = physics_of(env)
    views = [engine.Camera(physics, size, size, c).render() for c in range(physics.model.ncam)]
    assert all(not np.array_equal(views[camera_id], v) for c, v in enumerate(views) if c != camera_id)  # cameras differ
    assert resolve_settings(domain, task, benchmark="medium").camera_id == camera_id
    env.close()
    plain.close()
