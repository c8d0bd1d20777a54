"""Real files for the video tests: JPEG/PNG frames written with cv2.imwrite, videos with cv2.VideoWriter."""
from pathlib import Path

import cv2
import numpy as np


def frame_rgb(index: int, rgb=(200, 40, 20), width: int = 96, height: int = 54) -> np.ndarray:
    """A flat RGB frame whose brightness grows with ``index`` (so the order can be read back)."""
    frame = np.empty((height, width, 3), np.uint8)
    frame[...] = np.clip(np.asarray(rgb) * (0.3 + 0.1 * index), 0, 255).astype(np.uint8)
    return frame


def write_frames(folder: Path, count: int, rgb=(200, 40, 20), ext: str = ".jpg", width: int = 96, height: int = 54,
                 names=None) -> list[Path]:
    """Writes ``count`` frames 00000.jpg, 00001.jpg, ... (or ``names``) with cv2.imwrite."""
    folder.mkdir(parents=True, exist_ok=True)
    names = names or [f"{i:05d}{ext}" for i in range(count)]
    paths = []
    for i, name in enumerate(names):
        path = folder / name
        assert cv2.imwrite(str(path), np.ascontiguousarray(frame_rgb(i, rgb, width, height)[..., ::-1]))
        paths.append(path)
    return paths


def write_video(path: Path, count: int, rgb=(20, 160, 220), size=(64, 48)) -> Path:
    """A small video file written with cv2.VideoWriter (mp4v for .mp4, MJPG otherwise)."""
    fourcc = cv2.VideoWriter_fourcc(*("mp4v" if path.suffix == ".mp4" else "MJPG"))
    writer = cv2.VideoWriter(str(path), fourcc, 10.0, size)
    assert writer.isOpened(), f"this OpenCV build cannot write {path.suffix}"
    for i in range(count):
        writer.write(np.ascontiguousarray(frame_rgb(i, rgb, *size)[..., ::-1]))
    writer.release()
    return path


COLORS = [(200, 40, 20), (30, 180, 40), (40, 60, 210), (180, 180, 30)]
