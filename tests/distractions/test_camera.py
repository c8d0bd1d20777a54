"""CameraDistraction on real dm_control physics and rendering (Stone et al. 2021, Sec. 3.1)."""
import math

import mujoco
import numpy as np
import pytest
import torch
from dm_control.mujoco import engine
from scipy import stats
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import CameraDistraction, RenderPixels, make_env
from dcs_torchrl.distractions import camera_math as cm

from dcs_test_utils import PAPER_TASKS, physics_of


def camera_env(domain, task, scale, dynamic=False, frame_skip=1, render=False, **kwargs):
    transforms = [CameraDistraction(scale, dynamic, seed=0, expose=True, **kwargs)]
    if render:
        transforms.append(RenderPixels())
    return TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=frame_skip), Compose(*transforms))


def original_pose(domain, task):
    """(radius, azimuth, elevation-from-z) of camera 0 about its sphere centre, undistracted."""
    env = DMControlEnv(domain, task, from_pixels=False)
    env.reset()
    physics = physics_of(env)
    centre = physics.data.subtree_com[1] if physics.model.cam_mode[0] == 2 else np.zeros(3)
    return cm.cart_to_sphere(*(physics.data.cam_xpos[0] - centre))


def measured_pose(physics, camera=0):
    """The pose actually written into the scene, recovered from data.cam_xpos."""
    centre = physics.data.subtree_com[int(physics.model.cam_bodyid[camera])] if physics.model.cam_mode[camera] == 2 else 0
    return cm.cart_to_sphere(*(physics.data.cam_xpos[camera] - centre))


@pytest.mark.parametrize("domain,task", PAPER_TASKS)
def test_static_poses_cover_the_spec_range(domain, task):
    scale = 0.3
    radius0, azimuth0, elevation0 = original_pose(domain, task)
    env = camera_env(domain, task, scale)
    poses = np.stack([env.reset()["distractions", "camera"].numpy() for _ in range(200)])
    azimuth, elevation, radius, roll = poses.T
    delta = math.pi * scale / 2
    overhead = domain == "reacher"  # the reference's exception: no quadrant limit, pole-safe look-at
    az_range = (azimuth0 - delta, azimuth0 + delta)
    el_range = (elevation0 - delta, elevation0 + delta)
    if not overhead:
        az_range = (max(az_range[0], -math.pi), min(az_range[1], 0.0))
        el_range = (max(el_range[0], 0.0), min(el_range[1], math.pi / 2))
    r_range = (radius0 * (1 - 0.5 * scale), radius0 * (1 + 1.5 * scale))
    tol = 1e-5
    assert r_range[0] - tol <= radius.min() and radius.max() <= r_range[1] + tol
    assert -delta - tol <= roll.min() and roll.max() <= delta + tol
    # covered uniformly (KS test), not a corner of the range
    assert stats.kstest(radius, stats.uniform(r_range[0], r_range[1] - r_range[0]).cdf).pvalue > 0.001
    assert stats.kstest(roll, stats.uniform(-delta, 2 * delta).cdf).pvalue > 0.001
    if not overhead:
        assert az_range[0] - tol <= azimuth.min() and azimuth.max() <= az_range[1] + tol
        assert el_range[0] - tol <= elevation.min() and elevation.max() <= el_range[1] + tol
        assert stats.kstest(azimuth, stats.uniform(az_range[0], az_range[1] - az_range[0]).cdf).pvalue > 0.001
        assert stats.kstest(elevation, stats.uniform(el_range[0], el_range[1] - el_range[0]).cdf).pvalue > 0.001
    else:  # near the pole the reference canonicalises the pose; its tilt stays within δ of vertical
        assert np.all(np.abs(elevation) <= delta + tol)


@pytest.mark.parametrize("domain,task", [("cartpole", "swingup"), ("cheetah", "run"), ("reacher", "easy")])
def test_exposed_pose_is_the_rendered_camera(domain, task):
    env = camera_env(domain, task, 0.4, dynamic=True)
    env.reset()
    physics = physics_of(env)
    for td in env.rollout(20, break_when_any_done=False).unbind(0):
        pass
    azimuth, elevation, radius, roll = td["next", "distractions", "camera"].numpy()
    r, az, el = measured_pose(physics)
    assert (r, el) == pytest.approx((radius, elevation), abs=1e-5)
    assert math.remainder(az - azimuth, 2 * math.pi) == pytest.approx(0.0, abs=1e-5)
    rotation = physics.data.cam_xmat[0].reshape(3, 3)
    assert np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6)


@pytest.mark.parametrize("domain,task", [("cartpole", "swingup"), ("cheetah", "run")])
def test_camera_looks_at_its_focus_with_the_sampled_roll(domain, task):
    reference = DMControlEnv(domain, task, from_pixels=False)
    reference.set_seed(1)
    reference.reset()
    ref_physics = physics_of(reference)
    env = camera_env(domain, task, 0.5)
    env.set_seed(1)
    td = env.reset()
    physics = physics_of(env)
    # the focus: on the original view ray, at the original distance to the agent
    position, view = ref_physics.data.cam_xpos[0], -ref_physics.data.cam_xmat[0].reshape(3, 3)[:, 2]
    focus = position + view * np.linalg.norm(position - ref_physics.data.subtree_com[1])
    rotation = physics.data.cam_xmat[0].reshape(3, 3)
    direction = focus - physics.data.cam_xpos[0]
    assert np.allclose(-rotation[:, 2], direction / np.linalg.norm(direction), atol=1e-6)
    roll = td["distractions", "camera"][3].item()
    horizontal = np.cross(-rotation[:, 2], [0.0, 0.0, 1.0])
    horizontal /= np.linalg.norm(horizontal)
    # roll: the turn of the image x axis away from the horizontal, about the camera's z axis
    measured = math.atan2(np.cross(horizontal, rotation[:, 0]) @ rotation[:, 2], horizontal @ rotation[:, 0])
    assert measured == pytest.approx(roll, abs=1e-5)


def test_fixed_camera_orbits_the_world_origin_and_tracking_camera_the_agent():
    fixed = camera_env("cartpole", "swingup", 0.3, dynamic=True)
    fixed.rollout(30, break_when_any_done=False)
    physics = physics_of(fixed)
    assert np.linalg.norm(physics.data.cam_xpos[0]) == pytest.approx(
        float(fixed.transform[0].state()[2]), rel=1e-6
    )
    tracking = camera_env("cheetah", "run", 0.3, dynamic=False)
    td = tracking.reset()
    physics = physics_of(tracking)
    start = physics.data.subtree_com[1].copy()
    offsets = [physics.data.cam_xpos[0] - start]
    for _ in range(30):  # full torque on every joint: the cheetah lurches (0.07-0.3 in 30 steps)
        td["action"] = torch.ones(6, dtype=torch.float64)
        td = tracking.step(td)["next"]
        offsets.append(physics.data.cam_xpos[0] - physics.data.subtree_com[1])
    assert np.linalg.norm(physics.data.subtree_com[1] - start) > 0.02  # the agent moved ...
    assert np.allclose(offsets, offsets[0], atol=1e-9)  # ... and the static pose rode along with it


def test_static_pose_is_constant_within_an_episode():
    env = camera_env("walker", "walk", 0.5, dynamic=False)
    td = env.rollout(30, break_when_any_done=False)
    poses = td["next", "distractions", "camera"]
    assert torch.equal(poses, poses[:1].expand_as(poses))
    assert torch.equal(td["distractions", "camera"][0], poses[0])


@pytest.mark.parametrize("frame_skip", [1, 4])
def test_dynamic_step_size_per_control_step(frame_skip):
    scale, domain, task = 0.5, "cartpole", "swingup"
    radius0 = original_pose(domain, task)[0]
    env = camera_env(domain, task, scale, dynamic=True, frame_skip=frame_skip)
    td = env.rollout(300 // frame_skip, break_when_any_done=False)
    poses = td["next", "distractions", "camera"].double().numpy()
    positions = np.array([cm.sphere_to_cart(r, az, el) for az, el, r, _ in poses])
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    roll_steps = np.abs(np.diff(poses[:, 3]))
    max_speed, max_roll = 0.4 * scale * radius0 / 4, math.pi * scale / 50
    # one agent step = frame_skip control steps of at most v_max each (the paper's Sec. 3.1, with the 2021 code's r0/4 scaling: docs/paper.md)
    assert steps.max() <= frame_skip * max_speed + 1e-5
    assert roll_steps.max() <= frame_skip * max_roll + 1e-5
    assert np.median(steps) > 0.2 * max_speed  # it really moves, at the right scale


def test_frame_skip_advances_the_walk_per_control_step():
    # one agent step with frame_skip=4 == four agent steps with frame_skip=1 (fixed camera)
    coarse = camera_env("cartpole", "swingup", 0.5, dynamic=True, frame_skip=4)
    fine = camera_env("cartpole", "swingup", 0.5, dynamic=True, frame_skip=1)
    a = coarse.rollout(5, break_when_any_done=False)["next", "distractions", "camera"]
    b = fine.rollout(20, break_when_any_done=False)["next", "distractions", "camera"]
    torch.testing.assert_close(a, b[3::4])


def test_scale_zero_leaves_the_camera_alone():
    env = camera_env("cheetah", "run", 0.0, dynamic=True)
    reference = DMControlEnv("cheetah", "run", from_pixels=False)
    env.set_seed(3)
    reference.set_seed(3)
    td, ref_td = env.reset(), reference.reset()
    for _ in range(5):
        action = env.action_spec.rand()
        env.step(td.set("action", action))
        reference.step(ref_td.set("action", action))
    assert np.array_equal(physics_of(env).data.cam_xmat, physics_of(reference).data.cam_xmat)
    assert np.array_equal(physics_of(env).data.cam_xpos, physics_of(reference).data.cam_xpos)


@pytest.mark.parametrize("domain,task", PAPER_TASKS)
def test_blind_camera_sees_no_agent_geom(domain, task):
    env = make_env(domain, task, benchmark="blind", dynamic=True, seed=0)
    physics = physics_of(env)
    camera = engine.Camera(physics, 84, 84, 0)
    body_of_geom = physics.model.geom_bodyid
    for episode in range(3):
        env.reset()
        for _ in range(10):
            env.rand_step()
            seg = camera.render(segmentation=True)
            geoms = seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]
            assert not np.any(body_of_geom[geoms] != 0), f"{domain}: an agent geom is in view"
    # the same scene with the camera facing forward does show the agent
    seen = make_env(domain, task, benchmark="medium", seed=0)
    seen.reset()
    seg = engine.Camera(physics_of(seen), 84, 84, 0).render(segmentation=True)
    assert np.any(physics_of(seen).model.geom_bodyid[seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]] != 0)


@pytest.mark.parametrize("domain", ["humanoid", "quadruped", "fish", "swimmer", "hopper", "point_mass"])
def test_other_domains_work(domain):
    from dm_control import suite

    task = next(t for d, t in suite.ALL_TASKS if d == domain)
    env = make_env(domain, task, camera_scale=0.3, color_scale=0.0, num_videos=0, dynamic=True, seed=0, expose_distractions=True)
    td = env.rollout(5, break_when_any_done=False)
    assert td["next", "pixels"].float().std() > 1  # a picture, not a blank


def test_bad_camera_arguments():
    with pytest.raises(ValueError, match=r"scale must be in \[0, 1\]"):
        CameraDistraction(1.5)
    with pytest.raises(ValueError, match="camera_id=7 is out of range"):
        camera_env("cartpole", "swingup", 0.1, camera_id=7)
