"""TextureDistraction: the floor's and the bodies' surfaces textured from a set (beyond the paper: docs/lighting_textures.md).

Each episode a world draws one texture of the set for its floor and one for its bodies. A surface
shows the texture blended with its own look by β_tex: the floor ``(1 - β) · its texture + β · T``, a
body ``(1 - β) · white + β · T`` (MuJoCo multiplies a texture by the material's colour, so a body at
β = 1 wears ``T`` in its own colour, and the colour distraction still acts on it). β_tex is a weight, as
β_bg is for the videos, not a count of textures as b is: a robustness curve needs an axis that moves
continuously, and how many textures a split holds is a property of the set (``texture_split``).

MuJoCo textures live in the model: the floor's is the task's (the suite's ``grid``), rewritten in
place; the bodies have none, so the model needs one more, unused 2D texture the distraction points their
materials at: :func:`surface_slot` adds it while the suite compiles its models
(:func:`dcs_torchrl.make_env` does so whenever ``texture_scale > 0``). The Warp backend keeps every blend
of the set as a texture of its own and points each world's materials at its draw.
"""
from __future__ import annotations

import collections
import contextlib
import hashlib
import os
from collections.abc import Iterator

import cv2
import mujoco
import numpy as np

from dcs_torchrl._scene import Scene, originals
from dcs_torchrl.distractions.base import DistractionTransform, check_scale
from dcs_torchrl.textures import TEXTURE_SPLITS, TextureSet, texture_set

#: The name of the 2D texture :func:`surface_slot` adds for the bodies, and its side in texels.
SURFACE_TEXTURE, SURFACE_SIDE = "dcs_surface", 256
_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
_MATERIALS_ASSET = "./common/materials.xml"  # every suite model includes it


@contextlib.contextmanager
def surface_slot() -> Iterator[None]:
    """dm_control suite models compiled meanwhile hold one more 2D texture, ``dcs_surface``
    (:data:`SURFACE_SIDE` texels a side, white, used by no material: the render is unchanged), that a
    :class:`TextureDistraction` textures the bodies with."""
    from dm_control.suite import common

    original = common.ASSETS.get(_MATERIALS_ASSET)
    if original is None:  # pragma: no cover - dm_control without its common assets
        yield
        return
    text = original.decode() if isinstance(original, bytes) else original
    slot = (f'<texture name="{SURFACE_TEXTURE}" type="2d" builtin="flat" rgb1="1 1 1" '
            f'width="{SURFACE_SIDE}" height="{SURFACE_SIDE}"/>')
    edited = text.replace("<asset>", "<asset>\n    " + slot, 1)
    common.ASSETS[_MATERIALS_ASSET] = edited.encode() if isinstance(original, bytes) else edited
    try:
        yield
    finally:
        common.ASSETS[_MATERIALS_ASSET] = original


def surfaces(model) -> tuple[np.ndarray, int, np.ndarray, int]:
    """``(floor materials, floor texture, body materials, body texture)`` of ``model``: the materials of
    the world body's planes that carry a 2D RGB texture, and that texture (-1: none); the materials of
    every other body's geoms, and the :func:`surface_slot` texture (-1: none)."""
    matid, body = np.asarray(model.geom_matid), np.asarray(model.geom_bodyid)
    plane = np.asarray(model.geom_type) == mujoco.mjtGeom.mjGEOM_PLANE
    texid = np.asarray(model.mat_texid)[:, _RGB]
    floor = np.unique(matid[(body == 0) & plane & (matid >= 0)])
    floor = floor[texid[floor] >= 0]
    floor_tex = -1
    if len(floor):
        floor_tex = int(texid[floor[0]])
        floor = floor[texid[floor] == floor_tex]
        if model.tex_type[floor_tex] != mujoco.mjtTexture.mjTEXTURE_2D or model.tex_nchannel[floor_tex] != 3:
            floor, floor_tex = floor[:0], -1
    bodies = np.setdiff1d(np.unique(matid[(body != 0) & (matid >= 0)]), floor)
    slot = mujoco.mj_name2id(model.ptr if hasattr(model, "ptr") else model, mujoco.mjtObj.mjOBJ_TEXTURE,
                             SURFACE_TEXTURE)
    return floor.astype(np.int64), floor_tex, bodies.astype(np.int64), int(slot)


def texture_image(model, tex_id: int, data=None) -> np.ndarray:
    """Texture ``tex_id`` of ``model`` (a 2D RGB one) as uint8 ``[height, width, 3]`` (from ``data``, its
    original bytes, if given)."""
    w, h = int(model.tex_width[tex_id]), int(model.tex_height[tex_id])
    if data is None:
        adr = int(model.tex_adr[tex_id])
        data = model.tex_data[adr:adr + w * h * 3]
    return np.asarray(data, np.uint8).reshape(h, w, 3)


#: The blends made last, by what they are made of: the envs of a process (a batch's worlds) share one copy,
#: and a batch adds each to its renderers once.
_BLENDS: "collections.OrderedDict[tuple, tuple[np.ndarray, np.ndarray]]" = collections.OrderedDict()
_BLENDS_KEPT = 8


def _blends(textures: TextureSet, scale: float, floor_original: np.ndarray, body_side: int) -> tuple[np.ndarray, np.ndarray]:
    """Every texture of ``textures`` blended by ``scale`` over the floor's original texture (uint8 ``[h, w, 3]``;
    ``[0, 0, 3]``: no floor) into uint8 ``[K, h, w, 3]``, and over white for the bodies into ``[K, s, s, 3]``
    (``s = body_side``; 0: no bodies). Read-only, and the same arrays for the same arguments."""
    key = (textures.key, scale, floor_original.shape, hashlib.sha256(floor_original.tobytes()).hexdigest(), body_side)
    if key in _BLENDS:
        _BLENDS.move_to_end(key)
        return _BLENDS[key]
    k, (h, w) = len(textures), floor_original.shape[:2]
    floor = np.zeros((k, h, w, 3), np.uint8)
    base = floor_original.astype(np.float64)
    for i in range(k if h else 0):
        image = textures.image(i, max(h, w))
        if h != w:
            image = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)
        floor[i] = np.rint((1.0 - scale) * base + scale * image)
    body = np.zeros((k, body_side, body_side, 3), np.uint8)
    for i in range(k if body_side else 0):
        body[i] = np.rint((1.0 - scale) * 255.0 + scale * textures.image(i, body_side).astype(np.float64))
    floor.setflags(write=False)
    body.setflags(write=False)
    _BLENDS[key] = floor, body
    while len(_BLENDS) > _BLENDS_KEPT:
        _BLENDS.popitem(last=False)
    return floor, body


class TextureDistraction(DistractionTransform):
    """Textures the floor and the bodies from a texture set, one draw an episode (beyond the paper;
    docs/lighting_textures.md; the module's text says how).

    Args:
        scale (float): β_tex in [0, 1], the textures' weight against the surfaces' own look. 0 leaves
            the surfaces untouched.

    Keyword Args:
        texture_dir (str or path, optional): a folder of images (searched recursively; e.g. the
            Describable Textures Dataset's ``images``); ``None``: the stand-in textures made on first use
            (:func:`dcs_torchrl.textures.texture_set`).
        split (str): ``"train"`` or ``"val"`` (held-out textures).
        seed (int, optional), expose (bool): see :class:`DistractionTransform`; the exposed state is
            int64 ``[floor texture, body texture]``, indices into the split (-1: untouched).

    Examples:
        >>> from torchrl.envs import DMControlEnv, TransformedEnv, Compose
        >>> from dcs_torchrl import RenderPixels, TextureDistraction
        >>> from dcs_torchrl.distractions.texture import surface_slot
        >>> with surface_slot():  # the bodies' texture in the model
        ...     base = DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8)
        >>> env = TransformedEnv(base, Compose(TextureDistraction(0.8, seed=0, expose=True), RenderPixels()))
        >>> env.rollout(2)["next", "distractions", "texture"].shape
        torch.Size([2, 2])
    """

    state_name = "texture"
    seed_tag = 5

    def __init__(self, scale: float, *, texture_dir: str | os.PathLike | None = None, split: str = "train",
                 seed: int | None = None, expose: bool = False):
        self.scale = check_scale("TextureDistraction scale", scale)
        if split not in TEXTURE_SPLITS:
            raise ValueError(f"unknown texture split {split!r}; choose one of {list(TEXTURE_SPLITS)}.")
        self.texture_dir, self.split = texture_dir, split
        self.textures = texture_set(texture_dir, split) if self.scale > 0 else None
        super().__init__(seed=seed, expose=expose)

    def _on_bind(self, scene: Scene) -> None:
        model = scene.physics.model
        self.floor_materials, self.floor_texture, self.body_materials, self.body_texture = surfaces(model)
        self.floor_images = self.body_images = None
        if self.scale == 0:
            return
        if self.body_texture < 0 and len(self.body_materials):
            raise ValueError(
                f"TextureDistraction(scale={self.scale}) textures the bodies through one more 2D texture of the "
                f"model, {SURFACE_TEXTURE!r}, which this {scene.domain!r} model lacks: build the env inside "
                "`with dcs_torchrl.distractions.texture.surface_slot():` (make_env(texture_scale=...) does).")
        if not len(self.floor_materials) and not len(self.body_materials):
            raise ValueError(f"the {scene.domain!r} model has no textured floor and no body material: "
                             "TextureDistraction has nothing to texture; leave texture_scale at 0.")
        floor = np.zeros((0, 0, 3), np.uint8)
        if self.floor_texture >= 0:
            floor = texture_image(model, self.floor_texture, originals(scene.physics).texture(self.floor_texture))
        side = int(model.tex_width[self.body_texture]) if self.body_texture >= 0 else 0
        self.floor_images, self.body_images = _blends(self.textures, self.scale, floor, side)
        self._shown: tuple[int, int] | None = None
        self._upload: list[int] = []

    def _new_worlds(self, scene: Scene) -> "TextureWorlds":
        return TextureWorlds(1)

    def _edit_scene(self, physics) -> None:
        worlds, row = self._worlds, self.row
        if not worlds.placed[row]:
            return
        shown = (int(worlds.floor[row]), int(worlds.body[row]))
        if shown == self._shown:
            return
        model = physics.model
        for tex, image in ((self.floor_texture, self.floor_images), (self.body_texture, self.body_images)):
            if tex >= 0 and len(image):
                adr, k = int(model.tex_adr[tex]), shown[0] if tex == self.floor_texture else shown[1]
                model.tex_data[adr:adr + image[k].size] = image[k].reshape(-1)
                self._upload.append(tex)
        if self.body_texture >= 0:
            model.mat_texid[self.body_materials, _RGB] = self.body_texture
        self._shown = shown

    def upload_textures(self, context) -> None:
        """Called by RenderPixels right before it renders: sends the textures this distraction rewrote."""
        if getattr(self, "_upload", None):
            context.upload_textures(self._upload)
            self._upload = []

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros(2, dtype=np.int64)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(scale={self.scale}, texture_dir={self.texture_dir!r}, split={self.split!r})"


class TextureWorlds:
    """The texture distraction of N worlds as arrays: each world's floor and body texture (drawn at its
    episode start, :meth:`start`), written for the worlds at once into a renderer's per-world material
    textures (:meth:`place`). A :class:`TextureDistraction` on one env keeps its state in a one-world
    instance; a batch keeps its worlds' in one (:meth:`TextureDistraction.share`) and tells each world
    where its blends lie among the renderer's textures (:attr:`first`).

    Args:
        n (int): the worlds.
    """

    def __init__(self, n: int):
        self.n = n
        self.floor = np.full(n, -1, np.int64)
        self.body = np.full(n, -1, np.int64)
        self.placed = np.zeros(n, bool)
        #: per world, the renderer's texture id of its floor blend 0 and of its body blend 0 (-1: none)
        self.first = np.full((n, 2), -1, np.int64)
        self.floor_materials = np.zeros(0, np.int64)
        self.body_materials = np.zeros(0, np.int64)

    def start(self, row: int, distraction: TextureDistraction) -> None:
        """World ``row``'s episode start: a floor and a body texture drawn from ``distraction``'s generator."""
        self.placed[row] = distraction.scale > 0
        if not self.placed[row]:
            self.floor[row] = self.body[row] = -1
            return
        self.floor_materials, self.body_materials = distraction.floor_materials, distraction.body_materials
        k = len(distraction.textures)
        self.floor[row], self.body[row] = distraction._rng.integers(k, size=2)

    def advance(self, rows: np.ndarray) -> None:
        """Nothing: a world's textures stay for its episode."""

    def place(self, rows: np.ndarray, offset: int, mat_texid: np.ndarray) -> None:
        """Points the materials of the worlds ``rows`` whose textures the distraction sets at their draws:
        ``mat_texid[row - offset]`` (``[.., nmat]``, the RGB role's texture per material)."""
        rows = rows[self.placed[rows]]
        if not len(rows):
            return
        local = rows - offset
        if len(self.floor_materials):
            mat_texid[local[:, None], self.floor_materials[None]] = (self.first[rows, 0] + self.floor[rows])[:, None]
        if len(self.body_materials):
            mat_texid[local[:, None], self.body_materials[None]] = (self.first[rows, 1] + self.body[rows])[:, None]

    def states(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The exposed state (int64 ``[floor texture, body texture]``) of the worlds ``rows`` (all: ``None``)."""
        rows = np.arange(self.n) if rows is None else rows
        return np.stack([self.floor[rows], self.body[rows]], axis=1)
