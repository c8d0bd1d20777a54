"""Which parts of the skybox cube a camera can see, so that only those need uploading.

MuJoCo's classic renderer draws the skybox as a cylinder centred on the camera, its
cube-map coordinates generated from the cylinder's object coordinates as
``(s, t, r) = (x, z, -y)`` (``settexture`` in ``render_gl3.c``). A view ray of world
direction ``d`` therefore samples the cube face of the largest of ``|d_x|, |d_z|,
|d_y|`` (OpenGL's major-axis rule); in OpenGL's face order +X, -X, +Y, -Y, +Z, -Z
that is the world direction +x, -x, +z (overhead), -z, -y, +y (checked by rendering
six coloured faces, ``tests/test_skybox.py``). Filtering near a face edge also reads
the neighbouring face (Mesa enables seamless cube maps), within a texel: the frustum
is widened by a margin that covers it.

Everything but :func:`camera_regions` is plain Python, testable without MuJoCo.
"""
from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np

# world axis and sign of GL cube faces +X, -X, +Y, -Y, +Z, -Z under MuJoCo's skybox mapping
FACE_DIRECTIONS = ((0, 1), (0, -1), (2, 1), (2, -1), (1, -1), (1, 1))
_FACE_OF = {(axis, sign > 0): face for face, (axis, sign) in enumerate(FACE_DIRECTIONS)}
# per face, the world components (and signs) giving its texture coordinates s and t: OpenGL's
# table of cube-map face selection (sc, tc over |ma|) with (rx, ry, rz) = (x, z, -y)
_FACE_ST = ((1, 1, 2, -1), (1, -1, 2, -1), (0, 1, 1, -1), (0, 1, 1, 1), (0, 1, 2, -1), (0, -1, 2, -1))
FULL = (0.0, 0.0, 1.0, 1.0)
_DIAGONALS = tuple((a, b, sign) for a, b in ((0, 1), (0, 2), (1, 2)) for sign in (1, -1))
_CUBE_CORNERS = tuple(itertools.product((1.0, -1.0), repeat=3))
_MAX_HALF_ANGLE = math.radians(89.0)  # a wider frustum is taken to see all of every face


def skybox_texture(model) -> int | None:
    """The model's skybox texture (the first of type ``mjTEXTURE_SKYBOX``; not always texture 0), or ``None``."""
    skyboxes = np.flatnonzero(np.asarray(model.tex_type) == mujoco.mjtTexture.mjTEXTURE_SKYBOX)
    return int(skyboxes[0]) if len(skyboxes) else None


def cube_faces(texels: np.ndarray, width: int, height: int, channels: int) -> np.ndarray:
    """A cube texture's bytes (``width x height``, faces stacked as MuJoCo stores them: six, or one shown on
    all six) as ``[height // width, width, width, channels]``."""
    return np.asarray(texels[: width * height * channels]).reshape(height // width, width, width, channels)


def face_margin(coarsest_side: int) -> float:
    """Angle (radians) to widen a frustum by so that it covers every texel filtering may read.

    Linear filtering reads texels up to one texel of the coarsest mip level away from a
    sampled direction (across a face edge too: Mesa enables seamless cube maps), at most
    ``2 / coarsest_side`` radians (such a texel at a face's centre); the margin is that plus
    one degree. With neither margin nor padding, renders differed by up to 2 grey levels.
    """
    return math.radians(1.0) + 2.0 / max(1, int(coarsest_side))


def visible_regions(rotation, bounds, margin: float = 0.0) -> dict[int, tuple]:
    """The skybox faces a perspective frustum sees, each with the part of it that is seen.

    Args:
        rotation: the camera's 3x3 world rotation, columns right, up and backward (MuJoCo's
            ``data.cam_xmat``: the camera looks along its -z axis).
        bounds: ``(left, right, bottom, top)`` of the image on the plane one unit in front
            of the camera (tangents of the half-angles; ``left`` and ``bottom`` negative
            for a centred frustum).
        margin: angle in radians to widen every side of the frustum by.

    Returns:
        ``{face: (s0, t0, s1, t1)}`` for every face (GL order) that a direction of the
        widened frustum falls on: the bounding box, in that face's texture coordinates
        (``s`` along a row, ``t`` down the rows, both in [0, 1], OpenGL's cube-map
        convention), of the directions falling on it.

    The directions of the frustum that fall on a face form a convex cone (the frustum's
    and the face's square pyramid intersected), whose edges are of three kinds: the
    frustum's corner rays inside the face, the points where the frustum's sides cross the
    face's boundary, and the cube's corner directions inside the frustum. Projected onto
    the face (a central projection keeps straight lines straight) they are the corners of
    a convex polygon, so their bounding box is the region's. Exact, in plain Python (the
    per-step cost matters more than vectorising).

    Examples:
        >>> import numpy as np
        >>> looking_along_y = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # cheetah's side camera
        >>> regions = visible_regions(looking_along_y, (-0.5, 0.5, -0.5, 0.5))
        >>> {face: [round(v, 3) for v in box] for face, box in regions.items()}
        {5: [0.25, 0.25, 0.75, 0.75]}
    """
    angles = (-math.atan(bounds[0]), math.atan(bounds[1]), -math.atan(bounds[2]), math.atan(bounds[3]))
    if max(angles) + margin >= _MAX_HALF_ANGLE:
        return dict.fromkeys(range(6), FULL)
    left, right, bottom, top = (
        -math.tan(angles[0] + margin), math.tan(angles[1] + margin),
        -math.tan(angles[2] + margin), math.tan(angles[3] + margin),
    )
    (r0, u0, b0), (r1, u1, b1), (r2, u2, b2) = np.asarray(rotation, dtype=float).reshape(3, 3).tolist()
    corners = [
        (r0 * x + u0 * y - b0, r1 * x + u1 * y - b1, r2 * x + u2 * y - b2)  # forward + x right + y up
        for x, y in ((left, bottom), (right, bottom), (right, top), (left, top))
    ]
    points: dict[int, list] = {}
    for d in corners:
        points.setdefault(_face(d), []).append(d)
    if len(points) > 1:  # the frustum crosses face boundaries (else one face holds it all)
        for p, q in zip(corners, corners[1:] + corners[:1]):
            for a, b, sign in _DIAGONALS:  # the plane d_a = sign * d_b between two faces
                fp, fq = p[a] - sign * p[b], q[a] - sign * q[b]
                if fp * fq > 0 or fp == fq:
                    continue
                w = fp / (fp - fq)
                r = (p[0] + w * (q[0] - p[0]), p[1] + w * (q[1] - p[1]), p[2] + w * (q[2] - p[2]))
                if abs(r[a]) >= abs(r[3 - a - b]):  # on the edge between faces (a, .) and (b, .)
                    points.setdefault(_FACE_OF[a, r[a] > 0], []).append(r)
                    points.setdefault(_FACE_OF[b, r[b] > 0], []).append(r)
        for k in _CUBE_CORNERS:
            ahead = -(b0 * k[0] + b1 * k[1] + b2 * k[2])
            x, y = r0 * k[0] + r1 * k[1] + r2 * k[2], u0 * k[0] + u1 * k[1] + u2 * k[2]
            if ahead > 0 and left * ahead <= x <= right * ahead and bottom * ahead <= y <= top * ahead:
                for axis in range(3):
                    points.setdefault(_FACE_OF[axis, k[axis] > 0], []).append(k)
    return {face: _box(face, directions) for face, directions in points.items()}


def _face(d) -> int:
    """The face (GL order) a direction falls on: its largest component, by OpenGL's rule."""
    axis = 0
    if abs(d[1]) > abs(d[axis]):
        axis = 1
    if abs(d[2]) > abs(d[axis]):
        axis = 2
    return _FACE_OF[axis, d[axis] > 0]


def _box(face: int, directions) -> tuple[float, float, float, float]:
    """Bounding box, in ``face``'s texture coordinates, of directions that fall on it."""
    axis = FACE_DIRECTIONS[face][0]
    s_axis, s_sign, t_axis, t_sign = _FACE_ST[face]
    s_values, t_values = [], []
    for d in directions:
        scale = 0.5 / abs(d[axis])
        s_values.append(0.5 + s_sign * d[s_axis] * scale)
        t_values.append(0.5 + t_sign * d[t_axis] * scale)
    return (max(0.0, min(s_values)), max(0.0, min(t_values)),
            min(1.0, max(s_values)), min(1.0, max(t_values)))


def camera_regions(physics, camera_id: int, aspect: float, margin: float) -> dict[int, tuple]:
    """:func:`visible_regions` of the view MuJoCo renders from ``camera_id`` at ``aspect`` (width/height).

    The pose and frustum are those :func:`mujoco.mjv_updateCamera` gives the renderer
    (``data.cam_xmat`` of the fixed camera, its ``fovy`` or intrinsics, the image aspect
    ratio for the width); dm_control renders in mono, from the camera's own position, which
    is the skybox's centre. The free camera (-1) and orthographic cameras get all of every face.
    """
    model = physics.model
    projection = getattr(model, "cam_projection", getattr(model, "cam_orthographic", None))
    if camera_id < 0 or (projection is not None and projection[camera_id] != 0):  # free or orthographic
        return dict.fromkeys(range(6), FULL)
    if model.cam_sensorsize[camera_id][1] == 0:  # no intrinsics: the vertical field of view
        top = math.tan(math.radians(float(model.cam_fovy[camera_id])) / 2)
        bottom, zhor = -top, (0.0, 0.0)
    else:
        camera = mujoco.MjvCamera()
        camera.type, camera.fixedcamid = mujoco.mjtCamera.mjCAMERA_FIXED, camera_id
        zver, zhor, zclip = np.zeros(2, np.float32), np.zeros(2, np.float32), np.zeros(2, np.float32)
        mujoco.mjv_cameraFrustum(zver, zhor, zclip, model.ptr, camera)
        near = float(zclip[0])
        bottom, top = -float(zver[0]) / near, float(zver[1]) / near
        zhor = (float(zhor[0]) / near, float(zhor[1]) / near)
    if zhor[0] == 0 and zhor[1] == 0:  # width from the viewport, as mjr_render's setView does
        half = 0.5 * aspect * (top - bottom)
        left, right = -half, half
    else:
        left, right = -zhor[0], zhor[1]
    return visible_regions(physics.data.cam_xmat[camera_id], (left, right, bottom, top), margin)
