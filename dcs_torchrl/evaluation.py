"""Evaluation protocol: N full episodes of the deterministic policy, mean and standard error.

Stone et al. (2021), Sec. 5: results "evaluated for 100 episodes", mean and standard error (docs/paper.md).
:func:`evaluate` works on a single TorchRL env or a batched one (``SerialEnv``, TorchRL's
``ParallelEnv``, the suite's :class:`~dcs_torchrl.ParallelSuiteEnv`, or any env with a 1-d batch size): every sub-env runs whole episodes, new episodes are only
started while fewer than ``episodes`` have been started, and every started episode is run to its
end, so short episodes are not over-represented. Returns are reported in the order the episodes
were started (sub-env index order within a step).

How episodes spread over sub-envs: with n sub-envs and equal-length episodes (every DM Control
task: a time limit), sub-env i runs episodes i, i + n, i + 2n, ... one after the other. Where an
env carries state across episodes — the 2021 code's background blend
(``make_env(reference_blend=True)``), whose sky accumulates over an env's episodes — a result
depends on the episodes per env: the recipes' final evaluation runs all of them in one env unless
``eval.num_workers`` says otherwise, and ``python -m dcs_torchrl.robustness`` runs each point in one env.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

__all__ = ["EvalResult", "evaluate"]


@dataclass(frozen=True)
class EvalResult:
    """Returns of an evaluation, with their mean and standard error.

    Attributes:
        returns (tuple of float): every episode return, in the order the episodes started.

    Examples:
        >>> result = EvalResult((1.0, 3.0))
        >>> result.mean, round(result.stderr, 3), result.to_dict()["episodes"]
        (2.0, 1.0, 2)
    """

    returns: tuple[float, ...]

    @property
    def episodes(self) -> int:
        return len(self.returns)

    @property
    def mean(self) -> float:
        return float(sum(self.returns) / len(self.returns))

    @property
    def stderr(self) -> float:
        """Standard error of the mean: sample standard deviation (n - 1) / sqrt(n); 0 for n = 1."""
        n = len(self.returns)
        if n < 2:
            return 0.0
        mean = self.mean
        var = sum((r - mean) ** 2 for r in self.returns) / (n - 1)
        return math.sqrt(var / n)

    def to_dict(self) -> dict:
        """``{"mean", "stderr", "episodes", "returns"}``, the ``eval`` entry of ``results.json``."""
        return {"mean": self.mean, "stderr": self.stderr, "episodes": self.episodes, "returns": list(self.returns)}


def evaluate(
    env: EnvBase,
    policy: Callable[[TensorDictBase], TensorDictBase],
    episodes: int,
    *,
    seed: int | None = None,
    exploration_type: ExplorationType = ExplorationType.DETERMINISTIC,
    reward_key: NestedKey = "reward",
    done_key: NestedKey = "done",
    max_steps: int | None = None,
) -> EvalResult:
    """Runs ``episodes`` full episodes of ``policy`` on ``env`` and returns their returns.

    The policy runs under ``set_exploration_type(exploration_type)`` (deterministic by default:
    the tanh-Gaussian's ``tanh(mean)``, CEM without exploration noise) and ``torch.no_grad()``.

    Args:
        env (EnvBase): a TorchRL env, single (batch size ``[]``) or batched (``[n]``); its
            episodes must end (``done``), e.g. DM Control's time limit.
        policy (callable): a TensorDict module mapping observations to ``"action"``.
        episodes (int): number of episodes.

    Keyword Args:
        seed (int, optional): ``env.set_seed(seed)`` before the first reset.
        exploration_type (ExplorationType): defaults to ``DETERMINISTIC``.
        reward_key, done_key (NestedKey): entries under ``"next"``.
        max_steps (int, optional): safety limit on env steps; exceeding it raises.

    Examples:
        >>> from torchrl.envs import DMControlEnv
        >>> env = DMControlEnv("cartpole", "swingup", frame_skip=8)
        >>> policy = lambda td: td.set("action", env.action_spec.zero())
        >>> result = evaluate(env, policy, 2, seed=0)
        >>> result.episodes, len(result.to_dict()["returns"])
        (2, 2)
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}.")
    if len(env.batch_size) > 1:
        raise ValueError(f"evaluate supports single envs and 1-d batched envs, got batch size {tuple(env.batch_size)}.")
    num_envs = env.batch_size.numel()
    returns: list[float | None] = [None] * episodes
    slot = [i if i < episodes else -1 for i in range(num_envs)]  # episode index run by each sub-env
    started = min(num_envs, episodes)
    finished = 0
    running = torch.zeros(num_envs, dtype=torch.float64)
    steps = 0
    if seed is not None:
        env.set_seed(seed)
    with set_exploration_type(exploration_type), torch.no_grad():
        td = env.reset()
        while finished < episodes:
            td = policy(td)
            td_out, td = env.step_and_maybe_reset(td)
            steps += 1
            reward = td_out.get(("next", reward_key)).reshape(num_envs, -1).sum(-1)
            done = td_out.get(("next", done_key)).reshape(num_envs, -1).any(-1)
            running += reward.to(torch.float64)
            for i in done.nonzero().flatten().tolist():
                if slot[i] >= 0:
                    returns[slot[i]] = float(running[i])
                    finished += 1
                    if started < episodes:
                        slot[i], started = started, started + 1
                    else:
                        slot[i] = -1
                running[i] = 0.0
            if max_steps is not None and steps >= max_steps and finished < episodes:
                raise RuntimeError(
                    f"evaluate: {finished} of {episodes} episodes finished after max_steps={max_steps} env steps."
                )
    return EvalResult(tuple(returns))
