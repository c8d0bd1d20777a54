"""The paper's six tasks over arrays: each control step's reward and the state observation of N envs at
once, from the arrays of their MuJoCo data, equal to dm_control's task methods on the same states.

:class:`~dcs_torchrl.vector.batched.BatchedSuiteEnv` steps its envs' physics in MuJoCo's C (no dm_control
Python per step) and records, after each control step, the :class:`TaskArrays` ``fields`` of every env's
``MjData`` into arrays ``[..., N, *field shape]``; ``reward`` and ``observation`` then compute over them,
each line the line of dm_control's ``suite/<domain>.py`` it mirrors, with the same operations in the same
order (``dm_control.utils.rewards.tolerance`` itself, which takes arrays), so the values are dm_control's
bit for bit (``tests/test_task_arrays.py`` compares them on every task, over many states). None of the six
tasks overrides ``before_step`` (the action into ``ctrl``), ``after_step`` or ``get_termination`` (so an
episode ends only at its time limit): :func:`task_arrays` checks that on the task it is given and returns
``None`` for any other task, which then keeps dm_control's per-env step.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.suite import ball_in_cup, base, cartpole, cheetah, finger, reacher, walker
from dm_control.utils.rewards import tolerance

__all__ = ["TASKS", "TaskArrays", "task_arrays"]

_ZZ, _XZ, _XX = 8, 2, 0  # columns of a 3x3 rotation matrix stored row-major (dm_control's 'zz', 'xz', 'xx')


class Ids:
    """Indices of a model's named elements, each resolved once and kept (what dm_control's ``physics.named``
    looks up at every call)."""

    def __init__(self, model):
        self.model = model
        # kept by this Ids, not by a cache on the class (which would keep every batch's model for good)
        self._ids: dict[tuple[mujoco.mjtObj, str], int] = {}
        self._sensors: dict[tuple[str, ...], np.ndarray] = {}

    def _id(self, kind: mujoco.mjtObj, name: str) -> int:
        index = self._ids.get((kind, name))
        if index is None:
            index = mujoco.mj_name2id(self.model, kind, name)
            if index < 0:
                raise KeyError(f"the model has no {kind.name[6:].lower()} named {name!r}")
            self._ids[kind, name] = index
        return index

    def body(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_BODY, name)

    def geom(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_GEOM, name)

    def site(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_SITE, name)

    def qpos(self, joint: str) -> int:
        return int(self.model.jnt_qposadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, joint)])

    def sensor(self, *names: str) -> np.ndarray:
        """The ``sensordata`` indices of ``names``, concatenated (dm_control's ``named.data.sensordata[names]``)."""
        if names not in self._sensors:
            index = []
            for name in names:
                s = self._id(mujoco.mjtObj.mjOBJ_SENSOR, name)
                adr, dim = int(self.model.sensor_adr[s]), int(self.model.sensor_dim[s])
                index += range(adr, adr + dim)
            self._sensors[names] = np.asarray(index)
        return self._sensors[names]


@dataclass(frozen=True)
class TaskArrays:
    """One task over arrays.

    ``fields``: the ``MjData`` fields read, recorded whole after each control step (arrays ``[..., N, ...]``).
    ``model_fields``: the ``MjModel`` fields read, recorded at each reset (a task may set them per episode).
    ``reward(data, model, ids)``: ``[...]`` float64, dm_control's ``get_reward`` of each recorded state.
    ``observation(data, model, ids)``: dm_control's ``get_observation``, each key ``[..., *shape]``.
    """

    fields: tuple[str, ...]
    model_fields: tuple[str, ...]
    reward: Callable[[dict, dict, Ids], np.ndarray]
    observation: Callable[[dict, dict, Ids], dict]


Arrays = dict  # field name -> array [..., N, *field shape]


# ---------------------------------------------------------------- cartpole swingup (suite/cartpole.py)
def _cartpole_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:  # Balance._get_reward, sparse=False
    poles = slice(2, None)  # xmat[2:, 'zz']: the poles' bodies
    upright = (d["xmat"][..., poles, _ZZ] + 1) / 2
    centered = tolerance(d["qpos"][..., ids.qpos("slider")], margin=2)
    centered = (1 + centered) / 2
    small_control = tolerance(d["ctrl"], margin=1, value_at_margin=0, sigmoid="quadratic")[..., 0]
    small_control = (4 + small_control) / 5
    small_velocity = tolerance(d["qvel"][..., 1:], margin=5).min(axis=-1)
    small_velocity = (1 + small_velocity) / 2
    return upright.mean(axis=-1) * small_control * small_velocity * centered


def _cartpole_observation(d: Arrays, m: Arrays, ids: Ids) -> dict:
    cart = d["qpos"][..., ids.qpos("slider"), None]
    pole = d["xmat"][..., 2:, :][..., [_ZZ, _XZ]]
    return {"position": np.concatenate([cart, pole.reshape(*pole.shape[:-2], -1)], axis=-1),
            "velocity": d["qvel"].copy()}


# ---------------------------------------------------------------- cheetah run (suite/cheetah.py)
def _cheetah_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:
    speed = d["sensordata"][..., ids.sensor("torso_subtreelinvel")[0]]
    return tolerance(speed, bounds=(cheetah._RUN_SPEED, float("inf")), margin=cheetah._RUN_SPEED,
                     value_at_margin=0, sigmoid="linear")


def _cheetah_observation(d: Arrays, m: Arrays, ids: Ids) -> dict:
    return {"position": d["qpos"][..., 1:].copy(), "velocity": d["qvel"].copy()}


# ---------------------------------------------------------------- walker walk (suite/walker.py)
def _walker_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:  # PlanarWalker.get_reward, move_speed=_WALK_SPEED
    torso = ids.body("torso")
    standing = tolerance(d["xpos"][..., torso, 2], bounds=(walker._STAND_HEIGHT, float("inf")),
                         margin=walker._STAND_HEIGHT / 2)
    upright = (1 + d["xmat"][..., torso, _ZZ]) / 2
    stand_reward = (3 * standing + upright) / 4
    move_reward = tolerance(d["sensordata"][..., ids.sensor("torso_subtreelinvel")[0]],
                            bounds=(walker._WALK_SPEED, float("inf")), margin=walker._WALK_SPEED / 2,
                            value_at_margin=0.5, sigmoid="linear")
    return stand_reward * (5 * move_reward + 1) / 6


def _walker_observation(d: Arrays, m: Arrays, ids: Ids) -> dict:
    orientations = d["xmat"][..., 1:, :][..., [_XX, _XZ]]
    return {"orientations": orientations.reshape(*orientations.shape[:-2], -1),
            "height": d["xpos"][..., ids.body("torso"), 2].copy(),
            "velocity": d["qvel"].copy()}


# ---------------------------------------------------------------- finger spin (suite/finger.py)
def _finger_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:  # Spin.get_reward
    hinge_velocity = d["sensordata"][..., ids.sensor("hinge_velocity")[0]]
    return (hinge_velocity <= -finger._SPIN_VELOCITY).astype(np.float64)


def _finger_observation(d: Arrays, m: Arrays, ids: Ids) -> dict:
    s = d["sensordata"]
    tip = s[..., ids.sensor("tip")[[0, 2]]] - s[..., ids.sensor("spinner")[[0, 2]]]
    return {"position": np.concatenate([s[..., ids.sensor("proximal", "distal")], tip], axis=-1),
            "velocity": s[..., ids.sensor("proximal_velocity", "distal_velocity", "hinge_velocity")],
            "touch": np.log1p(s[..., ids.sensor("touchtop", "touchbottom")])}


# ---------------------------------------------------------------- reacher easy (suite/reacher.py)
def _finger_to_target(d: Arrays, ids: Ids) -> np.ndarray:
    return d["geom_xpos"][..., ids.geom("target"), :2] - d["geom_xpos"][..., ids.geom("finger"), :2]


def _reacher_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:
    size = m["geom_size"]  # [N, ngeom, 3]: the target's size is drawn per episode
    radii = size[..., ids.geom("target"), 0] + size[..., ids.geom("finger"), 0]
    v = _finger_to_target(d, ids)
    distance = np.sqrt(v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1])  # np.linalg.norm of a 2-vector
    # tolerance(distance, (0, radii)) with radii per env (tolerance takes scalar bounds): margin 0
    return np.where(np.logical_and(0 <= distance, distance <= radii), 1.0, 0.0)


def _reacher_observation(d: Arrays, m: Arrays, ids: Ids) -> dict:
    return {"position": d["qpos"].copy(), "to_target": _finger_to_target(d, ids), "velocity": d["qvel"].copy()}


# ---------------------------------------------------------------- ball_in_cup catch (suite/ball_in_cup.py)
def _ball_in_cup_reward(d: Arrays, m: Arrays, ids: Ids) -> np.ndarray:  # Physics.in_target
    target = d["site_xpos"][..., ids.site("target"), :][..., [0, 2]]
    ball = d["xpos"][..., ids.body("ball"), :][..., [0, 2]]
    ball_to_target = abs(target - ball)
    target_size = m["site_size"][..., ids.site("target"), :][..., [0, 2]]
    ball_size = m["geom_size"][..., ids.geom("ball"), 0]
    return np.all(ball_to_target < target_size - ball_size[..., None], axis=-1).astype(np.float64)


def _position_velocity(d: Arrays, m: Arrays, ids: Ids) -> dict:
    return {"position": d["qpos"].copy(), "velocity": d["qvel"].copy()}


#: The tasks computed over arrays, by ``(domain, task)``: each with the dm_control task class it mirrors.
TASKS: dict[tuple[str, str], tuple[type, TaskArrays]] = {
    ("cartpole", "swingup"): (cartpole.Balance, TaskArrays(("qpos", "qvel", "ctrl", "xmat"), (), _cartpole_reward,
                                                           _cartpole_observation)),
    ("cheetah", "run"): (cheetah.Cheetah, TaskArrays(("qpos", "qvel", "sensordata"), (), _cheetah_reward,
                                                     _cheetah_observation)),
    ("walker", "walk"): (walker.PlanarWalker, TaskArrays(("qvel", "xpos", "xmat", "sensordata"), (), _walker_reward,
                                                         _walker_observation)),
    ("finger", "spin"): (finger.Spin, TaskArrays(("sensordata",), (), _finger_reward, _finger_observation)),
    ("reacher", "easy"): (reacher.Reacher, TaskArrays(("qpos", "qvel", "geom_xpos"), ("geom_size",),
                                                      _reacher_reward, _reacher_observation)),
    ("ball_in_cup", "catch"): (ball_in_cup.BallInCup, TaskArrays(("qpos", "qvel", "xpos", "site_xpos"),
                                                                 ("site_size", "geom_size"), _ball_in_cup_reward,
                                                                 _position_velocity)),
}

# what the arrays assume of dm_control: the task's step hooks are the base task's (the action into ctrl,
# nothing after the step, no termination but the time limit)
_BASE_HOOKS = {"before_step": base.Task.before_step, "after_step": base.Task.after_step,
               "get_termination": control.Task.get_termination}


def task_arrays(domain: str, task: str, dm_task) -> TaskArrays | None:
    """The :class:`TaskArrays` of ``(domain, task)`` if its dm_control task (``dm_task``, the instance an
    env steps) is the one they mirror, with the base task's step hooks and no reward colours; else ``None``."""
    entry = TASKS.get((domain, task))
    if entry is None:
        return None
    cls, arrays = entry
    if type(dm_task) is not cls or getattr(dm_task, "visualize_reward", False):
        return None
    if any(getattr(type(dm_task), name) is not hook for name, hook in _BASE_HOOKS.items()):
        return None
    return arrays
