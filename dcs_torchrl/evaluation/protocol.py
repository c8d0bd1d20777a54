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

:func:`evaluate_in_processes` runs the same episodes with each sub-env in a process of its own,
holding a copy of the policy: the way to spread an evaluation over the cores when the policy runs
on the CPU (a batched env's workers wait while a CPU policy acts on their batch).
"""
from __future__ import annotations

import math
import multiprocessing as mp
import os
import traceback
from collections.abc import Callable
from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from dcs_torchrl.vector._threads import torch_threads

__all__ = ["EVAL_THREADS", "EvalResult", "evaluate", "evaluate_in_processes", "torch_threads"]

#: torch's threads while an evaluation runs (:func:`evaluate`'s ``threads``), in every path: one
#: env here, a batched env, a process per env. On some CPUs torch's matrix products round
#: differently with the thread count (the encoder's 39200-wide linear layer on an Intel Xeon with
#: AVX-512, though not on an AMD EPYC with AVX2), and an episode amplifies it (a cartpole return of
#: 267.0 with one thread, 244.5 with two), so the thread count is fixed: an episode's return
#: depends on its seed, not on the cores or how many envs ran beside it. One: what a process of a
#: full evaluation (one env per core) can have.
EVAL_THREADS = 1


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
    threads: int | None = EVAL_THREADS,
) -> EvalResult:
    """Runs ``episodes`` full episodes of ``policy`` on ``env`` and returns their returns.

    The policy runs under ``set_exploration_type(exploration_type)`` (deterministic by default:
    the tanh-Gaussian's ``tanh(mean)``, CEM without exploration noise), ``torch.no_grad()`` and
    ``threads`` torch threads.

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
        threads (int, optional): torch's threads while the episodes run, this process's setting
            restored after; default :data:`EVAL_THREADS` (1), so that a return does not depend on
            the machine's cores or the number of envs (a policy on the CPU rounds differently with
            the thread count on some CPUs); ``None`` keeps this process's setting.

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
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads must be an int >= 1 (torch's threads while evaluating) or None (this "
                         f"process's setting), got {threads!r}.")
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
    with torch_threads(threads), set_exploration_type(exploration_type), torch.no_grad():
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


def evaluate_in_processes(
    make_env: Callable[[], EnvBase],
    policy: Callable[[TensorDictBase], TensorDictBase],
    episodes: int,
    workers: int,
    *,
    seed: int,
    threads: int | None = None,
    **options,
) -> EvalResult:
    """:func:`evaluate` on ``workers`` envs from ``make_env``, each in its own process with its own
    copy of ``policy``: the episodes of a batched evaluation, without the batch.

    Env i is seeded as a batched env (:class:`~dcs_torchrl.ParallelSuiteEnv`, TorchRL's) seeds
    its sub-env i: env 0 with ``seed``, each next one with what the previous one's ``set_seed``
    returns; it runs episodes i, i + workers, i + 2 workers, ..., one after the other, as sub-env i
    does where every episode lasts as long (a time limit: every DM Control task; see the module
    docstring). This process runs env 0 while ``workers - 1`` spawned processes run the others;
    the returns come back in episode order.

    For a policy on the CPU: there acting costs about as much as a step, and a batched env's
    workers wait while the policy acts on the batch; here each process acts on its own
    observation while the others step (docs/performance.md, "Evaluation on the CPU"). Each
    observation is given to the policy alone, not in a batch: the returns are those of one env
    per seed (``tests/test_evaluation.py``).

    Args:
        make_env (callable): builds one env (batch size ``[]``); pickled to the processes: a
            module-level function or a ``functools.partial``.
        policy (callable): pickled to the processes (a TensorDict module on the CPU).
        episodes (int): number of episodes.
        workers (int): envs (processes, this one included); at most ``episodes`` are used.

    Keyword Args:
        seed (int): the first env's seed.
        threads (int, optional): Mesa llvmpipe render threads per spawned process
            (``LP_NUM_THREADS``, unless set already) and its torch threads outside the episodes
            (building its env); default: the cores shared out, ``max(1, cores // workers)``. This
            process's own render threads were fixed when it first imported dm_control. The episodes
            themselves run with :func:`evaluate`'s ``threads`` (:data:`EVAL_THREADS`, as everywhere).
        **options: :func:`evaluate`'s keyword arguments (``exploration_type``, ``max_steps``, ...).
    """
    from concurrent.futures.process import BrokenProcessPool

    from dcs_torchrl.render.egl_devices import RENDER_THREADS_VARIABLE, render_threads_share
    from dcs_torchrl.vector.process_pool import SpawnedPool

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1, got {workers!r}.")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}.")
    if workers > 1 and mp.current_process().daemon:
        raise RuntimeError("evaluate_in_processes cannot start processes from a daemonic process: use workers=1 there.")
    shares = min(workers, episodes)
    if threads is None:
        threads = max(1, (os.cpu_count() or 1) // shares)
    counts = [len(range(i, episodes, workers)) for i in range(shares)]
    env = make_env()
    try:
        seeds = [seed]
        for _ in range(shares - 1):
            seeds.append(env.set_seed(seeds[-1]))
        with SpawnedPool(max(1, shares - 1), environment={RENDER_THREADS_VARIABLE: render_threads_share(threads)},
                         threads=threads) as pool:
            futures = [pool.submit(_evaluate_share, make_env, policy, counts[i], seeds[i], options)
                       for i in range(1, shares)]
            returns = [evaluate(env, policy, counts[0], seed=seeds[0], **options).returns]
            for i, future in enumerate(futures, start=1):
                try:
                    returns.append(future.result())
                except BrokenProcessPool as error:  # a process died: killed (out of memory) or gone without its error
                    raise pool.died("evaluation process", "evaluate with fewer workers") from error
                except Exception as error:
                    raise RuntimeError(f"evaluation process {i} failed:\n{_remote_traceback(error)}") from error
    finally:
        env.close()
    ordered: list[float] = [0.0] * episodes
    for i, share in enumerate(returns):
        ordered[i:episodes:workers] = share
    return EvalResult(tuple(ordered))


def _remote_traceback(error: BaseException) -> str:
    """The traceback a pool's process sent with ``error`` (its ``__cause__``), else the error."""
    cause = error.__cause__
    return str(cause) if cause is not None else "".join(traceback.format_exception(error))


def _evaluate_share(make_env, policy, episodes: int, seed: int, options: dict) -> tuple[float, ...]:
    """One process's share of :func:`evaluate_in_processes`: its env's episodes' returns."""
    env = make_env()
    try:
        return evaluate(env, policy, episodes, seed=seed, **options).returns
    finally:
        env.close()
