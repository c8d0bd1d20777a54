"""DavisSource: the DAVIS 2017 videos the paper projects onto the sky."""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from dcs_torchrl.videos.decode import IMAGE_EXTENSIONS, has_extension, read_frames, visible_entries
from dcs_torchrl.videos.lists import DAVIS17_SPLITS, DAVIS17_TRAIN, DAVIS17_VAL, canonical_split
from dcs_torchrl.videos.source import VideoSource

DAVIS_URL = "https://davischallenge.org/davis2017/code.html"
DAVIS_NAMES = frozenset(DAVIS17_TRAIN + DAVIS17_VAL)
LAYOUT = "DAVIS/JPEGImages/480p/<video>/00000.jpg"
HOW_TO_GET = (
    f"download 'TrainVal - Images and Annotations - 480p' (DAVIS-2017-trainval-480p.zip) from {DAVIS_URL} "
    "and extract it"
)


def find_frames_dir(root: str | os.PathLike) -> Path | None:
    """The ``JPEGImages/480p`` folder under a DAVIS root, a ``JPEGImages`` folder or itself.

    ``root`` itself counts when it holds a sub-folder named after a DAVIS 2017 video.
    Returns ``None`` when none of these is found.
    """
    root = Path(root).expanduser()
    for candidate in (root / "JPEGImages" / "480p", root / "480p", root / "DAVIS" / "JPEGImages" / "480p"):
        if candidate.is_dir():
            return candidate
    if root.is_dir() and any(e.is_dir() and e.name in DAVIS_NAMES for e in visible_entries(root)):
        return root
    return None


class DavisSource(VideoSource):
    """The DAVIS 2017 videos of one split, in the official order, from a local copy.

    The training split has 60 videos (``bear``, ``bmx-bumps``, ...): the suite uses the
    first b of them. The validation split has the 30 held-out videos the paper evaluates
    on ("test"). Frames are ``<root>/JPEGImages/480p/<video>/00000.jpg, 00001.jpg, ...``
    (sorted names), decoded lazily at the texture size.

    The folder is checked at construction by listing it (nothing is decoded). A copy
    holding only the first videos of the split (a partial extraction) is accepted with
    a warning and serves those; a gap in the official order is an error.

    Args:
        root (str or os.PathLike): the DAVIS root (holding ``JPEGImages``), the
            ``JPEGImages`` folder or the ``JPEGImages/480p`` folder itself.
        split (str): ``"train"`` (alias ``"training"``) or ``"val"`` (``"validation"``, ``"test"``).

    Examples:
        >>> from dcs_torchrl.videos import DavisSource
        >>> videos = DavisSource("~/data/DAVIS", "train").first(8)  # doctest: +SKIP
        >>> videos.names[:2], videos.frames(0, 256).shape  # doctest: +SKIP
        (('bear', 'bmx-bumps'), (82, 256, 256, 3))
    """

    def __init__(self, root: str | os.PathLike, split: str = "train"):
        self.split = canonical_split(split)
        self.root = Path(root).expanduser()
        frames_dir = find_frames_dir(self.root)
        if frames_dir is None:
            what = "does not exist" if not self.root.exists() else "does not hold DAVIS 2017 frames"
            raise FileNotFoundError(
                f"DAVIS folder {str(self.root)!r} {what}: expected the layout {LAYOUT}. "
                f"To get it, {HOW_TO_GET}; then pass the DAVIS folder."
            )
        self.frames_dir = frames_dir
        self._frame_files: list[tuple[str, ...]] = []
        names = self._scan(DAVIS17_SPLITS[self.split])
        self.more_hint = f"{HOW_TO_GET} (all 60 train and 30 val videos)"
        super().__init__(names, ("davis", str(frames_dir.resolve())))

    def _scan(self, official: tuple[str, ...]) -> tuple[str, ...]:
        present = [(self.frames_dir / name).is_dir() for name in official]
        if not any(present):
            raise FileNotFoundError(
                f"none of the {len(official)} DAVIS 2017 {self.split} videos ({official[0]}, {official[1]}, ...) "
                f"is in {self.frames_dir}: {HOW_TO_GET}. The TrainVal archive holds both splits."
            )
        count = present.index(False) if not all(present) else len(official)
        if any(present[count:]):
            missing = official[count]
            raise FileNotFoundError(
                f"DAVIS video {missing!r} of the {self.split} split is missing (expected folder "
                f"{self.frames_dir / missing}) while later videos are present: the copy is incomplete. "
                f"Re-extract DAVIS-2017-trainval-480p.zip ({DAVIS_URL})."
            )
        for name in official[:count]:
            folder = self.frames_dir / name
            files = tuple(e.name for e in visible_entries(folder) if has_extension(e.name, IMAGE_EXTENSIONS))
            if not files:
                raise FileNotFoundError(
                    f"DAVIS video {name!r} has no frames in {folder} (expected 00000.jpg, 00001.jpg, ...): "
                    f"re-extract DAVIS-2017-trainval-480p.zip ({DAVIS_URL})."
                )
            self._frame_files.append(files)
        if count < len(official):
            warnings.warn(
                f"{self.frames_dir} holds only the first {count} of the {len(official)} DAVIS 2017 "
                f"{self.split} videos (missing {official[count]!r} onwards): using those {count}. "
                f"For the full split, {HOW_TO_GET}.",
                stacklevel=3,
            )
        return official[:count]

    def frame_paths(self, index: int) -> list[Path]:
        """The frame files of video ``index``, in order."""
        folder = self.frames_dir / self.names[index]
        return [folder / name for name in self._frame_files[index]]

    def _decode(self, index: int, size: int) -> np.ndarray:
        return read_frames(self.frame_paths(index), size)

    def __repr__(self) -> str:
        return f"DavisSource({str(self.frames_dir)!r}, split={self.split!r})"
