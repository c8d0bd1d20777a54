"""The camera math alone (Stone et al. 2021, Sec. 3.1; docs/paper.md): ranges, the velocity random walk, look-at matrices."""
import math

import numpy as np
import pytest
from scipy import stats

from dcs_torchrl.distractions import camera_math as cm

R0, AZ0, EL0 = 4.0, -math.pi / 2, 1.3  # a cartpole-like camera


@pytest.mark.parametrize("scale", [0.1, 0.3, 1.0])
def test_pose_range_matches_spec(scale):
    r = cm.pose_range(R0, AZ0, EL0, scale, dynamic=True, upper_quadrant=True)
    delta = math.pi * scale / 2
    assert r.azimuth == pytest.approx((max(AZ0 - delta, -math.pi), min(AZ0 + delta, 0.0)))
    assert r.elevation == pytest.approx((max(EL0 - delta, 0.0), min(EL0 + delta, math.pi / 2)))
    assert r.roll == pytest.approx((-delta, delta))
    assert r.radius == pytest.approx((R0 * (1 - 0.5 * scale), R0 * (1 + 1.5 * scale)))
    # v_max = 2β/5, σ = β/10, scaled by r0/4; roll: πβ/50, πβ/300
    assert r.max_speed == pytest.approx(2 * scale / 5 * R0 / 4)
    assert r.speed_std == pytest.approx(scale / 10 * R0 / 4)
    assert r.max_roll_speed == pytest.approx(math.pi * scale / 50)
    assert r.roll_speed_std == pytest.approx(math.pi * scale / 300)


def test_static_range_has_no_motion():
    r = cm.pose_range(R0, AZ0, EL0, 0.5, dynamic=False, upper_quadrant=True)
    assert r.max_speed == r.speed_std == r.start_speed == r.max_roll_speed == r.roll_speed_std == 0


def test_overhead_range_is_not_clipped_to_the_quadrant():
    r = cm.pose_range(0.75, 0.0, 0.0, 0.4, dynamic=False, upper_quadrant=False)
    delta = math.pi * 0.4 / 2
    assert r.azimuth == pytest.approx((-delta, delta))
    assert r.elevation == pytest.approx((-delta, delta))


def test_sphere_round_trip(rng):
    for _ in range(100):
        radius, az, el = rng.uniform(0.1, 5), rng.uniform(-math.pi, math.pi), rng.uniform(0.01, math.pi - 0.01)
        assert cm.cart_to_sphere(*cm.sphere_to_cart(radius, az, el)) == pytest.approx((radius, az, el))


def test_sampled_poses_are_uniform_over_the_range(rng):
    r = cm.pose_range(R0, AZ0, EL0, 0.3, dynamic=True, upper_quadrant=True)
    poses = [cm.sample_pose(rng, r) for _ in range(2000)]
    for name in ("azimuth", "elevation", "radius", "roll"):
        low, high = getattr(r, name)
        values = np.array([getattr(p, name) for p in poses])
        assert stats.kstest(values, stats.uniform(low, high - low).cdf).pvalue > 0.001, name
    speeds = np.array([np.linalg.norm(p.velocity) for p in poses])
    assert stats.kstest(speeds, stats.uniform(0, r.start_speed).cdf).pvalue > 0.001


def test_walk_steps_stay_within_speed_and_range(rng):
    scale = 0.3
    r = cm.pose_range(R0, AZ0, EL0, scale, dynamic=True, upper_quadrant=True)
    pose = cm.sample_pose(rng, r)
    positions, rolls = [], []
    for _ in range(3000):
        pose = cm.walk(pose, r, rng.standard_normal(4))
        positions.append(cm.sphere_to_cart(pose.radius, pose.azimuth, pose.elevation))
        rolls.append(pose.roll)
        assert r.radius[0] - 1e-9 <= pose.radius <= r.radius[1] + 1e-9
        assert r.azimuth[0] - 1e-9 <= pose.azimuth <= r.azimuth[1] + 1e-9
        assert r.elevation[0] - 1e-9 <= pose.elevation <= r.elevation[1] + 1e-9
        assert r.roll[0] - 1e-9 <= pose.roll <= r.roll[1] + 1e-9
    steps = np.linalg.norm(np.diff(np.array(positions), axis=0), axis=1)
    roll_steps = np.abs(np.diff(rolls))
    assert steps.max() <= r.max_speed + 1e-9  # |c_n - c_{n-1}| <= v_max r0/4
    assert np.quantile(steps, 0.9) > 0.5 * r.max_speed  # and it does move at that scale
    assert roll_steps.max() <= r.max_roll_speed + 1e-9
    assert np.quantile(roll_steps, 0.9) > 0.3 * r.max_roll_speed
    # the walk explores the range, not a corner of it
    azimuths = np.array([cm.cart_to_sphere(*p)[1] for p in positions])
    assert azimuths.max() - azimuths.min() > 0.5 * (r.azimuth[1] - r.azimuth[0])


def test_walk_velocity_increments_have_the_spec_std(rng):
    # Far from every bound and below the speed limit the velocity does a Gaussian walk of σ·r0/4.
    r = cm.pose_range(R0, AZ0, 1.0, 1.0, dynamic=True, upper_quadrant=False)
    big = cm.PoseRange(**{**r.__dict__, "max_speed": 1e9})
    increments = []
    for _ in range(2000):
        pose = cm.Pose(R0, AZ0, 1.0, 0.0)
        moved = cm.walk(pose, big, rng.standard_normal(4))
        increments.append(moved.velocity)
    assert np.std(increments, axis=0) == pytest.approx([r.speed_std] * 3, rel=0.08)


def test_velocity_is_rederived_after_clipping():
    r = cm.pose_range(R0, AZ0, EL0, 0.2, dynamic=True, upper_quadrant=True)
    outwards = np.array(cm.sphere_to_cart(1.0, AZ0, EL0)) * r.max_speed
    top = cm.Pose(r.radius[1], AZ0, EL0, 0.0, velocity=tuple(outwards))  # pushing radially out
    moved = cm.walk(top, r, np.zeros(4))
    assert moved.radius == pytest.approx(r.radius[1])
    assert np.linalg.norm(moved.velocity) < 1e-9  # the clipped move leaves no outward velocity


def _looks_at(rotation, target, position):
    view = -rotation[:, 2]
    direction = (target - position) / np.linalg.norm(target - position)
    return np.allclose(view, direction, atol=1e-9)


@pytest.mark.parametrize("look_at", [cm.look_at_upright, cm.look_at_shortest])
def test_look_at_is_a_rotation_facing_the_target(look_at, rng):
    for _ in range(200):
        target, position = rng.normal(size=3), rng.normal(size=3) * 3
        rotation = look_at(target, position)
        assert np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9)
        assert np.linalg.det(rotation) == pytest.approx(1.0)
        assert _looks_at(rotation, target, position)


@pytest.mark.parametrize("look_at", [cm.look_at_upright, cm.look_at_shortest])
def test_roll_turns_the_camera_about_its_view_axis(look_at, rng):
    for _ in range(100):
        target, position, roll = rng.normal(size=3), rng.normal(size=3) * 3, rng.uniform(-1.6, 1.6)
        assert np.allclose(look_at(target, position, roll), look_at(target, position) @ cm.rotation_z(roll), atol=1e-12)


def test_upright_look_at_has_no_roll(rng):
    for _ in range(100):
        rotation = cm.look_at_upright(rng.normal(size=3), rng.normal(size=3) * 3)
        assert abs(rotation[2, 0]) < 1e-9  # camera x axis is horizontal
        assert rotation[2, 1] >= -1e-9  # image up points up


def test_shortest_look_at_is_smooth_through_the_pole():
    target = np.zeros(3)
    above = cm.look_at_shortest(target, np.array([0.0, 0.0, 1.0]))
    assert np.allclose(above, np.eye(3))  # a down-looking camera is not turned
    for dx in (1e-6, -1e-6):
        assert np.allclose(cm.look_at_shortest(target, np.array([dx, 0.0, 1.0])), above, atol=1e-5)
    below = cm.look_at_shortest(np.array([0.0, 0.0, 2.0]), np.zeros(3))  # straight up: a proper rotation
    assert np.linalg.det(below) == pytest.approx(1.0)
    assert _looks_at(below, np.array([0.0, 0.0, 2.0]), np.zeros(3))


@pytest.mark.parametrize("azimuth, turn", [
    (-math.pi / 2, 0.0), (-1.58, 0.0), (0.0, math.pi / 2), (math.pi / 2, math.pi), (math.pi, 3 * math.pi / 2),
    (2.5, 3 * math.pi / 2), (-2.93, -math.pi / 2),
])
def test_frame_turn_brings_the_camera_to_the_front(azimuth, turn):
    """Seen in the turned frame (world = rotation_z(turn) @ local, as CameraDistraction uses it) the
    camera is in the front quadrant, on the -y side where the paper's cameras are: |x| <= -y."""
    assert cm.frame_turn(azimuth) == pytest.approx(turn, abs=1e-12)  # worked out by hand
    to_world = cm.rotation_z(cm.frame_turn(azimuth))
    assert np.allclose(np.abs(to_world).sum(0), 1.0)  # a quarter turn: world axes go to world axes
    x, y, _ = to_world.T @ np.array(cm.sphere_to_cart(1.0, azimuth, 1.0))
    assert y < 0 and abs(x) <= -y + 1e-9


def test_paper_cameras_are_not_turned():
    # every camera of the six paper tasks already faces the front: no change from the reference
    for azimuth in (-math.pi / 2, -1.5808, -1.5608):
        assert cm.frame_turn(azimuth) == 0.0


def test_walk_many_is_walk_step_by_step():
    # walk_many runs the steps in one loop (this runs every agent step): the same floats as one walk per step
    r = cm.pose_range(R0, AZ0, EL0, 0.3, dynamic=True, upper_quadrant=True)
    start = cm.sample_pose(np.random.default_rng(1), r)
    many = cm.walk_many(start, r, np.random.default_rng(2), 50)
    pose = start
    for noise in np.random.default_rng(2).standard_normal((50, 4)):
        pose = cm.walk(pose, r, noise)
    assert many == pose
    assert cm.walk_many(start, r, np.random.default_rng(2), 0) == start
