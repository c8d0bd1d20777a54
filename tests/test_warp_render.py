"""dcs_torchrl.render.warp: what its users see of Warp (the frames: tests/test_batched.py)."""
import os
import subprocess
import sys

import pytest
import torch

pytest.importorskip("mujoco_warp")

RENDER_ON_THE_CPU = """
import dcs_torchrl as dcs
env = dcs.make_env("cartpole", "swingup", num_envs=1, backend="warp", height=8, width=8, seed=0)
env.rollout(1)
print("rendered")
"""


def test_the_cpu_is_rendered_on_without_a_cuda_driver_warning():
    """Warp probes for an NVIDIA driver at its start whatever the device; where there is none, asking
    for the CPU prints nothing about it (on a machine with a driver this holds trivially)."""
    done = subprocess.run([sys.executable, "-c", RENDER_ON_THE_CPU], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert done.returncode == 0 and "rendered" in done.stdout, done.stderr
    assert "CUDA driver" not in done.stderr and "Warp CUDA warning" not in done.stderr, done.stderr


@pytest.fixture
def warp_cpu():
    """Warp's CPU device, and the process's default device put back after the test."""
    from dcs_torchrl.render.warp import import_warp

    wp, _ = import_warp("cpu")
    cpu = wp.get_device("cpu")
    before = cpu.runtime.default_device
    yield cpu
    cpu.runtime.default_device = before


def test_the_default_device_stays_while_any_render_runs_and_comes_back_after_the_last(warp_cpu):
    """Two render threads leave in the order they did not enter (wp.ScopedDevice would put the former
    default back under the one still rendering, and MuJoCo Warp launch there)."""
    from dcs_torchrl.render.warp import _DefaultDevice

    runtime, former = warp_cpu.runtime, object()
    runtime.default_device = former
    scopes = _DefaultDevice()
    first, second = scopes.scope(warp_cpu), scopes.scope(warp_cpu)
    first.__enter__()
    second.__enter__()
    assert runtime.default_device is warp_cpu
    first.__exit__(None, None, None)
    assert runtime.default_device is warp_cpu  # the second still renders
    second.__exit__(None, None, None)
    assert runtime.default_device is former


def test_a_block_for_another_device_waits_for_the_renders_on_the_first(warp_cpu):
    import threading
    import types

    from dcs_torchrl.render.warp import _DefaultDevice

    other = types.SimpleNamespace(runtime=warp_cpu.runtime, is_cuda=False)  # a second device, as a GPU box has
    scopes, entered, seen = _DefaultDevice(), threading.Event(), []

    def render_on_other():
        with scopes.scope(other):
            seen.append(warp_cpu.runtime.default_device)
            entered.set()

    with scopes.scope(warp_cpu):
        thread = threading.Thread(target=render_on_other)
        thread.start()
        assert not entered.wait(0.5) and warp_cpu.runtime.default_device is warp_cpu
    assert entered.wait(10)
    thread.join(10)
    assert seen == [other]


def test_renders_set_the_default_device_through_the_counted_scope_only(monkeypatch, warp_cpu):
    import warp

    import dcs_torchrl as dcs
    from dcs_torchrl.render import warp as warp_render

    def unshared(*args, **kwargs):
        raise AssertionError("wp.ScopedDevice in a render: threads rendering at once restore it under each other")

    entered = []
    scope = warp_render.DEFAULT_DEVICE.scope
    monkeypatch.setattr(warp, "ScopedDevice", unshared)
    monkeypatch.setattr(warp_render.DEFAULT_DEVICE, "scope", lambda device: entered.append(device.alias) or scope(device))
    env = dcs.make_env("cartpole", "swingup", num_envs=4, backend="warp", height=8, width=8, seed=0)
    parts = len(env.base_env.renderers) if hasattr(env, "base_env") else len(env.renderers)
    env.rollout(2)
    env.close()
    assert parts > 1 and entered.count("cpu") == parts + 3 * parts  # each part's set-up, its render at the reset and 2 steps


# ---------------------------------------------------------------- per-world lighting and textures

SIDE = 32  # pixels a side: the properties hold pixel by pixel, small images suffice


def _physics(domain: str, task: str):
    """A suite task's physics a few steps into an episode (the agent off its start pose)."""
    import numpy as np
    from dm_control import suite

    env = suite.load(domain, task, task_kwargs={"random": 0})
    env.reset()
    for _ in range(20):
        env.step(np.full(env.action_spec().shape, 0.7))
    return env.physics


def _renderer(physics, n: int, device="cpu"):
    """A renderer of ``n`` worlds of the physics' model, camera 0, and its state with every world at the
    physics' pose, the model's colours and sky."""
    from dcs_torchrl.render.warp import WarpRenderer, skybox_faces

    renderer = WarpRenderer(physics.model, n, SIDE, SIDE, 0, device)
    state = renderer.state(skybox_faces(physics.model)[None])
    _pose(state, physics)
    return renderer, state


def _pose(state, physics) -> None:
    """Every world of ``state`` at the physics' pose, with the model's colours."""
    d = physics.data
    for field in ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir"):
        getattr(state, field)[:] = getattr(d, field)
    state.mat_rgba[:] = physics.model.mat_rgba


def _foreign(state, model):
    """A WorldState that is not the renderer's own (so read by copying, as on CUDA), holding ``state``'s values."""
    import numpy as np

    from dcs_torchrl.render.warp import WorldState

    copy = WorldState.empty(model, len(state.geom_xpos), state.sky)
    for field in ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir", "mat_rgba",
                  "sky_index", "light_ambient", "light_gain", "mat_texid"):
        np.copyto(getattr(copy, field), getattr(state, field))
    return copy


def _render(renderer, state):
    """``(pixels, geom)``: the frames (int64 numpy ``[n, h, w, 3]``) and the geom each pixel shows (-1: the sky)."""
    import warp as wp
    from mujoco_warp import get_segmentation

    from dcs_torchrl.render.warp import DEFAULT_DEVICE

    pixels = renderer.render(state)[0].cpu().numpy().astype("int64")
    with DEFAULT_DEVICE.scope(wp.get_device(renderer.device)):
        seg = wp.zeros((renderer.n, renderer.height, renderer.width), dtype=wp.vec2i)
        get_segmentation(renderer.context, 0, seg)
        geom = seg.numpy()[..., 0]
    return pixels, geom


def _both_paths(renderer, state, model):
    """The render of ``state`` copied in (the CUDA path) while the renderer's own arrays hold the
    defaults, and read in place, checked equal."""
    import numpy as np

    from dcs_torchrl.render.warp import WorldState

    copy, fields = _foreign(state, model), ("light_ambient", "light_gain", "mat_texid")
    defaults = WorldState.empty(model, renderer.n, state.sky)
    for field in fields:  # the model's values, where a render that did not copy would read them
        np.copyto(getattr(state, field), getattr(defaults, field))
    copied = _render(renderer, copy)
    for field in fields:
        np.copyto(getattr(state, field), getattr(copy, field))
    own = _render(renderer, state)
    assert np.array_equal(own[0], copied[0]) and np.array_equal(own[1], copied[1])
    return own


TASKS = [("cartpole", "swingup"), ("finger", "spin")]


@pytest.mark.parametrize("domain,task", TASKS)
def test_the_default_lighting_and_textures_are_the_models_and_render_as_the_models_written_out(domain, task):
    import numpy as np

    from dcs_torchrl.render.warp import WorldState

    physics = _physics(domain, task)
    model = physics.model
    renderer, state = _renderer(physics, 3)
    for defaults in (state, WorldState.empty(model, 3, state.sky)):
        assert defaults.light_ambient.dtype == np.float32 and defaults.light_gain.dtype == np.float32
        assert defaults.mat_texid.dtype == np.int32
        assert np.array_equal(defaults.light_ambient, np.broadcast_to(model.light_ambient, (3, model.nlight, 3)))
        assert np.array_equal(defaults.light_gain, np.ones((3, 3)))
        assert np.array_equal(defaults.mat_texid, np.broadcast_to(model.mat_texid[:, 1], (3, model.nmat)))
    pixels, geom = _render(renderer, state)
    assert (geom >= 0).any() and (geom < 0).any()  # surfaces and sky both seen
    assert np.array_equal(pixels[1:], np.broadcast_to(pixels[0], pixels[1:].shape))
    written = _foreign(state, model)
    written.light_gain[:] = 1.0
    written.light_ambient[:] = model.light_ambient
    written.mat_texid[:] = model.mat_texid[:, 1]
    again, geom_again = _render(renderer, written)
    assert np.array_equal(pixels, again) and np.array_equal(geom, geom_again)
    # the other texture roles stay the model's in every world
    warp_texid = renderer.model.mat_texid.numpy()
    assert np.array_equal(warp_texid, np.broadcast_to(model.mat_texid, warp_texid.shape))
    # a state made again is back at the defaults
    state.light_gain[:], state.light_ambient[:], state.mat_texid[:] = 0.5, 0.5, -1
    fresh = renderer.state(state.sky)
    _pose(fresh, physics)
    assert np.array_equal(_render(renderer, fresh)[0], pixels)


@pytest.mark.parametrize("domain,task", TASKS)
def test_a_worlds_light_gain_scales_its_lit_surfaces_only(domain, task):
    import numpy as np

    physics = _physics(domain, task)
    renderer, state = _renderer(physics, 3)
    state.mat_rgba[..., 3] = 1.0  # every surface opaque: its pixel is its lit colour alone
    before, geom = _render(renderer, state)
    state.light_gain[1] = 0.5
    state.light_gain[2] = (1.0, 0.25, 2.0)
    after, geom_after = _both_paths(renderer, state, physics.model)
    assert np.array_equal(geom, geom_after)
    assert np.array_equal(after[0], before[0])
    for world, gain in ((1, np.array([0.5] * 3)), (2, np.array([1.0, 0.25, 2.0]))):
        surface, sky = geom[world] >= 0, geom[world] < 0
        assert surface.any() and sky.any()
        assert np.array_equal(after[world][sky], before[world][sky])
        expected = np.clip(before[world][surface] * gain, 0, 255)  # rounded half up: within half a level
        assert np.abs(after[world][surface] - expected).max() <= 0.5


def test_a_light_gain_is_every_lights_colour_scaled_up_to_the_clamping_to_white():
    """The gain equals a model whose lights (the headlight too: MuJoCo Warp bakes it in its kernel)
    are that much dimmer, within a grey level (the trace truncates its colours to bytes), wherever
    the undimmed colour is not clamped at 255."""
    import copy

    import numpy as np

    from dcs_torchrl.render.warp import WarpRenderer

    physics = _physics("finger", "spin")
    gain = 0.5
    renderer, state = _renderer(physics, 1)
    state.mat_rgba[..., 3] = 1.0
    lit, geom = _render(renderer, state)
    state.light_gain[:] = gain
    scaled, _ = _render(renderer, state)
    dim = copy.copy(physics.model.ptr)
    for field in ("light_ambient", "light_diffuse", "light_specular"):
        getattr(dim, field)[:] *= gain
    for field in ("ambient", "diffuse", "specular"):
        getattr(dim.vis.headlight, field)[:] *= gain
    dimmer = WarpRenderer(dim, 1, SIDE, SIDE, 0, "cpu")  # the same state, rendered from the dimmer model
    dim_state = dimmer.state(state.sky)
    _pose(dim_state, physics)
    dim_state.mat_rgba[..., 3] = 1.0
    dimmed, _ = _render(dimmer, dim_state)
    unclamped = (geom >= 0) & np.all(lit < 255, axis=-1)
    assert unclamped.sum() > 0.2 * geom.size
    assert np.abs(scaled[unclamped] - dimmed[unclamped]).max() <= 1


@pytest.mark.parametrize("domain,task", TASKS)
def test_a_worlds_raised_ambient_brightens_that_world_only(domain, task):
    import numpy as np

    physics = _physics(domain, task)
    renderer, state = _renderer(physics, 3)
    before, geom = _render(renderer, state)
    state.light_ambient[1] += 0.3
    after, _ = _both_paths(renderer, state, physics.model)
    assert np.array_equal(after[[0, 2]], before[[0, 2]])
    surface = geom[1] >= 0
    assert np.array_equal(after[1][~surface], before[1][~surface])
    assert (after[1] >= before[1]).all()
    white = np.all(before[1] == 255, axis=-1)
    assert (after[1].sum(-1) > before[1].sum(-1))[surface & ~white].all()


def _texture(model, name: str):
    """The material ``name``'s RGB texture: its id and pixels (uint8 ``[h, w, 3]``)."""
    import mujoco

    material = mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_MATERIAL, name)
    tex = int(model.mat_texid[material, 1])
    h, w, c = int(model.tex_height[tex]), int(model.tex_width[tex]), int(model.tex_nchannel[tex])
    adr = int(model.tex_adr[tex])
    return material, tex, model.tex_data[adr: adr + h * w * c].reshape(h, w, c)[..., :3].copy()


@pytest.mark.parametrize("domain,task", TASKS)
def test_added_textures_are_shown_where_a_worlds_material_points_at_them(domain, task):
    """The floor (the suite's "grid" material) of world 1 shows an added copy of the grid texture: the
    frame is world 0's; world 2's an added red one and world 3's a green one: their floors turn that
    colour and nothing else of theirs changes."""
    import numpy as np

    physics = _physics(domain, task)
    model = physics.model
    renderer, state = _renderer(physics, 4)
    before, geom = _render(renderer, state)
    grid, tex, image = _texture(model, "grid")
    red = np.zeros_like(image)
    red[..., 0] = 255
    green = np.zeros((8, 8, 3), np.uint8)
    green[..., 1] = 255
    first = renderer.add_textures(np.stack([image, red]))
    assert first == model.ntex  # after the model's own, whose ids stay
    assert renderer.add_textures(torch.from_numpy(green)[None]) == first + 2
    state.mat_texid[1, grid], state.mat_texid[2, grid], state.mat_texid[3, grid] = first, first + 1, first + 2
    after, _ = _both_paths(renderer, state, model)
    assert np.array_equal(after[[0, 1]], before[[0, 0]])
    floor = np.isin(geom, np.flatnonzero(np.asarray(model.geom_matid) == grid))
    for world, channel in ((2, 0), (3, 1)):
        assert floor[world].sum() > 0.1 * floor[world].size
        shown = after[world][floor[world]]
        others = np.delete(shown, channel, axis=-1)
        assert (shown[:, channel] > others.max(-1)).all()
        assert np.array_equal(after[world][~floor[world]], before[world][~floor[world]])
    state.mat_texid[:, grid] = tex  # back to the model's texture: the frames of before
    assert np.array_equal(_render(renderer, state)[0], before)


def test_bad_textures_and_texture_ids_are_refused_with_the_fix():
    import numpy as np

    physics = _physics("cartpole", "swingup")
    renderer, state = _renderer(physics, 2)
    with pytest.raises(TypeError, match="uint8"):
        renderer.add_textures(np.zeros((1, 4, 4, 3), np.float32))
    with pytest.raises(ValueError, match=r"\[K, height, width, 3\]"):
        renderer.add_textures(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match=r"\[K, height, width, 3\]"):
        renderer.add_textures(np.zeros((1, 4, 4, 4), np.uint8))
    with pytest.raises(ValueError, match="at least one image"):
        renderer.add_textures(np.zeros((0, 4, 4, 3), np.uint8))
    ntex = physics.model.ntex
    for bad in (ntex, -2):
        state.mat_texid[1, 0] = bad
        with pytest.raises(ValueError, match="add_textures"):
            renderer.render(state)
    state.mat_texid[1, 0] = renderer.add_textures(np.zeros((1, 4, 4, 3), np.uint8))  # now it is one
    renderer.render(state)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_renders_the_lighting_and_textures_as_the_cpu_within_a_grey_level():
    import numpy as np

    physics = _physics("finger", "spin")
    frames = []
    for device in ("cpu", "cuda"):
        renderer, state = _renderer(physics, 3, device)
        grid, _, image = _texture(physics.model, "grid")
        red = np.zeros_like(image)
        red[..., 0] = 255
        first = renderer.add_textures(red[None])
        state.light_gain[1] = (0.5, 0.7, 0.9)
        state.light_ambient[2] += 0.3
        state.mat_texid[0, grid] = first
        frames.append(_render(renderer, state)[0])
    assert np.abs(frames[0] - frames[1]).max() <= 1
