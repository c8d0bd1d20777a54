"""Camera-pose distraction math (Stone et al. 2021, Sec. 3.1; docs/paper.md), free of MuJoCo so it can be tested alone.

Conventions (those of the authors' 2021 code, which define the published numbers):

* spherical coordinates ``(radius, azimuth, elevation)`` with
  ``azimuth = atan2(y, x)`` and ``elevation`` the angle from the +z axis
  (0 = straight above the focus, π/2 = level with it): the *upper frontal quadrant*
  is ``elevation in [0, π/2]``, ``azimuth in [-π, 0]`` (DM Control cameras look along +y);
* coordinates are taken about the world origin for fixed cameras and about the tracked
  centre of mass for tracking cameras, in a frame turned about z by a multiple of π/2
  (``frame_turn``) so that the original camera sits in the frontal quadrant. For the
  paper's six tasks the turn is 0; it lets cameras that look along another axis
  (humanoid, quadruped, fish, ...) use the same rule;
* a camera looks along its -z axis, with +y up in the image.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

HALF_PI = math.pi / 2


def cart_to_sphere(x: float, y: float, z: float) -> tuple[float, float, float]:
    """Cartesian offset to ``(radius, azimuth, elevation-from-+z)``."""
    return math.sqrt(x * x + y * y + z * z), math.atan2(y, x), math.atan2(math.hypot(x, y), z)


def sphere_to_cart(radius: float, azimuth: float, elevation: float) -> tuple[float, float, float]:
    """``(radius, azimuth, elevation-from-+z)`` to a Cartesian offset."""
    s = math.sin(elevation)
    return radius * s * math.cos(azimuth), radius * s * math.sin(azimuth), radius * math.cos(elevation)


def frame_turn(azimuth: float) -> float:
    """The multiple of π/2 to turn the world by so that ``azimuth`` lands in [-3π/4, -π/4]."""
    return HALF_PI * round((azimuth + HALF_PI) / HALF_PI)


def rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def look_at_upright(target, position, roll: float = 0.0) -> np.ndarray:
    """Camera rotation (columns = camera axes in world) looking at ``target``, then rolled by ``roll``.

    Before the roll the camera's x axis stays horizontal: the camera is yawed about the world
    z axis and pitched about its own x axis (``rotation_z(-yaw) @ R_x(pitch) @
    rotation_z(roll)``, written out: this runs at every agent step). Unstable right above or
    below the target, which the frontal-quadrant limit keeps the camera away from.
    """
    dx, dy, dz = (float(t) - float(p) for t, p in zip(target, position))
    yaw = math.atan2(dx, dy)
    pitch = math.atan2(dz, math.hypot(dx, dy)) + HALF_PI  # camera starts looking at -z
    c, s = math.cos(yaw), -math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    # columns of rotation_z(-yaw) @ R_x(pitch) (R_x: the rotation about x): x = (c, s, 0), y = (-s cp, c cp, sp), z = (s sp, -c sp, cp)
    yx, yy, yz = -s * cp, c * cp, sp
    return np.array([
        [c * cr + yx * sr, yx * cr - c * sr, s * sp],
        [s * cr + yy * sr, yy * cr - s * sr, -c * sp],
        [yz * sr, yz * cr, cp],
    ])


def look_at_shortest(target: np.ndarray, position: np.ndarray, roll: float = 0.0) -> np.ndarray:
    """Camera rotation looking at ``target`` by the smallest rotation of a down-looking camera, then rolled.

    Used for cameras above the scene (reacher): it stays smooth through the pole, at the
    price of some roll. Looking straight up turns the camera by π about its x axis.
    """
    d = np.asarray(target, float) - np.asarray(position, float)
    d = d / np.linalg.norm(d)
    down = np.array([0.0, 0.0, -1.0])
    axis = np.cross(down, d)
    sin_t = float(np.linalg.norm(axis))
    cos_t = float(d @ down)
    if sin_t < 1e-12:
        turn = np.eye(3) if cos_t > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        axis /= sin_t
        k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        turn = np.eye(3) + sin_t * k + (1.0 - cos_t) * (k @ k)
    return turn @ rotation_z(roll)


@dataclass(frozen=True)
class PoseRange:
    """The camera's allowed poses and speeds for one episode (the paper's Sec. 3.1)."""

    radius: tuple[float, float]
    azimuth: tuple[float, float]
    elevation: tuple[float, float]
    roll: tuple[float, float]
    max_speed: float  # |v| limit, already scaled by r0 / 4
    speed_std: float  # σ of the velocity random walk, already scaled by r0 / 4
    start_speed: float  # v0 ~ U(0, start_speed) in a random direction (unscaled, as in the reference)
    max_roll_speed: float
    roll_speed_std: float


def pose_range(
    radius0: float, azimuth0: float, elevation0: float, scale: float, dynamic: bool, upper_quadrant: bool
) -> PoseRange:
    """The pose range about an original pose for scale β (the paper's Sec. 3.1, with the 2021 code's choices: docs/paper.md).

    Angles within ±πβ/2 of the original (clipped to the upper frontal quadrant when
    ``upper_quadrant``), roll within ±πβ/2, radius in [r0(1 - β/2), r0(1 + 3β/2)];
    dynamic speeds v_max = 2β/5, σ = β/10 (both times r0/4), roll v_max = πβ/50,
    σ_roll = πβ/300.
    """
    delta = HALF_PI * scale
    az = (azimuth0 - delta, azimuth0 + delta)
    el = (elevation0 - delta, elevation0 + delta)
    if upper_quadrant:
        az = (max(az[0], -math.pi), min(az[1], 0.0))
        el = (max(el[0], 0.0), min(el[1], HALF_PI))
    speed_scale = radius0 / 4.0
    moving = scale if dynamic else 0.0
    return PoseRange(
        radius=(max(radius0 * (1.0 - 0.5 * scale), 0.0), radius0 * (1.0 + 1.5 * scale)),
        azimuth=az,
        elevation=el,
        roll=(-delta, delta),
        max_speed=0.4 * moving * speed_scale,
        speed_std=0.1 * moving * speed_scale,
        start_speed=0.4 * moving,
        max_roll_speed=math.pi / 50 * moving,
        roll_speed_std=math.pi / 300 * moving,
    )


class Pose(NamedTuple):
    """Camera pose ``c = (azimuth, elevation, radius, roll)`` plus its velocities (a tuple: one
    is made per control step)."""

    radius: float
    azimuth: float
    elevation: float
    roll: float
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    roll_velocity: float = 0.0

    def as_array(self, azimuth_offset: float = 0.0) -> np.ndarray:
        """``[azimuth, elevation, radius, roll]`` with the azimuth in the world frame, in (-π, π]."""
        az = math.remainder(self.azimuth + azimuth_offset, 2 * math.pi)
        return np.array([az, self.elevation, self.radius, self.roll], dtype=np.float32)


def sample_pose(rng: np.random.Generator, r: PoseRange) -> Pose:
    """A uniform start pose in the range and a start velocity ~U(0, v_max) in a random direction."""
    azimuth = rng.uniform(*r.azimuth)
    elevation = rng.uniform(*r.elevation)
    radius = rng.uniform(*r.radius)
    roll = rng.uniform(*r.roll)
    direction = rng.standard_normal(3)
    direction /= np.linalg.norm(direction)
    velocity = direction * rng.uniform(0.0, r.start_speed)
    roll_velocity = rng.uniform(-r.max_roll_speed, r.max_roll_speed)
    return Pose(radius, azimuth, elevation, roll, tuple(velocity.tolist()), roll_velocity)


def walk(pose: Pose, r: PoseRange, noise) -> Pose:
    """Advances the pose by one control step of the velocity random walk.

    ``noise`` holds 4 standard normals (x, y, z, roll). The velocity is perturbed,
    clipped to its maximum, added to the Cartesian position, the result clipped to the
    range in spherical coordinates, and the velocity re-derived from the clipped move
    so it never keeps pushing out of range; likewise for roll.
    """
    return _walk_rows(pose, r, [[float(x) for x in noise]])


def walk_many(pose: Pose, r: PoseRange, rng: np.random.Generator, n_steps: int) -> Pose:
    """``n_steps`` control steps of :func:`walk`, drawing the noise in one call."""
    return _walk_rows(pose, r, rng.standard_normal((n_steps, 4)).tolist())


def _walk_rows(pose: Pose, r: PoseRange, rows: list) -> Pose:
    """One :func:`walk` step per row of 4 noise floats. Written out in plain floats, one pose
    made at the end: this runs at every agent step, right after a render has left the caches
    cold, where each call and object costs several times what it does warm."""
    radius, azimuth, elevation, roll = pose.radius, pose.azimuth, pose.elevation, pose.roll
    vx, vy, vz = pose.velocity
    roll_velocity = pose.roll_velocity
    r_lo, r_hi = r.radius
    az_lo, az_hi = r.azimuth
    el_lo, el_hi = r.elevation
    roll_lo, roll_hi = r.roll
    std, max_speed, roll_std, max_roll = r.speed_std, r.max_speed, r.roll_speed_std, r.max_roll_speed
    sin, cos, atan2, sqrt = math.sin, math.cos, math.atan2, math.sqrt
    s = sin(elevation)
    x, y, z = radius * s * cos(azimuth), radius * s * sin(azimuth), radius * cos(elevation)
    for n0, n1, n2, n3 in rows:
        vx += n0 * std
        vy += n1 * std
        vz += n2 * std
        roll_velocity = min(max(roll_velocity + n3 * roll_std, -max_roll), max_roll)
        speed = sqrt(vx * vx + vy * vy + vz * vz)
        if speed > max_speed:
            shrink = max_speed / speed
            vx, vy, vz = vx * shrink, vy * shrink, vz * shrink
        px, py, pz = x + vx, y + vy, z + vz
        radius = min(max(sqrt(px * px + py * py + pz * pz), r_lo), r_hi)
        azimuth = min(max(atan2(py, px), az_lo), az_hi)
        elevation = min(max(atan2(math.hypot(px, py), pz), el_lo), el_hi)
        s = sin(elevation)
        nx, ny, nz = radius * s * cos(azimuth), radius * s * sin(azimuth), radius * cos(elevation)
        vx, vy, vz = nx - x, ny - y, nz - z
        x, y, z = nx, ny, nz
        new_roll = min(max(roll + roll_velocity, roll_lo), roll_hi)
        roll_velocity = new_roll - roll
        roll = new_roll
    return Pose(radius, azimuth, elevation, roll, (vx, vy, vz), roll_velocity)
