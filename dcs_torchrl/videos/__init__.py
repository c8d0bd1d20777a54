"""Background videos for :class:`~dcs_torchrl.BackgroundDistraction` (the paper's background distraction).

A :class:`VideoSource` is an ordered set of videos whose frames come out as read-only
uint8 arrays [T, size, size, 3] (RGB), decoded once per process through a shared,
bounded cache. :func:`open_source` picks the source for a path:

- ``None``: :class:`EmbeddedSource`, 60 + 30 procedural clips that need no download
  (a stand-in, not the paper's backgrounds; their version is :data:`EMBEDDED_VERSION`);
- a DAVIS 2017 folder: :class:`DavisSource`, the paper's videos in official order;
- any other folder of frame folders or video files: :class:`FolderSource`.

``python -m dcs_torchrl.videos --out sheet.png`` draws a contact sheet of a source.
"""
from __future__ import annotations

import os
from pathlib import Path

from dcs_torchrl.videos.cache import CacheInfo, cache_info, clear_cache, set_cache_limit
from dcs_torchrl.videos.davis import DavisSource, find_frames_dir
from dcs_torchrl.videos.embedded import EMBEDDED_VERSION, EmbeddedSource
from dcs_torchrl.videos.folder import FolderSource
from dcs_torchrl.videos.lists import DAVIS17_TRAIN, DAVIS17_VAL, SPLIT_ALIASES, canonical_split
from dcs_torchrl.videos.source import ArraySource, VideoSource
from dcs_torchrl.videos.statistics import frame_statistics

__all__ = [
    "ArraySource",
    "CacheInfo",
    "DAVIS17_TRAIN",
    "DAVIS17_VAL",
    "DavisSource",
    "EMBEDDED_VERSION",
    "EmbeddedSource",
    "FolderSource",
    "SPLIT_ALIASES",
    "VideoSource",
    "cache_info",
    "canonical_split",
    "clear_cache",
    "frame_statistics",
    "open_source",
    "set_cache_limit",
]


def open_source(path: str | os.PathLike | None = None, split: str = "train") -> VideoSource:
    """The video source for ``path``: embedded default, DAVIS 2017 or a generic folder.

    Args:
        path (str or os.PathLike, optional): ``None`` for the embedded clips; a DAVIS
            root, ``JPEGImages`` or ``JPEGImages/480p`` folder for DAVIS 2017; any other
            folder of frame folders or video files for :class:`FolderSource`.
        split (str): ``"train"`` (``"training"``) or ``"val"`` (``"validation"``, ``"test"``).

    Examples:
        >>> from dcs_torchrl.videos import open_source
        >>> open_source(None, "test")
        EmbeddedSource(split='val')
    """
    split = canonical_split(split)
    if path is None:
        return EmbeddedSource(split)
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a folder path or None (embedded videos), got {type(path).__name__}.")
    root = Path(path).expanduser()
    if not root.exists():
        raise FileNotFoundError(
            f"background video path {str(root)!r} does not exist: pass a DAVIS 2017 folder, a folder "
            "of videos, or None for the embedded default clips."
        )
    if is_davis(root):
        return DavisSource(root, split)
    return FolderSource(root, split)


def is_davis(root: Path) -> bool:
    """Whether ``root`` is (or holds) a DAVIS 2017 ``JPEGImages/480p`` folder.

    A plain folder counts when every sub-folder is named after a DAVIS 2017 video.
    """
    if not root.is_dir():
        return False
    frames_dir = find_frames_dir(root)
    if frames_dir is None:
        return False
    if frames_dir != root:
        return True
    folders = {e.name for e in os.scandir(root) if e.is_dir() and not e.name.startswith(".")}
    folders -= set(SPLIT_ALIASES)  # train/ and val/ make a FolderSource, even though "train" is a DAVIS name
    return bool(folders) and folders <= set(DAVIS17_TRAIN + DAVIS17_VAL)
