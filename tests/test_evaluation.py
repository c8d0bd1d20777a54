"""The evaluation protocol on real dm_control physics (cartpole swingup from states)."""
import functools
import math
import os

import pytest
import torch
from tensordict.nn import TensorDictSequential
from torchrl.envs import CatTensors, Compose, DMControlEnv, DoubleToFloat, ParallelEnv, SerialEnv, TransformedEnv

from dcs_torchrl import ParallelSuiteEnv
from dcs_torchrl.evaluation.protocol import EvalResult, evaluate, evaluate_in_processes
from dcs_torchrl.modules import make_encoder, make_sac_actor

# cartpole's 1000-step time limit at action repeat 100: episodes of 10 steps, where what these tests check
# (which env runs which episode, whose rewards make which return) holds for episodes of any length
ACTION_REPEAT = 100
EPISODE_STEPS = 1000 // ACTION_REPEAT


def _env(seed: int | None = None) -> TransformedEnv:
    env = TransformedEnv(
        DMControlEnv("cartpole", "swingup", frame_skip=ACTION_REPEAT),
        Compose(CatTensors(in_keys=["position", "velocity"], out_key="observation"), DoubleToFloat()),
    )
    if seed is not None:
        env.set_seed(seed)
    return env


def _policy(seed: int = 0):
    torch.manual_seed(seed)
    env = _env()
    encoder = make_encoder((env.observation_spec["observation"].shape[-1],))
    return TensorDictSequential(encoder, make_sac_actor(env.action_spec, encoder.feature_dim, hidden_dim=32))


def _stepped_returns(policy, seed: int, episodes: int) -> list[float]:
    """The returns of consecutive episodes on one seeded env, stepped and summed by hand."""
    env, returns = _env(seed=seed), []
    with torch.no_grad():
        for _ in range(episodes):
            td, total = env.reset(), 0.0
            for _ in range(EPISODE_STEPS):
                td = env.step(policy(td))
                total += td["next", "reward"].item()
                td = td["next"]
            returns.append(total)
    return returns


def test_eval_result_statistics():
    result = EvalResult((1.0, 2.0, 6.0))
    assert result.mean == 3.0
    assert result.stderr == pytest.approx(math.sqrt(7.0 / 3.0))  # sample std (n - 1) / sqrt(n)
    assert result.to_dict() == {"mean": 3.0, "stderr": result.stderr, "episodes": 3, "returns": [1.0, 2.0, 6.0]}
    assert EvalResult((5.0,)).stderr == 0.0


def test_evaluate_runs_full_deterministic_episodes_and_is_reproducible():
    policy = _policy()
    steps = []

    def counting_policy(td):
        steps.append(td.batch_size)
        return policy(td)

    result = evaluate(_env(), counting_policy, 3, seed=1)
    assert len(steps) == 3 * EPISODE_STEPS  # every episode runs to dm_control's time limit
    assert result.episodes == 3 and len(result.returns) == 3
    # each return is its own episode's reward sum (episodes start apart: the returns differ)
    assert list(result.returns) == pytest.approx(_stepped_returns(policy, 1, 3), rel=1e-6)
    assert len(set(result.returns)) == 3
    assert result.mean == pytest.approx(sum(result.returns) / 3)
    # deterministic policy + seeded env: the same returns again
    assert evaluate(_env(), policy, 3, seed=1).returns == result.returns


def test_evaluate_uses_the_deterministic_action():
    policy = _policy()
    direct = _env(seed=3)
    td = direct.reset()
    total = 0.0
    with torch.no_grad():
        for _ in range(EPISODE_STEPS):
            td = policy(td)
            torch.testing.assert_close(td["action"], torch.tanh(td["loc"]))  # no sampling when unset
            td = direct.step(td)
            total += td["next", "reward"].item()
            td = td["next"]
    assert evaluate(_env(), policy, 1, seed=3).returns[0] == pytest.approx(total)


def test_evaluate_on_a_batched_env_counts_each_started_episode_once():
    policy = _policy()
    calls = []

    def counting_policy(td):
        calls.append(tuple(td.batch_size))
        return policy(td)

    env = SerialEnv(2, _env)
    result = evaluate(env, counting_policy, 3, seed=4)
    # episodes 0 and 1 run side by side, then sub-env 0 runs episode 2 while sub-env 1 idles
    assert calls == [(2,)] * (2 * EPISODE_STEPS)
    assert result.episodes == 3 and all(isinstance(r, float) for r in result.returns)
    assert evaluate(env, policy, 3, seed=4).returns == result.returns
    env.close()


def test_evaluate_errors():
    with pytest.raises(ValueError, match="episodes must be >= 1"):
        evaluate(_env(), _policy(), 0)
    with pytest.raises(RuntimeError, match="0 of 1 episodes finished after max_steps=5"):
        evaluate(_env(), _policy(), 1, max_steps=5)
    for threads in (0, True, 1.5, "2"):
        with pytest.raises(ValueError, match="threads must be an int >= 1"):
            evaluate(_env(), _policy(), 1, threads=threads)


def _sub_env_seeds(seed: int, num_envs: int) -> list[int]:
    """The seed each sub-env of a batched env gets from ``set_seed(seed)``: TorchRL's chain, the
    next sub-env's seed being what the previous one's ``set_seed`` returns."""
    seeds = [seed]
    for _ in range(num_envs - 1):
        seeds.append(_env().set_seed(seeds[-1]))
    return seeds


@pytest.mark.parametrize("batched, num_envs, episodes", [
    ("serial", 2, 5),    # sub-env 0 runs episodes 0, 2, 4; sub-env 1 runs 1, 3
    ("serial", 3, 4),    # sub-envs 1 and 2 idle while sub-env 0 runs episode 3
    pytest.param("parallel", 2, 3, marks=pytest.mark.slow),  # TorchRL's; by default the suite's, in a worker too:
    ("suite", 2, 3),     # the suite's ParallelSuiteEnv
    ("processes", 2, 3),  # evaluate_in_processes: each env in its own process with its own policy
])
def test_a_batched_evaluation_gives_each_episode_the_return_of_that_episode_run_alone(batched, num_envs, episodes):
    """Episode by episode, a batched evaluation's returns are those of the same episodes stepped
    one env at a time: sub-env i, seeded as the batched env seeds it, runs episodes i, i + n, ...
    (module docstring of dcs_torchrl.evaluation.protocol). A reward of one sub-env counted in another's
    return, or an episode's return given to another, fails here."""
    policy = _policy()
    if batched == "processes":
        result = evaluate_in_processes(_env, policy, episodes, num_envs, seed=4)
    else:
        env = {"serial": SerialEnv, "parallel": functools.partial(ParallelEnv, mp_start_method="spawn"),
               "suite": ParallelSuiteEnv}[batched](num_envs, _env)
        result = evaluate(env, policy, episodes, seed=4)
        env.close()
    expected = [None] * episodes
    for i, seed in enumerate(_sub_env_seeds(4, num_envs)):
        runs = list(range(i, episodes, num_envs))
        for index, ret in zip(runs, _stepped_returns(policy, seed, len(runs))):
            expected[index] = ret
    assert list(result.returns) == pytest.approx(expected, rel=1e-6)
    assert len(set(result.returns)) == episodes  # every episode its own return


def _env_failing_in_another_process(parent: int) -> TransformedEnv:
    if os.getpid() != parent:
        raise ValueError("no env in this process")
    return _env()


def test_evaluate_in_processes_reports_a_failed_process_and_refuses_bad_workers():
    policy = _policy()
    make = functools.partial(_env_failing_in_another_process, os.getpid())
    with pytest.raises(RuntimeError, match=r"evaluation process 1 failed:(.|\n)*no env in this process"):
        evaluate_in_processes(make, policy, 2, 2, seed=0)
    for workers in (0, True, 1.5):
        with pytest.raises(ValueError, match="workers must be an int >= 1"):
            evaluate_in_processes(_env, policy, 2, workers, seed=0)
    # more workers than episodes: the extra envs run nothing, episode 0 is env 0's first
    assert evaluate_in_processes(_env, policy, 1, 3, seed=4).returns == pytest.approx(_stepped_returns(policy, 4, 1), rel=1e-6)
