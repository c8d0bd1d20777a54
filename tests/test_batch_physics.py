"""BatchPhysics: one compiled call steps every env as dm_control's ``Environment.step`` does (states, warmstart,
rewards, observations, episode ends, PhysicsError), on the threads it is given, whatever their number."""
import threading

import mujoco
import numpy as np
import pytest
from dm_control import suite
from dm_control.rl.control import PhysicsError

from dcs_torchrl._compat.private_api import episode_clock
from dcs_torchrl.vector.batch_physics import BatchPhysics, physics_threads
from dcs_torchrl.vector.task_arrays import TASKS, task_arrays

#: MjData's state that carries from a step to the next (the solver's warmstart included), compared whole
STATE = mujoco.mjtState.mjSTATE_INTEGRATION
#: a short time limit (seconds): episodes of a few agent steps, the last one cut at the limit
TIME_LIMIT = 0.25


def _envs(domain: str, task: str, n: int, time_limit: float | None = None) -> list:
    limit = {} if time_limit is None else {"time_limit": time_limit}
    envs = [suite.load(domain, task, task_kwargs={"random": i, **limit}) for i in range(n)]
    for env in envs:
        env.reset()
    return envs


def _state(env) -> np.ndarray:
    physics = env.physics
    state = np.empty(mujoco.mj_stateSize(physics.model.ptr, STATE))
    mujoco.mj_getState(physics.model.ptr, physics.data.ptr, state, STATE)
    return np.concatenate([state, physics.data.qacc, physics.data.xpos.ravel(), physics.data.sensordata])


def _dm_control_step(env, action, k: int):
    """TorchRL's DMControlEnv over dm_control: ``k`` control steps (fewer at the episode's end), rewards summed."""
    reward = 0
    for _ in range(k):
        step = env.step(action)
        reward = reward + step.reward
        if step.last():
            break
    return reward, step.last(), step.observation


@pytest.mark.parametrize("domain, task", sorted(TASKS), ids=[f"{d}-{t}" for d, t in sorted(TASKS)])
def test_every_env_steps_as_dm_controls_step_across_episode_ends(domain, task):
    """Three envs, action repeats 2, 3, 4 (the last agent step of an episode cut at its limit), some steps of
    some envs only and out of order, an ended env reset by dm_control's own step: each env's states (the
    warmstart too), rewards, episode ends and observations are those of its twin stepped by dm_control."""
    n, repeats = 3, [2, 3, 4]
    envs, twins = _envs(domain, task, n, TIME_LIMIT), _envs(domain, task, n, TIME_LIMIT)
    batch = BatchPhysics(envs, task_arrays(domain, task, envs[0].task), repeats, threads=2)
    rng = np.random.default_rng(0)
    nu = envs[0].physics.model.nu
    ends = 0
    for t in range(16):
        indices = np.array([2, 0] if t % 5 == 3 else range(n))
        over = [i for i in indices if batch.over(i)]
        indices = np.array([i for i in indices if not batch.over(i)], np.int64)
        actions = rng.uniform(-1, 1, (n, nu))
        for i in over:  # dm_control's step resets an ended env (the clock the batch wrote back says it ended)
            assert envs[i].step(actions[i]).first() and twins[i].step(actions[i]).first()
            batch.after_reset(i)
        if not len(indices):
            continue
        reward, truncated, observation = batch.step(indices, actions[indices])
        for row, i in enumerate(indices):
            want_reward, want_last, want_observation = _dm_control_step(twins[i], actions[i], repeats[i])
            where = f"step {t}, env {i}"
            assert np.array_equal(_state(envs[i]), _state(twins[i])), where
            assert reward[row] == want_reward and truncated[row] == want_last, where
            for key, value in want_observation.items():
                assert np.array_equal(observation[key][row], np.reshape(value, observation[key][row].shape)), where
            ends += int(want_last)
    batch.close()
    assert ends >= n, "no episode ended: the test would miss a wrong episode end"


def test_any_number_of_threads_steps_the_same_states_on_that_many_threads():
    """The compiled step runs once per thread on a contiguous part of the envs, ``threads`` parts (every core
    for None, at most one per env): one on the calling thread, the others on the pool's ``threads - 1``;
    the states are the same for any number."""
    n, steps = 5, 6
    runs = {}
    for threads in (1, 2, 3, 7, None):
        envs = _envs("walker", "walk", n)
        batch = BatchPhysics(envs, task_arrays("walker", "walk", envs[0].task), [2, 3, 2, 3, 2], threads)
        called, step_worlds = [], batch._step_worlds

        def spy(worlds, *args, step_worlds=step_worlds, called=called):
            called.append((threading.get_ident(), worlds.tolist()))
            return step_worlds(worlds, *args)

        batch._step_worlds = spy
        rng, run = np.random.default_rng(0), []
        for _ in range(steps):
            called.clear()
            reward, _, observation = batch.step(np.arange(n), rng.uniform(-1, 1, (n, 6)))
            run.append((reward, observation["velocity"], np.stack([_state(env) for env in envs])))
            expected = min(n, physics_threads() if threads is None else threads)
            first = {worlds[0]: ident for ident, worlds in called}  # part 0 on this thread, the others on the pool's
            assert batch.threads == expected == len(called) and first[0] == threading.get_ident(), threads
            idents = set(first.values())
            assert len(idents) == expected if expected <= 2 else 2 <= len(idents) <= expected, threads
            assert sorted(world for _, worlds in called for world in worlds) == list(range(n))
            assert all(worlds == list(range(worlds[0], worlds[-1] + 1)) for _, worlds in called)
        batch.close()
        runs[threads] = run
    for threads, run in runs.items():
        for t, (a, b) in enumerate(zip(runs[1], run)):
            for x, y in zip(a, b):
                assert np.array_equal(x, y), (threads, t)


def test_bad_thread_counts_and_actions_are_refused():
    env = _envs("cartpole", "swingup", 1)[0]
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match="physics_threads must be a positive integer"):
            BatchPhysics([env], task_arrays("cartpole", "swingup", env.task), 8, bad)
    batch = BatchPhysics([env], task_arrays("cartpole", "swingup", env.task), 8)
    with pytest.raises(ValueError, match="actions of 2 values an env, the task's have 1"):
        batch.step([0], np.zeros((1, 2)))


def test_a_diverging_state_raises_dm_controls_physics_error_after_the_control_step_that_warned():
    """The env whose state diverges stops after the control step whose warnings grew, as dm_control's step
    raises there; the other env is stepped whole; the batch steps on once the env is reset."""
    envs, twins = _envs("cheetah", "run", 2), _envs("cheetah", "run", 2)
    batch = BatchPhysics(envs, task_arrays("cheetah", "run", envs[0].task), 4, 1)
    action = np.full(6, 0.5)
    for env in (envs[1], twins[1]):
        env.physics.data.qvel[:] = 1e300  # MuJoCo warns (a huge qpos after the first substep) and resets the data
    with pytest.raises(PhysicsError, match="Physics state is invalid. Warning\\(s\\) raised: mjWARN_BADQPOS"):
        batch.step(np.arange(2), np.stack([action, action]))
    with pytest.raises(PhysicsError, match="Physics state is invalid. Warning\\(s\\) raised: mjWARN_BADQPOS"):
        twins[1].step(action)
    _dm_control_step(twins[0], action, 4)
    for i, (env, twin) in enumerate(zip(envs, twins)):
        assert np.array_equal(_state(env), _state(twin))
        count, _, over = episode_clock(twin)  # env 0: 4 control steps; env 1: none (its first raised)
        assert (batch._count[i], batch.over(i)) == (count, over) == ((4, False), (0, False))[i]
    for env in (envs[1], twins[1]):
        env.reset()
    batch.after_reset(1)
    batch.step(np.arange(2), np.stack([action, action]))
    for env, twin in zip(envs, twins):
        _dm_control_step(twin, action, 4)
        assert np.array_equal(_state(env), _state(twin))


def test_stepping_an_ended_env_is_refused():
    """An ended env's next step is dm_control's (a reset): the batch refuses it until after_reset."""
    env = _envs("cartpole", "swingup", 1, time_limit=0.05)[0]  # 5 control steps
    batch = BatchPhysics([env], task_arrays("cartpole", "swingup", env.task), 8)
    _, truncated, _ = batch.step([0], np.zeros((1, 1)))
    assert truncated.tolist() == [True] and batch.over(0)
    with pytest.raises(ValueError, match=r"envs \[0\] are over: reset them"):
        batch.step([0], np.zeros((1, 1)))


def test_a_step_makes_as_many_python_calls_for_eight_envs_as_for_two():
    """No Python per env on the step path: the calls a step makes (Python and C functions called from
    Python, counted on this thread) are the same for 2 and 8 envs (no episode ends within the step)."""
    import sys

    counts = []
    for n in (2, 8):
        envs = _envs("cartpole", "swingup", n)
        batch = BatchPhysics(envs, task_arrays("cartpole", "swingup", envs[0].task), 8, threads=1)
        batch.step(np.arange(n), np.zeros((n, 1)))  # compiled and warm
        calls = []
        sys.setprofile(lambda frame, event, arg: calls.append(event) if event in ("call", "c_call") else None)
        try:
            batch.step(np.arange(n), np.zeros((n, 1)))
        finally:
            sys.setprofile(None)
        counts.append(len(calls))
    assert counts[0] == counts[1], counts
