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


def test_a_dropped_gl_envs_contexts_are_freed_at_the_next_render():
    """Its GL and MuJoCo render contexts go with its physics: retired by the collector, freed by the next render."""
    from dcs_torchrl.render import gl

    env = make_env("cartpole", "swingup", **SMALL)
    env.rollout(2)
    contexts = physics_of(env).contexts
    del env  # not closed: the collector frees it
    gc.collect()
    assert not contexts.gl.terminated and gl._RETIRED
    other = make_env("cartpole", "swingup", **SMALL)
    other.rollout(2)
    assert contexts.gl.terminated and contexts.mujoco.ptr is None and gl._RETIRED == []
    other.close()


@pytest.mark.parametrize("upload", [5, 9])
def test_an_env_collected_inside_a_render_changes_no_frame(monkeypatch, upload):
    """The collector may run inside a render (any allocation can start it). dm_control frees a GL context by
    making it current, then none: a dropped env freed there would leave the rendering env's next GL calls (a
    new video frame's upload) to no context, and a stale sky in its frames. Here a collection runs before the
    ``upload``-th texture upload of a dynamic episode, with a dropped, unclosed env to free."""
    from OpenGL import GL

    def frames():
        env = make_env("cartpole", "swingup", seed=3, benchmark="medium", dynamic=True, **SMALL)
        out = env.rollout(4, policy=lambda td: td.set("action", torch.zeros(env.action_spec.shape)))
        out = out["next", "pixels"].clone()
        env.close()
        return out

    expected = frames()
    sub_image = GL.glTexSubImage2D
    calls, collected = [0], []

    def upload_after_a_collection(*args):
        calls[0] += 1
        if calls[0] == upload:
            collected.append(gc.collect())
        return sub_image(*args)

    dropped = make_env("cartpole", "swingup", **SMALL)
    dropped.rollout(2)
    del dropped  # not closed, held by reference cycles: freed by the next collection, inside the render
    monkeypatch.setattr(GL, "glTexSubImage2D", upload_after_a_collection)
    seen = frames()
    assert collected and collected[0] > 0 and calls[0] > upload
    assert torch.equal(seen, expected)
