"""VideoSource: an ordered set of background videos, decoded once per process.

Every source answers ``frames(index, size)`` with a read-only uint8 array
[T, size, size, 3] (RGB, each frame squashed to the square sky texture like the
authors' code), decoded through the shared :mod:`~dcs_torchrl.videos.cache`.
"""
from __future__ import annotations

import uuid
import weakref
from collections.abc import Hashable, Sequence

import cv2
import numpy as np

from dcs_torchrl.videos.cache import FRAME_CACHE


def check_size(size) -> int:
    """``size`` as a positive int (the side of the square texture in pixels)."""
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"size must be a positive number of pixels (e.g. 256), got {size!r}.")
    return int(size)


class VideoSource:
    """An ordered set of videos whose frames are decoded once per process and shared.

    Subclasses set ``names`` and ``cache_key`` (via ``__init__``) and implement
    ``_decode(index, size)``; :meth:`frames` does the caching, checks and read-only
    flag. Use :func:`dcs_torchrl.videos.open_source` to get one from a path.

    Args:
        names (sequence of str): the video names, in order (unique).
        cache_key (hashable): identifies the videos' content across instances, e.g.
            ``("davis", "/data/DAVIS/JPEGImages/480p")``.
    """

    more_hint = "point at a folder with more videos (dcs_torchrl.videos.open_source(path))"

    def __init__(self, names: Sequence[str], cache_key: Hashable):
        names = tuple(names)
        if len(set(names)) != len(names):
            duplicates = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"video names must be unique, got duplicates {duplicates}.")
        self._names = names
        self._cache_key = cache_key

    @property
    def names(self) -> tuple[str, ...]:
        """The video names, in order."""
        return self._names

    @property
    def cache_key(self) -> Hashable:
        """The key of this source's videos in the process-wide frame cache."""
        return self._cache_key

    def __len__(self) -> int:
        return len(self._names)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({len(self)} videos)"

    def frames(self, index: int, size: int = 256) -> np.ndarray:
        """All frames of video ``index`` as a read-only uint8 array [T, size, size, 3], RGB.

        Decoded on first use and then shared by every caller in the process.

        Args:
            index (int): position of the video in :attr:`names`.
            size (int): side of the square frames (the sky texture size).

        Examples:
            >>> import numpy as np
            >>> from dcs_torchrl.videos import ArraySource
            >>> source = ArraySource([np.zeros((5, 48, 64, 3), np.uint8)])
            >>> source.frames(0, 32).shape
            (5, 32, 32, 3)
        """
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"video index must be an int, got {type(index).__name__}.")
        if not 0 <= index < len(self):
            raise IndexError(f"video index {index} is out of range for {self!r}: use 0 .. {len(self) - 1}.")
        size = check_size(size)
        index = int(index)
        return FRAME_CACHE.get((self.cache_key, self._names[index], size), lambda: self._checked(index, size))

    def _checked(self, index: int, size: int) -> np.ndarray:
        video = self._decode(index, size)
        if video.dtype != np.uint8 or video.ndim != 4 or video.shape[1:] != (size, size, 3) or len(video) == 0:
            raise RuntimeError(
                f"{type(self).__name__}._decode returned {video.dtype} {video.shape} for "
                f"{self._names[index]!r}, expected uint8 [T >= 1, {size}, {size}, 3]."
            )
        return np.ascontiguousarray(video)

    def _decode(self, index: int, size: int) -> np.ndarray:
        raise NotImplementedError(f"{type(self).__name__} must implement _decode(index, size).")

    def first(self, num_videos: int | None) -> VideoSource:
        """The first ``num_videos`` videos (b in the paper), sharing this source's cache.

        Args:
            num_videos (int, optional): how many, from the start of :attr:`names`;
                ``None`` keeps all of them, 0 none.

        Examples:
            >>> from dcs_torchrl.videos import EmbeddedSource
            >>> EmbeddedSource("train").first(4).names
            ('embedded-train-00', 'embedded-train-01', 'embedded-train-02', 'embedded-train-03')
        """
        if num_videos is None:
            return self
        if isinstance(num_videos, bool) or not isinstance(num_videos, (int, np.integer)):
            raise TypeError(f"num_videos must be an int or None (all videos), got {type(num_videos).__name__}.")
        num_videos = int(num_videos)
        if num_videos < 0:
            raise ValueError(f"num_videos must be >= 0 (0 = no background videos), got {num_videos}.")
        if num_videos > len(self):
            raise ValueError(
                f"num_videos={num_videos} but {self!r} has only {len(self)} videos: "
                f"lower num_videos to at most {len(self)}, or {self.more_hint}."
            )
        if num_videos == len(self):
            return self
        return FirstVideos(self, num_videos)


class FirstVideos(VideoSource):
    """The first ``num_videos`` videos of another source (see :meth:`VideoSource.first`)."""

    def __init__(self, parent: VideoSource, num_videos: int):
        super().__init__(parent.names[:num_videos], parent.cache_key)
        self.parent = parent
        self.more_hint = parent.more_hint

    def _decode(self, index: int, size: int) -> np.ndarray:
        return self.parent._decode(index, size)

    def first(self, num_videos: int | None) -> VideoSource:
        subset = super().first(num_videos)  # checks num_videos against this subset
        return subset if subset is self else self.parent.first(len(subset))

    def __repr__(self) -> str:
        return f"{self.parent!r}.first({len(self)})"


def squash(frame: np.ndarray, size: int, out: np.ndarray | None = None) -> np.ndarray:
    """Resizes one [H, W, 3] frame to [size, size, 3] (aspect ratio not kept, like the authors' code)."""
    if frame.shape[:2] == (size, size):
        if out is None:
            return frame.copy()
        out[...] = frame
        return out
    return cv2.resize(frame, (size, size), dst=out, interpolation=cv2.INTER_AREA)


class ArraySource(VideoSource):
    """Videos given as in-memory uint8 arrays [T, H, W, 3] (RGB).

    For tests ("a solid-colour video shows up in the sky") and for researchers with their
    own data. The arrays are read (and resized) when a video is first used: do not modify
    them afterwards. Cached frames are dropped when the source is garbage-collected.

    Args:
        videos (sequence of np.ndarray): each uint8 [T >= 1, H, W, 3], RGB.
        names (sequence of str, optional): one per video; default ``video-00``, ``video-01``, ...

    Examples:
        >>> import numpy as np
        >>> red = np.zeros((10, 64, 64, 3), np.uint8); red[..., 0] = 255
        >>> source = ArraySource([red], names=["red"])
        >>> source.frames(0, 16)[3, 5, 5].tolist()
        [255, 0, 0]
    """

    more_hint = "pass more arrays to ArraySource"

    def __init__(self, videos: Sequence[np.ndarray], names: Sequence[str] | None = None):
        if isinstance(videos, np.ndarray) or not isinstance(videos, Sequence):
            raise TypeError(
                "videos must be a list of uint8 arrays [T, H, W, 3] (wrap a single video in a list), "
                f"got {type(videos).__name__}."
            )
        self._videos = [self._check(i, video) for i, video in enumerate(videos)]
        if names is None:
            names = [f"video-{i:02d}" for i in range(len(self._videos))]
        names = list(names)
        if len(names) != len(self._videos) or not all(isinstance(n, str) for n in names):
            raise ValueError(f"names must be {len(self._videos)} strings, one per video, got {names!r}.")
        super().__init__(names, ("array", uuid.uuid4().hex))
        self._drop_frames_when_collected()

    @staticmethod
    def _check(i: int, video) -> np.ndarray:
        if not isinstance(video, np.ndarray):
            raise TypeError(f"video {i} is a {type(video).__name__}: pass numpy uint8 arrays [T, H, W, 3].")
        if video.ndim != 4 or video.shape[-1] != 3 or min(video.shape) < 1:
            raise ValueError(
                f"video {i} has shape {video.shape}: expected [T, H, W, 3] with T, H, W >= 1 "
                "(RGB frames, time first; add a time axis with video[None] for a single frame)."
            )
        if video.dtype != np.uint8:
            raise ValueError(
                f"video {i} has dtype {video.dtype}: expected uint8 in [0, 255] "
                "(convert floats in [0, 1] with (video * 255).round().astype(np.uint8))."
            )
        return video

    def _drop_frames_when_collected(self) -> None:
        weakref.finalize(self, FRAME_CACHE.discard, self._cache_key)

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._drop_frames_when_collected()

    def _decode(self, index: int, size: int) -> np.ndarray:
        video = self._videos[index]
        out = np.empty((len(video), size, size, 3), np.uint8)
        for t, frame in enumerate(video):
            squash(np.ascontiguousarray(frame), size, out[t])
        return out

    def __repr__(self) -> str:
        return f"ArraySource({len(self)} videos)"
