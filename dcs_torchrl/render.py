"""RenderPixels: render the (distracted) scene once per agent step, after every edit.

The render context of a physics is created by the suite, with the settings of a render
*profile* (DESIGN.md, "where the render time goes"):

========== ================================ ===============================================
profile    settings                         versus ``physics.render`` of the same scene
========== ================================ ===============================================
default    4x MSAA, shadow map scaled to    mean abs. pixel difference ≤ 0.1 (measured in
           the image, buffer = image size,  the tests); what the paper's numbers were
           one persistent camera            rendered with
fast       no MSAA, small shadow map, ...   mean difference ≤ 1 grey level, ~2x faster
========== ================================ ===============================================

Textures edited by the distractions (the skybox) are uploaded here, right before the
render, so that a frame-skip of k costs one upload and one render per agent step
(see :meth:`_Context.upload_cube` for how that upload is kept cheap).
"""
from __future__ import annotations

import ctypes
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
from dcs_torchrl._scene import Scene, locate


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


def _shadow_size(profile: RenderProfile, side: int) -> int:
    size = 1 << max(0, int(np.ceil(np.log2(profile.shadow_per_pixel * side))))
    return int(min(max(size, profile.min_shadow), 4096))


class _Context:
    """The render context the suite made for one physics, shared by its RenderPixels."""

    def __init__(self, physics, profile: str, width: int, height: int):
        self.physics = physics
        self.profile = profile
        self.width, self.height = width, height
        self.uploaded: dict[int, tuple[int, int]] = {}
        self._make()

    def _make(self) -> None:
        physics, model = self.physics, self.physics.model
        settings = PROFILES[self.profile]
        if getattr(physics, "_contexts", None):
            physics._free_rendering_contexts()  # made by someone else, with other settings
        model.vis.global_.offwidth = self.width
        model.vis.global_.offheight = self.height
        model.vis.quality.offsamples = settings.msaa_samples
        model.vis.quality.shadowsize = _shadow_size(settings, max(self.width, self.height))
        physics.contexts  # creates the GL and MuJoCo contexts, uploads every texture
        self.uploaded = {i: (int(model.tex_width[i]), int(model.tex_height[i])) for i in range(model.ntex)}

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
        """Uploads a cube/skybox texture whose data the caller wrote into ``model.tex_data``.

        ``faces`` holds the six faces (or one face repeated on all six), each [s, s, 3]
        uint8. A new texture size goes through ``mjr_uploadTexture`` (which allocates the
        texture and its mipmaps); the same size again only replaces the pixels of the
        two finest mipmap levels with ``glTexSubImage2D``, the texture being limited to
        those two (``GL_TEXTURE_MAX_LEVEL``). At the sizes a sky is seen at, rendering is
        the same as with the full chain (measured), and the upload ~3x cheaper than
        regenerating mipmaps; RGBA source data is the fast path of Mesa's llvmpipe.
        """
        model, contexts = self.physics.model, self.physics.contexts
        size = (int(model.tex_width[tex_id]), int(model.tex_height[tex_id]))
        texture = int(contexts.mujoco.ptr.texture[tex_id])
        with contexts.gl.make_current() as ctx:
            if self.uploaded.get(tex_id) != size:
                ctx.call(mujoco.mjr_uploadTexture, model.ptr, contexts.mujoco.ptr, tex_id)
                ctx.call(_limit_levels, texture, _SKY_LEVELS - 1)
                self.uploaded[tex_id] = size
            else:
                ctx.call(_sub_upload_cube, texture, [_rgba_levels(face) for face in faces])


_SKY_LEVELS = 2  # mipmap levels kept for a skybox the suite rewrites (finest first)


def _rgba_levels(face: np.ndarray) -> list[np.ndarray]:
    levels = [cv2.cvtColor(face, cv2.COLOR_RGB2RGBA)]
    while len(levels) < _SKY_LEVELS and levels[-1].shape[0] > 1:
        side = max(1, levels[-1].shape[0] // 2)
        levels.append(cv2.resize(levels[-1], (side, side), interpolation=cv2.INTER_AREA))
    return levels


def _limit_levels(texture: int, max_level: int) -> None:
    from OpenGL import GL  # imported late: dm_control selects the GL platform first

    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, texture)
    GL.glTexParameteri(GL.GL_TEXTURE_CUBE_MAP, GL.GL_TEXTURE_MAX_LEVEL, max_level)


def _sub_upload_cube(texture: int, levels_per_face: list[list[np.ndarray]]) -> None:
    from OpenGL import GL
    from OpenGL.raw.GL.VERSION import GL_1_1  # unchecked entry point: ~40% less call overhead

    GL.glBindTexture(GL.GL_TEXTURE_CUBE_MAP, texture)
    for face in range(6):
        levels = levels_per_face[face if len(levels_per_face) == 6 else 0]
        for level, image in enumerate(levels):
            side = image.shape[0]
            GL_1_1.glTexSubImage2D(
                GL.GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, level, 0, 0, side, side,
                GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, image.ctypes.data_as(ctypes.c_void_p),
            )


_CONTEXTS: "weakref.WeakKeyDictionary[object, _Context]" = weakref.WeakKeyDictionary()


def render_context(physics, profile: str, width: int, height: int) -> _Context:
    """The suite's render context of ``physics`` (created on first use)."""
    if profile not in PROFILES:
        raise ValueError(f"unknown render profile {profile!r}; choose one of {sorted(PROFILES)}.")
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
            difference ≤ 0.1) or ``"fast"`` (≤ 1 grey level, about twice as fast).
        pixels_only (bool): drop the state observations of the base env. Defaults to ``True``.
        out_keys (list of keys): where to write the image. Defaults to ``["pixels"]``.

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
        pixels_only: bool = True,
        out_keys=None,
    ):
        if int(height) < 1 or int(width) < 1:
            raise ValueError(f"RenderPixels needs a positive image size, got height={height}, width={width}.")
        if profile not in PROFILES:
            raise ValueError(f"unknown render profile {profile!r}; choose one of {sorted(PROFILES)}.")
        super().__init__(in_keys=[], out_keys=out_keys or ["pixels"])
        self.height, self.width = int(height), int(width)
        self.camera_id = camera_id
        self.profile = profile
        self.pixels_only = bool(pixels_only)
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
        for name in ("_scene", "_camera", "_state_keys_cache"):
            self.__dict__[name] = None

    def _bind(self) -> Scene:
        scene = self.__dict__.get("_scene")
        if scene is None:
            scene = locate(self, strict=True)
            cid = self._resolved_camera(scene)
            for t in scene.before():
                moved = getattr(t, "camera_id", None)
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
        context = render_context(scene.physics, self.profile, self.width, self.height)
        for t in scene.before():
            upload = getattr(t, "upload_textures", None)
            if upload is not None:
                upload(context)
        camera = self.__dict__.get("_camera")
        if camera is None:
            camera = engine.Camera(scene.physics, self.height, self.width, self._resolved_camera(scene))
            self.__dict__["_camera"] = camera
        return torch.from_numpy(np.ascontiguousarray(camera.render()))

    def _state_keys(self) -> list:
        keys = self.__dict__.get("_state_keys_cache")
        if keys is None:
            keys = self.__dict__["_state_keys_cache"] = list(self._bind().base_env.observation_spec.keys(True, True))
        return keys

    def _drop_states(self, tensordict: TensorDictBase) -> TensorDictBase:
        return tensordict.exclude(*self._state_keys()) if self.pixels_only else tensordict

    # ---------------------------------------------------------- TorchRL hooks
    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        tensordict_reset = self._drop_states(tensordict_reset)
        return tensordict_reset.set(self.out_keys[0], self._render())

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        next_tensordict = self._drop_states(next_tensordict)
        return next_tensordict.set(self.out_keys[0], self._render())

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        raise RuntimeError("RenderPixels renders a live MuJoCo scene; it cannot transform stored data.")

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        if self.pixels_only:
            present = set(observation_spec.keys(True, True))
            for key in self._state_keys():
                if key in present:
                    del observation_spec[key]
        observation_spec[self.out_keys[0]] = Bounded(
            low=0, high=255, shape=(self.height, self.width, 3), dtype=torch.uint8, device=observation_spec.device
        )
        return observation_spec

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(height={self.height}, width={self.width}, camera_id={self.camera_id}, "
            f"profile={self.profile!r}, pixels_only={self.pixels_only})"
        )
