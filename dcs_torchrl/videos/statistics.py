"""Image statistics of background frames: contrast, saturation, edges, spectral slope.

One definition shared by the tests of the embedded clips and by
``benchmarks/natural_clips.py``, so "the stand-ins reach natural-image contrast" means
the same numbers everywhere. Each statistic is computed per frame and averaged over the
frames given:

- ``contrast``: RMS contrast, the standard deviation over the frame's pixels of its
  luminance Y = 0.299 R + 0.587 G + 0.114 B (Rec. 601 weights) with R, G, B in [0, 1].
- ``saturation``: the mean of OpenCV's HSV saturation channel (``cv2.COLOR_RGB2HSV`` on
  the uint8 frame, S / 255, so in [0, 1]; S = (max - min) / max of R, G, B, 0 on black).
- ``gradient``: the mean over pixels of |Sobel_x| + |Sobel_y| of the luminance in grey
  levels (Y * 255), each 3x3 Sobel response divided by 8 so that a ramp rising by one
  grey level per pixel scores 1 (borders: reflected, OpenCV's default).
- ``slope``: the spectral slope, the least-squares slope of log power against log
  spatial frequency, the power being the radially averaged |FFT|^2 of the mean-removed,
  Hann-windowed luminance, over frequencies 4/N .. 0.4 cycles per pixel (natural images:
  about -2).

Two more per clip (:func:`clip_statistics`):

- ``motion``: the mean over consecutive frames of the mean |ΔY| in grey levels (Y * 255).
- ``brightness``: the mean luminance Y of the part of the frames the tasks' cameras look at
  most (:func:`looked_at`: the lower three quarters, middle half of the columns).

Examples:
    >>> import numpy as np
    >>> from dcs_torchrl.videos.statistics import frame_statistics
    >>> frame_statistics(np.zeros((2, 32, 32, 3), np.uint8))["contrast"]
    0.0
"""
from __future__ import annotations

import cv2
import numpy as np

LUMA = np.array([0.299, 0.587, 0.114])  # Rec. 601
NAMES = ("contrast", "saturation", "gradient", "slope")
CLIP_NAMES = NAMES + ("motion", "brightness")


def looked_at(frames: np.ndarray) -> np.ndarray:
    """The part of square frames [..., S, S, 3] the six tasks' cameras see most of when the video is
    their sky: rows S/4 to S (cartpole looks at the upper middle of that, ball_in_cup, finger and
    walker at its lower part), columns S/4 to 3S/4."""
    size = frames.shape[-2]
    return frames[..., size // 4 :, size // 4 : 3 * size // 4, :]


def luminance(frames: np.ndarray) -> np.ndarray:
    """Rec. 601 luminance in [0, 1] of uint8 RGB frames [..., 3], as float64 [...]."""
    return (np.asarray(frames, np.float64) / 255.0) @ LUMA


def _slope(y: np.ndarray) -> float:
    n = min(y.shape)
    y = y[:n, :n] - y[:n, :n].mean()
    hann = np.hanning(n)
    power = np.abs(np.fft.fft2(y * np.outer(hann, hann))) ** 2
    f = np.fft.fftfreq(n)
    radius = np.sqrt(f[:, None] ** 2 + f[None, :] ** 2)
    bins = np.round(radius * n).astype(int)
    keep = (bins >= 4) & (radius <= 0.4)
    sums = np.bincount(bins[keep], power[keep])
    counts = np.bincount(bins[keep])
    k = np.nonzero(counts)[0]
    spectrum = sums[k] / counts[k]
    if np.any(spectrum <= 0) or len(k) < 2:
        return float("nan")
    return float(np.polyfit(np.log(k / n), np.log(spectrum), 1)[0])


def frame_statistics(frames: np.ndarray, slope: bool = True) -> dict[str, float]:
    """The mean over ``frames`` of each frame's contrast, saturation, gradient (and slope).

    Args:
        frames (np.ndarray): uint8 RGB, [T, H, W, 3] or one frame [H, W, 3].
        slope (bool): also the spectral slope (an FFT per frame: the slowest of the four).

    Returns:
        dict with ``contrast``, ``saturation``, ``gradient`` and, if ``slope``, ``slope``
        (definitions in the module docstring).
    """
    frames = np.asarray(frames)
    if frames.dtype != np.uint8 or frames.shape[-1] != 3 or frames.ndim not in (3, 4):
        raise ValueError(f"frames must be uint8 RGB [T, H, W, 3] or [H, W, 3], got {frames.dtype} {frames.shape}.")
    if frames.ndim == 3:
        frames = frames[None]
    sums = dict.fromkeys(NAMES[:4] if slope else NAMES[:3], 0.0)
    for frame in frames:
        y = luminance(frame)
        sums["contrast"] += float(y.std())
        sums["saturation"] += float(cv2.cvtColor(np.ascontiguousarray(frame), cv2.COLOR_RGB2HSV)[..., 1].mean()) / 255
        grey = y * 255.0
        gx = cv2.Sobel(grey, cv2.CV_64F, 1, 0, ksize=3) / 8.0
        gy = cv2.Sobel(grey, cv2.CV_64F, 0, 1, ksize=3) / 8.0
        sums["gradient"] += float(np.mean(np.abs(gx) + np.abs(gy)))
        if slope:
            sums["slope"] += _slope(y)
    return {name: total / len(frames) for name, total in sums.items()}


def warmth(frames: np.ndarray) -> float:
    """The mean R - B (R, G, B in [0, 1]) of :func:`looked_at` of uint8 frames [..., S, S, 3]."""
    part = looked_at(np.asarray(frames)).astype(np.float64) / 255.0
    return float(np.mean(part[..., 0] - part[..., 2]))


def clip_statistics(clips, frames_per_clip: int | None = None, slope: bool = True) -> list[dict[str, float]]:
    """:func:`frame_statistics` of each clip (uint8 [T, S, S, 3]), on all its frames or
    ``frames_per_clip`` evenly spaced ones, with its ``motion`` (over all its frames) and
    ``brightness`` (see the module docstring)."""
    out = []
    for clip in clips:
        y = luminance(clip) * 255.0
        extra = {"motion": float(np.mean(np.abs(np.diff(y, axis=0)))) if len(clip) > 1 else 0.0,
                 "brightness": float(looked_at(y[..., None])[..., 0].mean()) / 255.0}
        if frames_per_clip is not None and len(clip) > frames_per_clip:
            clip = clip[np.linspace(0, len(clip) - 1, frames_per_clip).round().astype(int)]
        out.append(frame_statistics(clip, slope=slope) | extra)
    return out


def summary(per_clip: list[dict[str, float]]) -> dict[str, tuple[float, float]]:
    """(mean, min) over clips of each statistic of :func:`clip_statistics`."""
    return {name: (float(np.mean([s[name] for s in per_clip])), float(np.min([s[name] for s in per_clip])))
            for name in per_clip[0]}
