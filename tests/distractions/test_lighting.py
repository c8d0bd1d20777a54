"""LightingDistraction on real dm_control models (beyond the paper; docs/lighting_textures.md)."""
import math

import numpy as np
import pytest
import torch
from dm_control import mujoco as dm_mujoco
from dm_control.rl import control
from dm_control.suite import base as suite_base
from torchrl.envs import Compose, DMControlEnv, DMControlWrapper, TransformedEnv

from dcs_torchrl import LightingDistraction, RenderPixels
from dcs_torchrl.distractions import lighting as lt
from dcs_test_utils import physics_of


def light_env(scale, dynamic=False, frame_skip=2, domain="cartpole", task="swingup", render=False, seed=0, size=32):
    transforms = [LightingDistraction(scale, dynamic, seed=seed, expose=True)]
    if render:
        transforms.append(RenderPixels(size, size))
    return TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=frame_skip), Compose(*transforms))


def _zero(env):
    return lambda td: td.set("action", env.action_spec.zero())


def _u(states: np.ndarray) -> np.ndarray:
    """The five numbers in units of the range (what the walk bounds), from exposed states."""
    s = np.asarray(states, np.float64)
    return np.stack([s[..., 0] / lt.MAX_TILT, s[..., 1] / lt.MAX_TILT, (s[..., 2] - 1) / lt.GAIN_RANGE,
                     np.log(s[..., 3] / lt.WHITE_KELVIN) / math.log(lt.TEMPERATURE_RATIO),
                     s[..., 4] / lt.AMBIENT_RANGE], axis=-1)


def test_static_lighting_is_one_uniform_draw_an_episode_within_the_scale():
    scale = 0.5
    env = light_env(scale)
    episodes = []
    for _ in range(60):
        td = env.reset()
        first = td["distractions", "lighting"].clone()
        rollout = env.rollout(3, auto_reset=False, tensordict=td)
        assert torch.equal(rollout["next", "distractions", "lighting"], first.expand(3, 5)), "static moved"
        episodes.append(first.numpy())
    u = _u(np.stack(episodes))
    assert np.all(np.abs(u) <= scale + 1e-5)
    assert np.all(u.min(0) < -0.3) and np.all(u.max(0) > 0.3)  # each number spans its range
    assert len({e.tobytes() for e in episodes}) == len(episodes)  # a new draw every episode


def test_dynamic_lighting_moves_every_step_smoothly_within_range():
    scale, skip = 0.8, 2
    env = light_env(scale, dynamic=True, frame_skip=skip)
    td = env.rollout(300, break_when_any_done=False)
    u = _u(td["next", "distractions", "lighting"].numpy())
    assert np.all(np.abs(u) <= scale + 1e-5)
    steps = np.abs(np.diff(u, axis=0))
    assert np.all(steps.max(axis=1) > 0), "a step where the lighting stood still"
    # the velocity walk: at most the largest speed a control step
    assert np.linalg.norm(np.diff(u, axis=0), axis=1).max() <= skip * lt._MAX_SPEED * scale + 1e-5
    assert np.ptp(u, axis=0).min() > 0.2 * scale  # it wanders, every number


def test_the_same_seed_gives_the_same_lighting_and_frames():
    runs = []
    for _ in range(2):
        env = light_env(0.7, dynamic=True, render=True)
        env.set_seed(11)  # the physics and the lighting
        td = env.rollout(6, _zero(env), break_when_any_done=False)
        runs.append((td["next", "distractions", "lighting"], td["next", "pixels"]))
    assert torch.equal(runs[0][0], runs[1][0]) and torch.equal(runs[0][1], runs[1][1])
    other = light_env(0.7, dynamic=True, seed=12).rollout(6, break_when_any_done=False)
    assert torch.equal(light_env(0.7, dynamic=True, seed=11).rollout(6, break_when_any_done=False)[
        "next", "distractions", "lighting"], runs[0][0])  # the transform's own seed alone
    assert not torch.equal(other["next", "distractions", "lighting"], runs[0][0])


@pytest.mark.parametrize("domain, task", [("cartpole", "swingup"), ("cheetah", "run"), ("finger", "spin")])
def test_zero_scale_edits_nothing_and_renders_the_tasks_own_lighting(domain, task):
    plain = TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=2), RenderPixels(32, 32))
    env = light_env(0.0, dynamic=True, domain=domain, task=task, render=True)
    plain.set_seed(3)
    env.set_seed(3)
    a = plain.rollout(5, _zero(plain), break_when_any_done=False)["next", "pixels"]
    b = env.rollout(5, _zero(env), break_when_any_done=False)
    assert torch.equal(a, b["next", "pixels"])
    state = b["next", "distractions", "lighting"][-1]
    assert state.tolist() == [0.0, 0.0, 1.0, lt.WHITE_KELVIN, 0.0]


def test_the_scene_gets_the_drawn_lights_every_step():
    """The lights orbit their floor point and the colours carry the gain and tint, headlight included."""
    env = light_env(1.0, dynamic=True, domain="cheetah", task="run")
    physics = physics_of(env)
    model = physics.model
    ambient0 = np.array(model.vis.headlight.ambient, np.float64)
    diffuse0, light_diffuse0 = np.array(model.vis.headlight.diffuse, np.float64), model.light_diffuse.copy()
    td = env.reset()
    for _ in range(4):
        state = td["distractions", "lighting"].double().numpy()
        gain = (1 + lt.GAIN_RANGE * _u(state)[2]) * lt.tint(state[3])
        np.testing.assert_allclose(model.vis.headlight.diffuse, diffuse0 * gain, rtol=1e-6)
        np.testing.assert_allclose(model.vis.headlight.ambient, (ambient0 + state[4]) * gain, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(model.light_diffuse, light_diffuse0 * gain, rtol=1e-6)
        # the light is where its undistracted pose, orbited about its floor point, puts it
        physics.forward()  # the kinematics again: the undistracted pose
        pos, direction = physics.data.light_xpos[0].copy(), physics.data.light_xdir[0].copy()
        pivot = pos + direction * (-pos[2] / direction[2])
        rot = _rot_y(state[1]) @ _rot_x(state[0])
        expected_pos, expected_dir = pivot + rot @ (pos - pivot), rot @ direction
        env.transform[0]._edit_scene(physics)
        np.testing.assert_allclose(physics.data.light_xpos[0], expected_pos, atol=1e-9)
        np.testing.assert_allclose(physics.data.light_xdir[0], expected_dir, atol=1e-9)
        td = env.step(td.set("action", env.action_spec.rand()))["next"]


def _rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_tint_is_white_at_6500_kelvin_warm_below_and_cold_above():
    np.testing.assert_allclose(lt.tint(6500.0), [1, 1, 1], atol=1e-12)
    warm, cold = lt.tint(2600.0), lt.tint(16250.0)
    assert warm[0] > 1 > warm[2] and cold[2] > 1 > cold[0]
    for t in (warm, cold):
        assert abs(t @ [0.2126, 0.7152, 0.0722] - 1) < 1e-12  # the luminance of white


def test_darker_and_brighter_frames_follow_the_gain():
    """Pixels at the largest gain are brighter than at the smallest (the same state otherwise)."""
    env = light_env(1.0, render=True, size=48)
    td = env.reset()
    worlds, physics = env.transform[0].worlds, physics_of(env)
    means = []
    for gain in (-1.0, 1.0):
        worlds.u[0] = [0, 0, gain, 0, 0]
        worlds._colour(np.array([0]))
        env.transform[0]._edit_scene(physics)
        means.append(env.transform[1]._render().double().mean().item())
    assert means[1] > means[0] + 10


def test_bad_scale_and_a_model_without_lights_are_refused():
    for bad in (-0.1, 1.5):
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            LightingDistraction(bad)
    xml = """<mujoco><worldbody><geom type="plane" size="1 1 .1"/>
             <camera pos="0 -2 1" xyaxes="1 0 0 0 .5 1"/><body pos="0 0 .5"><freejoint/><geom type="box" size=".1 .1 .1"/></body></worldbody></mujoco>"""

    class Still(suite_base.Task):
        def initialize_episode(self, physics):
            pass

        def get_observation(self, physics):
            return {"qpos": physics.data.qpos.copy()}

        def get_reward(self, physics):
            return 0.0

    physics = dm_mujoco.Physics.from_xml_string(xml)
    base = DMControlWrapper(control.Environment(physics, Still(random=0), time_limit=1.0), from_pixels=False)
    with pytest.raises(ValueError, match="has none: add a <light>"):
        TransformedEnv(base, Compose(LightingDistraction(0.5), RenderPixels(16, 16))).reset()
    TransformedEnv(base, Compose(LightingDistraction(0.0), RenderPixels(16, 16))).reset()  # 0: nothing to turn


def test_hold_sets_the_lighting_now_and_refuses_values_outside_the_scale():
    env = light_env(0.5)
    with pytest.raises(RuntimeError, match="reset"):
        env.transform[0].hold([0, 0, 0, 0, 0])
    env.reset()
    t, physics = env.transform[0], physics_of(env)
    t.hold([0.5, 0, -0.5, 0, 0])
    state = t.state()
    assert state[0] == pytest.approx(0.5 * lt.MAX_TILT) and state[2] == pytest.approx(1 - 0.5 * lt.GAIN_RANGE)
    physics.forward()
    undistracted = physics.data.light_xdir[0].copy()
    t._edit_scene(physics)
    assert not np.allclose(physics.data.light_xdir[0], undistracted)  # the light is turned
    for bad in ([0.6, 0, 0, 0, 0], [0, 0, 0, 0]):
        with pytest.raises(ValueError, match="within the scale"):
            t.hold(bad)
