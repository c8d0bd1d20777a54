"""BatchPhysics: the control steps of N dm_control envs in MuJoCo's C, over threads, their tasks over arrays.

A dm_control ``Environment.step(action)`` runs, in Python: the task's ``before_step`` (the action into
``data.ctrl``), ``physics.step(n_sub_steps)`` (MuJoCo's "legacy" step: ``mj_step2``, ``mj_step`` for the
other substeps, ``mj_step1``, so that the data's positions and velocities are those of the new state), the
task's ``after_step``, ``get_reward``, ``get_observation`` and the time limit. For a task of
:data:`dcs_torchrl.vector.task_arrays.TASKS` this module does the same: each env's MuJoCo calls on its own data
(``mj_step2`` / ``mj_step`` / ``mj_step1`` release the GIL, so the envs' physics run on every core, in
contiguous parts of the batch, one thread each), each control step's :class:`TaskArrays` fields recorded
into arrays, then the rewards and the last step's observation computed over all the envs at once. The
states, rewards, observations and episode ends are dm_control's, bit for bit (``tests/test_batched.py``).

The time limit is the dm_control env's own count (its episode clock, kept as ``Environment.step`` keeps
it: :func:`dcs_torchrl._compat.private_api.episode_clock`), so each env stays a dm_control env that
its own ``reset`` (the task's ``initialize_episode``) and ``step`` continue exactly.
"""
from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np
from dm_control.rl.control import PhysicsError

from dcs_torchrl._compat.private_api import episode_clock, set_episode_clock, sub_steps
from dcs_torchrl.vector._batching import shares
from dcs_torchrl.vector.task_arrays import Ids, TaskArrays

__all__ = ["BatchPhysics", "RETUNE", "TRIALS", "physics_threads", "threads_among"]

#: Steps each thread count is tried on when :class:`BatchPhysics` chooses its threads.
TRIALS = 5
#: Steps after which the choice is measured again: early in an episode a walker, in the air, costs
#: MuJoCo less than on the floor with its contacts, where threads gain more.
RETUNE = 200


def physics_threads() -> int:
    """The threads :class:`BatchPhysics` steps a batch's physics in by default: the cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def threads_among(processes: int) -> int | None:
    """The physics threads of each of ``processes`` batches stepped at once on this machine: one where a
    process has a core or less of its own (more only oversubscribe the cores), else ``None`` (chosen)."""
    return 1 if physics_threads() <= processes else None


class BatchPhysics:
    """The physics and task of N dm_control envs of one task, stepped together.

    Args:
        dm_envs (sequence of dm_control ``Environment``): the envs, each with its own physics (the
            suite's envs of one batch), one task.
        arrays (TaskArrays): the task over arrays (:func:`dcs_torchrl.vector.task_arrays.task_arrays`).
        frame_skip (int or sequence of int): control steps per agent step (the action repeat), of all
            the envs or of each.
        threads (int, optional): threads the physics run on. ``None``: chosen by measurement among 1, 2,
            4, ... up to :func:`physics_threads` (each tried on :data:`TRIALS` steps, the counts in
            turn, then the fastest per env by median kept, and measured again every :data:`RETUNE`
            steps): a task whose MuJoCo step is short gains nothing from threads that
            take the GIL in turn between calls, one whose step is long gains from every core. The
            states are the same for any number.
    """

    def __init__(self, dm_envs: Sequence, arrays: TaskArrays, frame_skip: int | Sequence[int],
                 threads: int | None = None):
        self.envs = list(dm_envs)
        self.arrays = arrays
        n = len(self.envs)
        self.frame_skips = np.broadcast_to(np.asarray(frame_skip, dtype=np.int64), (n,)).copy()
        self.frame_skip = int(self.frame_skips.max())
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ValueError(f"physics_threads must be a positive integer (or None), got {threads!r}.")
        most = min(physics_threads() if threads is None else threads, n)
        # the thread counts tried (each on TRIALS steps, in turn), their seconds per env-step, the schedule
        self._trials = [] if threads is not None else [t for t in (2 ** e for e in range(most.bit_length())) if t <= most]
        if self._trials and self._trials[-1] != most:
            self._trials.append(most)
        if len(self._trials) < 2:
            self._trials = []  # nothing to choose from
        self._kept = 0
        self._timings: dict[int, list[float]] = {t: [] for t in self._trials}
        self._schedule = self._trials * TRIALS  # the counts in turn, round after round: noise hits each alike
        self.threads = self._schedule[0] if self._schedule else most
        first = self.envs[0].physics
        self.ids = Ids(first.model.ptr)
        self._sub_steps = [sub_steps(env) for env in self.envs]
        self._rk4 = [env.physics.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4 for env in self.envs]
        # per env: its MjModel, MjData, the data arrays recorded, its warning counters
        self._models = [env.physics.model.ptr for env in self.envs]
        self._datas = [env.physics.data.ptr for env in self.envs]
        self._sources = [[getattr(data, f) for f in arrays.fields] for data in self._datas]
        self._warnings = [data.warning.number for data in self._datas]
        self.record = {f: np.zeros((self.frame_skip, n, *np.shape(getattr(self._datas[0], f))), np.float64)
                       for f in arrays.fields}
        self._record = [self.record[f] for f in arrays.fields]
        self.model = {f: np.zeros((n, *np.shape(getattr(first.model, f))), np.float64) for f in arrays.model_fields}
        for i in range(n):
            self.after_reset(i)
        self._pool = ThreadPoolExecutor(most, thread_name_prefix="dcs-physics") if most > 1 else None

    def after_reset(self, i: int) -> None:
        """Env ``i`` was reset (its task drew a new episode): read the model fields its task may have set."""
        model = self.envs[i].physics.model
        for f, values in self.model.items():
            values[i] = getattr(model, f)

    def over(self, i: int) -> bool:
        """Whether env ``i``'s episode has ended (dm_control resets it on its next step)."""
        return bool(episode_clock(self.envs[i])[2])

    def step(self, indices: np.ndarray, actions: np.ndarray, observe: bool = True):
        """One agent step (``frame_skip`` control steps, fewer where an episode reaches its time limit) of
        the envs ``indices`` (none of them :meth:`over`), ``actions[i]`` applied to env ``indices[i]``.

        Returns ``(reward, truncated, observation)`` for those envs, in order: the control steps' rewards
        summed as TorchRL's ``DMControlEnv`` sums them (float64), whether the time limit ended the
        episode (the six tasks end no other way), and dm_control's observation of the last state (a dict
        of ``[len(indices), ...]`` float64 arrays; ``None`` unless ``observe``).
        """
        indices = np.asarray(indices, dtype=np.int64)
        n = len(indices)
        clocks = [episode_clock(self.envs[i]) for i in indices]
        counts = np.array([count for count, _, _ in clocks], dtype=np.float64)
        limits = np.array([limit for _, limit, _ in clocks], dtype=np.float64)
        # control steps until the limit: dm_control ends the episode at the first step with count >= limit
        steps = np.minimum(self.frame_skips[indices], np.maximum(1, np.ceil(limits - counts))).astype(np.int64)
        truncated = counts + steps >= limits
        parts = self._parts(n)
        work = [(indices[part], actions[part], steps[part], part) for part in parts]
        start = time.perf_counter()
        if len(work) == 1:
            self._run(*work[0])
        else:
            for future in [self._pool.submit(self._run, *item) for item in work]:
                future.result()
        if len(self._timings) > 1:
            self._choose_threads((time.perf_counter() - start) / n)
        elif self._trials:  # chosen: measured again every RETUNE steps (a task's step costs change over an episode)
            self._kept += 1
            if self._kept >= RETUNE:
                self._schedule = self._trials * TRIALS
                self._timings = {t: [] for t in self._trials}
                self.threads = self._schedule[0]
        for i, count, ended in zip(indices.tolist(), (counts + steps).tolist(), truncated.tolist()):
            set_episode_clock(self.envs[i], int(count) if math.isfinite(count) else count, ended)
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

    def _choose_threads(self, seconds: float) -> None:
        """Records a step's seconds per env under :attr:`threads`; moves to the next count of the
        schedule, or, once each has had :data:`TRIALS` steps, keeps the fastest (by median)."""
        self._timings[self.threads].append(seconds)
        self._schedule = self._schedule[1:]
        if self._schedule:
            self.threads = self._schedule[0]
            return
        self.threads = min(self._timings, key=lambda t: float(np.median(self._timings[t])))
        self._kept = 0  # steps since: the choice is measured again after RETUNE of them
        self._timings = {self.threads: []}

    def _parts(self, n: int) -> list[slice]:
        return [slice(part.start, part.stop) for part in shares(n, self.threads)]

    def _run(self, indices: np.ndarray, actions: np.ndarray, steps: np.ndarray, part: slice) -> None:
        """The control steps of envs ``indices`` (one thread), recorded in rows ``part`` of :attr:`record`."""
        record = self._record
        for row, i, action, k in zip(range(part.start, part.stop), indices.tolist(), actions, steps.tolist()):
            model, data = self._models[i], self._datas[i]
            sources, sub, rk4 = self._sources[i], self._sub_steps[i], self._rk4[i]
            warnings = self._warnings[i]
            before = warnings.copy()
            np.copyto(data.ctrl, action)  # the task's before_step: physics.set_control(action)
            for j in range(k):
                if rk4:  # dm_control's Physics.step with legacy_step
                    mujoco.mj_step(model, data, sub)
                else:
                    mujoco.mj_step2(model, data)
                    if sub > 1:
                        mujoco.mj_step(model, data, sub - 1)
                mujoco.mj_step1(model, data)
                for values, source in zip(record, sources):
                    values[j, row] = source
            if (warnings > before).any():
                names = [name for name, new in zip(mujoco.mjtWarning.__members__, warnings > before) if new]
                raise PhysicsError(f"Physics state is invalid. Warning(s) raised: {', '.join(names)}")

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
