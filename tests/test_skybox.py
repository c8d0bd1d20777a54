"""Which parts of the skybox a camera sees: the geometry alone, then against MuJoCo's own render."""
import math

import mujoco
import numpy as np
import pytest
from dm_control import suite
from dm_control.mujoco import engine
from scipy.spatial.transform import Rotation

from dcs_torchrl.render.gl import render_context
from dcs_torchrl.render.skybox import FULL, camera_regions, face_margin, visible_regions

# GL face order +X, -X, +Y, -Y, +Z, -Z shows these world directions under MuJoCo's skybox mapping
FACE_WORLD_DIRECTION = [(1, 0, 0), (-1, 0, 0), (0, 0, 1), (0, 0, -1), (0, -1, 0), (0, 1, 0)]


def looking(forward, up):
    """A camera rotation (columns right, up, backward, like ``data.cam_xmat``) looking along ``forward``."""
    forward, up = np.asarray(forward, float), np.asarray(up, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    return np.stack([right, np.cross(right, forward), -forward], axis=1)


def gl_face_coords(directions):
    """Face and (s, t) of world directions [n, 3], straight from OpenGL's table of cube-map face
    selection (sc, tc, ma per major axis) with MuJoCo's skybox coordinates (rx, ry, rz) = (x, z, -y)."""
    d = np.asarray(directions, float)
    rx, ry, rz = d[:, 0], d[:, 2], -d[:, 1]
    table = [  # (major value, face, sc, tc)
        (rx, 0, -rz, -ry), (-rx, 1, rz, -ry), (ry, 2, rx, rz), (-ry, 3, rx, -rz), (rz, 4, rx, -ry), (-rz, 5, -rx, -ry),
    ]
    major = np.abs(np.stack([rx, ry, rz])).argmax(axis=0)
    faces, s, t = np.empty(len(d), int), np.empty(len(d)), np.empty(len(d))
    for axis in range(3):
        for ma, face, sc, tc in table[2 * axis : 2 * axis + 2]:
            pick = (major == axis) & (ma > 0)
            faces[pick], s[pick], t[pick] = face, 0.5 * (sc[pick] / ma[pick] + 1), 0.5 * (tc[pick] / ma[pick] + 1)
    return faces, s, t


def sampled(rotation, bounds, n=41):
    """``{face: (s, t) arrays}`` of a grid of directions over the image (brute force)."""
    xs, ys = np.meshgrid(np.linspace(bounds[0], bounds[1], n), np.linspace(bounds[2], bounds[3], n))
    directions = np.stack([xs.ravel(), ys.ravel(), -np.ones(xs.size)], axis=1) @ np.asarray(rotation).T
    faces, s, t = gl_face_coords(directions)
    return {int(face): (s[faces == face], t[faces == face]) for face in np.unique(faces)}


@pytest.mark.parametrize("face", range(6))
def test_a_narrow_view_along_a_face_axis_sees_the_middle_of_that_face(face):
    forward = np.array(FACE_WORLD_DIRECTION[face], float)
    up = (0, 1, 0) if forward[2] else (0, 0, 1)
    t = math.tan(math.radians(20))
    regions = visible_regions(looking(forward, up), (-t, t, -t, t))
    assert list(regions) == [face]
    s0, t0, s1, t1 = regions[face]
    assert (s0 + s1) / 2 == pytest.approx(0.5) and (t0 + t1) / 2 == pytest.approx(0.5)
    assert s1 - s0 == pytest.approx(t) and t1 - t0 == pytest.approx(t)


def test_regions_hold_every_direction_of_the_view():
    rng = np.random.default_rng(0)
    for _ in range(500):
        rotation = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        half = rng.uniform(0.05, 1.4, 4)
        bounds = (-math.tan(half[0]), math.tan(half[1]), -math.tan(half[2]), math.tan(half[3]))
        regions = visible_regions(rotation, bounds)
        for face, (s, t) in sampled(rotation, bounds).items():
            assert face in regions
            s0, t0, s1, t1 = regions[face]
            assert s0 - 1e-9 <= s.min() and s.max() <= s1 + 1e-9 and t0 - 1e-9 <= t.min() and t.max() <= t1 + 1e-9


def test_regions_are_tight():
    rng = np.random.default_rng(1)
    for _ in range(20):
        rotation = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        t = math.tan(rng.uniform(0.2, 0.9))
        regions = visible_regions(rotation, (-t, t, -t, t))
        samples = sampled(rotation, (-t, t, -t, t), n=601)
        assert set(regions) >= set(samples)
        for face, (s, tt) in samples.items():
            assert regions[face] == pytest.approx((s.min(), tt.min(), s.max(), tt.max()), abs=0.01)
        for face in set(regions) - set(samples):  # a sliver the grid missed
            s0, t0, s1, t1 = regions[face]
            assert min(s1 - s0, t1 - t0) < 0.01


def test_margin_widens_and_a_near_hemisphere_takes_everything():
    forward_y = looking((0, 1, 0), (0, 0, 1))
    t = math.tan(math.radians(22.5))
    assert list(visible_regions(forward_y, (-t, t, -t, t), math.radians(22))) == [5]
    assert sorted(visible_regions(forward_y, (-t, t, -t, t), math.radians(23))) == [0, 1, 2, 3, 5]
    assert visible_regions(forward_y, (-60.0, 60.0, -1.0, 1.0)) == dict.fromkeys(range(6), FULL)
    assert face_margin(128) > math.radians(1) + 1 / 128  # more than half a coarse texel beyond a degree


def render_centre(physics, camera, forward, up):
    """The centre pixel of a render of the sky alone, the camera looking along ``forward``."""
    physics.data.cam_xmat[0] = looking(forward, up).ravel()
    option = engine.wrapper.MjvOption()
    option.geomgroup[:] = 0  # no geoms: only the sky
    return camera.render(scene_option=option)[42, 42].astype(int)


def test_face_layout_is_mujocos():
    """Each face painted with its own colour and a gradient of its texture coordinates: the
    centre of a render looking in a direction shows the face and (s, t) the geometry predicts."""
    physics = suite.load("cheetah", "run").physics
    render_context(physics, "default", 84, 84)
    model, sky = physics.model, int(np.flatnonzero(physics.model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)[0])
    side = 64
    ramp = (np.arange(side) + 0.5) / side
    faces = np.zeros((6, side, side, 3), np.uint8)
    faces[..., 0] = np.round(255 * ramp)[None, None, :]  # red follows s (along a row)
    faces[..., 1] = np.round(255 * ramp)[None, :, None]  # green follows t (down the rows)
    faces[..., 2] = (40 * np.arange(6))[:, None, None]  # blue tells the face
    model.tex_width[sky], model.tex_height[sky] = side, 6 * side
    adr = int(model.tex_adr[sky])
    model.tex_data[adr : adr + faces.size] = faces.reshape(-1)
    with physics.contexts.gl.make_current() as ctx:
        ctx.call(mujoco.mjr_uploadTexture, model.ptr, physics.contexts.mujoco.ptr, sky)
    camera = engine.Camera(physics, 84, 84, 0)
    rng = np.random.default_rng(1)
    for face, axis in enumerate(FACE_WORLD_DIRECTION):
        for _ in range(4):
            forward = np.array(axis, float) + rng.uniform(-0.6, 0.6, 3) * (np.array(axis) == 0)
            up = (0.1, 1.0, 0.2) if axis[2] else (0.1, 0.2, 1.0)
            predicted = visible_regions(looking(forward, up), (0.0, 0.0, 0.0, 0.0))
            assert list(predicted) == [face]
            s, t, _, _ = predicted[face]
            red, green, blue = render_centre(physics, camera, forward, up)
            assert blue == pytest.approx(40 * face, abs=2)
            assert (red, green) == pytest.approx((255 * s, 255 * t), abs=6)


def test_camera_regions_follow_the_model_camera():
    physics = suite.load("cheetah", "run").physics  # the side camera looks along +y, fovy 45
    regions = camera_regions(physics, 0, 1.0, 0.0)
    assert list(regions) == [5]
    t = math.tan(math.radians(22.5)) / 2
    assert regions[5] == pytest.approx((0.5 - t, 0.5 - t, 0.5 + t, 0.5 + t), abs=1e-6)
    wide = camera_regions(physics, 0, 2.0, 0.0)[5]  # twice as wide an image: twice the width
    assert wide[2] - wide[0] == pytest.approx(4 * t, abs=1e-6) and wide[3] - wide[1] == pytest.approx(2 * t, abs=1e-6)
    assert camera_regions(physics, -1, 1.0, 0.0) == dict.fromkeys(range(6), FULL)  # the free camera: all
