"""FolderSource: any folder of videos, as frame folders or video files."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dcs_torchrl.videos.decode import (
    IMAGE_EXTENSIONS,
    VIDEO_EXTENSIONS,
    has_extension,
    read_frames,
    read_video_file,
    visible_entries,
)
from dcs_torchrl.videos.lists import SPLIT_ALIASES, canonical_split, split_folder_names
from dcs_torchrl.videos.source import VideoSource

_KINDS = "sub-folders of frames (" + "/".join(e[1:] for e in IMAGE_EXTENSIONS) + ") or video files (" + "/".join(
    e[1:] for e in VIDEO_EXTENSIONS
) + ")"


def split_folder(root: Path, split: str) -> Path | None:
    """The sub-folder of ``root`` holding ``split`` (``val/``, ``validation/``, ``test/``, ...), if any."""
    for name in split_folder_names(split):
        if (root / name).is_dir():
            return root / name
    return None


class FolderSource(VideoSource):
    """Every video in a folder: one sub-folder of frames or one video file per video.

    Videos are taken in name order (numbers compared by value), frames within a frame
    folder likewise (``00000.jpg``, ``00001.jpg``, ... or ``frame2.png`` before
    ``frame10.png``). Video files are decoded with ``cv2.VideoCapture``. A video is named
    after its folder or its file name without extension. Hidden files are ignored.

    Splits: if ``root/train/`` or ``root/val/`` exists (or an alias: ``training/``,
    ``validation/``, ``test/``), each split reads its own sub-folder; without a ``train/``
    folder the training split is every other video in ``root``. A folder without any
    split sub-folder is all training videos.

    Args:
        root (str or os.PathLike): the folder.
        split (str): ``"train"`` (alias ``"training"``) or ``"val"`` (``"validation"``, ``"test"``).

    Examples:
        >>> from dcs_torchrl.videos import FolderSource
        >>> videos = FolderSource("~/my_backgrounds")  # doctest: +SKIP
        >>> videos.names  # doctest: +SKIP
        ('beach.mp4', 'city', 'forest')
    """

    def __init__(self, root: str | os.PathLike, split: str = "train"):
        self.split = canonical_split(split)
        self.root = Path(root).expanduser()
        if not self.root.exists():
            raise FileNotFoundError(f"video folder {str(self.root)!r} does not exist.")
        if not self.root.is_dir():
            raise NotADirectoryError(
                f"{str(self.root)!r} is a file: pass the folder that holds the videos "
                f"({_KINDS}), even for a single video."
            )
        self.folder = self._split_root()
        self._videos: list[Path | tuple[Path, ...]] = []
        names = self._scan()
        super().__init__(names, ("folder", str(self.folder.resolve())))

    def _split_root(self) -> Path:
        folder = split_folder(self.root, self.split)
        if folder is not None:
            return folder
        if self.split == "val":
            raise ValueError(
                f"{self.root} has no held-out videos (no {'/, '.join(split_folder_names('val'))}/ sub-folder), "
                "so all its videos are the train split. For split='val' point at a folder of held-out "
                f"videos, or move them into {self.root / 'val'}."
            )
        return self.root

    def _scan(self) -> list[str]:
        names = []
        skip_split_folders = self.folder == self.root
        for entry in visible_entries(self.folder):
            path = Path(entry.path)
            if entry.is_dir():
                if skip_split_folders and entry.name.lower() in SPLIT_ALIASES:
                    continue
                self._videos.append(self._frame_files(path))
                names.append(entry.name)
            elif has_extension(entry.name, VIDEO_EXTENSIONS):
                self._videos.append(path)
                names.append(path.stem)
            elif has_extension(entry.name, IMAGE_EXTENSIONS):
                raise ValueError(
                    f"{self.folder} holds image files ({entry.name}, ...) directly: it looks like the "
                    "frames of one video. Pass the folder above it, which must hold one sub-folder of "
                    "frames (or one video file) per video."
                )
            else:
                raise ValueError(
                    f"unsupported file {path} in the video folder: it must hold only {_KINDS}. "
                    "Move or delete the file."
                )
        if not names:
            raise FileNotFoundError(f"no videos in {self.folder}: expected {_KINDS}.")
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(
                f"{self.folder} holds several videos named {duplicates[0]!r} (a folder and a file, or "
                "files with different extensions): rename or remove one."
            )
        return names

    @staticmethod
    def _frame_files(folder: Path) -> tuple[Path, ...]:
        files = []
        for entry in visible_entries(folder):
            if entry.is_file() and has_extension(entry.name, IMAGE_EXTENSIONS):
                files.append(Path(entry.path))
            else:
                raise ValueError(
                    f"unsupported entry {entry.path} in the frame folder {folder}: a video folder must "
                    f"hold only frames ({'/'.join(e[1:] for e in IMAGE_EXTENSIONS)}). Move or delete it."
                )
        if not files:
            raise FileNotFoundError(
                f"video folder {folder} has no frames: put the frames in it as "
                f"{'/'.join(e[1:] for e in IMAGE_EXTENSIONS)} files (sorted by name), or remove it."
            )
        return tuple(files)

    def _decode(self, index: int, size: int) -> np.ndarray:
        video = self._videos[index]
        if isinstance(video, tuple):
            return read_frames(video, size)
        return read_video_file(video, size)

    def __repr__(self) -> str:
        return f"FolderSource({str(self.folder)!r}, split={self.split!r})"
