"""Contact sheet of background videos: first, middle and last frame of each clip.

    python -m dcs_torchrl.videos --out sheet.png [--path DIR] [--split train] [--count 12]

Without ``--path`` it shows the embedded default clips; with a DAVIS 2017 folder or any
folder of videos, those (see :func:`dcs_torchrl.videos.open_source`).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from dcs_torchrl.videos import VideoSource, open_source


def contact_sheet(source: VideoSource, count: int = 12, size: int = 128, columns: int = 2) -> np.ndarray:
    """An RGB uint8 image: per video its name and its first, middle and last frame.

    Args:
        source (VideoSource): the videos; the first ``count`` are shown.
        count (int): how many videos (at most ``len(source)``).
        size (int): side of each frame thumbnail in pixels.
        columns (int): videos per row of the sheet.

    Examples:
        >>> from dcs_torchrl.videos import ArraySource
        >>> sheet = contact_sheet(ArraySource([np.zeros((4, 8, 8, 3), np.uint8)]), size=32)
        >>> sheet.shape
        (50, 104, 3)
    """
    label, gap = 16, 4
    cells = []
    for index in range(min(count, len(source))):
        frames = source.frames(index, size)
        strip = np.concatenate([frames[0], frames[len(frames) // 2], frames[-1]], axis=1)
        head = np.full((label, strip.shape[1], 3), 255, np.uint8)
        text = f"{source.names[index]}  ({len(frames)} frames)"
        cv2.putText(head, text, (2, label - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        cell = np.concatenate([head, strip], axis=0)
        cells.append(np.pad(cell, ((0, gap), (0, gap), (0, 0)), constant_values=255))
    if not cells:
        raise ValueError(f"{source!r} has no videos to show.")
    blank = np.full_like(cells[0], 255)
    cells += [blank] * (-len(cells) % columns)
    rows = [np.concatenate(cells[i : i + columns], axis=1) for i in range(0, len(cells), columns)]
    return np.concatenate(rows, axis=0)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="where to write the sheet (.png or .jpg)")
    parser.add_argument("--path", default=None, help="DAVIS 2017 or video folder (default: embedded clips)")
    parser.add_argument("--split", default="train", help="train or val (aliases: training, validation, test)")
    parser.add_argument("--count", type=int, default=12, help="how many videos, from the first")
    parser.add_argument("--size", type=int, default=128, help="thumbnail side in pixels")
    parser.add_argument("--columns", type=int, default=2, help="videos per row")
    args = parser.parse_args(argv)
    if args.count < 1 or args.size < 8 or args.columns < 1:
        parser.error("--count and --columns must be >= 1 and --size >= 8")
    source = open_source(args.path, args.split)
    sheet = contact_sheet(source, args.count, args.size, args.columns)
    out = Path(args.out)
    if not cv2.imwrite(str(out), np.ascontiguousarray(sheet[..., ::-1])):
        parser.error(f"could not write {out}: use a .png or .jpg name in an existing folder")
    print(f"wrote {out}: {min(args.count, len(source))} of {len(source)} videos of {source!r}", file=sys.stderr)


if __name__ == "__main__":
    main()
