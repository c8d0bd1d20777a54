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
    z axis and pitched about its own x axis (``rotation_z(-yaw) @ R_x(pitch) @ rotation_z(roll)``).
    Unstable right above or below the target, which the frontal-quadrant limit keeps the camera
    away from. The compiled :func:`dcs_torchrl.distractions.camera_kernels.look_at`, on one camera.
    """
    return _look_at(target, position, roll, True)


def look_at_shortest(target, position, roll: float = 0.0) -> np.ndarray:
    """Camera rotation looking at ``target`` by the smallest rotation of a down-looking camera, then rolled.

    Used for cameras above the scene (reacher): it stays smooth through the pole, at the
    price of some roll. Looking straight up turns the camera by π about its x axis. The compiled
    :func:`dcs_torchrl.distractions.camera_kernels.look_at`, on one camera.
    """
    return _look_at(target, position, roll, False)


def _look_at(target, position, roll: float, upright: bool) -> np.ndarray:
    from dcs_torchrl.distractions import camera_kernels as ck

    out = np.empty(9)
    ck.look_at(np.asarray(target, np.float64), np.asarray(position, np.float64), float(roll), upright, out)
    return out.reshape(3, 3)


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

    def limits(self) -> tuple[float, ...]:
        """The range as a row of :data:`dcs_torchrl.distractions.camera_kernels.LIMITS`."""
        return (*self.radius, *self.azimuth, *self.elevation, *self.roll, self.speed_std, self.max_speed,
                self.roll_speed_std, self.max_roll_speed)


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
    """Camera pose ``c = (azimuth, elevation, radius, roll)`` plus its velocities."""

    radius: float
    azimuth: float
    elevation: float
    roll: float
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    roll_velocity: float = 0.0


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
    return _walk_rows(pose, r, np.asarray(noise, np.float64).reshape(1, 4))


def walk_many(pose: Pose, r: PoseRange, rng: np.random.Generator, n_steps: int) -> Pose:
    """``n_steps`` control steps of :func:`walk`, drawing the noise in one call."""
    return _walk_rows(pose, r, rng.standard_normal((n_steps, 4)))


def _walk_rows(pose: Pose, r: PoseRange, rows: np.ndarray) -> Pose:
    """One :func:`walk` step per row of 4 noise numbers: the compiled walk of the worlds
    (:func:`dcs_torchrl.distractions.camera_kernels.walk`) on one world."""
    from dcs_torchrl.distractions import camera_kernels as ck

    state = np.array([[pose.radius, pose.azimuth, pose.elevation, pose.roll]])
    velocity, roll_velocity = np.array([pose.velocity], np.float64), np.array([pose.roll_velocity])
    limits = np.array([r.limits()])
    ck.walk(np.zeros(1, np.int64), np.array([len(rows)]), rows.reshape(1, -1), np.zeros(1, np.int64), state, velocity,
            roll_velocity, limits)
    radius, azimuth, elevation, roll = state[0].tolist()
    return Pose(radius, azimuth, elevation, roll, tuple(velocity[0].tolist()), float(roll_velocity[0]))
