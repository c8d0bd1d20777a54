"""BatchSkies: the one owner of the skies a batch's worlds show, in the arrays its Warp renderers read.

A world of a batch shows one of three skies, the same for every world of the batch:

* ``"clean"``: no video; the model's own sky, averaged down to about a texel per pixel (GL samples it
  through mipmaps, Warp's renderer has none), one row every world shares;
* ``"frame"``: a video frame alone (``background_blend`` 1), one face on all six: a row of a
  :class:`FrameTable` of the clips' frames (each clip once, uploaded once to CUDA; a step writes each
  world's row number), or each world's own row its frame is copied into (no second copy of the clips);
* ``"blend"``: the frame blended onto the model's six faces, each world's own row.

What a world shows comes from its source (the background distraction's public side: ``sky_faces``,
``shown_frame()``, ``sky()``) and two arrays over the worlds: the frame each shows and whether it changed
since its sky was taken (:class:`~dcs_torchrl.distractions.background.BackgroundWorlds`). A step's update
of the ``"clean"`` and ``"frame"`` skies is whole-array work with no Python per world; a ``"blend"`` sky
is blended world by world (an image operation per world whose frame changed). Whoever changes a sky's
rows raises its ``sky_version`` (a CUDA renderer then uploads them again).
"""
from __future__ import annotations

import numpy as np
from numba import carray, njit

from dcs_torchrl._compat.pointers import address, uint8_at
from dcs_torchrl.render.warp import WorldState, skybox_faces

__all__ = ["BatchSkies", "FrameTable", "TABLE_FROM"]

#: Worlds from which a CPU batch shows frames alone from a :class:`FrameTable` by default: each world's own
#: row then holds more than a set of clips does, and copying each world's frame in at each step costs more
#: memory traffic than the rest of the step outside the render.
TABLE_FROM = 256


class FrameTable:
    """The video frames a batch's worlds show, each clip once, as rows of one array (uint8 ``[rows, 1, side,
    side, 3]``): a world showing a frame alone shows a row of it. Clips are added as worlds first show them;
    the array grows by doubling into a new one, so a render still reading the former sees the rows it
    indexes unchanged."""

    def __init__(self, side: int):
        self.rows = np.zeros((1, 1, side, side, 3), np.uint8)  # one blank row: a sky to index before any clip
        self.used = 1
        self.version = 0  #: raised whenever rows are added (a renderer that copies them copies again)
        self._offsets: dict[int, tuple[int, np.ndarray]] = {}  # id(clip) -> (first row, the clip, kept alive)

    def row(self, clip: np.ndarray, frame: int) -> int:
        """The row of frame ``frame`` of ``clip`` (uint8 ``[T, side, side, 3]``, added on first sight)."""
        entry = self._offsets.get(id(clip))  # the clip is kept: its id is not another's
        if entry is None:
            entry = self._offsets[id(clip)] = (self._add(clip), clip)
        return entry[0] + frame

    def _add(self, clip: np.ndarray) -> int:
        start, end = self.used, self.used + len(clip)
        if end > len(self.rows):
            grown = np.zeros((max(end, 2 * len(self.rows)), *self.rows.shape[1:]), np.uint8)
            grown[:start] = self.rows[:start]
            self.rows = grown
        self.rows[start:end, 0] = clip
        self.used = end
        self.version += 1
        return start


@njit(nogil=True, cache=True)
def _copy_frames(rows, offset, clips, frame, size, out):  # pragma: no cover (compiled)
    """``out[i - offset] = frame[i]`` of the clip at ``clips[i]`` (``size`` bytes a frame), each ``i`` of ``rows``."""
    for r in range(len(rows)):
        i = rows[r]
        out[i - offset, :] = carray(uint8_at(clips[i] + frame[i] * size), size)


def clean_sky(model, height: int, camera_id: int) -> np.ndarray:
    """The model's skybox faces, averaged down to about one texel per pixel of this camera."""
    import cv2

    faces = skybox_faces(model)
    side = faces.shape[1]
    fovy = float(model.cam_fovy[camera_id])
    footprint = int(np.ceil(height / np.tan(np.radians(fovy) / 2)))  # pixels a face spans
    if footprint >= side:
        return faces
    return np.stack([cv2.resize(f, (footprint, footprint), interpolation=cv2.INTER_AREA) for f in faces])


class BatchSkies:
    """The skies of N worlds rendered in parts (``chunks``), one sky array per part.

    Args:
        model: the model the batch renders from (its clean sky).
        sources (sequence): per world, its background distraction (``None``: none), read through
            ``sky_faces``, ``texture_size``, ``shown_frame()`` and ``sky()``.
        frame (np.ndarray): int64 ``[N]``, the frame each world shows (read, never written).
        changed (np.ndarray): bool ``[N]``, whether a world's sky changed since it was taken (cleared here).
        chunks (sequence of range): the parts of the batch.
        height (int), camera_id (int): the camera rendered (how far the clean sky is averaged down).
        table (bool, optional): a frame alone as a :class:`FrameTable` row (``True``) or copied into each
            world's own row (``False``); ``None``: the table on a CUDA device and from :data:`TABLE_FROM` worlds,
            else the rows (no second copy of the clips).
        cuda (bool): the renderer runs on a CUDA device.
    """

    def __init__(self, model, sources, frame: np.ndarray, changed: np.ndarray, chunks, height: int,
                 camera_id: int, table: bool | None, cuda: bool):
        if table is not None and not isinstance(table, bool):
            raise ValueError(f"sky_table must be True, False or None (the table on CUDA, rows on the CPU), got {table!r}.")
        self.sources, self.frame, self.changed, self.chunks = list(sources), frame, changed, list(chunks)
        shows = [s is not None and s.sky_faces > 0 for s in self.sources]
        if any(shows) and not all(shows):
            raise ValueError("the envs of one batch must all show background videos or none of them: build "
                             "the settings with videos and those without in separate batches.")
        if not any(shows):
            self.kind, self.table = "clean", None
            sky = clean_sky(model, height, camera_id)[None]
            self._arrays = [sky] * len(self.chunks)
            return
        sides = sorted({s.texture_size for s in self.sources})
        if len(sides) > 1:
            raise ValueError(f"the envs of one batch show videos at texture_size {sides}: give them one "
                             "texture_size, or build them in separate batches.")
        side = sides[0]
        self.kind = "frame" if all(s.sky_faces == 1 for s in self.sources) else "blend"
        table = (cuda or len(self.sources) >= TABLE_FROM) if table is None else table
        self.table = FrameTable(side) if table and self.kind == "frame" else None
        faces = 1 if self.kind == "frame" else 6
        self._arrays = ([self.table.rows] * len(self.chunks) if self.table is not None else
                        [np.zeros((len(chunk), faces, side, side, 3), np.uint8) for chunk in self.chunks])
        n = len(self.sources)
        self._first = np.zeros(n, np.int64)  # the table's row of each world's clip's first frame
        self._clips: list[np.ndarray | None] = [None] * n  # each world's clip (its address in _addresses)
        self._addresses = np.zeros(n, np.int64)
        self._frame_bytes = side * side * 3

    def array(self, chunk: int) -> np.ndarray:
        """The sky array part ``chunk``'s renderer reads (:meth:`dcs_torchrl.render.warp.WarpRenderer.state`)."""
        return self._arrays[chunk]

    def started(self, rows) -> None:
        """The worlds ``rows`` began an episode (a new video): where their clips' frames lie."""
        if self.kind != "frame":
            return
        for i in rows:
            clip, _ = self.sources[i].shown_frame()
            if self.table is not None:
                self._first[i] = self.table.row(clip, 0)
            else:
                self._clips[i], self._addresses[i] = clip, address(clip, np.uint8)

    def update(self, chunk: int, scene: WorldState, rows: np.ndarray) -> None:
        """The skies of the worlds ``rows`` (int64, all in part ``chunk``) into ``scene``, that part's state."""
        if self.kind == "clean":
            return
        offset = self.chunks[chunk].start
        if self.table is not None:
            scene.sky_index[rows - offset] = self._first[rows] + self.frame[rows]
            self.changed[rows] = False
            if scene.sky is not self.table.rows or scene.sky_version != self.table.version:
                scene.sky, scene.sky_version = self.table.rows, self.table.version
            return
        rows = rows[self.changed[rows]]
        if not len(rows):
            return
        if self.kind == "frame":
            _copy_frames(rows, offset, self._addresses, self.frame, self._frame_bytes,
                         scene.sky.reshape(len(scene.sky), -1))
            self.changed[rows] = False
        else:
            for i in rows.tolist():  # a blend: an image operation per world whose frame changed
                scene.sky[i - offset] = np.stack(self.sources[i].sky())
        scene.sky_version += 1
