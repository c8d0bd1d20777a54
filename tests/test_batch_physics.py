"""BatchPhysics: the same states, rewards and episode ends whatever threads step them; the threads chosen by measurement."""
import numpy as np
import pytest
from dm_control import suite
from dm_control.rl.control import PhysicsError

from dcs_torchrl.vector.batch_physics import RETUNE, TRIALS, BatchPhysics
from dcs_torchrl.vector.task_arrays import task_arrays


def _run(threads, steps: int = 2 * TRIALS + RETUNE + 3, n: int = 5):
    envs = [suite.load("walker", "walk", task_kwargs={"random": i}) for i in range(n)]
    for env in envs:
        env.reset()
    batch = BatchPhysics(envs, task_arrays("walker", "walk", envs[0].task), [2, 3, 2, 3, 2][:n], threads)
    rng = np.random.default_rng(0)
    out, tried = [], []
    for _ in range(steps):
        reward, ended, observation = batch.step(np.arange(n), rng.uniform(-1, 1, (n, 6)))
        out.append((reward, ended, observation["velocity"], np.stack([e.physics.data.qpos.copy() for e in envs])))
        tried.append(batch.threads)
        for i in np.flatnonzero(ended):
            envs[i].reset()
            batch.after_reset(i)
    if threads is None and len(batch._trials) > 1:  # tried in turn, kept, tried again after RETUNE steps
        assert tried[:2 * TRIALS - 1] == [2, 1] * (TRIALS - 1) + [2]
        assert len(set(tried[2 * TRIALS: 2 * TRIALS + RETUNE - 1])) == 1
        assert tried[2 * TRIALS + RETUNE - 1: 2 * TRIALS + RETUNE + 1] == [1, 2]
    chosen = batch.threads
    batch.close()
    return out, chosen


def test_any_number_of_threads_steps_the_same_states_and_the_count_is_chosen_among_those_tried():
    one, _ = _run(1)
    for threads in (2, None):
        other, chosen = _run(threads)
        for t, (a, b) in enumerate(zip(one, other)):
            for x, y in zip(a, b):
                assert np.array_equal(x, y), (threads, t)
    assert chosen in (1, 2)


def test_bad_thread_counts_are_refused():
    env = suite.load("cartpole", "swingup")
    env.reset()
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match="physics_threads must be a positive integer"):
            BatchPhysics([env], task_arrays("cartpole", "swingup", env.task), 8, bad)


def test_a_diverging_state_raises_dm_controls_physics_error():
    envs = [suite.load("cheetah", "run", task_kwargs={"random": i}) for i in range(2)]
    for env in envs:
        env.reset()
    batch = BatchPhysics(envs, task_arrays("cheetah", "run", envs[0].task), 4, 1)
    envs[1].physics.data.qvel[:] = 1e300  # MuJoCo warns (bad qacc) and resets the data, as under dm_control's step
    with pytest.raises(PhysicsError, match="Physics state is invalid"):
        batch.step(np.arange(2), np.zeros((2, 6)))
    envs[0].physics.data.qvel[:] = 1e300
    with pytest.raises(PhysicsError, match="Physics state is invalid"):
        envs[0].step(np.zeros(6))
