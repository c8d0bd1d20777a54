"""EmbeddedSource: the default background videos, generated procedurally (no download).

DAVIS 2017 cannot be downloaded when the package is installed, so the suite ships a
stand-in: 60 training and 30 validation clips of 50-80 frames, each a textured scene
(sky, hills, fields, water, forest, street or indoor court) seen by a smoothly panning
and zooming camera, with one to four shaded objects moving through it (animals,
people, vehicles, birds, boats, balls), no cuts. They are *not* the paper's
backgrounds: to reproduce its numbers, download DAVIS 2017 (TrainVal 480p,
https://davischallenge.org/davis2017/code.html) and pass its folder, e.g.
``make_env(..., background_dir="~/data/DAVIS")`` or
``dcs_torchrl.videos.open_source("~/data/DAVIS")``.

A clip is generated the first time it is used (~0.1 s at 256x256), straight at the
texture size, and then shared through the frame cache. Each clip has a fixed seed, so
it is the same bits on every machine for a given numpy and OpenCV version (only IEEE
arithmetic and OpenCV's bit-exact ``INTER_LINEAR_EXACT`` resize are used).
"""
from __future__ import annotations

import cv2
import numpy as np

from dcs_torchrl.videos.actors import CAST, MAKERS, Actor, mirrored
from dcs_torchrl.videos.lists import canonical_split
from dcs_torchrl.videos.procedural import bezier, hsv, paste, render, uniform
from dcs_torchrl.videos.scenes import SCENES, paint
from dcs_torchrl.videos.source import VideoSource

GENERATOR_VERSION = 1  # bump when the clips change, so stale cache keys cannot be reused
CLIPS = {"train": 60, "val": 30}
LENGTHS = (50, 80)  # frames, inclusive; DAVIS 2017 videos average ~70
FPS = 24.0
POSES = 8  # gait phases rendered per actor
_SPLIT_IDS = {"train": 0, "val": 1}
# Scene of clip i: consecutive clips differ (the first b are varied for every b), a third are open landscapes.
SCENE_CYCLE = ("meadow", "city", "coast", "forest", "meadow", "arena")


def clip_seed(split: str, index: int) -> list[int]:
    """The seed of embedded clip ``index`` of ``split`` (train and val never share one)."""
    return [0xDC5, _SPLIT_IDS[canonical_split(split)], int(index)]


class _Track:
    """One actor moving through the world: its sprites per gait phase and its path."""

    def __init__(self, rng, actor: Actor, foot: float, height_px: float, length: int, width: int):
        self.foot = foot  # y of the feet in the world, in pixels: constant, the actor walks across
        facing = 1 if rng.random() < 0.5 else -1
        step = facing * actor.speed * height_px / FPS * uniform(rng, 0.6, 1.2)  # px per frame
        travel = step * (length - 1)
        lo, hi = 0.05 * width - min(travel, 0.0), 0.95 * width - max(travel, 0.0)  # stay in the world
        start = uniform(rng, *sorted((lo, hi)))
        wobble = [0.0, uniform(rng, -1, 1), uniform(rng, -1, 1), 0.0]
        t = np.linspace(0.0, 1.0, length)
        self.x = start + step * np.arange(length) + 0.15 * abs(travel) * bezier(wobble, t)
        phase0 = uniform(rng, 0, 1)
        distance = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(self.x)))])
        self.phase = phase0 + actor.stride * distance / height_px
        poses = [actor.pose(k / POSES) for k in range(POSES)]
        self.sprites = [render(mirrored(p) if facing < 0 else p, height_px) for p in poses]

    def draw(self, canvas: np.ndarray, t: int, left: int, top: int) -> None:
        pose = int(np.floor(self.phase[t] * POSES)) % POSES
        paste(canvas, self.sprites[pose], self.x[t] - left, self.foot - top)


def generate_clip(seed, size: int, scene: str | None = None) -> np.ndarray:
    """One embedded clip as uint8 [T, size, size, 3] (RGB), T in [50, 80], from its seed.

    Args:
        seed: anything ``np.random.default_rng`` accepts (see :func:`clip_seed`).
        size (int): side of the square frames; the scene is drawn at this resolution.
        scene (str, optional): one of ``scenes.SCENES``; drawn from the seed if ``None``.

    Examples:
        >>> clip = generate_clip(clip_seed("train", 0), 64)
        >>> clip.dtype, clip.shape[1:]
        (dtype('uint8'), (64, 64, 3))
    """
    if scene is not None and scene not in SCENES:
        raise ValueError(f"unknown scene {scene!r}: use one of {SCENES} or None.")
    rng = np.random.default_rng(seed)
    length = int(rng.integers(LENGTHS[0], LENGTHS[1] + 1))
    drawn = SCENES[int(rng.integers(len(SCENES)))]
    kind = drawn if scene is None else scene
    height, width = round(1.4 * size), round(2.2 * size)  # the camera sees up to 1.35 size
    low, high = {"arena": (0.3, 0.6), "city": (0.35, 0.7)}.get(kind, (-0.25, 0.7))
    horizon = height * uniform(rng, low, high)
    world = paint(rng, kind, height, width, horizon)
    ground = max(horizon, 0.0)

    # the main subject, near the camera; the camera follows it more or less closely
    mains, extras = CAST[kind]
    actor = MAKERS[mains[int(rng.integers(len(mains)))]](rng)
    if kind == "coast" and actor.kind == "person":  # a surfer
        actor.params["board"] = hsv(uniform(rng, 0, 1), uniform(rng, 0.2, 0.9), uniform(rng, 0.6, 1.0))
    foot = ground + (height - ground) * uniform(rng, 0.5, 0.92)
    subject_px = min(max((foot - horizon) * uniform(rng, 0.4, 0.8), 0.15 * size), 0.45 * size)
    subject = _Track(rng, actor, foot, subject_px, length, width)
    tracks = [subject]
    for _ in range(int(rng.integers(0, 4))):
        actor = MAKERS[extras[int(rng.integers(len(extras)))]](rng)
        if actor.where == "sky":
            if horizon < 0.25 * height:
                continue
            foot = uniform(rng, 0.1, 0.8) * horizon
            px = size * uniform(rng, 0.04, 0.1)
        else:
            foot = ground + (height - ground) * uniform(rng, 0.05, 0.95)
            px = min(max((foot - horizon) * uniform(rng, 0.3, 0.7), 0.04 * size), 0.4 * size)
        tracks.append(_Track(rng, actor, foot, px, length, width))
    tracks.sort(key=lambda track: track.foot)  # far ones first

    # the camera: a square window of side zoom * size pixels of the world
    t = np.linspace(0.0, 1.0, length)
    zoom = bezier([uniform(rng, 1.0, 1.35) for _ in range(4)], t)
    follow = uniform(rng, 0.3, 1.0)
    pan = bezier([uniform(rng, 0.3, 0.7) * width for _ in range(4)], t)
    lead = uniform(rng, -0.15, 0.15) * size
    centre_x = follow * (subject.x + lead) + (1 - follow) * pan
    centre_y = bezier([subject.foot - uniform(rng, 0.1, 0.35) * size for _ in range(4)], t)

    out = np.empty((length, size, size, 3), np.uint8)
    for i in range(length):
        side = min(int(np.floor(zoom[i] * size + 0.5)), height)
        left = int(np.clip(np.floor(centre_x[i] - side / 2 + 0.5), 0, width - side))
        top = int(np.clip(np.floor(centre_y[i] - side / 2 + 0.5), 0, height - side))
        canvas = world[top : top + side, left : left + side].copy()
        for track in tracks:
            track.draw(canvas, i, left, top)
        cv2.resize(canvas, (size, size), dst=out[i], interpolation=cv2.INTER_LINEAR_EXACT)
    return out


class EmbeddedSource(VideoSource):
    """The default background videos: 60 train and 30 val procedural clips, no download needed.

    A stand-in for DAVIS 2017 with the same split sizes (see the module docstring), *not*
    the paper's backgrounds: for those, use :class:`DavisSource` on a local copy of DAVIS.

    Args:
        split (str): ``"train"`` (alias ``"training"``, 60 clips) or ``"val"``
            (``"validation"``, ``"test"``, 30 clips, disjoint from the training ones).

    Examples:
        >>> from dcs_torchrl.videos import EmbeddedSource
        >>> videos = EmbeddedSource("val")
        >>> len(videos), videos.names[0]
        (30, 'embedded-val-00')
    """

    more_hint = (
        "point at a folder with more videos (dcs_torchrl.videos.open_source(path)); like DAVIS 2017, "
        "the embedded set has 60 train and 30 val videos"
    )

    def __init__(self, split: str = "train"):
        self.split = canonical_split(split)
        names = [f"embedded-{self.split}-{i:02d}" for i in range(CLIPS[self.split])]
        super().__init__(names, ("embedded", GENERATOR_VERSION, self.split))

    def _decode(self, index: int, size: int) -> np.ndarray:
        return generate_clip(clip_seed(self.split, index), size, SCENE_CYCLE[index % len(SCENE_CYCLE)])

    def __repr__(self) -> str:
        return f"EmbeddedSource(split={self.split!r})"
