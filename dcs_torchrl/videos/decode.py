"""Reading frames from disk into square RGB uint8 arrays: image sequences and video files.

JPEGs much larger than the target are decoded at reduced size by libjpeg's DCT scaling
(``cv2.IMREAD_REDUCED_COLOR_2/4/8``), cheaper than a full decode, then squashed to
[size, size] with ``cv2.INTER_AREA``.
"""
from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from dcs_torchrl.videos.source import squash

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png")
VIDEO_EXTENSIONS = (".mp4", ".avi", ".mov", ".mkv", ".webm")
# Operating-system droppings that may sit in any folder; ignored like hidden files.
IGNORED_FILES = frozenset({"thumbs.db", "desktop.ini"})
_REDUCED = {2: cv2.IMREAD_REDUCED_COLOR_2, 4: cv2.IMREAD_REDUCED_COLOR_4, 8: cv2.IMREAD_REDUCED_COLOR_8}


def natural_key(name: str):
    """Sort key that orders numbers by value: ``frame2`` before ``frame10``."""
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", name)]


def visible_entries(folder: Path) -> list[os.DirEntry]:
    """The entries of ``folder`` except hidden files and OS droppings, in natural name order."""
    with os.scandir(folder) as it:
        entries = [e for e in it if not e.name.startswith(".") and e.name.lower() not in IGNORED_FILES]
    return sorted(entries, key=lambda e: natural_key(e.name))


def has_extension(name: str, extensions: Sequence[str]) -> bool:
    return os.path.splitext(name)[1].lower() in extensions


def reduction(width: int, height: int, size: int) -> int:
    """The largest JPEG reduction (1, 2, 4, 8) that keeps at least size x size pixels.

    A frame is decoded at 1/k scale when it has at least k times the target's side
    (by pixel count): an 854x480 DAVIS frame is decoded at 427x240 for a 256 texture
    and at 213x120 for an 84 one.

    Examples:
        >>> reduction(854, 480, 256), reduction(854, 480, 84), reduction(300, 300, 256)
        (2, 4, 1)
    """
    for k in (8, 4, 2):
        if width * height >= (k * size) ** 2:
            return k
    return 1


def _corrupt(path: Path) -> ValueError:
    return ValueError(
        f"could not decode frame {path}: the file is corrupt or not an image. Re-extract the "
        "archive it came from (for DAVIS: DAVIS-2017-trainval-480p.zip), or delete the file."
    )


def read_image(path: Path, flag: int = cv2.IMREAD_COLOR) -> np.ndarray:
    """One image as BGR uint8 [H, W, 3]; a ValueError naming the file if it cannot be decoded."""
    data = np.fromfile(path, np.uint8)  # also works for non-ASCII paths, unlike cv2.imread on Windows
    image = cv2.imdecode(data, flag) if data.size else None
    if image is None:
        raise _corrupt(path)
    return image


def read_frames(paths: Sequence[Path], size: int) -> np.ndarray:
    """The images at ``paths`` (one video, in order) as RGB uint8 [T, size, size, 3].

    The first frame is decoded in full; its size decides the reduced decode of the others.
    """
    out = np.empty((len(paths), size, size, 3), np.uint8)
    first = read_image(paths[0])
    k = reduction(first.shape[1], first.shape[0], size)
    for t, path in enumerate(paths):
        if t == 0:
            image = first
        elif k > 1 and has_extension(path.name, (".jpg", ".jpeg")):
            image = read_image(path, _REDUCED[k])
        else:
            image = read_image(path)
        squash(image, size, out[t])
        cv2.cvtColor(out[t], cv2.COLOR_BGR2RGB, dst=out[t])
    return out


def read_video_file(path: Path, size: int) -> np.ndarray:
    """Every frame of a video file (through ``cv2.VideoCapture``) as RGB uint8 [T, size, size, 3]."""
    capture = cv2.VideoCapture(str(path))
    frames = []
    try:
        while capture.isOpened():
            ok, frame = capture.read()
            if not ok:
                break
            frames.append(cv2.cvtColor(squash(frame, size), cv2.COLOR_BGR2RGB))
    finally:
        capture.release()
    if not frames:
        raise ValueError(
            f"could not read any frame from video file {path}: it is empty, corrupt or in a codec "
            "this OpenCV build cannot decode. Re-encode it (e.g. ffmpeg -i in.mov -c:v mpeg4 out.mp4), "
            "extract its frames into a folder of JPEGs, or remove it from the folder."
        )
    return np.stack(frames)
