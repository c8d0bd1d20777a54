"""BackgroundDistraction: video frames on the skybox, a see-through floor (Stone et al. 2021, Sec. 3.3)."""
from __future__ import annotations

import os
from collections.abc import Sequence

import cv2
import mujoco
import numpy as np

from dcs_torchrl._scene import Scene, originals
from dcs_torchrl.distractions.base import DistractionTransform, check_scale, per_world
from dcs_torchrl.render.skybox import cube_faces, skybox_texture
from dcs_torchrl.videos import ArraySource, VideoSource, open_source


def as_video_source(videos, split: str = "train") -> VideoSource:
    """A :class:`~dcs_torchrl.videos.VideoSource` from what a user may pass as ``videos``.

    ``None`` is the embedded default set, a path is a DAVIS or generic video folder, a
    sequence of uint8 arrays [T, H, W, 3] is a set of in-memory videos.
    """
    if videos is None or isinstance(videos, (str, os.PathLike)):
        return open_source(videos, split)
    if isinstance(videos, VideoSource):
        return videos
    if isinstance(videos, np.ndarray):
        return ArraySource([videos] if videos.ndim == 4 else list(videos))
    if isinstance(videos, Sequence):
        return ArraySource(list(videos))
    raise TypeError(
        "videos must be None (the embedded default), a folder path, a dcs_torchrl.videos.VideoSource "
        f"or a sequence of uint8 arrays [T, H, W, 3]; got {type(videos).__name__}."
    )


def bounce(frame: int, direction: int, length: int, n_steps: int) -> tuple[int, int]:
    """Plays ``n_steps`` frames forward or backward, reversing at the first and last frame."""
    frames, directions = bounce_many(*(np.array([x], np.int64) for x in (frame, direction, length, n_steps)))
    return int(frames[0]), int(directions[0])


def bounce_many(frame: np.ndarray, direction: np.ndarray, length: np.ndarray, n_steps: np.ndarray):
    """:func:`bounce` over arrays (int64), in closed form: a clip of L frames played back and forth is a
    cycle of 2 (L - 1) phases, phase p showing frame p going forward and frame 2 (L - 1) - p going back."""
    period = np.maximum(2 * (length - 1), 1)
    phase = np.where(direction > 0, frame, period - frame) % period
    new = (phase + n_steps) % period
    moved = (length >= 2) & (n_steps > 0)
    frames = np.where(moved, np.where(new <= length - 1, new, period - new), frame)
    directions = np.where(moved, np.where((new > 0) & (new <= length - 1), 1, -1), direction)
    return frames, directions


class BackgroundDistraction(DistractionTransform):
    """Projects background videos onto the skybox and makes the floor see-through (Stone et al. 2021, Sec. 3.3).

    At every reset one of the first ``num_videos`` videos and one frame of it are drawn
    uniformly. Static: that frame stays for the episode. Dynamic: the video plays one
    frame per control step (``frame_skip`` frames per agent step), forward or backward
    (drawn at reset), reversing direction at the first and last frame, so the motion
    never cuts. The frame is written into the skybox texture (``model.tex_data``; one
    square face repeated on the six cube faces, as in the authors' code) and uploaded by
    :class:`~dcs_torchrl.RenderPixels` right before it renders, once per agent step (only
    the part of the sky the camera sees: the pixels are those of a whole upload).

    With ``blend`` β_bg < 1 each of the six faces shows β_bg · video + (1 - β_bg) · the
    original face, so β_bg = 0 is the original sky: the paper's blend (section 3.3).

    ``reference_blend=True`` blends as the authors' 2021 code does instead: at each reset
    it reads the sky back from the model and blends the new video onto it, in float32 with
    the sum truncated to uint8. Its ``env.reset()`` restores the physics state, not the
    model, so the sky read back is the last frame the previous episode showed, and the
    original sky's weight after k episodes of one env is (1 - β_bg)^k: over 100 episodes at
    β_bg = 0.1 its mean weight is about 0.09, and the agent mostly sees earlier videos. Both
    exist because the published robustness to β_bg (section 5.1) was measured with that
    code; ``False`` is what the paper's text describes. The history belongs to this
    transform (one env): each env of a batch accumulates over its own episodes, and
    seeding (``env.set_seed``) starts it again from the original sky. At β_bg = 1 the
    two modes are identical.

    Args:
        videos: ``None`` for the embedded default set (a stand-in for DAVIS that needs no
            download), a DAVIS 2017 ``JPEGImages/480p`` folder or any folder of videos
            (see :func:`dcs_torchrl.videos.open_source`), a
            :class:`~dcs_torchrl.videos.VideoSource`, or a list of uint8 arrays [T, H, W, 3].
        dynamic (bool): play the video during the episode. Defaults to ``False``.

    Keyword Args:
        num_videos (int, optional): b, use the first b videos of the split; ``None``
            uses all of them, 0 none (the sky is left alone).
        blend (float): β_bg in [0, 1], the weight of the video against the original sky.
        ground_alpha (float, optional): opacity of the floor (material ``grid``) set at
            every reset; ``None`` leaves it. The suite uses 1.0 for cheetah and walker,
            0.0 for reacher and 0.3 elsewhere (``dcs_torchrl.presets.GROUND_ALPHA``).
        split (str): ``"train"`` or ``"val"``, when ``videos`` is ``None`` or a path.
        texture_size (int): side of the square sky texture the frames are decoded to.
            256 is indistinguishable from the reference's 800 at 84x84 (mean pixel
            difference below 1) and keeps 60 videos in memory; raise it for large renders.
        reference_blend (bool): accumulate the blend over episodes as the 2021 code
            does (above). Defaults to ``False``.
        seed (int, optional), expose (bool): see :class:`DistractionTransform`; the exposed
            state is int64 ``[video index, frame index]``, ``[-1, -1]`` without videos.

    Examples:
        >>> import numpy as np
        >>> from torchrl.envs import DMControlEnv, TransformedEnv, Compose
        >>> from dcs_torchrl import BackgroundDistraction, RenderPixels
        >>> red = np.zeros((10, 64, 64, 3), np.uint8); red[..., 0] = 255
        >>> env = TransformedEnv(
        ...     DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8),
        ...     Compose(BackgroundDistraction([red], dynamic=True, ground_alpha=0.3, seed=0), RenderPixels()),
        ... )
        >>> int(env.reset()["pixels"][0, 0, 0])  # the sky is red
        255
    """

    state_name = "background"
    seed_tag = 3

    def __init__(
        self,
        videos=None,
        dynamic: bool = False,
        *,
        num_videos: int | None = None,
        blend: float = 1.0,
        ground_alpha: float | None = None,
        split: str = "train",
        texture_size: int = 256,
        reference_blend: bool = False,
        seed: int | None = None,
        expose: bool = False,
    ):
        self.videos = as_video_source(videos, split).first(num_videos)
        self.dynamic = bool(dynamic)
        self.blend = check_scale("BackgroundDistraction blend", blend)
        self.ground_alpha = None if ground_alpha is None else check_scale("ground_alpha", ground_alpha)
        if int(texture_size) < 1:
            raise ValueError(f"texture_size must be a positive number of pixels, got {texture_size}.")
        self.texture_size = int(texture_size)
        self.reference_blend = bool(reference_blend)
        self._pending: list[np.ndarray] | None = None
        super().__init__(seed=seed, expose=expose)

    def reseed(self, seed: int | None) -> None:
        """Restarts the random stream and, with ``reference_blend``, the sky's history."""
        super().reseed(seed)
        self._shown = None  # the faces this env last displayed (reference_blend); None: the original sky

    @property
    def active(self) -> bool:
        return len(self.videos) > 0 and self.blend > 0

    def _on_bind(self, scene: Scene) -> None:
        model = scene.physics.model
        if self.ground_alpha is not None:
            self._grid = mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_MATERIAL, "grid")
            if self._grid < 0:
                raise ValueError("this model has no 'grid' material (the floor): pass ground_alpha=None.")
        if not self.active:
            return
        sky = self._sky = skybox_texture(model)
        if sky is None:
            raise ValueError("this model has no skybox texture to show background videos on: use num_videos=0.")
        width, height = originals(scene.physics).tex_size[sky]
        s = self.texture_size
        if int(model.tex_nchannel[sky]) != 3 or 6 * s * s > width * height:
            raise ValueError(
                f"texture_size={s} does not fit the skybox texture ({width}x{height}, "
                f"{int(model.tex_nchannel[sky])} channels): use texture_size <= {width}."
            )
        self._sky_faces = None
        if self.blend < 1:
            data = cube_faces(originals(scene.physics).texture(sky), width, height, 3)
            faces = [data[min(i, len(data) - 1)] for i in range(6)]  # one face repeated, or six
            self._sky_faces = [cv2.resize(f, (s, s), interpolation=cv2.INTER_AREA) for f in faces]

    # --------------------------------------------------------------- contract
    def _new_worlds(self, scene: Scene) -> "BackgroundWorlds":
        return BackgroundWorlds(1, scene.frame_skip)

    def _start(self, physics) -> None:
        if self.ground_alpha is not None:
            physics.model.mat_rgba[self._grid, 3] = self.ground_alpha
        if not self.active:
            return
        self._frames = self._worlds.start(self.row, self)
        if self.reference_blend and self._sky_faces is not None:
            under = self._sky_faces if self._shown is None else self._shown
            self._dimmed = [np.float32(1.0 - self.blend) * face.astype(np.float32) for face in under]

    def _edit_scene(self, physics) -> None:
        if not (self.active and self._worlds.changed[self.row]):
            return
        model, sky, s = physics.model, self._sky, self.texture_size
        faces = self.sky()
        model.tex_width[sky] = s
        model.tex_height[sky] = s * len(faces)
        adr = int(model.tex_adr[sky])
        for i, face in enumerate(faces):
            model.tex_data[adr + i * s * s * 3 : adr + (i + 1) * s * s * 3] = face.reshape(-1)
        self._pending = faces

    def sky(self) -> list[np.ndarray]:
        """The sky this world shows now, as uint8 ``[texture_size, texture_size, 3]`` faces: one (a video
        frame alone, on all six) or six (the frame blended onto the model's sky); marks it taken."""
        self._worlds.changed[self.row] = False
        frame = self._frames[self._worlds.frame[self.row]]
        if self._sky_faces is None:
            return [frame]  # a frame of the cached, read-only clip: shown again and again
        if self.reference_blend:  # the 2021 code's arithmetic: float32, truncated
            video = np.float32(self.blend) * frame.astype(np.float32)
            self._shown = [(dimmed + video).astype(np.uint8) for dimmed in self._dimmed]
            return self._shown
        return [cv2.addWeighted(frame, self.blend, face, 1.0 - self.blend, 0.0) for face in self._sky_faces]

    @property
    def sky_faces(self) -> int:
        """Faces of the sky this distraction shows (:meth:`sky`): 1 (a frame alone) or 6 (blended onto
        the model's sky); 0 where it shows no video."""
        self._bind()
        return 0 if not self.active else 1 if self._sky_faces is None else 6

    def upload_textures(self, context) -> None:
        """Called by RenderPixels right before it renders: hands over the new sky, if any.

        The render context then uploads the part of it the rendered camera sees (see
        :meth:`dcs_torchrl.render.gl._Context.upload_cube`), and the rest when a camera needs it.
        """
        if self._pending is not None:
            context.upload_cube(self._sky, self._pending)
            self._pending = None

    def shown_frame(self) -> tuple[np.ndarray, int] | None:
        """What the sky shows where it is a video frame alone (``blend`` 1): ``(frames, t)``, the clip's
        frames (uint8 ``[T, texture_size, texture_size, 3]``, the array the process's frame cache
        shares) and the frame's index; ``None`` where the sky shows no video or a blend."""
        if not self.active or self._sky_faces is not None:
            return None
        return self._frames, int(self._worlds.frame[self.row])

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.array([-1, -1], dtype=np.int64)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(videos={self.videos!r}, dynamic={self.dynamic}, "
            f"blend={self.blend}, ground_alpha={self.ground_alpha}, reference_blend={self.reference_blend})"
        )


class BackgroundWorlds:
    """The background distraction of N worlds as arrays: each world's video, frame and direction (drawn at
    its episode start, :meth:`start`), played for all the worlds at once (:meth:`advance`). A
    :class:`BackgroundDistraction` on one env keeps its state in a one-world instance; a batch keeps
    its worlds' in one (:meth:`BackgroundDistraction.share`).

    Args:
        n (int): the worlds.
        frame_skip (int or array of int): frames a world's video plays per agent step (dynamic).
    """

    def __init__(self, n: int, frame_skip):
        self.n = n
        self.frame_skip = per_world(frame_skip, n)
        self.video = np.full(n, -1, np.int64)
        self.frame = np.full(n, -1, np.int64)
        self.direction = np.ones(n, np.int64)
        self.length = np.zeros(n, np.int64)
        self.moving = np.zeros(n, bool)  # the video plays (active and dynamic)
        self.changed = np.zeros(n, bool)  # the frame shown changed since the world's sky was last taken

    def start(self, row: int, distraction: BackgroundDistraction) -> np.ndarray:
        """World ``row``'s episode start: a video, a frame of it and a direction drawn from
        ``distraction``'s generator; returns the video's frames (uint8 ``[T, side, side, 3]``)."""
        rng = distraction._rng
        video = int(rng.integers(len(distraction.videos)))
        frames = distraction.videos.frames(video, distraction.texture_size)
        self.video[row], self.length[row] = video, len(frames)
        self.frame[row] = int(rng.integers(len(frames)))
        self.direction[row] = 1 if rng.random() < 0.5 else -1
        self.moving[row] = distraction.dynamic
        self.changed[row] = True
        return frames

    def advance(self, rows: np.ndarray) -> None:
        """One agent step (each world's frame skip in frames) of the videos of the worlds ``rows`` that play."""
        rows = rows[self.moving[rows]]
        if len(rows):
            self.frame[rows], self.direction[rows] = bounce_many(self.frame[rows], self.direction[rows],
                                                                 self.length[rows], self.frame_skip[rows])
            self.changed[rows] = True

    def states(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The exposed state (int64 ``[video, frame]``, ``[-1, -1]`` without videos) of the worlds ``rows`` (all: ``None``)."""
        rows = np.arange(self.n) if rows is None else rows
        return np.stack([self.video[rows], self.frame[rows]], axis=-1)
