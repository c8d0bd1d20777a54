"""Surface textures for the texture distraction: the floor's and the bodies' looks, drawn per episode.

A :class:`TextureSet` is an ordered set of square RGB images of one split, made or decoded at the
size asked for and cached. :func:`texture_set` picks it for ``texture_dir``:

- ``None``: 20 training and 5 held-out procedural stand-ins (:mod:`~dcs_torchrl.textures.procedural`),
  made on first use, the same bits on every machine;
- a folder: every image under it (e.g. the Describable Textures Dataset's ``dtd/images``), every
  fifth held out as ``"val"``.

Examples:
    >>> from dcs_torchrl.textures import TEXTURE_SPLITS, texture_set
    >>> [len(texture_set(None, split)) for split in TEXTURE_SPLITS]
    [20, 5]
"""
from __future__ import annotations

from dcs_torchrl.textures.procedural import STANDIN_VERSION
from dcs_torchrl.textures.sets import TEXTURE_EXTENSIONS, TEXTURE_SPLITS, TextureSet, texture_set

__all__ = ["STANDIN_VERSION", "TEXTURE_EXTENSIONS", "TEXTURE_SPLITS", "TextureSet", "texture_set"]
