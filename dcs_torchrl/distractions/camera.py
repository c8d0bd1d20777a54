"""CameraDistraction: random camera poses around the task's camera (Stone et al. 2021, Sec. 3.1)."""
from __future__ import annotations

import math

import numpy as np

from dcs_torchrl import presets
from dcs_torchrl._scene import Scene
from dcs_torchrl.distractions import camera_kernels as ck
from dcs_torchrl.distractions import camera_math as cm
from dcs_torchrl.distractions.base import DistractionTransform, check_scale, per_world
from dcs_torchrl.distractions.noise import NoiseBank

_FIXED, _TRACK, _TRACKCOM = ck.FIXED, ck.TRACK, ck.TRACKCOM
_MODE_NAMES = ("fixed", "track", "trackcom", "targetbody", "targetbodycom")
# A camera this close to straight above its focus uses the pole-safe look-at (the
# reference's reacher rule); every other camera is kept in the upper frontal quadrant.
_OVERHEAD_ELEVATION = math.pi / 8


class CameraDistraction(DistractionTransform):
    """Moves the rendering camera on a sphere around its focus, static or dynamic (Stone et al. 2021, Sec. 3.1; docs/paper.md).

    The pose ``(azimuth, elevation, radius, roll)`` is sampled uniformly at every reset
    within ±πβ/2 (angles and roll) and [r0(1-β/2), r0(1+3β/2)] (radius) of the task's
    camera; in the dynamic setting it then follows a velocity random walk, ``frame_skip``
    steps per agent step. The camera always looks at its focus: the agent's starting
    position for fixed cameras, its current centre of mass for tracking cameras.
    Physics and rewards are unchanged: only ``data.cam_xpos`` / ``data.cam_xmat`` are
    rewritten after each physics step, before :class:`~dcs_torchrl.RenderPixels`.

    Args:
        scale (float): β_cam in [0, 1]. 0 leaves the camera untouched (unless ``blind``).
        dynamic (bool): move the camera at every control step. Defaults to ``False``.

    Keyword Args:
        camera_id (int, optional): the camera to move; must be the one rendered.
            Defaults to the suite's camera of the domain (0, or 2 for quadruped).
        blind (bool): turn the camera backwards, facing away from its focus, so that
            no task-relevant body is in view (the paper's ``blind`` benchmark).
        upper_quadrant (bool, optional): keep the camera in the upper frontal quadrant
            with a roll-free look-at. ``None`` (default) does so for every camera that is
            not looking down from above (the authors' rule: all domains but reacher).
        seed (int, optional), expose (bool): see :class:`DistractionTransform`.

    Examples:
        >>> from torchrl.envs import DMControlEnv, TransformedEnv, Compose
        >>> from dcs_torchrl import CameraDistraction, RenderPixels
        >>> env = TransformedEnv(
        ...     DMControlEnv("cheetah", "run", from_pixels=False, frame_skip=4),
        ...     Compose(CameraDistraction(0.2, dynamic=True, seed=0, expose=True), RenderPixels()),
        ... )
        >>> td = env.rollout(3)
        >>> td["next", "distractions", "camera"].shape
        torch.Size([3, 4])
    """

    state_name = "camera"
    seed_tag = 1

    def __init__(
        self,
        scale: float,
        dynamic: bool = False,
        *,
        camera_id: int | None = None,
        blind: bool = False,
        upper_quadrant: bool | None = None,
        seed: int | None = None,
        expose: bool = False,
    ):
        self.scale = check_scale("CameraDistraction scale", scale)
        self.dynamic = bool(dynamic)
        self.blind = bool(blind)
        self.upper_quadrant = upper_quadrant
        self._requested_camera = camera_id
        self.camera_id: int | None = None
        super().__init__(seed=seed, expose=expose)

    @property
    def active(self) -> bool:
        return self.scale > 0 or self.blind

    def _on_bind(self, scene: Scene) -> None:
        model = scene.physics.model
        cid = self._requested_camera
        if cid is None:
            cid = presets.default_camera(scene.domain)
        if not 0 <= cid < model.ncam:
            raise ValueError(
                f"CameraDistraction camera_id={cid} is out of range: the model has {model.ncam} "
                f"camera(s); pass camera_id between 0 and {model.ncam - 1}."
            )
        mode = int(model.cam_mode[cid])
        if mode not in (_FIXED, _TRACK, _TRACKCOM):
            raise ValueError(
                f"CameraDistraction supports fixed and tracking cameras; camera {cid} uses mode "
                f"{_MODE_NAMES[mode]!r}. Pass the camera_id of a fixed or tracking camera."
            )
        self.camera_id = cid
        self._mode = mode

    # --------------------------------------------------------------- contract
    def _new_worlds(self, scene: Scene) -> "CameraWorlds":
        return CameraWorlds(1, scene.frame_skip)

    def _start(self, physics) -> None:
        self._worlds.start(self.row, self, physics)

    def _edit_scene(self, physics) -> None:
        data = physics.data
        views = [a[None] for a in (data.cam_xpos, data.cam_xmat, data.subtree_com, data.xpos)]
        self._worlds.place(self._rows, 0, *views, views[0], views[1])

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros(4, dtype=np.float32)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(scale={self.scale}, dynamic={self.dynamic}, "
            f"camera_id={self._requested_camera}, blind={self.blind})"
        )


class CameraWorlds:
    """The camera distraction of N worlds as arrays: each world's pose, velocity and range (drawn at its
    episode start, :meth:`start`), advanced and placed for all the worlds at once (:meth:`advance`,
    :meth:`place`, compiled: :mod:`dcs_torchrl.distractions.camera_kernels`). A
    :class:`CameraDistraction` on one env keeps its state in a one-world instance; a batch keeps its
    worlds' in one (:meth:`CameraDistraction.share`).

    Args:
        n (int): the worlds.
        frame_skip (int or array of int): control steps a world walks per agent step.
    """

    def __init__(self, n: int, frame_skip):
        self.n = n
        self.frame_skip = per_world(frame_skip, n)
        self.pose = np.zeros((n, 4))  # radius, azimuth, elevation, roll (the turned frame)
        self.velocity = np.zeros((n, 3))
        self.roll_velocity = np.zeros(n)
        self.limits = np.zeros((n, len(ck.LIMITS)))
        self.turn = np.zeros(n)  # the frame's turn about z (a multiple of pi/2) ...
        self.turn_cos_sin = np.zeros((n, 2))  # ... as cos, sin
        self.camera = np.zeros(n, np.int64)
        self.mode = np.zeros(n, np.int64)
        self.body = np.zeros(n, np.int64)
        self.upright = np.zeros(n, bool)
        self.blind = np.zeros(n, bool)
        self.fixed_focus = np.full((n, 3), np.nan)  # a fixed camera's focus; NaN: the task camera's, each step
        self.placed = np.zeros(n, bool)  # the distraction moves the camera (active)
        self.moving = np.zeros(n, bool)  # ... at every control step (dynamic)
        self.noise = NoiseBank(n, 4, self.frame_skip)

    def start(self, row: int, distraction: CameraDistraction, physics) -> None:
        """World ``row``'s episode start: its range about the task's camera, a pose drawn in it from
        ``distraction``'s generator (with ``distraction``'s settings), the noise of its walk to come."""
        self.noise.rewind(row)
        model, data = physics.model, physics.data
        cid, mode = distraction.camera_id, distraction._mode
        body = int(model.cam_bodyid[cid])
        origin = data.subtree_com[body] if mode == _TRACKCOM else data.xpos[body] if mode == _TRACK else np.zeros(3)
        radius0, azimuth0, elevation0 = cm.cart_to_sphere(*(data.cam_xpos[cid] - origin))
        turn = cm.frame_turn(azimuth0)
        azimuth0 -= turn
        upright = distraction.upper_quadrant
        if upright is None:
            upright = elevation0 >= _OVERHEAD_ELEVATION
        r = cm.pose_range(radius0, azimuth0, elevation0, distraction.scale, distraction.dynamic, upright)
        self.camera[row], self.mode[row], self.body[row], self.upright[row] = cid, mode, body, upright
        self.turn[row], self.turn_cos_sin[row] = turn, (math.cos(turn), math.sin(turn))
        self.limits[row] = r.limits()
        self.blind[row] = distraction.blind
        self.placed[row] = distraction.active
        self.moving[row] = distraction.active and distraction.dynamic
        if not distraction.active:
            self.pose[row] = radius0, azimuth0, elevation0, 0.0
            self.velocity[row], self.roll_velocity[row] = 0.0, 0.0
            return
        self.fixed_focus[row] = np.nan
        if mode == _FIXED:  # the task's camera's focus, kept for the episode
            ck.task_focus(data.cam_xpos[cid], data.cam_xmat[cid], data.subtree_com[1], self.fixed_focus[row])
        rng = distraction._rng
        pose = cm.sample_pose(rng, r)
        self.pose[row] = pose.radius, pose.azimuth, pose.elevation, pose.roll
        self.velocity[row], self.roll_velocity[row] = pose.velocity, pose.roll_velocity
        # the reference runs one random-walk step right after sampling (also when static): it
        # canonicalises the spherical coordinates and clips them to the range
        one, at = np.zeros(1, np.int64), slice(row, row + 1)  # this world's rows, as a batch of one
        ck.walk(one, np.ones(1, np.int64), rng.standard_normal((1, 4)), one, self.pose[at], self.velocity[at],
                self.roll_velocity[at], self.limits[at])

    def advance(self, rows: np.ndarray) -> None:
        """One agent step (each world's frame skip in control steps) of the walk of the worlds ``rows`` that move."""
        rows = rows[self.moving[rows]]
        if len(rows):
            ck.walk(rows, self.frame_skip[rows], self.noise.values, self.noise.take(rows), self.pose, self.velocity,
                    self.roll_velocity, self.limits)

    def place(self, rows: np.ndarray, offset: int, cam_xpos, cam_xmat, subtree_com, xpos, out_xpos,
              out_xmat) -> None:
        """Writes the camera of the worlds ``rows`` whose camera the distraction moves into
        ``out_xpos[row - offset]`` / ``out_xmat[row - offset]`` (``[.., ncam, 3]`` / ``[.., ncam, 9]``, any
        float dtype), from the new state's ``cam_xpos`` / ``cam_xmat`` / ``subtree_com`` / ``xpos`` (float64,
        ``[N, ...]``: row ``row`` is world ``row``'s)."""
        rows = rows[self.placed[rows]]
        if len(rows):
            ck.place(rows, offset, self.camera, self.pose, self.turn_cos_sin, self.mode, self.body,
                     self.upright, self.blind, self.fixed_focus, cam_xpos, cam_xmat, subtree_com, xpos,
                     out_xpos, out_xmat)

    def states(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The exposed state (float32 ``[azimuth in the world frame, elevation, radius, roll]``) of the worlds ``rows`` (all: ``None``)."""
        rows = np.arange(self.n) if rows is None else rows
        out = np.empty((len(rows), 4), np.float32)
        ck.state(self.pose[rows], self.turn[rows], out)
        return out

