"""A closed env holds nothing: its physics, models and render contexts are freed once the caller lets go.

A process that builds envs one after another (a sweep, an evaluation, the test suite) must not keep each one's
MuJoCo model (cartpole's skybox alone is 11 MB) or GL context for good. Two module-level tables did: the GL
render contexts (keyed weakly by a physics, each holding its physics) and a cache on the batch's name lookups.
"""
import gc
import weakref

import pytest
import torch

from dm_control import suite

from dcs_torchrl import make_env

from dcs_test_utils import physics_of

SMALL = dict(height=32, width=32, action_repeat=50)


def _freed(refs: list[weakref.ref]) -> list[bool]:
    gc.collect()
    return [ref() is None for ref in refs]


@pytest.mark.parametrize("settings", [dict(benchmark="medium", dynamic=True),
                                      dict(benchmark="medium", light_scale=0.5, texture_scale=0.5)])
def test_a_rendered_gl_env_is_freed(settings):
    env = make_env("cartpole", "swingup", **SMALL, **settings)
    env.set_seed(0)
    env.rollout(3)  # renders: the suite's render context of the physics is made
    physics = physics_of(env)
    refs = [weakref.ref(physics), weakref.ref(physics.model.ptr), weakref.ref(physics.data.ptr)]
    del physics
    env.close()
    del env
    suite.load("cartpole", "swingup")  # dm_control keeps the last model it parsed (a textured env parses its own)
    assert _freed(refs) == [True, True, True]


@pytest.mark.parametrize("settings", [dict(benchmark="none"),
                                      dict(benchmark="medium", dynamic=True, light_scale=0.5, texture_scale=0.5)])
def test_a_closed_warp_batch_is_freed(settings):
    pytest.importorskip("mujoco_warp")
    env = make_env("cartpole", "swingup", num_envs=3, backend="warp", **SMALL, **settings)
    assert env.physics is not None  # the batch's physics over arrays (its name lookups) is part of what is checked
    env.set_seed(0)
    env.rollout(3)
    refs = [weakref.ref(env)]
    for world in env._worlds:
        refs += [weakref.ref(world.physics), weakref.ref(world.physics.model.ptr), weakref.ref(world.physics.data.ptr)]
    refs += [weakref.ref(renderer) for renderer in env.renderers]
    env.close()
    del env, world
    suite.load("cartpole", "swingup")  # dm_control keeps the last model it parsed: the batch's last world's
    assert all(_freed(refs)), f"still alive: {[i for i, freed in enumerate(_freed(refs)) if not freed]}"


def test_a_dropped_gl_envs_contexts_are_freed():
    """Its GL and MuJoCo render contexts go with its physics."""
    env = make_env("cartpole", "swingup", **SMALL)
    env.rollout(2)
    contexts = weakref.ref(physics_of(env).contexts.gl)
    env.close()
    del env
    assert _freed([contexts]) == [True]


def test_an_env_collected_inside_a_render_changes_no_frame(monkeypatch):
    """The collector may run inside a render (any allocation can start it), and dm_control frees a GL
    context by making it current: a dropped env freed there leaves the rendering env's frames as they are."""
    from dm_control.mujoco import engine

    def frames():
        env = make_env("cartpole", "swingup", seed=3, benchmark="medium", dynamic=True, **SMALL)
        out = env.rollout(4, policy=lambda td: td.set("action", torch.zeros(env.action_spec.shape)))
        out = out["next", "pixels"].clone()
        env.close()
        return out

    expected = frames()
    render = engine.mujoco.mjr_render
    collected = []

    def render_after_a_collection(*args):
        collected.append(gc.collect())
        return render(*args)

    dropped = make_env("cartpole", "swingup", **SMALL)
    dropped.rollout(2)
    dropped.close()
    del dropped  # held by reference cycles: freed by the next collection, inside the next render
    monkeypatch.setattr(engine.mujoco, "mjr_render", render_after_a_collection)
    seen = frames()
    assert collected and collected[0] > 0
    assert torch.equal(seen, expected)
