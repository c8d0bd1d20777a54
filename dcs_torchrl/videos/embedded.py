"""EmbeddedSource: the default background videos, generated procedurally (no download).

DAVIS 2017 cannot be downloaded when the package is installed, so the suite ships a
stand-in: 60 training and 30 validation clips of 50-80 frames, each a textured scene
(sky, hills, fields, water, forest, street or court with a crowd) with still props
(bushes, rocks, flowers, signs, cones, crates, parasols) seen by a smoothly panning and
zooming camera that follows one large subject near the middle of the frame (an animal,
a person, a vehicle or a boat, as DAVIS shows), with one to four more patterned, shaded
objects moving through it, no cuts. Since version 2 they are colour-graded to natural-image
statistics (see :mod:`dcs_torchrl.videos.statistics`): luminance RMS contrast ~0.21 and HSV
saturation ~0.47 per split in version 3 (:data:`EMBEDDED_VERSION`; every clip >= 0.17 and
>= 0.28), like slow pans over natural photographs (~0.21 and ~0.49;
``benchmarks/natural_clips.py``); version 1 had ~0.13 and ~0.33. Version 3 also sets each clip's brightness and warmth (mean
R - B) where the tasks' cameras look to natural-photo levels (:func:`tone`), spread so that
the first b clips span the natural range for every b (the benchmarks use b = 4, 8 and 60):
version 2's clips were darker and much cooler there than natural footage, and so distracted
the shipped agents less. They are *not* the paper's
backgrounds: to reproduce its numbers, download DAVIS 2017 (TrainVal 480p,
https://davischallenge.org/davis2017/code.html) and pass its folder, e.g.
``make_env(..., background_dir="~/data/DAVIS")`` or
``dcs_torchrl.videos.open_source("~/data/DAVIS")``.

A clip is generated the first time it is used, straight at the
texture size, and then shared through the frame cache. Each clip has a fixed seed, so
it is the same bits on every machine for a given numpy and OpenCV version (only IEEE
arithmetic, numpy's power for the tone curves' tables and OpenCV's bit-exact
``INTER_LINEAR_EXACT`` resize are used; the colour grade's means, gains and gammas are
rounded to coarse steps so a reduction's last bit cannot change them).
"""
from __future__ import annotations

import cv2
import numpy as np

from dcs_torchrl.videos.actors import CAST, MAKERS, PROPS, SUBJECT_SIZE, Actor, mirrored, prop, vivid
from dcs_torchrl.videos.lists import canonical_split
from dcs_torchrl.videos.procedural import F32, bezier, paste, render, uniform
from dcs_torchrl.videos.scenes import SCENES, paint
from dcs_torchrl.videos.source import VideoSource
from dcs_torchrl.videos.statistics import looked_at

# The version of the embedded set: results computed on different versions are not comparable, so
# every run records it (EmbeddedSource.version). 1: the first stand-ins (luminance RMS contrast ~0.13,
# HSV saturation ~0.33); 2: natural-image statistics (see the module docstring); 3: as 2, each clip's
# brightness and warmth where the tasks' cameras look set to natural-photo levels (tone), stratified so
# that every prefix of the training list (the first b videos) spans the same ranges. Bump it whenever a
# clip's bytes change; it is part of the frame cache key, so stale frames are never reused.
EMBEDDED_VERSION = 3
GENERATOR_VERSION = EMBEDDED_VERSION  # the name before version 2
CLIPS = {"train": 60, "val": 30}
LENGTHS = (50, 80)  # frames, inclusive; DAVIS 2017 videos average ~70
FPS = 24.0
POSES = 8  # gait phases rendered per actor
LUMA = (F32(0.299), F32(0.587), F32(0.114))  # Rec. 601, as in dcs_torchrl.videos.statistics


def _luma(image: np.ndarray) -> np.ndarray:
    """Luminance of float32 RGB, by elementwise arithmetic (a matmul could go through BLAS and vary)."""
    return image[..., 0] * LUMA[0] + image[..., 1] * LUMA[1] + image[..., 2] * LUMA[2]
_SPLIT_IDS = {"train": 0, "val": 1}
# Scene of clip i: consecutive clips differ (the first b are varied for every b), a third are open landscapes.
SCENE_CYCLE = ("meadow", "city", "coast", "forest", "meadow", "arena")


def clip_seed(split: str, index: int) -> list[int]:
    """The seed of embedded clip ``index`` of ``split`` (train and val never share one)."""
    return [0xDC5, _SPLIT_IDS[canonical_split(split)], int(index)]


class _Track:
    """One actor moving through the world: its sprites per gait phase and its path."""

    def __init__(self, rng, actor: Actor, foot: float, height_px: float, length: int, width: int,
                 near: float | None = None, size: int = 0, span: tuple[float, float] = (0.05, 0.95),
                 reach: float = 1.0):
        self.foot = foot  # y of the feet in the world, in pixels: constant, the actor walks across
        facing = 1 if rng.random() < 0.5 else -1
        step = facing * actor.speed * height_px / FPS * uniform(rng, 0.6, 1.2)  # px per frame
        step = float(np.clip(step, -reach * width / length, reach * width / length))  # stays in the world
        travel = step * (length - 1)
        lo, hi = span[0] * width - min(travel, 0.0), span[1] * width - max(travel, 0.0)  # stay in the world
        if near is not None:  # start near x = near (within a frame side), where the camera looks
            lo, hi = max(lo, near - 0.6 * size - travel / 2), min(hi, near + 0.6 * size - travel / 2)
        start = uniform(rng, *sorted((lo, hi)))
        wobble = [0.0, uniform(rng, -1, 1), uniform(rng, -1, 1), 0.0]
        t = np.linspace(0.0, 1.0, length)
        self.x = start + step * np.arange(length) + 0.15 * abs(travel) * bezier(wobble, t)
        phase0 = uniform(rng, 0, 1)
        distance = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(self.x)))])
        self.phase = phase0 + actor.stride * distance / height_px
        poses = [actor.pose(k / POSES) for k in range(POSES)]
        self.sprites = [render(mirrored(p) if facing < 0 else p, height_px) for p in poses]
        self.rise = float(self.sprites[0].anchor[1] - self.sprites[0].cover.shape[0] / 2)  # middle above the foot

    def draw(self, canvas: np.ndarray, t: int, left: int, top: int) -> None:
        pose = int(np.floor(self.phase[t] * POSES)) % POSES
        paste(canvas, self.sprites[pose], self.x[t] - left, self.foot - top)


# Colour grade of each clip, as a camera's picture style, so that every clip reaches natural-photo
# statistics (dcs_torchrl.videos.statistics; pans over natural photographs: ~0.21 and ~0.5):
# 1. the world (the still background, props included): the luminance RMS contrast of the part the
#    camera visits is raised to at least GRADE_CONTRAST and its mean HSV saturation brought to
#    GRADE_SATURATION if outside [GRADE_SATURATION, MAX_SATURATION];
# 2. the finished frames, only if large pale actors still leave the clip below FLOOR_CONTRAST or
#    FLOOR_SATURATION (measured on every 8th frame): raised to those.
GRADE_CONTRAST, GRADE_SATURATION, MAX_SATURATION = 0.23, 0.5, 0.6
FLOOR_CONTRAST, FLOOR_SATURATION = 0.2, 0.43
_STEP = 64  # gains and means are rounded to multiples of 1/64 or 1/1024: a last-bit difference cannot matter


def _graded(image: np.ndarray, contrast: float, saturation: float, mean: float, pull: float) -> np.ndarray:
    """float32 RGB in [0, 1]: chroma times ``saturation``, luminance deviations from ``mean`` times
    ``contrast``, the mean moved by ``pull`` of the way to mid-grey 0.45 (less clipping)."""
    y = _luma(image)[..., None]
    out = (image - y) * F32(saturation)
    out += (y - F32(mean)) * F32(contrast) + F32(mean + (0.45 - mean) * pull)
    return np.clip(out, F32(0), F32(1))


def _hsv_saturation(image: np.ndarray) -> float:
    top, low = image.max(axis=-1), image.min(axis=-1)
    return float(np.mean(np.where(top > 0, (top - low) / np.maximum(top, F32(1e-6)), 0), dtype=np.float64))


def _gains(sample: np.ndarray, contrast_to: float, saturation_to: float, saturation_max: float, pull: float):
    """(contrast gain, saturation gain, mean) that bring the float32 ``sample`` to the targets."""
    mean = float(np.floor(np.mean(_luma(sample), dtype=np.float64) * 1024) / 1024)
    contrast = saturation = 1.0
    for _ in range(4):  # fixed-point steps: clipping at 0 and 1 makes the gains non-linear
        graded = _graded(sample, contrast, saturation, mean, pull)
        c = float(np.std(_luma(graded), dtype=np.float64))
        s = _hsv_saturation(graded)
        if c < contrast_to:
            contrast = min(max(contrast * contrast_to / max(c, 1e-3), 1.0), 4.0)
        if s < saturation_to or s > saturation_max:
            saturation = min(max(saturation * saturation_to / max(s, 1e-3), 0.5), 3.5)
    return float(np.ceil(contrast * _STEP) / _STEP), float(np.ceil(saturation * _STEP) / _STEP), mean


def grade(world: np.ndarray, region: tuple[slice, slice]) -> np.ndarray:
    """``world`` (uint8) graded so that its ``region`` reaches GRADE_CONTRAST and GRADE_SATURATION.

    The gains come from a 1-in-3 subsample of the region in a few fixed-point steps and are
    rounded up to multiples of 1/64 before the whole world is graded with them.
    """
    sample = world[region][::3, ::3].astype(F32) / F32(255)
    contrast, saturation, mean = _gains(sample, GRADE_CONTRAST, GRADE_SATURATION, MAX_SATURATION, 0.5)
    if contrast == 1.0 and saturation == 1.0:
        return world
    graded = _graded(world.astype(F32) / F32(255), contrast, saturation, mean, 0.5)
    return np.floor(graded * F32(255) + F32(0.5)).astype(np.uint8)


def floor_grade(frames: np.ndarray) -> None:
    """Raises a finished clip (uint8, in place) to FLOOR_CONTRAST and FLOOR_SATURATION if below."""
    sample = frames[::8, ::3, ::3].astype(F32) / F32(255)
    contrast, saturation, mean = _gains(sample, FLOOR_CONTRAST, FLOOR_SATURATION, 1.0, 0.0)
    if contrast == 1.0 and saturation == 1.0:
        return
    for frame in frames:
        graded = _graded(frame.astype(F32) / F32(255), contrast, saturation, mean, 0.0)
        frame[...] = np.floor(graded * F32(255) + F32(0.5)).astype(np.uint8)


# Tone (version 3): where the six tasks' cameras look into the sky (statistics.looked_at), each clip's
# mean Rec. 601 luminance and its warmth, the mean of R - B (R, G, B in [0, 1]), are brought to the clip's
# targets by per-channel curves. Pans over natural photographs (benchmarks/natural_clips.py) have
# brightness 0.40 and warmth 0.19 there on average (5-95%: 0.2-0.6 and -0.15-0.45: skin, fur, wood,
# brick, flowers); version 2's graded scenes, bright sky over darker ground, blue and green, had 0.36 and
# 0.04. A cool background differs little from the tasks' blue skies, a warm one a lot: over single clips
# the shipped cartpole agent's score at beta_bg = 0.3 follows warmth more than any other statistic
# (docs/results.md). The targets spread evenly over BRIGHTNESS and WARMTH along a Halton sequence (base 2
# and base 3), so the first b clips span both ranges for every b.
BRIGHTNESS = (0.3, 0.54)
WARMTH = (-0.1, 0.46)


def van_der_corput(n: int, base: int = 2) -> float:
    """The n-th (n >= 1) point of the van der Corput sequence in (0, 1): 1/2, 1/4, 3/4, 1/8, ... in base 2."""
    out, scale = 0.0, 1.0 / base
    while n:
        n, digit = divmod(n, base)
        out += scale * digit
        scale /= base
    return out


def tone_targets(index: int) -> tuple[float, float]:
    """Clip ``index``'s (brightness, warmth) targets (see BRIGHTNESS and WARMTH), multiples of 1/1024."""
    return tuple(float(np.floor((low + (high - low) * van_der_corput(index + 1, base)) * 1024) / 1024)
                 for (low, high), base in ((BRIGHTNESS, 2), (WARMTH, 3)))


def _solve(measure, target: float, low: float, high: float) -> float:
    """The x in [low, high] (a multiple of 1/64) where the increasing ``measure(x)`` meets ``target``."""
    for _ in range(12):
        middle = (low + high) / 2
        low, high = (low, middle) if measure(middle) > target else (middle, high)
    return round((low + high) / 2 * _STEP) / _STEP


_LEVELS = np.arange(256, dtype=np.float64) / 255.0


def _table(curve: np.ndarray) -> np.ndarray:
    return np.floor(np.clip(curve, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _tables(gamma: float, warm: float) -> np.ndarray:
    """uint8 [3, 256]: R times 1 + warm, B times 1 - warm, then every channel to the power gamma."""
    gains = np.array([1.0 + warm, 1.0, 1.0 - warm])[:, None]
    return _table(np.clip(_LEVELS[None, :] * gains, 0.0, 1.0) ** gamma)


def _apply(frames: np.ndarray, tables: np.ndarray) -> np.ndarray:
    return np.stack([tables[c][frames[..., c]] for c in range(3)], axis=-1)


def tone(frames: np.ndarray, brightness: float, warmth: float) -> None:
    """Sets the mean luminance and the mean R - B of ``looked_at(frames)`` (uint8, in place) to
    ``brightness`` and ``warmth``: R and B scaled by 1 + w and 1 - w (w in [-0.75, 0.75]), then every
    channel through a gamma curve (gamma in [1/4, 4]), each a multiple of 1/64 found by bisection,
    two rounds. Lookup tables: black stays black, and each channel keeps the order of its values."""
    sample = np.ascontiguousarray(looked_at(frames[::4, ::2, ::2]))  # every 4th frame, every 2nd pixel

    def stats(gamma: float, warm: float) -> tuple[float, float]:
        graded = _apply(sample, _tables(gamma, warm)).astype(np.float64) / 255.0
        luma = graded[..., 0] * 0.299 + graded[..., 1] * 0.587 + graded[..., 2] * 0.114
        return float(np.mean(luma)), float(np.mean(graded[..., 0] - graded[..., 2]))

    gamma, warm = 1.0, 0.0
    for _ in range(2):
        warm = _solve(lambda w: stats(gamma, w)[1], warmth, -0.75, 0.75)
        gamma = -_solve(lambda g: stats(-g, warm)[0], brightness, -4.0, -0.25)  # the mean falls as gamma grows
    if (gamma, warm) != (1.0, 0.0):
        frames[...] = _apply(frames, _tables(gamma, warm))


def generate_clip(seed, size: int, scene: str | None = None,
                  tone_to: tuple[float, float] | None = None) -> np.ndarray:
    """One embedded clip as uint8 [T, size, size, 3] (RGB), T in [50, 80], from its seed.

    Args:
        seed: anything ``np.random.default_rng`` accepts (see :func:`clip_seed`).
        size (int): side of the square frames; the scene is drawn at this resolution.
        scene (str, optional): one of ``scenes.SCENES``; drawn from the seed if ``None``.
        tone_to (tuple, optional): (brightness, warmth) where the cameras look (:func:`tone`);
            ``None`` leaves the graded clip's own.

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
    height, width = round(1.4 * size), round(2.2 * size)  # the camera sees up to 1.3 size
    low, high = {"arena": (0.25, 0.5), "city": (0.3, 0.55)}.get(kind, (0.05, 0.5))
    horizon = height * uniform(rng, low, high)

    # the main subject, large and near the camera, which follows it closely (DAVIS-like)
    mains, extras = CAST[kind]
    actor = MAKERS[mains[int(rng.integers(len(mains)))]](rng)
    if kind == "coast" and actor.kind == "person":  # a surfer
        actor.params["board"] = vivid(rng)
    subject_px = size * uniform(rng, *SUBJECT_SIZE[actor.kind])
    subject = _Track(rng, actor, 0.0, subject_px, length, width, span=(0.3, 0.7), reach=0.35)
    # the world is 1.4 sides tall, so the camera's centre stays near y = 0.7 side: the subject's middle too
    subject.foot = foot = min(0.7 * size + subject.rise + uniform(rng, -0.05, 0.05) * size, height - 1.0)
    horizon = min(horizon, foot - 0.1 * size)
    ground = max(horizon, 0.0)
    world = paint(rng, kind, height, width, horizon)
    middle = float(subject.x.mean())

    # still props on the ground around the subject's path, far ones first
    spots = sorted(uniform(rng, 0.05, 1.0) for _ in range(int(rng.integers(6, 13))))
    for depth in spots:
        kinds = PROPS[kind]
        foot_y = ground + (height - ground) * depth
        px = size * (0.08 + 0.4 * depth) * uniform(rng, 0.6, 1.2)
        x = middle + uniform(rng, -1.0, 1.0) * size
        if kind == "coast" and depth < 0.5:
            continue  # nothing stands far out at sea
        paste(world, render(prop(rng, kinds[int(rng.integers(len(kinds)))]), px), x, foot_y)

    tracks = [subject]
    for _ in range(int(rng.integers(1, 5))):
        actor = MAKERS[extras[int(rng.integers(len(extras)))]](rng)
        if actor.where == "sky":
            if horizon < 0.25 * height:
                continue
            foot = uniform(rng, 0.1, 0.8) * horizon
            px = size * uniform(rng, 0.08, 0.2)
        else:
            foot = ground + (height - ground) * uniform(rng, 0.2, 1.0)
            px = size * uniform(rng, 0.2, 0.6) * (0.4 + 0.6 * (foot - ground) / max(height - ground, 1.0))
        tracks.append(_Track(rng, actor, foot, px, length, width, near=middle, size=size, reach=0.6))
    tracks.sort(key=lambda track: track.foot)  # far ones first

    # the camera: a square window of side zoom * size pixels of the world, centred on the subject
    t = np.linspace(0.0, 1.0, length)
    zoom = bezier([uniform(rng, 1.0, 1.3) for _ in range(4)], t)
    follow = uniform(rng, 0.6, 1.0)
    pan = bezier([middle + uniform(rng, -0.4, 0.4) * size for _ in range(4)], t)
    lead = uniform(rng, -0.1, 0.1) * size
    centre_x = follow * (subject.x + lead) + (1 - follow) * pan
    centre_y = bezier([subject.foot - subject.rise + uniform(rng, -0.1, 0.1) * size for _ in range(4)], t)
    windows = []
    for i in range(length):
        side = min(int(np.floor(zoom[i] * size + 0.5)), height)
        left = int(np.clip(np.floor(centre_x[i] - side / 2 + 0.5), 0, width - side))
        top = int(np.clip(np.floor(centre_y[i] - side / 2 + 0.5), 0, height - side))
        windows.append((left, top, side))
    seen = (slice(min(w[1] for w in windows), max(w[1] + w[2] for w in windows)),
            slice(min(w[0] for w in windows), max(w[0] + w[2] for w in windows)))
    world = grade(world, seen)

    out = np.empty((length, size, size, 3), np.uint8)
    for i, (left, top, side) in enumerate(windows):
        canvas = world[top : top + side, left : left + side].copy()
        for track in tracks:
            track.draw(canvas, i, left, top)
        cv2.resize(canvas, (size, size), dst=out[i], interpolation=cv2.INTER_LINEAR_EXACT)
    floor_grade(out)
    if tone_to is not None:
        tone(out, *tone_to)
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

    version = EMBEDDED_VERSION  # of the clips' content: record it with results (see EMBEDDED_VERSION)
    more_hint = (
        "point at a folder with more videos (dcs_torchrl.videos.open_source(path)); like DAVIS 2017, "
        "the embedded set has 60 train and 30 val videos"
    )

    def __init__(self, split: str = "train"):
        self.split = canonical_split(split)
        names = [f"embedded-{self.split}-{i:02d}" for i in range(CLIPS[self.split])]
        super().__init__(names, ("embedded", EMBEDDED_VERSION, self.split))

    def _decode(self, index: int, size: int) -> np.ndarray:
        return generate_clip(clip_seed(self.split, index), size, SCENE_CYCLE[index % len(SCENE_CYCLE)],
                             tone_targets(index))

    def __repr__(self) -> str:
        return f"EmbeddedSource(split={self.split!r})"
