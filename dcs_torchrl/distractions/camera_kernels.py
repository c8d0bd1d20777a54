"""The camera distraction's step over N worlds, compiled (numba): the random walk and the camera it places.

One call walks every world's pose by its control steps (:func:`walk`) and one writes every world's
camera position and orientation (:func:`place`): no Python per world. The one-world transform
(:class:`~dcs_torchrl.CameraDistraction` on a ``DMControlEnv``) calls the same two functions with one row,
so a world of the Warp batch and the GL env seeded alike place the same camera bit for bit. The
maths is that of :mod:`dcs_torchrl.distractions.camera_math` (the paper's Sec. 3.1 and the 2021 code's
conventions), written in scalars: MuJoCo's conventions, ``xmat`` row-major, a camera looking along -z.

Arrays (``N`` worlds, float64 unless said):

* ``pose [N, 4]``: radius, azimuth, elevation (from +z), roll, in the turned frame;
* ``velocity [N, 3]`` (Cartesian) and ``roll_velocity [N]``;
* ``limits [N, 12]``: radius, azimuth, elevation, roll (low, high each), then the walk's σ and maximum
  speed, the roll's σ and maximum speed (:data:`LIMITS`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["LIMITS", "look_at", "place", "state", "task_focus", "walk"]

#: The columns of ``limits``.
LIMITS = ("radius_low", "radius_high", "azimuth_low", "azimuth_high", "elevation_low", "elevation_high",
          "roll_low", "roll_high", "speed_std", "max_speed", "roll_speed_std", "max_roll_speed")

FIXED, TRACK, TRACKCOM = 0, 1, 2  # MuJoCo's camera modes the distraction supports


@njit(cache=True, nogil=True)
def walk(rows, steps, noise, start, pose, velocity, roll_velocity, limits):  # pragma: no cover - compiled
    """``steps[j]`` control steps of the velocity random walk for world ``rows[j]``, with
    ``noise[rows[j], start[j] + 4 t:][:4]`` (standard normals: x, y, z, roll) at step ``t``: the velocity perturbed and clipped to its maximum,
    added to the Cartesian position, the result clipped to the range in spherical coordinates and the
    velocity re-derived from the clipped move (so it never keeps pushing out of range); likewise for roll."""
    for j in range(rows.shape[0]):
        i = rows[j]
        radius, azimuth, elevation, roll = pose[i, 0], pose[i, 1], pose[i, 2], pose[i, 3]
        vx, vy, vz = velocity[i, 0], velocity[i, 1], velocity[i, 2]
        roll_v = roll_velocity[i]
        r_lo, r_hi, az_lo, az_hi = limits[i, 0], limits[i, 1], limits[i, 2], limits[i, 3]
        el_lo, el_hi, roll_lo, roll_hi = limits[i, 4], limits[i, 5], limits[i, 6], limits[i, 7]
        std, max_speed, roll_std, max_roll = limits[i, 8], limits[i, 9], limits[i, 10], limits[i, 11]
        s = math.sin(elevation)
        x, y, z = radius * s * math.cos(azimuth), radius * s * math.sin(azimuth), radius * math.cos(elevation)
        for t in range(steps[j]):
            at = start[j] + 4 * t
            vx += noise[i, at] * std
            vy += noise[i, at + 1] * std
            vz += noise[i, at + 2] * std
            roll_v = min(max(roll_v + noise[i, at + 3] * roll_std, -max_roll), max_roll)
            speed = math.sqrt(vx * vx + vy * vy + vz * vz)
            if speed > max_speed:
                shrink = max_speed / speed
                vx, vy, vz = vx * shrink, vy * shrink, vz * shrink
            px, py, pz = x + vx, y + vy, z + vz
            radius = min(max(math.sqrt(px * px + py * py + pz * pz), r_lo), r_hi)
            azimuth = min(max(math.atan2(py, px), az_lo), az_hi)
            elevation = min(max(math.atan2(math.sqrt(px * px + py * py), pz), el_lo), el_hi)
            s = math.sin(elevation)
            nx, ny, nz = radius * s * math.cos(azimuth), radius * s * math.sin(azimuth), radius * math.cos(elevation)
            vx, vy, vz = nx - x, ny - y, nz - z
            x, y, z = nx, ny, nz
            new_roll = min(max(roll + roll_v, roll_lo), roll_hi)
            roll_v = new_roll - roll
            roll = new_roll
        pose[i, 0], pose[i, 1], pose[i, 2], pose[i, 3] = radius, azimuth, elevation, roll
        velocity[i, 0], velocity[i, 1], velocity[i, 2] = vx, vy, vz
        roll_velocity[i] = roll_v


@njit(cache=True, nogil=True)
def look_at(target, position, roll, upright, out):  # pragma: no cover - compiled
    """The rotation (row-major, columns the camera's axes in the world) of a camera at ``position``
    looking at ``target``, rolled by ``roll``, into ``out[9]``. ``upright``: yawed about the world's z axis
    and pitched about its own x axis, its x axis level before the roll (unstable right above the target,
    which the upper frontal quadrant keeps it away from); else the smallest rotation of a camera looking
    down (smooth through the pole, for cameras above the scene: reacher's)."""
    dx, dy, dz = target[0] - position[0], target[1] - position[1], target[2] - position[2]
    cr, sr = math.cos(roll), math.sin(roll)
    if upright:
        yaw = math.atan2(dx, dy)
        pitch = math.atan2(dz, math.sqrt(dx * dx + dy * dy)) + math.pi / 2  # the camera starts looking at -z
        c, s = math.cos(yaw), -math.sin(yaw)
        cp, sp = math.cos(pitch), math.sin(pitch)
        yx, yy, yz = -s * cp, c * cp, sp  # the y column of rotation_z(-yaw) @ R_x(pitch)
        t00, t01, t02 = c, yx, s * sp
        t10, t11, t12 = s, yy, -c * sp
        t20, t21, t22 = 0.0, yz, cp
    else:
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        dx, dy, dz = dx / norm, dy / norm, dz / norm
        sin_t = math.sqrt(dy * dy + dx * dx)  # |down x d|, down = (0, 0, -1): the axis (dy, -dx, 0)
        cos_t = -dz
        if sin_t < 1e-12:
            flip = 1.0 if cos_t > 0 else -1.0  # looking straight up: turned by pi about x
            t00, t01, t02, t10, t11, t12, t20, t21, t22 = 1.0, 0.0, 0.0, 0.0, flip, 0.0, 0.0, 0.0, flip
        else:
            ax, ay = dy / sin_t, -dx / sin_t
            one = 1.0 - cos_t  # Rodrigues: I + sin K + (1 - cos) K^2, K the cross product with (ax, ay, 0)
            t00, t01, t02 = 1.0 - one * ay * ay, one * ax * ay, sin_t * ay
            t10, t11, t12 = one * ax * ay, 1.0 - one * ax * ax, -sin_t * ax
            t20, t21, t22 = -sin_t * ay, sin_t * ax, 1.0 - one
    # times rotation_z(roll)
    out[0], out[1], out[2] = t00 * cr + t01 * sr, t01 * cr - t00 * sr, t02
    out[3], out[4], out[5] = t10 * cr + t11 * sr, t11 * cr - t10 * sr, t12
    out[6], out[7], out[8] = t20 * cr + t21 * sr, t21 * cr - t20 * sr, t22


@njit(cache=True, nogil=True)
def task_focus(position, xmat, com, out):  # pragma: no cover - compiled
    """The point a camera at ``position`` (rotation ``xmat``, row-major: its view axis -(xmat[2], xmat[5],
    xmat[8])) looks at: on its view ray, at its distance to ``com`` (the agent's centre of mass), into ``out[3]``."""
    ex, ey, ez = position[0] - com[0], position[1] - com[1], position[2] - com[2]
    distance = math.sqrt(ex * ex + ey * ey + ez * ez)
    for a in range(3):
        out[a] = position[a] - distance * xmat[2 + 3 * a]


@njit(cache=True, nogil=True)
def place(rows, offset, camera, pose, turn, mode, body, upright, blind, fixed_focus, cam_xpos, cam_xmat,
          subtree_com, xpos, out_xpos, out_xmat):  # pragma: no cover - compiled
    """Writes the camera of each world ``rows[j]`` at its pose: ``out_xpos[rows[j] - offset, camera[i]]``
    and ``out_xmat[...]`` (any float dtype). The pose is about the world's origin (fixed cameras) or
    its tracked body (``xpos``) or centre of mass (``subtree_com``), in the frame turned about z by
    ``turn[i] = (cos, sin)``; the camera looks at ``fixed_focus[i]`` (fixed cameras; NaN: none) or at
    the task camera's own focus (on its view ray, at its distance to the agent, read from ``cam_xpos``
    / ``cam_xmat`` / ``subtree_com`` of the new state), the other way when ``blind``."""
    target = np.empty(3)
    position = np.empty(3)
    xmat = np.empty(9)
    for j in range(rows.shape[0]):
        i = rows[j]
        cid, b = camera[i], body[i]
        radius, azimuth, elevation = pose[i, 0], pose[i, 1], pose[i, 2]
        s = math.sin(elevation)
        x, y, z = radius * s * math.cos(azimuth), radius * s * math.sin(azimuth), radius * math.cos(elevation)
        c, sn = turn[i, 0], turn[i, 1]
        ox = oy = oz = 0.0
        if mode[i] == TRACKCOM:
            ox, oy, oz = subtree_com[i, b, 0], subtree_com[i, b, 1], subtree_com[i, b, 2]
        elif mode[i] == TRACK:
            ox, oy, oz = xpos[i, b, 0], xpos[i, b, 1], xpos[i, b, 2]
        position[0], position[1], position[2] = ox + c * x - sn * y, oy + sn * x + c * y, oz + z
        if not math.isnan(fixed_focus[i, 0]):
            target[0], target[1], target[2] = fixed_focus[i, 0], fixed_focus[i, 1], fixed_focus[i, 2]
        else:
            task_focus(cam_xpos[i, cid], cam_xmat[i, cid], subtree_com[i, 1], target)
        if blind[i]:  # look the other way
            for a in range(3):
                target[a] = 2.0 * position[a] - target[a]
        look_at(target, position, pose[i, 3], upright[i], xmat)
        r = i - offset
        for a in range(3):
            out_xpos[r, cid, a] = position[a]
        for a in range(9):
            out_xmat[r, cid, a] = xmat[a]


@njit(cache=True, nogil=True)
def _remainder(angle):  # pragma: no cover - compiled
    """``angle`` wrapped into [-pi, pi] (IEEE remainder by 2 pi)."""
    turns = angle / (2 * math.pi)
    return angle - 2 * math.pi * np.rint(turns)


@njit(cache=True, nogil=True)
def state(pose, azimuth_offset, out):  # pragma: no cover - compiled
    """The exposed state of every world, ``out[N, 4]`` (float32): azimuth in the world frame, in
    [-pi, pi], elevation, radius, roll."""
    for i in range(pose.shape[0]):
        out[i, 0] = _remainder(pose[i, 1] + azimuth_offset[i])
        out[i, 1], out[i, 2], out[i, 3] = pose[i, 2], pose[i, 0], pose[i, 3]
