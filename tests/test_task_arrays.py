"""The six tasks over arrays equal dm_control's task methods bit for bit, over many states at once."""
import numpy as np
import pytest
from dm_control import suite

from dcs_torchrl.vector.task_arrays import TASKS, Ids, task_arrays

STATES = 64


def _states(env, rng) -> list[dict]:
    """dm_control's physics put in ``STATES`` states (random joints, velocities and controls; some with the
    task's reward reached), each recorded as the fields its arrays read; with dm_control's reward and
    observation of each."""
    physics = env.physics
    arrays = task_arrays(*env._dcs_name, env.task)
    out = []
    for k in range(STATES):
        env.reset()  # the task's own draw (reacher: a target of its size), then a state around it
        with physics.reset_context():
            physics.data.qpos[:] += rng.normal(0, 0.5, physics.model.nq)
            physics.data.qvel[:] = rng.normal(0, 3 if k % 2 else 30, physics.model.nv)
            physics.data.ctrl[:] = rng.uniform(-1.5, 1.5, physics.model.nu)
            if env._dcs_name == ("reacher", "easy") and k % 3 == 0:  # the finger on the target
                target = Ids(physics.model.ptr).geom("target")
                physics.model.geom_pos[target, :2] = physics.data.geom_xpos[Ids(physics.model.ptr).geom("finger"), :2]
        if env._dcs_name == ("ball_in_cup", "catch") and k % 3 == 0:  # the ball in the cup
            with physics.reset_context():
                ids = Ids(physics.model.ptr)
                gap = physics.data.site_xpos[ids.site("target")] - physics.data.xpos[ids.body("ball")]
                physics.data.qpos[[ids.qpos("ball_x"), ids.qpos("ball_z")]] += gap[[0, 2]]
        out.append({"data": {f: np.array(getattr(physics.data, f)) for f in arrays.fields},
                    "model": {f: np.array(getattr(physics.model, f)) for f in arrays.model_fields},
                    "reward": env.task.get_reward(physics), "observation": env.task.get_observation(physics)})
    return out


@pytest.mark.parametrize("domain, task", sorted(TASKS))
def test_rewards_and_observations_over_arrays_are_dm_controls_bit_for_bit(domain, task):
    env = suite.load(domain, task, task_kwargs={"random": 0})
    env._dcs_name = (domain, task)
    arrays = task_arrays(domain, task, env.task)
    assert arrays is not None
    states = _states(env, np.random.default_rng(0))
    # as BatchPhysics records them: [control steps, envs, ...]; here 2 x STATES/2
    data = {f: np.stack([s["data"][f] for s in states]).reshape(2, STATES // 2, *states[0]["data"][f].shape)
            for f in arrays.fields}
    model = {f: np.stack([s["model"][f] for s in states]).reshape(2, STATES // 2, *states[0]["model"][f].shape)
             for f in arrays.model_fields}
    rewards = arrays.reward(data, model, arrays_ids := Ids(env.physics.model.ptr)).reshape(-1)
    observations = arrays.observation(data, model, arrays_ids)
    expected = np.array([s["reward"] for s in states])
    assert rewards.dtype == np.float64 and np.array_equal(rewards, expected), (rewards, expected)
    assert 0 < np.count_nonzero(expected), "no state reached any reward: the test would miss a wrong reward"
    for key in states[0]["observation"]:
        got = observations[key].reshape(STATES, -1)
        want = np.stack([np.reshape(s["observation"][key], -1) for s in states])
        assert np.array_equal(got, want), key
    assert set(observations) == set(states[0]["observation"])


def test_other_tasks_and_changed_tasks_keep_dm_controls_step():
    env = suite.load("hopper", "stand", task_kwargs={"random": 0})
    assert task_arrays("hopper", "stand", env.task) is None
    env = suite.load("cartpole", "swingup", task_kwargs={"random": 0})
    assert task_arrays("cartpole", "swingup", env.task) is not None
    env.task.visualize_reward = True  # after_step paints the reward: not over arrays
    assert task_arrays("cartpole", "swingup", env.task) is None

    class Terminating(type(env.task)):
        def get_termination(self, physics):
            return 0.0

    assert task_arrays("cartpole", "swingup", Terminating(swing_up=True, sparse=False)) is None
