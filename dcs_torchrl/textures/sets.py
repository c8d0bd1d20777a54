"""TextureSet: the surface textures of one split, the stand-ins or a folder of images, with their cache.

:func:`texture_set` picks the set for ``texture_dir``: ``None`` gives the procedural stand-ins of
:mod:`dcs_torchrl.textures.procedural`, a folder gives every image under it. Images are made or
decoded on first use at the size asked for and kept in a small process-wide LRU cache keyed by
``(set key, index, size)``.
"""
from __future__ import annotations

import functools
import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path

import cv2
import numpy as np

from dcs_torchrl.textures import procedural
from dcs_torchrl.videos.decode import natural_key, read_image, visible_entries
from dcs_torchrl.videos.lists import SPLIT_ALIASES
from dcs_torchrl.videos.source import check_size, squash

TEXTURE_SPLITS = ("train", "val")
TEXTURE_EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp")
_NAMES = "/".join(e[1:] for e in TEXTURE_EXTENSIONS)
HELD_OUT_EVERY = 5  # a folder's val split: the images at sorted positions 4, 9, 14, ...
CACHE_BYTES = 256 * 2**20


class _Cache:
    """A thread-safe LRU of read-only images, bounded in bytes."""

    def __init__(self, limit: int):
        self.limit = limit
        self._items: OrderedDict[Hashable, np.ndarray] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()

    def get(self, key: Hashable, make: Callable[[], np.ndarray]) -> np.ndarray:
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        image = make()  # outside the lock: two threads may make the same image, both get equal bits
        image.flags.writeable = False
        with self._lock:
            if key not in self._items:
                self._items[key] = image
                self._bytes += image.nbytes
                while self._bytes > self.limit and len(self._items) > 1:
                    self._bytes -= self._items.popitem(last=False)[1].nbytes
            return self._items[key]

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self._bytes = 0

    def __len__(self) -> int:
        return len(self._items)


TEXTURE_CACHE = _Cache(CACHE_BYTES)


def canonical_texture_split(split: str) -> str:
    """``"train"`` or ``"val"`` from a split name or one of the videos' aliases (``"validation"``, ``"test"``)."""
    key = split.strip().lower() if isinstance(split, str) else None
    if key not in SPLIT_ALIASES:
        raise ValueError(
            f"unknown texture split {split!r}: use one of {TEXTURE_SPLITS} ('train' = the textures drawn "
            "while training, 'val' = the held-out ones)."
        )
    return SPLIT_ALIASES[key]


class TextureSet:
    """An ordered set of square RGB textures, made or decoded at the size asked for.

    Build one with :func:`texture_set`. Each image is made once per process and size and shared
    (read-only) through a small LRU cache keyed by ``(key, index, size)``.

    Args:
        key (tuple): the set's identity, hashable, e.g. ``("standin", "train")`` or
            ``("/data/dtd/images", "val")``: equal keys mean the same images.
        names (sequence of str): one name per image, in order.
        load (callable): ``load(index, size)`` -> uint8 RGB [size, size, 3]; picklable (a module-level
            function or a ``functools.partial`` of one), so that the set travels to worker processes.
        source (str): what the images are, for the repr.

    Examples:
        >>> from dcs_torchrl.textures import texture_set
        >>> textures = texture_set(None, "val")
        >>> len(textures), textures.image(0, 32).shape, textures.key
        (5, (32, 32, 3), ('standin', 'val'))
    """

    def __init__(self, key: tuple, names, load: Callable[[int, int], np.ndarray], source: str):
        self.key = key
        self.names = tuple(names)
        self._load = load
        self._source = source

    @property
    def split(self) -> str:
        return self.key[-1]

    def __len__(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        return f"TextureSet({self._source}, split={self.split!r}, {len(self)} images)"

    def image(self, index: int, size: int) -> np.ndarray:
        """Image ``index`` as a read-only, C-contiguous uint8 array [size, size, 3], RGB.

        Args:
            index (int): 0 .. len - 1.
            size (int): the side in pixels.
        """
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < len(self):
            raise ValueError(f"texture index {index!r} is out of range for {self!r}: use 0 .. {len(self) - 1}.")
        size = check_size(size)
        index = int(index)
        return TEXTURE_CACHE.get((self.key, index, size), lambda: self._checked(index, size))

    def images(self, size: int) -> np.ndarray:
        """Every image of the set, uint8 [len, size, size, 3], RGB (a new, writable array)."""
        size = check_size(size)
        return np.stack([self.image(i, size) for i in range(len(self))])

    def _checked(self, index: int, size: int) -> np.ndarray:
        image = np.ascontiguousarray(self._load(index, size))
        if image.dtype != np.uint8 or image.shape != (size, size, 3):
            raise RuntimeError(f"texture {self.names[index]!r} came out {image.dtype} {image.shape}, "
                               f"expected uint8 [{size}, {size}, 3].")
        return image


def read_texture(path: Path, size: int) -> np.ndarray:
    """The image at ``path``, centre-cropped to a square and resized to [size, size] (``cv2.INTER_AREA``), RGB."""
    try:
        image = read_image(path)
    except ValueError as error:
        raise ValueError(
            f"could not decode texture image {path}: the file is corrupt or not an image. Re-extract the "
            "archive it came from (for DTD: dtd-r1.0.1.tar.gz), or delete the file."
        ) from error
    h, w = image.shape[:2]
    side = min(h, w)
    top, left = (h - side) // 2, (w - side) // 2
    square = squash(image[top : top + side, left : left + side], size)
    return cv2.cvtColor(square, cv2.COLOR_BGR2RGB)


def _read_nth(files: tuple[Path, ...], index: int, size: int) -> np.ndarray:
    return read_texture(files[index], size)


def image_files(root: Path, _above: tuple[str, ...] = ()) -> list[Path]:
    """Every image file (jpg, jpeg, png, bmp; any case) under ``root``, recursively, hidden files and
    folders skipped, sorted by relative path with numbers compared by value. A folder linked into itself
    (a symbolic link to a folder above it) is refused, naming the link."""
    here = os.path.realpath(root)
    if here in _above:
        raise ValueError(f"{root} is a link to a folder above it ({here}): the texture folder would hold itself "
                         "without end. Remove the link, or point texture_dir below it.")
    found = []
    for entry in visible_entries(root):
        if entry.is_dir():
            found += image_files(Path(entry.path), (*_above, here))
        elif entry.is_file() and os.path.splitext(entry.name)[1].lower() in TEXTURE_EXTENSIONS:
            found.append(Path(entry.path))
    return found


def split_files(files: list, split: str) -> list:
    """The files of ``split``: ``"val"`` holds every fifth (positions 4, 9, 14, ...), ``"train"`` the rest."""
    held_out = split == "val"
    return [f for i, f in enumerate(files) if (i % HELD_OUT_EVERY == HELD_OUT_EVERY - 1) == held_out]


def _folder_set(texture_dir, split: str) -> TextureSet:
    root = Path(texture_dir).expanduser()
    if not root.exists():
        raise ValueError(f"texture_dir {str(root)!r} does not exist: pass a folder of images "
                         f"({_NAMES}, e.g. DTD's dtd/images), or None for the stand-ins.")
    if not root.is_dir():
        raise ValueError(f"texture_dir {str(root)!r} is a file: pass the folder that holds the images "
                         f"({_NAMES}), even for a single image.")
    root = root.resolve()
    files = sorted(image_files(root), key=lambda p: [natural_key(part) for part in p.relative_to(root).parts])
    if not files:
        raise ValueError(f"no image files ({_NAMES}) under {root}: point texture_dir at a folder holding "
                         "images, in sub-folders or not (e.g. DTD's dtd/images/<category>/*.jpg).")
    chosen = split_files(files, split)
    if not chosen:
        raise ValueError(
            f"{root} holds {len(files)} image(s), so its 'val' split is empty: 'val' takes every fifth image "
            f"in sorted order (positions 4, 9, 14, ...), at least {HELD_OUT_EVERY} are needed. Add images, or "
            "use split='train'."
        )
    names = [str(f.relative_to(root).as_posix()) for f in chosen]
    return TextureSet((str(root), split), names, functools.partial(_read_nth, tuple(chosen)), repr(str(root)))


def texture_set(texture_dir: str | os.PathLike | None, split: str = "train") -> TextureSet:
    """The textures of ``split``: the procedural stand-ins, or every image under a folder.

    - ``None``: 20 training and 5 held-out stand-in textures made procedurally on first use
      (:mod:`dcs_torchrl.textures.procedural`): stones, bricks, wood, weaves, marble, ... They are
      *not* a texture dataset: for natural textures pass a folder, e.g. the Describable Textures
      Dataset (https://www.robots.ox.ac.uk/~vgg/data/dtd/, ``dtd/images/<category>/*.jpg``).
    - a folder: every image file under it, recursively (jpg, jpeg, png, bmp, any case; hidden files
      and folders skipped), sorted by relative path (numbers compared by value). The split holds
      out every fifth image: the images at sorted positions 4, 9, 14, ... are ``"val"``, the others
      ``"train"``. On DTD's layout (categories in alphabetical folders, 120 images each) this
      holds out 20% of every category. Each image is centre-cropped to a square and resized
      (``cv2.INTER_AREA``).

    Args:
        texture_dir (str, os.PathLike or None): the folder, or ``None`` for the stand-ins.
        split (str): ``"train"`` or ``"val"`` (also ``"training"``, ``"validation"``, ``"test"``).

    Examples:
        >>> from dcs_torchrl.textures import texture_set
        >>> texture_set(None)
        TextureSet(stand-ins, split='train', 20 images)
        >>> texture_set("~/data/dtd/images", "val")  # doctest: +SKIP
        TextureSet('/home/me/data/dtd/images', split='val', 1128 images)
    """
    split = canonical_texture_split(split)
    if texture_dir is None:
        count = procedural.STANDINS[split]
        names = [f"standin-{split}-{i:02d}-{procedural.family_of(split, i)}" for i in range(count)]
        return TextureSet(("standin", split), names, functools.partial(procedural.standin, split), "stand-ins")
    if not isinstance(texture_dir, (str, os.PathLike)):
        raise TypeError(f"texture_dir must be a folder's path (str or os.PathLike) or None for the stand-ins, "
                        f"got {type(texture_dir).__name__}.")
    return _folder_set(texture_dir, split)
