"""WarpRenderer: one batched render of N worlds of one dm_control model through MuJoCo Warp's ray tracer.

The worlds' state reaches the renderer as whole arrays (:class:`WorldState`: geom, camera and
light poses, material colours, the sky of each world), wherever they come from: here, from N
dm_control physics stepped in this process (:mod:`dcs_torchrl.vector.batched`). One call ray-traces every
world's camera (MuJoCo Warp's ``render``: the scene BVH refitted, shading with the model's lights,
textures, optional shadows) with the sky left black, then one kernel of this module finishes each
pixel as MuJoCo's OpenGL renderer does for the suite's scenes:

* where a ray meets a surface, its lit colour times the world's ``light_gain`` (RGB);
* where a ray meets nothing, the world's sky (a cube map: six faces, or one face on all six as the
  background distraction writes it) sampled along the pixel's ray, bilinear;
* where it meets a surface whose colour is not opaque (the floor at the preset's ``ground_alpha``),
  the surface over the sky seen through it, blended as GL blends it: MuJoCo's GL draws a transparent
  geom twice (front to back, then back to front) over the skybox, so ``a = 1 - (1 - alpha)^2`` of the
  surface shows (a transparent surface in front of another body is not handled: none of the suite's
  scenes has one);
* with ``masks``, a label per pixel (:data:`MASK_LABELS`) from the same trace's segmentation.

What differs from GL (no reflections, no multisampling, no mipmaps) is measured in docs/batched.md,
"Fidelity: the same states through both renderers". MuJoCo Warp (``pip install "dcs-torchrl[warp]"``)
is imported on first use.
"""
# no "from __future__ import annotations": Warp reads its kernels' annotations as objects
import contextlib
import os
import re
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from types import MappingProxyType

import mujoco
import numpy as np
import torch

from dcs_torchrl.render.skybox import cube_faces, skybox_texture

from dcs_torchrl._compat.private_api import render_offsets

#: The labels of ``masks`` (uint8 per pixel).
MASK_LABELS: MappingProxyType[str, int] = MappingProxyType({"background": 0, "floor": 1, "agent": 2})

WARP_EXTRA_HINT = 'backend="warp" needs MuJoCo Warp: pip install "dcs-torchrl[warp]" (mujoco-warp and warp-lang).'


def import_warp(device: str | None = None):
    """``(warp, mujoco_warp)``, or an ImportError naming the extra to install; with ``device``
    (:func:`warp_device`'s name), Warp initialised for it."""
    try:
        import warp

        warp.config.log_level = max(warp.config.log_level, warp.LOG_WARNING)  # no banner, no line per module
        import mujoco_warp
    except ImportError as error:  # pragma: no cover - exercised where the extra is missing
        raise ImportError(WARP_EXTRA_HINT) from error
    if device == "cpu":
        _init_without_driver_warning(warp)
    elif device is not None:
        warp.init()
    return warp, mujoco_warp


#: What Warp's native library prints on stderr at its start where no NVIDIA driver is installed.
_NO_DRIVER = re.compile(rb"Warp CUDA warning: Could not find or load the NVIDIA CUDA driver\.[^\n]*\n?")


def _init_without_driver_warning(warp) -> None:
    """``warp.init()`` with the CUDA-driver warning left out: Warp probes for a driver whatever the
    device asked for (warp-lang 1.19 has no setting to skip it), and a machine without one is fine for
    the CPU. Anything else it prints on stderr is passed on."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 2)
        try:
            warp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        captured.seek(0)
        rest = _NO_DRIVER.sub(b"", captured.read())
    if rest:
        os.write(2, rest)


def warp_device(device) -> str:
    """Warp's name of a torch device: ``"cpu"`` or ``"cuda:<i>"``."""
    device = torch.device("cpu" if device is None else device)
    if device.type == "cpu":
        return "cpu"
    if device.type == "cuda":
        return f"cuda:{0 if device.index is None else device.index}"
    raise ValueError(f'backend="warp" renders on "cpu" or a CUDA device, got {device}.')


class _DefaultDevice:
    """Warp's default device for blocks that run in several threads at once.

    MuJoCo Warp launches its kernels on Warp's default device, of which a process has one (not one
    a thread), and ``wp.ScopedDevice`` restores on exit the device it found on entry: two threads
    rendering at once (a batch's render threads) then restore it under each other, and on a machine
    with a GPU a CPU renderer's kernel goes to CUDA with host arrays (an illegal memory access).
    Here the blocks of one device run together, counted; the device found before the first is
    restored when the last leaves; a block for another device waits until then."""

    def __init__(self):
        self._changed = threading.Condition()
        self._device, self._count, self._saved = None, 0, None

    @contextlib.contextmanager
    def scope(self, device):
        """A block in which ``device`` (a Warp device) is the default, and, for CUDA, its context current."""
        runtime = device.runtime
        with self._changed:
            while self._count and self._device is not device:
                self._changed.wait()
            if not self._count:
                self._device, self._saved = device, runtime.default_device
                runtime.default_device = device
            self._count += 1
        try:
            with device.context_guard if device.is_cuda else contextlib.nullcontext():  # a CUDA context per thread
                yield device
        finally:
            with self._changed:
                self._count -= 1
                if not self._count:
                    runtime.default_device, self._device = self._saved, None
                    self._changed.notify_all()


#: The one :class:`_DefaultDevice` of the process: every Warp block of this package goes through it.
DEFAULT_DEVICE = _DefaultDevice()


@dataclass
class WorldState:
    """What the renderer reads of N worlds, as whole arrays (numpy; float32, as Warp keeps them).

    ``sky`` is uint8 ``[rows, faces, side, side, 3]``, faces 6 (MuJoCo's cube order +X, -X, +Y,
    -Y, +Z, -Z) or 1 (one face on all six); world ``i`` shows row ``sky_index[i]``: a row of its
    own, one row every world shares, or a frame of a table of video frames. Whoever changes the
    rows' content raises ``sky_version`` (a CUDA renderer then uploads them again); the CPU renderer
    reads ``sky`` where it lies.

    Lighting and textures per world: ``light_ambient`` is each world's ``light_ambient`` (MuJoCo Warp
    adds ``colour * ambient`` of every active light to each surface, lit or not); ``light_gain``
    multiplies each world's lit surface colour (RGB; the sky is never multiplied), which is scaling
    every light's colour, the headlight's included, by it, up to the clamping of the lit colour to
    white; ``mat_texid`` is each material's RGB texture (MuJoCo's ``mat_texid[:, mjTEXROLE_RGB]``,
    -1 for none): a model texture's id or one :meth:`WarpRenderer.add_textures` returned.
    :meth:`empty` and :meth:`WarpRenderer.state` fill them with the model's values and a gain of 1.
    """

    geom_xpos: np.ndarray  # [n, ngeom, 3]
    geom_xmat: np.ndarray  # [n, ngeom, 9]
    cam_xpos: np.ndarray  # [n, ncam, 3]
    cam_xmat: np.ndarray  # [n, ncam, 9]
    light_xpos: np.ndarray  # [n, nlight, 3]
    light_xdir: np.ndarray  # [n, nlight, 3]
    mat_rgba: np.ndarray  # [n, nmat, 4]
    sky: np.ndarray  # [rows, faces, side, side, 3] uint8
    sky_index: np.ndarray  # [n] int32: the row of sky each world shows
    light_ambient: np.ndarray  # [n, nlight, 3]
    light_gain: np.ndarray  # [n, 3]: the lit surface colour's multiplier
    mat_texid: np.ndarray  # [n, nmat] int32: each material's RGB texture, -1 for none
    sky_version: int = 0

    @classmethod
    def empty(cls, model, n: int, sky: np.ndarray) -> "WorldState":
        """Zero poses and colours; the model's lights' ambient and materials' textures in every world, gain 1."""
        f32 = np.float32  # as Warp keeps them
        state = cls(
            geom_xpos=np.zeros((n, model.ngeom, 3), f32), geom_xmat=np.zeros((n, model.ngeom, 9), f32),
            cam_xpos=np.zeros((n, model.ncam, 3), f32), cam_xmat=np.zeros((n, model.ncam, 9), f32),
            light_xpos=np.zeros((n, model.nlight, 3), f32), light_xdir=np.zeros((n, model.nlight, 3), f32),
            mat_rgba=np.zeros((n, model.nmat, 4), np.float32), sky=sky, sky_index=_first_rows(n, sky),
            light_ambient=np.zeros((n, model.nlight, 3), f32), light_gain=np.zeros((n, 3), f32),
            mat_texid=np.zeros((n, model.nmat), np.int32),
        )
        _model_lighting(model, state)
        return state


def _model_lighting(model, state: WorldState) -> None:
    """``state``'s lighting and textures set to the model's in every world, with a gain of 1."""
    state.light_ambient[:] = np.asarray(model.light_ambient, np.float32).reshape(-1, 3)
    state.light_gain[:] = 1.0
    state.mat_texid[:] = np.asarray(model.mat_texid).reshape(-1, mujoco.mjtTextureRole.mjNTEXROLE)[:, _RGB]


#: The column of ``mat_texid`` MuJoCo Warp's render reads (the texture role ``mjTEXROLE_RGB``).
_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)


def _first_rows(n: int, sky: np.ndarray) -> np.ndarray:
    """World ``i``'s row before it is told one: its own, or the one row all share."""
    return np.arange(n, dtype=np.int32) % len(sky)


def skybox_faces(model) -> np.ndarray:
    """The model's skybox as uint8 ``[6 or 1, side, side, 3]`` (its texture data, faces stacked)."""
    sky = skybox_texture(model)
    if sky is None:
        return np.zeros((1, 1, 1, 3), np.uint8)
    adr = int(model.tex_adr[sky])
    data = cube_faces(model.tex_data[adr:], int(model.tex_width[sky]), int(model.tex_height[sky]),
                      int(model.tex_nchannel[sky]))
    return np.ascontiguousarray(data[..., :3])


_KERNELS: dict = {}


def _kernels(wp):
    """The compositing kernel (built once per process; Warp caches its compiled code on disk)."""
    if _KERNELS:
        return _KERNELS["finish"]

    @wp.func
    def sky_texel(sky: wp.array(dtype=wp.uint8, ndim=4), row: int, face: int, x: int, y: int, c: int) -> float:
        return float(sky[row, face * sky.shape[2] + y, x, c])

    @wp.func
    def sample_sky(sky: wp.array(dtype=wp.uint8, ndim=4), row: int, d: wp.vec3) -> wp.vec3:
        # MuJoCo's cube-map frame: s = x, t = z, r = -y (render_gl3.c); faces +X, -X, +Y, -Y, +Z, -Z
        rx = d[0]
        ry = d[2]
        rz = -d[1]
        ax = wp.abs(rx)
        ay = wp.abs(ry)
        az = wp.abs(rz)
        face = int(0)
        sc = float(0.0)
        tc = float(0.0)
        ma = float(1.0)
        if ax >= ay and ax >= az:
            ma = ax
            if rx > 0.0:
                face = 0
                sc = -rz
                tc = -ry
            else:
                face = 1
                sc = rz
                tc = -ry
        elif ay >= az:
            ma = ay
            if ry > 0.0:
                face = 2
                sc = rx
                tc = rz
            else:
                face = 3
                sc = rx
                tc = -rz
        else:
            ma = az
            if rz > 0.0:
                face = 4
                sc = rx
                tc = -ry
            else:
                face = 5
                sc = -rx
                tc = -ry
        side = sky.shape[2]
        if sky.shape[1] == side:  # one face on all six
            face = 0
        # texel centres at (i + 0.5) / side, clamped at the face's edges (GL_CLAMP_TO_EDGE)
        u = ((sc / ma + 1.0) * 0.5) * float(side) - 0.5
        v = ((tc / ma + 1.0) * 0.5) * float(side) - 0.5
        u = wp.clamp(u, 0.0, float(side - 1))
        v = wp.clamp(v, 0.0, float(side - 1))
        x0 = int(wp.floor(u))
        y0 = int(wp.floor(v))
        x1 = wp.min(x0 + 1, side - 1)
        y1 = wp.min(y0 + 1, side - 1)
        fx = u - float(x0)
        fy = v - float(y0)
        out = wp.vec3(0.0, 0.0, 0.0)
        for c in range(3):
            top = (1.0 - fx) * sky_texel(sky, row, face, x0, y0, c) + fx * sky_texel(sky, row, face, x1, y0, c)
            bottom = (1.0 - fx) * sky_texel(sky, row, face, x0, y1, c) + fx * sky_texel(sky, row, face, x1, y1, c)
            out[c] = (1.0 - fy) * top + fy * bottom
        return out

    @wp.kernel
    def finish(
        packed: wp.array2d(dtype=wp.uint32),
        packed_adr: int,
        seg: wp.array2d(dtype=wp.vec2i),
        seg_adr: int,
        rays: wp.array(dtype=wp.vec3),
        ray_adr: int,
        cam_xmat: wp.array2d(dtype=wp.mat33),
        camera: int,
        alpha: wp.array2d(dtype=float),
        agent: wp.array(dtype=wp.uint8),
        sky: wp.array(dtype=wp.uint8, ndim=4),
        sky_index: wp.array(dtype=wp.int32),
        light_gain: wp.array(dtype=wp.vec3),
        width: int,
        pixels: wp.array(dtype=wp.uint8, ndim=4),
        labels: wp.array3d(dtype=wp.uint8),
        want_labels: int,
    ):  # writes pixels and labels
        world, pixel = wp.tid()
        y = pixel // width
        x = pixel - y * width
        value = packed[world, packed_adr + pixel]
        color = wp.vec3(float((value >> wp.uint32(16)) & wp.uint32(255)),
                        float((value >> wp.uint32(8)) & wp.uint32(255)),
                        float(value & wp.uint32(255)))
        geom = seg[world, seg_adr + pixel][0]
        a = float(0.0)  # a ray that meets nothing shows the sky
        if geom >= 0:
            color = wp.cw_mul(color, light_gain[world])  # the lit surface only, before the sky shows through
            a = alpha[world, geom]
            # MuJoCo's GL draws each transparent geom twice, front to back then back to front
            # (render_gl3.c, "transparent regular rendering"): over the sky, 1 - (1 - a)^2 of it shows
            a = 1.0 - (1.0 - a) * (1.0 - a)
        if a < 1.0:
            d = cam_xmat[world, camera] * rays[ray_adr + pixel]
            color = a * color + (1.0 - a) * sample_sky(sky, sky_index[world], d)
        for c in range(3):
            pixels[world, y, x, c] = wp.uint8(wp.clamp(wp.round(color[c]), 0.0, 255.0))
        if want_labels != 0:
            label = wp.uint8(0)
            if geom >= 0:
                label = agent[geom]
            labels[world, y, x] = label

    _KERNELS["finish"] = finish
    return finish


class WarpRenderer:
    """Renders camera ``camera_id`` of ``n`` worlds of one MuJoCo model into uint8 ``[n, height, width, 3]``.

    Args:
        model: the ``mujoco.MjModel`` every world shares (the per-world parts are in :class:`WorldState`).
        n (int): the number of worlds.
        height, width (int): the image size.
        camera_id (int): the camera rendered (one per world).
        device: ``"cpu"`` or a CUDA device; the images are torch tensors there.

    Keyword Args:
        shadows (bool): MuJoCo Warp's shadow rays (GL draws shadows).
        agent_geoms (array of bool, optional): per geom, whether it is part of the agent; the
            labels of :meth:`render` are then :data:`MASK_LABELS` (``None``: no labels).
        floor_geoms (array of bool, optional): per geom, whether it is floor (label 1).
    """

    def __init__(self, model, n: int, height: int, width: int, camera_id: int, device="cpu", *,
                 shadows: bool = True, agent_geoms=None, floor_geoms=None):
        self.device = warp_device(device)
        wp, mjw = import_warp(self.device)
        self._wp = wp
        self.n, self.height, self.width, self.camera_id = int(n), int(height), int(width), int(camera_id)
        if not 0 <= self.camera_id < model.ncam:
            raise ValueError(f'backend="warp" renders a model camera: camera_id={camera_id} is not in [0, {model.ncam}).')
        self.torch_device = torch.device(self.device)
        mjm = model.ptr if hasattr(model, "ptr") else model
        with DEFAULT_DEVICE.scope(wp.get_device(self.device)):
            self.model = mjw.put_model(mjm, batch_sizes={"mat_rgba": self.n, "light_ambient": self.n,
                                                         "mat_texid": self.n})
            self.data = mjw.make_data(mjm, nworld=self.n, nconmax=1, njmax=1)
            self.context = mjw.create_render_context(
                mjm, nworld=self.n, cam_res=(self.width, self.height), render_rgb=True, render_depth=False,
                render_seg=True, use_textures=True, use_shadows=bool(shadows), cam_active=[self.camera_id],
                render_skybox=False, background_color=(0.0, 0.0, 0.0, 1.0),
            )
            self._offsets = render_offsets(self.context, 0)  # where the one active camera's pixels lie
            self.pixels = wp.zeros((self.n, self.height, self.width, 3), dtype=wp.uint8)
            self.want_labels = agent_geoms is not None
            self.labels = wp.zeros((self.n, self.height, self.width) if self.want_labels else (1, 1, 1), dtype=wp.uint8)
            label = np.zeros(mjm.ngeom, np.uint8)
            if self.want_labels:
                label[np.asarray(agent_geoms, bool)] = MASK_LABELS["agent"]
                if floor_geoms is not None:
                    label[np.asarray(floor_geoms, bool)] = MASK_LABELS["floor"]
            self._geom_label = wp.array(label, dtype=wp.uint8)
            self._alpha = wp.zeros((self.n, mjm.ngeom), dtype=float)
            self._sky_index = wp.zeros(self.n, dtype=wp.int32)
            self._light_gain = wp.ones(self.n, dtype=wp.vec3)
            self._sky, self._sky_source = None, None  # the sky on this device, and what it holds: (array, version)
            self._finish = _kernels(wp)
            # Build this renderer's kernels now, in the thread that makes it: MuJoCo Warp specialises
            # a kernel per render context at its first render (dcs_torchrl/_compat/private_api.py), and the
            # renderers of one batch render in threads at once (BatchedSuiteEnv), where two first
            # renders must not build theirs together. A render of the zeroed worlds builds it.
            mjw.refit_bvh(self.model, self.data, self.context)
            mjw.render(self.model, self.data, self.context)
            wp.load_module(self._finish.module, device=self.device)
        self._mjm, self._own = mjm, None
        # every texture the trace may sample (the model's, then those added), kept alive here: Warp's
        # array of textures holds their handles, not the textures
        self._textures = list(self.context.textures_registry)
        # the model's texture ids of every role: a CUDA render writes the RGB column of each world into it
        self._mat_texid = np.array(self.model.mat_texid.numpy())
        self._mjw = mjw
        # the colour (geom's or material's, as MuJoCo picks it) whose alpha says how much sky shows through
        self._geom_matid = np.asarray(mjm.geom_matid).copy()
        self._geom_rgba = np.asarray(mjm.geom_rgba).copy()
        self._uses_material = (self._geom_matid >= 0) & np.all(self._geom_rgba == (0.5, 0.5, 0.5, 1.0), axis=1)
        self.seconds = 0.0  #: time spent in :meth:`render`, for the benchmarks
        self._pixels_torch = wp.to_torch(self.pixels)
        self._labels_torch = wp.to_torch(self.labels)

    def state(self, sky: np.ndarray) -> WorldState:
        """A :class:`WorldState` to fill for :meth:`render`, showing ``sky`` (uint8 ``[rows, faces, side,
        side, 3]``, the caller's; world ``i`` row ``i % rows`` until its ``sky_index`` says otherwise; the
        model's lighting and textures, gain 1). On the CPU its poses, lighting and textures are this
        renderer's own arrays (float32, as Warp keeps them) and ``sky`` is read where it lies: a render
        then copies nothing in."""
        d, m, n = self.data, self.model, self.n
        if self.device != "cpu":
            state = WorldState.empty(self._mjm, n, sky)
        else:
            state = WorldState(
                geom_xpos=d.geom_xpos.numpy(), geom_xmat=d.geom_xmat.numpy().reshape(n, -1, 9),
                cam_xpos=d.cam_xpos.numpy(), cam_xmat=d.cam_xmat.numpy().reshape(n, -1, 9),
                light_xpos=d.light_xpos.numpy(), light_xdir=d.light_xdir.numpy(), mat_rgba=m.mat_rgba.numpy(),
                sky=sky, sky_index=self._sky_index.numpy(), light_ambient=m.light_ambient.numpy(),
                light_gain=self._light_gain.numpy(), mat_texid=m.mat_texid.numpy()[:, :, _RGB],
            )
            state.sky_index[:] = _first_rows(n, sky)
            _model_lighting(self._mjm, state)
        self._own = state
        return state

    def _put_sky(self, state: WorldState) -> None:
        """``state.sky`` as the kernel reads it (faces stacked, as in MuJoCo): on the CPU the array itself;
        on a CUDA device a copy, made again when the array or its ``sky_version`` changes."""
        source = (state.sky, state.sky_version)
        if self._sky_source is not None and source[0] is self._sky_source[0] and source[1] == self._sky_source[1]:
            return
        rows, faces, side = state.sky.shape[:3]
        strip = np.ascontiguousarray(state.sky).reshape(rows, faces * side, side, 3)
        if self.device == "cpu":
            self._sky = self._wp.array(strip, dtype=self._wp.uint8, device="cpu", copy=False)
        else:
            if self._sky is None or tuple(self._sky.shape) != strip.shape:
                self._sky = self._wp.zeros(strip.shape, dtype=self._wp.uint8, device=self.device)
            self._put(self._sky, strip, self._wp.uint8)
        self._sky_source = source

    def _put(self, target, values: np.ndarray, dtype) -> None:
        """Copies ``values`` (host) into the Warp array ``target`` (same shape)."""
        wp = self._wp
        host = {wp.uint8: np.uint8, wp.int32: np.int32}.get(dtype, np.float32)
        source = wp.array(np.ascontiguousarray(values, dtype=host), dtype=dtype, device="cpu", copy=False)
        wp.copy(target, source)

    def add_textures(self, images) -> int:
        """Adds textures the worlds' materials may show (through ``WorldState.mat_texid``); returns the id of
        the first, the others following it (the model's textures keep their ids).

        Args:
            images: uint8 ``[K, height, width, 3]`` (numpy or a torch tensor), K >= 1: RGB, opaque. Each
                becomes a texture as MuJoCo Warp makes the model's own, so an image equal to a model
                texture's pixels renders as that texture does.
        """
        if isinstance(images, torch.Tensor):
            images = images.detach().cpu().numpy()
        images = np.asarray(images)
        if images.dtype != np.uint8:
            raise TypeError(f"add_textures takes uint8 images, got {images.dtype}: convert them, e.g. "
                            "(image * 255).round().astype(np.uint8) for colours in [0, 1].")
        if images.ndim != 4 or images.shape[-1] != 3:
            raise ValueError(f"add_textures takes images [K, height, width, 3] (RGB), got shape {images.shape}: "
                             "stack them on a first axis (one image: images[None]).")
        if not all(images.shape[:3]):
            raise ValueError(f"add_textures takes at least one image of at least one pixel, got shape {images.shape}.")
        wp = self._wp
        # as MuJoCo Warp converts a texture (render_util._convert_texture_data): float RGBA, each byte
        # times the float32 1/255, alpha 255 where there is none
        scale = np.float32(1.0 / 255.0)
        rgba = np.empty((*images.shape[:3], 4), np.float32)
        rgba[..., :3] = images.astype(np.float32) * scale
        rgba[..., 3] = np.float32(255.0) * scale
        first = len(self._textures)
        with DEFAULT_DEVICE.scope(wp.get_device(self.device)):
            added = [wp.Texture2D(wp.array(image, dtype=float, device=self.device),
                                  filter_mode=wp.TextureFilterMode.LINEAR) for image in rgba]
            textures = self._textures + added
            self.context.textures = wp.array(textures, dtype=wp.Texture2D, device=self.device)
        self._textures = self.context.textures_registry = textures
        return first

    def _check_texids(self, mat_texid: np.ndarray) -> None:
        """Refuses a texture id that names no texture (the trace would read past its textures)."""
        if mat_texid.size and (mat_texid.min() < -1 or mat_texid.max() >= len(self._textures)):
            bad = mat_texid[(mat_texid < -1) | (mat_texid >= len(self._textures))]
            raise ValueError(f"WorldState.mat_texid holds {int(bad[0])}, not a texture of this renderer (ids -1 for "
                             f"none to {len(self._textures) - 1}): add the image with add_textures and use the "
                             "id it returns.")

    def render(self, state: WorldState) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Renders every world of ``state``: ``(pixels [n, h, w, 3] uint8, labels [n, h, w] uint8 or None)``.

        The tensors are this renderer's buffers, overwritten by the next call: copy to keep them.
        """
        wp, mjw, d, m, rc = self._wp, self._mjw, self.data, self.model, self.context
        n = self.n
        self._check_texids(state.mat_texid)
        start = time.perf_counter()
        with DEFAULT_DEVICE.scope(wp.get_device(self.device)):
            if state is not self._own or self.device != "cpu":  # else the arrays are Warp's already
                self._put(d.geom_xpos, state.geom_xpos, wp.vec3)
                self._put(d.geom_xmat, state.geom_xmat.reshape(n, -1, 3, 3), wp.mat33)
                self._put(d.cam_xpos, state.cam_xpos, wp.vec3)
                self._put(d.cam_xmat, state.cam_xmat.reshape(n, -1, 3, 3), wp.mat33)
                if m.nlight:
                    self._put(d.light_xpos, state.light_xpos, wp.vec3)
                    self._put(d.light_xdir, state.light_xdir, wp.vec3)
                self._put(m.mat_rgba, state.mat_rgba, wp.vec4)
                self._put(self._sky_index, state.sky_index, wp.int32)
                if m.nlight:
                    self._put(m.light_ambient, state.light_ambient, wp.vec3)
                self._put(self._light_gain, state.light_gain, wp.vec3)
                self._mat_texid[:, :, _RGB] = state.mat_texid
                self._put(m.mat_texid, self._mat_texid, wp.int32)
            self._put_sky(state)
            alpha = np.where(self._uses_material[None], state.mat_rgba[:, self._geom_matid.clip(0), 3],
                             self._geom_rgba[None, :, 3])
            self._put(self._alpha, alpha, float)
            mjw.refit_bvh(m, d, rc)
            mjw.render(m, d, rc)
            wp.launch(
                self._finish, dim=(n, self.height * self.width),
                inputs=[rc.rgb_data, self._offsets.rgb, rc.seg_data, self._offsets.seg, rc.ray, self._offsets.ray,
                        d.cam_xmat, self.camera_id, self._alpha, self._geom_label, self._sky, self._sky_index,
                        self._light_gain, self.width, self.pixels,
                        self.labels, int(self.want_labels)],
            )
            if self.device != "cpu":
                wp.synchronize_device(self.device)  # torch reads the buffers next, on its own stream
        self.seconds += time.perf_counter() - start
        return self._pixels_torch, (self._labels_torch if self.want_labels else None)
