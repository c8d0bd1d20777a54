"""RenderPixels: render the (distracted) scene once per agent step, after every edit.

The render context of a physics is created by the suite, with the settings of a render
*profile* (docs/performance.md, "Where the render time goes"):

========== ================================ ===============================================
profile    settings                         versus ``physics.render`` of the same scene
========== ================================ ===============================================
default    4x MSAA, shadow map scaled to    mean abs. pixel difference ≤ 0.1 (checked by
           the image, buffer = image size,  ``tests/test_render.py``); what the paper's
           one persistent camera            numbers were rendered with
fast       no MSAA, small shadow map, ...   mean difference ≤ 1 grey level, cheaper
========== ================================ ===============================================

Textures edited by the distractions (the skybox) are uploaded here, right before the
render, so that a frame-skip of k costs one upload and one render per agent step. Only
what the render samples is sent: of the six cube faces, the rectangles the camera's view
frustum covers (widened to cover texture filtering), each as its two finest mipmap
levels; the rest follows when a camera turns towards it. The pixels are those of a
six-face upload (compared exactly in ``tests/test_render.py``); see
:meth:`_Context.upload_cube` and :mod:`dcs_torchrl.render.skybox`.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from types import MappingProxyType

import cv2
import mujoco
import numpy as np
import torch
from dm_control.mujoco import engine
from tensordict import TensorDictBase
from torchrl.data import Bounded, Composite
from torchrl.envs import Transform

from dcs_torchrl import presets
from dcs_torchrl._compat.private_api import free_foreign_render_contexts
from dcs_torchrl._scene import Scene, locate
from dcs_torchrl.render import skybox


@dataclass(frozen=True)
class RenderProfile:
    """Render-context settings. The shadow map is ``shadow_per_pixel`` times the image side,
    rounded up to a power of two and clipped to [``min_shadow``, 4096]."""

    msaa_samples: int
    shadow_per_pixel: int
    min_shadow: int


PROFILES: MappingProxyType[str, RenderProfile] = MappingProxyType(
    {
        "default": RenderProfile(msaa_samples=4, shadow_per_pixel=6, min_shadow=512),
        "fast": RenderProfile(msaa_samples=0, shadow_per_pixel=2, min_shadow=128),
    }
)


def check_profile(profile: str) -> str:
    """``profile`` if it names one of :data:`PROFILES` (the render profiles of both backends), else a
    ValueError naming them."""
    if profile not in PROFILES:
        raise ValueError(f"unknown render_profile {profile!r}; choose one of {sorted(PROFILES)}.")
    return profile


def _shadow_size(profile: RenderProfile, side: int) -> int:
    size = 1 << max(0, int(np.ceil(np.log2(profile.shadow_per_pixel * side))))
    return int(min(max(size, profile.min_shadow), 4096))


class _Context:
    """The render context the suite made for one physics, shared by its RenderPixels."""

    #: Reference path (tests, benchmarks): send all six faces of every new cube texture, as
    #: the suite did before it sent only the faces a render samples. Same pixels, more work.
    upload_all_faces: bool = False

    def __init__(self, physics, profile: str, width: int, height: int):
        # weakly: _CONTEXTS is keyed by the physics, and a value holding its key keeps it (and its GL
        # context) alive for the life of the process
        self._physics = weakref.ref(physics)
        self._held = None  # the physics' contexts (GL, MuJoCo): freed by free_retired once the physics is gone
        self.profile = profile
        self.width, self.height = width, height
        self.uploaded: dict[int, tuple[int, int]] = {}
        self.pending: dict[int, _CubeContent] = {}  # cube textures whose GPU copy is partly stale
        self._make()
        weakref.finalize(physics, _RETIRED.append, self).atexit = False  # dm_control frees its contexts at exit

    @property
    def physics(self):
        physics = self._physics()
        if physics is None:
            raise RuntimeError("this render context's physics is gone: render through a live env.")
        return physics

    def _make(self) -> None:
        physics, model = self.physics, self.physics.model
        settings = PROFILES[self.profile]
        free_foreign_render_contexts(physics)  # made by someone else, with other settings
        model.vis.global_.offwidth = self.width
        model.vis.global_.offheight = self.height
        model.vis.quality.offsamples = settings.msaa_samples
        model.vis.quality.shadowsize = _shadow_size(settings, max(self.width, self.height))
        self._held = physics.contexts  # creates the GL and MuJoCo contexts, uploads every texture
        self.uploaded = {i: (int(model.tex_width[i]), int(model.tex_height[i])) for i in range(model.ntex)}
        self.skyboxes = {i for i in range(model.ntex) if model.tex_type[i] == mujoco.mjtTexture.mjTEXTURE_SKYBOX}
        self.own_storage: set[int] = set()  # textures given the suite's storage (RGBA8, _SKY_LEVELS levels) here
        self.pending = {}  # the new context was given model.tex_data, which holds every edit

    def fit(self, profile: str, width: int, height: int) -> None:
        """Makes the context serve one more RenderPixels (same profile, any size)."""
        if profile != self.profile:
            raise ValueError(
                f"this env already renders with profile {self.profile!r}; one physics has one "
                f"render context, so every RenderPixels on it must use that profile, not {profile!r}."
            )
        if width > self.width or height > self.height:
            self.width, self.height = max(width, self.width), max(height, self.height)
            self._make()

    def upload_cube(self, tex_id: int, faces: list[np.ndarray]) -> None:
        """Takes new content of a cube/skybox texture whose data the caller wrote into ``model.tex_data``.

        ``faces`` holds the six faces (or one face repeated on all six), each [s, s, 3]
        uint8; only the rectangles sent are converted to RGBA, at every upload. At its first new content in this context (and at a new size) the texture is
        given new storage, of that size, keeping MuJoCo's sampling parameters: RGBA8, so
        that RGBA texels are copied as they are (Mesa's llvmpipe converts them to its RGBX
        layout for MuJoCo's RGB textures), and its two finest mipmap levels only
        (``GL_TEXTURE_MAX_LEVEL``), which the suite writes itself (docs/performance.md, "The
        sky texture"). The content itself is only recorded here: :meth:`upload_visible`, right
        before each render, sends the part of the sky that render samples (``glTexSubImage2D``),
        and the rest when a later render needs it (a camera that turns).
        """
        model, contexts = self.physics.model, self.physics.contexts
        size = (int(model.tex_width[tex_id]), int(model.tex_height[tex_id]))
        resized = self.uploaded.get(tex_id) != size
        # a texture made by _make from model.tex_data has its whole mip chain, whose levels >= 2
        # would keep showing that first frame where a view samples them: replaced at first use
        if resized or tex_id not in self.own_storage:
            with contexts.gl.make_current() as ctx:
                ctx.call(_rgba_storage, int(contexts.mujoco.ptr.texture[tex_id]), size[0], _SKY_LEVELS)
            self.own_storage.add(tex_id)
            self.uploaded[tex_id] = size
        # the GPU copy holds none of it yet (new storage) or an earlier frame
        self.pending[tex_id] = _CubeContent(faces)

    def upload_textures(self, tex_ids) -> None:
        """Sends 2D textures ``tex_ids`` whose data the caller rewrote in ``model.tex_data`` (whole, as MuJoCo
        uploads them: a texture distraction rewrites them once an episode)."""
        model, contexts = self.physics.model, self.physics.contexts
        with contexts.gl.make_current() as ctx:
            for tex_id in dict.fromkeys(int(t) for t in tex_ids):
                ctx.call(mujoco.mjr_uploadTexture, model.ptr, contexts.mujoco.ptr, tex_id)

    def upload_visible(self, camera_id: int, aspect: float) -> None:
        """Sends the texels of pending cube textures that a render of ``camera_id`` samples and lack.

        For the skybox that is, on each face its view frustum (``aspect`` = width / height)
        meets, the rectangle around the part it sees, the frustum widened by a margin that
        covers texture filtering (:mod:`dcs_torchrl.render.skybox`); other cube textures, the
        free camera and :attr:`upload_all_faces` get whole faces. The pixels are those of
        a whole upload (``tests/test_render.py`` compares them exactly).
        """
        if not self.pending:
            return
        jobs = []
        for tex_id, content in list(self.pending.items()):
            if self.upload_all_faces or tex_id not in self.skyboxes or camera_id < 0:
                regions = _WHOLE_FACES
            else:
                fovy = float(self.physics.model.cam_fovy[camera_id])
                view = (camera_id, aspect, fovy, self.physics.data.cam_xmat[camera_id].tobytes())
                if view == content.last_view:
                    continue  # what this view samples was sent (a still camera)
                regions = skybox.camera_regions(self.physics, camera_id, aspect, content.margin)
                content.last_view = view
            rects = content.take(regions)
            if rects:
                texture = int(self.physics.contexts.mujoco.ptr.texture[tex_id])
                jobs.append((texture, [(face, rect[0], rect[1], content.levels(face, rect)) for face, rect in rects]))
            if content.complete:
                del self.pending[tex_id]
        if jobs:
            with self.physics.contexts.gl.make_current() as ctx:
                ctx.call(_sub_upload_cubes, jobs)


_SKY_LEVELS = 2  # mipmap levels kept for a skybox the suite rewrites (finest first)
_PAD = 2  # texels added around a rectangle to send (the frustum's margin already covers filtering)
_WHOLE_FACES = dict.fromkeys(range(6), skybox.FULL)


class _CubeContent:
    """New faces of a cube texture, and which texels of the six GPU faces show them already."""

    def __init__(self, faces: list[np.ndarray]):
        self.faces = faces
        self.side = int(faces[0].shape[0])
        self.margin = skybox.face_margin(max(1, self.side >> (_SKY_LEVELS - 1)))
        self.fresh: list[tuple[int, int, int, int] | None] = [None] * 6  # per GPU face, a rectangle sent
        self.last_view = None
        self._whole: dict[int, list[np.ndarray]] = {}

    @property
    def complete(self) -> bool:
        return all(rect == (0, 0, self.side, self.side) for rect in self.fresh)

    def take(self, regions: dict) -> list[tuple[int, tuple[int, int, int, int]]]:
        """The texel rectangles to send so that every region is fresh, now counted as sent.

        A region (texture coordinates) becomes level-0 texels padded by :data:`_PAD` and
        aligned to even texels, so that it maps exactly onto level 1 (whole faces when the
        side is odd). A face sent in part that needs more is sent whole: so a still sky
        under a turning camera costs each face at most one part and one whole.
        """
        n = self.side
        out = []
        for face, (s0, t0, s1, t1) in regions.items():
            if n % 2:
                rect = (0, 0, n, n)
            else:
                rect = (
                    max(0, (math.floor(s0 * n) - _PAD) & ~1), max(0, (math.floor(t0 * n) - _PAD) & ~1),
                    min(n, (math.ceil(s1 * n) + _PAD + 1) & ~1), min(n, (math.ceil(t1 * n) + _PAD + 1) & ~1),
                )
            old = self.fresh[face]
            if old is not None:
                if old[0] <= rect[0] and old[1] <= rect[1] and old[2] >= rect[2] and old[3] >= rect[3]:
                    continue
                rect = (0, 0, n, n)  # a view that moves on within a face will want the rest too
            self.fresh[face] = rect
            out.append((face, rect))
        return out

    def levels(self, face: int, rect: tuple[int, int, int, int]) -> list[np.ndarray]:
        """The RGBA mipmap levels of ``rect`` (level-0 texels) of ``face``, finest first, each a
        contiguous [h, w, 4] array: a conversion of ``rect`` alone (a whole face repeated on six
        faces is converted once)."""
        index = face if len(self.faces) == 6 else 0
        x0, y0, x1, y1 = rect
        if (x0, y0, x1, y1) == (0, 0, self.side, self.side):
            if index not in self._whole:
                self._whole[index] = _rgba_levels(self.faces[index])
            return self._whole[index]
        return _rgba_levels(self.faces[index][y0:y1, x0:x1])


def _rgba_levels(image: np.ndarray) -> list[np.ndarray]:
    """RGBA copies of an [h, w, 3] image and its halvings (area averages), finest first."""
    levels = [cv2.cvtColor(image, cv2.COLOR_RGB2RGBA)]
    while len(levels) < _SKY_LEVELS and max(levels[-1].shape[:2]) > 1:
        height, width = levels[-1].shape[:2]
        half = (max(1, width // 2), max(1, height // 2))
        levels.append(cv2.resize(levels[-1], half, interpolation=cv2.INTER_AREA))
    return levels


def _rgba_storage(texture: int, side: int, levels: int) -> None:
    """Gives a cube texture new, empty storage: ``levels`` mipmap levels, RGBA8, ``side`` texels."""
    from OpenGL import GL

    _limit_levels(texture, levels - 1)
    for face in range(6):
        for level in range(levels):
            n = max(1, side >> level)
            GL.glTexImage2D(GL.GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, level, GL.GL_RGBA8, n, n, 0,
                            GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, None)


def _limit_levels(texture: int, max_level: int) -> None:
    from OpenGL import GL  # imported late: dm_control selects the GL platform first

    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, texture)
    GL.glTexParameteri(GL.GL_TEXTURE_CUBE_MAP, GL.GL_TEXTURE_MAX_LEVEL, max_level)


def _sub_upload_cubes(jobs: list[tuple[int, list[tuple[int, int, int, list[np.ndarray]]]]]) -> None:
    """Per ``(texture, [(face, x0, y0, levels)])``, replaces texels of cube faces from (x0, y0) on
    with each level's RGBA array."""
    from OpenGL import GL

    for texture, uploads in jobs:
        GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, texture)
        for face, x0, y0, levels in uploads:
            for level, image in enumerate(levels):
                GL.glTexSubImage2D(GL.GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, level, x0 >> level, y0 >> level,
                                   image.shape[1], image.shape[0], GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, image)


_CONTEXTS: "weakref.WeakKeyDictionary[object, _Context]" = weakref.WeakKeyDictionary()
#: the suite's render contexts whose physics is gone, freed by :func:`free_retired` before the next render.
#: Not by the garbage collector: it may run inside another context's render, and dm_control frees a
#: context by making it current and then none, so that render's remaining GL calls (a new video frame's
#: upload) would go to no context (tests/test_memory.py).
_RETIRED: list[_Context] = []


def free_retired() -> None:
    """Frees the GL and MuJoCo contexts of every physics gone since the last call (the suite calls it
    before each render; call it yourself to release them sooner)."""
    while _RETIRED:
        context = _RETIRED.pop()
        held, context._held = context._held, None
        if held is not None:
            held.mujoco.free()
            held.gl.free()


def render_context(physics, profile: str, width: int, height: int) -> _Context:
    """The suite's render context of ``physics`` (created on first use)."""
    check_profile(profile)
    free_retired()
    context = _CONTEXTS.get(physics)
    if context is None:
        context = _CONTEXTS[physics] = _Context(physics, profile, width, height)
    else:
        context.fit(profile, width, height)
    return context


class RenderPixels(Transform):
    """Renders the scene into ``"pixels"`` once per agent step, after every distraction.

    Put it after the distractions in the ``Compose`` over a
    ``DMControlEnv(domain, task, from_pixels=False, frame_skip=k)``: the base env steps
    the physics k times without rendering, the distractions edit the scene, and this
    transform renders the last frame once.

    Args:
        height (int): image height. Defaults to 84.
        width (int): image width. Defaults to 84.
        camera_id (int, optional): the camera to render; defaults to the suite's camera
            of the domain (0, or 2 for quadruped).

    Keyword Args:
        profile (str): ``"default"`` (matches dm_control's own render, mean absolute
            difference ≤ 0.1) or ``"fast"`` (≤ 1 grey level, cheaper: docs/performance.md, "Env steps").
        out_keys (list of keys): where to write the image. Defaults to ``["pixels"]``.

    The base env's state observations stay: append TorchRL's
    ``ExcludeTransform(*base_env.observation_spec.keys())`` to drop them, as
    :func:`~dcs_torchrl.make_env` does (``pixels_only=True``).

    Examples:
        >>> from torchrl.envs import DMControlEnv, TransformedEnv
        >>> from dcs_torchrl import RenderPixels
        >>> env = TransformedEnv(DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8), RenderPixels())
        >>> env.reset()["pixels"].shape
        torch.Size([84, 84, 3])
    """

    def __init__(
        self,
        height: int = 84,
        width: int = 84,
        camera_id: int | None = None,
        *,
        profile: str = "default",
        out_keys=None,
    ):
        if int(height) < 1 or int(width) < 1:
            raise ValueError(f"RenderPixels needs a positive image size, got height={height}, width={width}.")
        check_profile(profile)
        super().__init__(in_keys=[], out_keys=out_keys or ["pixels"])
        self.height, self.width = int(height), int(width)
        self.camera_id = camera_id
        self.profile = profile
        self._forget()

    # ----------------------------------------------------------------- wiring
    def set_container(self, container) -> None:
        super().set_container(container)
        self._forget()
        locate(self, strict=False)  # catch misuse at construction

    def reset_parent(self) -> None:
        super().reset_parent()
        self._forget()

    def _forget(self) -> None:
        for name in ("_scene", "_camera"):
            self.__dict__[name] = None

    def _bind(self) -> Scene:
        scene = self.__dict__.get("_scene")
        if scene is None:
            scene = locate(self, strict=True)
            cid = self._resolved_camera(scene)
            for t in scene.before():
                moved = None if isinstance(t, RenderPixels) else getattr(t, "camera_id", None)
                if moved is not None and moved != cid:
                    raise ValueError(
                        f"{type(t).__name__} moves camera {moved} but RenderPixels renders camera {cid}: "
                        "pass the same camera_id to both."
                    )
            self.__dict__["_scene"] = scene
        return scene

    def _resolved_camera(self, scene: Scene) -> int:
        cid = self.camera_id if self.camera_id is not None else presets.default_camera(scene.domain)
        ncam = scene.physics.model.ncam
        if not -1 <= cid < ncam:
            raise ValueError(f"RenderPixels camera_id={cid} is out of range: the model has {ncam} camera(s).")
        return cid

    def _render(self) -> torch.Tensor:
        scene = self._bind()
        camera_id = self._resolved_camera(scene)
        context = render_context(scene.physics, self.profile, self.width, self.height)
        for t in scene.before():
            upload = getattr(t, "upload_textures", None)
            if upload is not None:
                upload(context)
        if context.pending:
            context.upload_visible(camera_id, self.width / self.height)
        camera = self.__dict__.get("_camera")
        if camera is None:
            camera = engine.Camera(scene.physics, self.height, self.width, camera_id)
            self.__dict__["_camera"] = camera
        return torch.from_numpy(np.ascontiguousarray(camera.render()))

    # ---------------------------------------------------------- TorchRL hooks
    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        return tensordict_reset.set(self.out_keys[0], self._render())

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict.set(self.out_keys[0], self._render())

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        raise RuntimeError("RenderPixels renders a live MuJoCo scene; it cannot transform stored data.")

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        observation_spec[self.out_keys[0]] = Bounded(
            low=0, high=255, shape=(self.height, self.width, 3), dtype=torch.uint8, device=observation_spec.device
        )
        return observation_spec

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(height={self.height}, width={self.width}, camera_id={self.camera_id}, "
            f"profile={self.profile!r})"
        )
