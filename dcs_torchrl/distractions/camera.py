"""CameraDistraction: random camera poses around the task's camera (Stone et al. 2021, Sec. 3.1)."""
from __future__ import annotations

import math

import numpy as np

from dcs_torchrl import presets
from dcs_torchrl._scene import Scene
from dcs_torchrl.distractions import camera_math as cm
from dcs_torchrl.distractions.base import DistractionTransform, check_scale

_FIXED, _TRACK, _TRACKCOM = 0, 1, 2
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
    step_attributes = frozenset({"_pose"})

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
        self._pose: cm.Pose | None = None
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

    # --------------------------------------------------------------- geometry
    def _origin(self, data) -> np.ndarray:
        """Centre of the camera's sphere: world origin, or the tracked body / centre of mass."""
        body = self._body
        if self._mode == _TRACKCOM:
            return data.subtree_com[body]
        if self._mode == _TRACK:
            return data.xpos[body]
        return np.zeros(3)

    def _focus(self, data) -> tuple[float, float, float]:
        """The point the task's camera looks at: on its view ray, at its distance to the agent."""
        cid = self.camera_id
        position = data.cam_xpos[cid].tolist()
        distance = math.dist(position, data.subtree_com[1].tolist())
        xmat = data.cam_xmat[cid].tolist()  # row-major: the camera's z axis is (xmat[2], xmat[5], xmat[8])
        return tuple(p - distance * axis for p, axis in zip(position, xmat[2::3]))

    # --------------------------------------------------------------- contract
    def _start(self, physics) -> None:
        model, data = physics.model, physics.data
        self._body = int(model.cam_bodyid[self.camera_id])
        offset = data.cam_xpos[self.camera_id] - self._origin(data)
        radius0, azimuth0, elevation0 = cm.cart_to_sphere(*offset)
        self._turn = cm.frame_turn(azimuth0)
        self._turn_cos_sin = (math.cos(self._turn), math.sin(self._turn))
        azimuth0 -= self._turn
        upper = self.upper_quadrant
        if upper is None:
            upper = elevation0 >= _OVERHEAD_ELEVATION
        self._look_at = cm.look_at_upright if upper else cm.look_at_shortest
        self._range = cm.pose_range(radius0, azimuth0, elevation0, self.scale, self.dynamic, upper)
        if not self.active:
            self._pose = cm.Pose(radius0, azimuth0, elevation0, 0.0)
            return
        self._fixed_focus = self._focus(data) if self._mode == _FIXED else None
        # The reference runs one random-walk step right after sampling (also when static):
        # it canonicalises the spherical coordinates and clips them to the range.
        self._pose = cm.walk_many(cm.sample_pose(self._rng, self._range), self._range, self._rng, 1)

    def _advance(self, n_steps: int) -> None:
        if self.active and self.dynamic:
            self._pose = cm.walk_many(self._pose, self._range, self._rng, n_steps)

    def _edit_scene(self, physics) -> None:
        if not self.active:
            return
        data, pose, cid = physics.data, self._pose, self.camera_id
        x, y, z = cm.sphere_to_cart(pose.radius, pose.azimuth, pose.elevation)
        c, s = self._turn_cos_sin  # the frame's quarter turn about z, in floats: this runs every step
        ox, oy, oz = self._origin(data).tolist()
        position = (ox + c * x - s * y, oy + s * x + c * y, oz + z)
        focus = self._fixed_focus if self._fixed_focus is not None else self._focus(data)
        if self.blind:
            focus = tuple(2.0 * p - f for p, f in zip(position, focus))  # look the other way
        data.cam_xpos[cid] = position
        data.cam_xmat[cid] = self._look_at(focus, position, pose.roll).ravel()

    def _state(self) -> np.ndarray:
        return self._pose.as_array(self._turn)

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros(4, dtype=np.float32)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(scale={self.scale}, dynamic={self.dynamic}, "
            f"camera_id={self._requested_camera}, blind={self.blind})"
        )
