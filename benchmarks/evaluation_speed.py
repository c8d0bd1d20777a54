"""Wall time of a CPU evaluation of the shipped agent: one env against n envs, each way they run.

    python benchmarks/evaluation_speed.py [--episodes 10] [--workers 2] [--rounds 3] [--benchmark medium]

Paths (the shipped SAC+RAD cartpole swingup agent, its final evaluation's seeds, dynamic):

- ``one env``: ``Pretrained.evaluate(episodes)``, one env in this process (the baseline, 1x);
- ``n processes``: ``Pretrained.evaluate(episodes, workers=n)`` on the CPU, as it comes: each env
  in its own process with a copy of the policy (``dcs_torchrl.evaluation.protocol.evaluate_in_processes``);
- ``ParallelSuiteEnv, batched policy``: the same n envs in one ``ParallelSuiteEnv``, the policy
  acting on their batch in this process (what ``workers=n`` does with a policy on a GPU, and did
  on the CPU before).

Each call is timed whole, as a user waits for it: the processes' and workers' start (a spawned
process imports torch, TorchRL and dm_control), the envs' build, every episode. The paths run in
interleaved rounds (each round in the other order to the last); per path the median round and
its ratio to the one env of the same round (median and range). Prints the CPU model.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

from machine import cpu_model  # noqa: E402

from dcs_torchrl.evaluation.protocol import evaluate  # noqa: E402
from dcs_torchrl.pretrained import agent_env_settings, load_pretrained  # noqa: E402
from dcs_torchrl.training.envs import batched_pixel_env, close_env, pixel_options  # noqa: E402

AGENT = "sac_rad_cartpole_swingup"


def batched_policy(agent, episodes: int, workers: int, settings: dict):
    """The n envs in one ParallelSuiteEnv, the policy acting on their batch here."""
    env = batched_pixel_env(agent_env_settings(agent._cfg, settings), num_workers=workers, seed=agent.eval_seed,
                            **pixel_options(agent._cfg.pixels))
    try:
        return evaluate(env, agent.policy, episodes, seed=agent.eval_seed)
    finally:
        close_env(env)


def main(argv: list[str] | None = None) -> dict:
    """Runs the benchmark; returns per path its rounds' seconds and the returns of its last round."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--benchmark", default="medium", help="make_env benchmark, dynamic")
    args = parser.parse_args(argv)
    agent = load_pretrained(AGENT)
    settings = dict(benchmark=args.benchmark, dynamic=True)
    n = args.workers
    paths = {
        "one env": lambda: agent.evaluate(args.episodes, **settings),
        f"{n} processes (workers={n})": lambda: agent.evaluate(args.episodes, workers=n, **settings),
        "ParallelSuiteEnv, batched policy": lambda: batched_policy(agent, args.episodes, n, settings),
    }
    print(f"{cpu_model()}, {os.cpu_count()} cores; {AGENT}, {args.benchmark} dynamic, {args.episodes} episodes, "
          f"{n} workers, median of {args.rounds} rounds")
    seconds = {name: [] for name in paths}
    returns = {}
    for round_ in range(args.rounds):
        for name in (list(paths) if round_ % 2 == 0 else list(paths)[::-1]):
            start = time.perf_counter()
            returns[name] = paths[name]().returns
            seconds[name].append(time.perf_counter() - start)
    print("| path | seconds | vs one env (speed), median (range) | mean return |\n|---|---:|---:|---:|")
    for name, values in seconds.items():
        ratios = [b / s for s, b in zip(values, seconds["one env"])]
        print(f"| {name} | {statistics.median(values):.1f} | {statistics.median(ratios):.2f} "
              f"({min(ratios):.2f}–{max(ratios):.2f}) | {statistics.mean(returns[name]):.1f} |")
    return {"seconds": seconds, "returns": returns}


if __name__ == "__main__":
    main()
