"""The contract every distraction transform must keep (like TorchRL's TransformBase tests)."""
import functools

import numpy as np
import pytest
import torch
from torchrl.envs import Compose, DMControlEnv, ParallelEnv, SerialEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs

from dcs_torchrl import BackgroundDistraction, CameraDistraction, ColorDistraction, ParallelSuiteEnv, RenderPixels, make_env
from dcs_test_utils import distraction_streams, numbered_video, shared_streams

DISTRACTIONS = {
    "camera": functools.partial(CameraDistraction, 0.3, True),
    "color": functools.partial(ColorDistraction, 0.3, True),
    "background": functools.partial(BackgroundDistraction, [numbered_video(9), numbered_video(5)], True),
}


def build(name, seed=None, expose=True, frame_skip=2):
    """A cartpole env with one distraction then RenderPixels (module level: picklable for workers)."""
    return TransformedEnv(
        DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=frame_skip),
        Compose(DISTRACTIONS[name](seed=seed, expose=expose), RenderPixels()),
    )


def build_all(seed=None):
    """A cartpole env with every distraction, each exposed, then RenderPixels (picklable for workers)."""
    return TransformedEnv(
        DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=2),
        Compose(*(DISTRACTIONS[name](seed=seed, expose=True) for name in sorted(DISTRACTIONS)), RenderPixels(32, 32)),
    )


def rollout(env, steps):
    """A rollout with seeded random actions (TorchRL draws them from torch's global generator)."""
    torch.manual_seed(0)
    return env.rollout(steps, break_when_any_done=False)


@pytest.fixture(params=sorted(DISTRACTIONS))
def name(request):
    return request.param


def test_specs_single(name):
    check_env_specs(build(name, seed=0))
    check_env_specs(build(name, seed=0, expose=False))


def test_specs_serial(name):
    env = SerialEnv(2, functools.partial(build, name))
    env.set_seed(0)
    check_env_specs(env)
    state = env.rollout(4)["next", "distractions", name]
    assert not torch.equal(state[0], state[1]), "sub-envs must not share a random stream"
    env.close()


# ParallelSuiteEnv's specs and a stream per worker, with every distraction exposed, by default:
# tests/test_parallel.py (each worker's distraction states are those of one env with its own seed).
@pytest.mark.parametrize("batched", [functools.partial(ParallelEnv, mp_start_method="spawn"),
                                     pytest.param(ParallelSuiteEnv, marks=pytest.mark.slow)],
                         ids=["ParallelEnv", "ParallelSuiteEnv"])
def test_specs_parallel(batched):
    """Every distraction in one env (one spawn of workers for the three): specs, and a stream per worker."""
    env = batched(2, build_all)
    env.set_seed(0)
    check_env_specs(env)
    td = env.rollout(4)
    for name in DISTRACTIONS:
        state = td["next", "distractions", name]
        assert not torch.equal(state[0], state[1]), f"workers must not share the {name} distraction's random stream"
    env.close()


def test_exposed_state_is_declared(name):
    env = build(name, seed=0)
    spec = env.observation_spec["distractions", name]
    td = env.reset()
    assert spec.is_in(td["distractions", name])
    assert "distractions" not in build(name, seed=0, expose=False).reset().keys()


def test_same_seed_same_distraction(name):
    # the transform's own seed fixes the distraction (the physics has its own seed: see below)
    a = rollout(build(name, seed=3), 6)
    b = rollout(build(name, seed=3), 6)
    assert torch.equal(a["distractions", name], b["distractions", name])
    assert torch.equal(a["next", "distractions", name], b["next", "distractions", name])


def test_different_seeds_differ(name):
    a = rollout(build(name, seed=3), 6)
    b = rollout(build(name, seed=4), 6)
    assert not torch.equal(a["next", "distractions", name], b["next", "distractions", name])


def test_env_set_seed_reseeds_the_distraction(name):
    env = build(name)  # unseeded: fresh entropy
    env.set_seed(7)
    a = rollout(env, 5)
    env.set_seed(7)
    b = rollout(env, 5)
    seeded = build(name, seed=7)
    seeded.set_seed(7)
    c = rollout(seeded, 5)
    assert torch.equal(a["next", "pixels"], b["next", "pixels"])
    assert torch.equal(a["next", "pixels"], c["next", "pixels"])


def test_set_seed_survives_wrapping(name):
    # TransformedEnv(env, t) rebuilds the env around the same base env: seeding still reaches the clone
    inner = build(name)
    outer = TransformedEnv(inner, Compose(), auto_unwrap=True)
    outer.set_seed(11)
    a = rollout(outer, 4)
    outer.set_seed(11)
    b = rollout(outer, 4)
    assert torch.equal(a["next", "pixels"], b["next", "pixels"])


def test_composes_with_the_other_distractions(name):
    others = [DISTRACTIONS[n](seed=1, expose=True) for n in sorted(DISTRACTIONS)]
    env = TransformedEnv(DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=2), Compose(*others, RenderPixels()))
    check_env_specs(env)
    td = env.rollout(3)
    assert set(td["next", "distractions"].keys()) == set(DISTRACTIONS)


def test_cannot_transform_stored_data(name):
    env = build(name, seed=0)
    with pytest.raises(RuntimeError, match="cannot transform stored data"):
        env.transform[0](env.reset())


def test_refused_after_render_pixels(name):
    with pytest.raises(RuntimeError, match="placed after RenderPixels"):
        TransformedEnv(
            DMControlEnv("cartpole", "swingup", from_pixels=False), Compose(RenderPixels(), DISTRACTIONS[name]())
        ).reset()


def test_physics_and_rewards_are_unchanged(name):
    env = build(name, seed=0, frame_skip=1)
    reference = DMControlEnv("cartpole", "swingup", from_pixels=False)
    env.set_seed(2)
    reference.set_seed(2)
    td, ref = env.reset(), reference.reset()
    rewards, ref_rewards = [], []
    for _ in range(20):
        action = torch.rand(1, dtype=torch.float64) * 2 - 1
        td = env.step(td.set("action", action))["next"]
        ref = reference.step(ref.set("action", action))["next"]
        rewards.append(td["reward"].item())
        ref_rewards.append(ref["reward"].item())
    assert np.array_equal(rewards, ref_rewards)


def test_each_distraction_has_its_own_stream():
    """One seed gives the three distractions three different random streams, each a function of the seed."""
    streams = distraction_streams(make_env("cartpole", "swingup", benchmark="easy", seed=5))
    assert sorted(streams) == ["BackgroundDistraction", "CameraDistraction", "ColorDistraction"]
    assert shared_streams(streams) == []
    assert distraction_streams(make_env("cartpole", "swingup", benchmark="easy", seed=5)) == streams
    assert distraction_streams(make_env("cartpole", "swingup", benchmark="easy", seed=6)) != streams
