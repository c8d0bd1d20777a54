"""BatchPhysics: the control steps of N dm_control envs in one compiled call over MuJoCo's C, their tasks over arrays.

A dm_control ``Environment.step(action)`` runs, in Python: the task's ``before_step`` (the action into
``data.ctrl``), ``physics.step(n_sub_steps)`` (MuJoCo's "legacy" step: ``mj_step2``, ``mj_step`` for the
other substeps, ``mj_step1``, so that the data's positions and velocities are those of the new state), the
task's ``after_step``, ``get_reward``, ``get_observation`` and the time limit. For a task of
:data:`dcs_torchrl.vector.task_arrays.TASKS` this module does the same: the envs' MuJoCo calls on their own
data and each control step's :class:`TaskArrays` fields recorded into arrays, all in one compiled call that
holds no GIL (:func:`dcs_torchrl.vector._mjstep.step_worlds`; on every core: contiguous parts of the batch,
one thread each), then the rewards and the last step's observation computed over all the envs at once. The
states, rewards, observations and episode ends are dm_control's, bit for bit (``tests/test_batch_physics.py``,
``tests/test_batched.py``).

The time limit is the dm_control env's own count (its episode clock:
:func:`dcs_torchrl._compat.private_api.episode_clock`), read at each reset (:meth:`BatchPhysics.after_reset`),
kept in arrays while the batch steps and written back to the env when its episode ends, so each env stays a
dm_control env that its own ``step`` resets and its own ``reset`` (the task's ``initialize_episode``) starts
again.
"""
from __future__ import annotations

import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np
from dm_control.rl.control import PhysicsError

from dcs_torchrl._compat.pointers import address
from dcs_torchrl._compat.private_api import episode_clock, set_episode_clock, struct_addresses, sub_steps
from dcs_torchrl.vector._batching import shares
from dcs_torchrl.vector.kinematics import Fields
from dcs_torchrl.vector.task_arrays import Ids, TaskArrays

__all__ = ["BatchPhysics", "physics_threads", "threads_among"]


def physics_threads() -> int:
    """The threads :class:`BatchPhysics` steps a batch's physics in by default: the cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def threads_among(processes: int) -> int | None:
    """The physics threads of each of ``processes`` batches stepped at once on this machine: one where a
    process has a core or less of its own (more only oversubscribe the cores), else ``None`` (every core)."""
    return 1 if physics_threads() <= processes else None


class BatchPhysics:
    """The physics and task of N dm_control envs of one task, stepped together.

    Args:
        dm_envs (sequence of dm_control ``Environment``): the envs, each with its own physics (the
            suite's envs of one batch), one task, reset (each env's clock is read there and at
            :meth:`after_reset`).
        arrays (TaskArrays): the task over arrays (:func:`dcs_torchrl.vector.task_arrays.task_arrays`).
        frame_skip (int or sequence of int): control steps per agent step (the action repeat), of all
            the envs or of each.
        threads (int, optional): threads the physics run on (this one and ``threads - 1`` of a pool),
            each stepping a contiguous part of the envs in one call that holds no GIL; ``None``:
            :func:`physics_threads`. The states are the same for any number.
    """

    def __init__(self, dm_envs: Sequence, arrays: TaskArrays, frame_skip: int | Sequence[int],
                 threads: int | None = None):
        from dcs_torchrl.vector import _mjstep  # compiled at the first batch, cached on disk after

        self._step_worlds = _mjstep.step_worlds
        self.envs = list(dm_envs)
        self.arrays = arrays
        n = len(self.envs)
        self.frame_skips = np.broadcast_to(np.asarray(frame_skip, dtype=np.int64), (n,)).copy()
        self.frame_skip = int(self.frame_skips.max())
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ValueError(f"physics_threads must be a positive integer (or None), got {threads!r}.")
        #: the threads the physics run on (at most one per env)
        self.threads = max(1, min(physics_threads() if threads is None else threads, n))
        first = self.envs[0].physics
        self.ids = Ids(first.model.ptr)
        self._nu = first.model.nu
        # per env, what the compiled step reads: its structs' and arrays' C addresses, its substeps and integrator
        models, datas = [env.physics.model.ptr for env in self.envs], [env.physics.data.ptr for env in self.envs]
        self._structs = np.array([struct_addresses(m, d) for m, d in zip(models, datas)], np.int64).reshape(n, 2)
        self._controls = np.array([address(d.ctrl, np.float64) for d in datas], np.int64)
        fields = Fields(datas, arrays.fields)  # the recorded fields side by side, a row a control step and env
        self._sources, self._offsets = fields.addresses, fields.offsets
        counts = datas[0].warning.number  # int32, one per mjtWarning, strided in mjWarningStat
        self._warnings = np.array([[d.warning.number.__array_interface__["data"][0], len(counts),
                                    counts.strides[0] // counts.itemsize] for d in datas], np.int64).reshape(n, 3)
        self._sub_steps = np.array([sub_steps(env) for env in self.envs], np.int64)
        self._rk4 = np.array([m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4 for m in models], np.bool_)
        self._datas = datas  # kept alive with the addresses above
        self._record = np.zeros((self.frame_skip, n, fields.width), np.float64)  # [frame_skip, N, all fields]
        self.record = fields.views(self._record)
        self.model = {f: np.zeros((n, *np.shape(getattr(first.model, f))), np.float64) for f in arrays.model_fields}
        # each env's episode clock: control steps this episode, the time limit, whether the episode is over
        self._count, self._limit = np.zeros(n, np.float64), np.zeros(n, np.float64)
        self.ended = np.zeros(n, np.bool_)  #: whether each env's episode is over (:meth:`over`)
        for i in range(n):
            self.after_reset(i)
        self._pool = (None if self.threads == 1
                      else ThreadPoolExecutor(self.threads - 1, thread_name_prefix="dcs-physics"))

    def after_reset(self, i: int) -> None:
        """Env ``i`` was reset or stepped by dm_control (its task drew a new episode): read its episode clock
        and the model fields its task may have set."""
        model = self.envs[i].physics.model
        for f, values in self.model.items():
            values[i] = getattr(model, f)
        self._count[i], self._limit[i], self.ended[i] = episode_clock(self.envs[i])

    def over(self, i: int) -> bool:
        """Whether env ``i``'s episode has ended (dm_control resets it on its next step)."""
        return bool(self.ended[i])

    def step(self, indices: np.ndarray, actions: np.ndarray, observe: bool = True):
        """One agent step (``frame_skip`` control steps, fewer where an episode reaches its time limit) of
        the envs ``indices`` (none of them :meth:`over`), ``actions[i]`` applied to env ``indices[i]``.

        Returns ``(reward, truncated, observation)`` for those envs, in order: the control steps' rewards
        summed as TorchRL's ``DMControlEnv`` sums them (float64), whether the time limit ended the
        episode (the six tasks end no other way), and dm_control's observation of the last state (a dict
        of ``[len(indices), ...]`` float64 arrays; ``None`` unless ``observe``).
        """
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        n = len(indices)
        actions = np.ascontiguousarray(actions, dtype=np.float64).reshape(n, -1)
        if actions.shape[1] != self._nu:
            raise ValueError(f"actions of {actions.shape[1]} values an env, the task's have {self._nu}")
        if self.ended[indices].any():
            raise ValueError(f"envs {indices[self.ended[indices]].tolist()} are over: reset them (dm_control's "
                             "step does) before stepping them here")
        counts, limits = self._count[indices], self._limit[indices]
        # control steps until the limit: dm_control ends the episode at the first step with count >= limit
        steps = np.minimum(self.frame_skips[indices], np.maximum(1, np.ceil(limits - counts))).astype(np.int64)
        truncated = counts + steps >= limits
        stopped, grown = np.zeros(n, np.int64), np.zeros((n, self._warnings[0, 1]), np.bool_)
        work = [(indices[part], actions[part], steps[part], self._structs, self._controls, self._sources,
                 self._warnings, self._sub_steps, self._rk4, self._offsets, self._record, part.start, stopped[part],
                 grown[part]) for part in (slice(p.start, p.stop) for p in shares(n, self.threads))]
        others = [self._pool.submit(self._step_worlds, *item) for item in work[1:]]  # the first part: this thread's
        try:
            if work:
                self._step_worlds(*work[0])
        finally:
            for future in others:
                future.result()
        failed = stopped > 0  # dm_control's check_invalid_state raised after control step stopped[w]: not counted
        truncated &= ~failed
        self._count[indices] = counts + np.where(failed, stopped - 1, steps)
        self.ended[indices] = truncated
        for i in indices[truncated].tolist():  # the episodes that ended: dm_control's env resets at its next step
            count = self._count[i]
            set_episode_clock(self.envs[i], int(count) if math.isfinite(count) else count, True)
        if failed.any():
            names = [name for name, new in zip(mujoco.mjtWarning.__members__, grown[np.flatnonzero(failed)[0]]) if new]
            raise PhysicsError(f"Physics state is invalid. Warning(s) raised: {', '.join(names)}")
        recorded = {f: values[:, :n] for f, values in self.record.items()}
        model = {f: values[indices] for f, values in self.model.items()}
        with np.errstate(all="ignore"):  # rows past an env's last step hold older states, masked out below
            rewards = self.arrays.reward(recorded, model, self.ids)
        reward = 0
        for j in range(self.frame_skip):  # DMControlEnv: reward = reward + step.reward, step by step
            reward = np.where(j < steps, reward + rewards[j], reward)
        observation = None
        if observe:
            last = {f: values[steps - 1, np.arange(n)] for f, values in recorded.items()}
            observation = self.arrays.observation(last, model, self.ids)
        return np.asarray(reward, np.float64), truncated, observation

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
