"""The shipped agents' clean scores rendered by GL and by MuJoCo Warp, on the same episodes.

    python benchmarks/backend_scores.py [--episodes 20] [--agents NAME ...] [--device cpu]

Per shipped agent, ``--episodes`` deterministic episodes in its training env, all at once: on GL, a
``SerialEnv`` of that many suite envs in this process; on Warp, one batched env
(``make_env(..., num_envs=episodes, backend="warp")``). Both are seeded from the agent's final-evaluation
seed as TorchRL seeds a batch (env ``i`` with the seed env ``i - 1``'s ``set_seed`` returns), so
episode ``i`` starts from the same physics state and draws the same distractions on both: the
difference is the renderer alone. Prints mean ± standard error per backend and the mean paired
difference (docs/results.md, "Warp backend").
"""
from __future__ import annotations

import argparse
import functools
import os
import statistics

os.environ.setdefault("MUJOCO_GL", "egl")

from machine import cpu_model  # noqa: E402  (benchmarks/ is the script's directory)


def backend_returns(name: str, backend: str, episodes: int, device: str) -> list[float]:
    from torchrl.envs import SerialEnv

    from dcs_torchrl.evaluation.protocol import evaluate
    from dcs_torchrl.pretrained import agent_env_settings, load_pretrained
    from dcs_torchrl.training.envs import pixel_env, pixel_options

    agent = load_pretrained(name, device)
    settings = agent_env_settings(agent._cfg, {})
    options = pixel_options(agent._cfg.pixels)
    if backend == "gl":
        env = SerialEnv(episodes, functools.partial(pixel_env, settings, **options))
    else:
        env = pixel_env(settings, backend="warp", num_envs=episodes, device=device, **options)
    try:
        return list(evaluate(env, agent.policy, episodes, seed=agent.eval_seed).returns)
    finally:
        env.close()


def main(argv=None):
    from dcs_torchrl.pretrained import shipped_agents

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--agents", nargs="+", default=sorted(shipped_agents()))
    parser.add_argument("--device", default="cpu", help="where the policy acts and Warp renders (cpu, cuda)")
    args = parser.parse_args(argv)
    if args.episodes < 2:
        parser.error("--episodes must be >= 2")
    print(f"{cpu_model()}; {args.episodes} episodes a row, all at once, seeded from each agent's final-evaluation seed")
    print("| agent | GL (Mesa) | Warp | Warp - GL, paired |\n|---|---:|---:|---:|")
    for name in args.agents:
        gl = backend_returns(name, "gl", args.episodes, args.device)
        warp = backend_returns(name, "warp", args.episodes, args.device)
        diff = [w - g for w, g in zip(warp, gl)]
        se = lambda x: statistics.stdev(x) / len(x) ** 0.5  # noqa: E731
        print(f"| {name} | {statistics.mean(gl):.1f} ± {se(gl):.1f} | {statistics.mean(warp):.1f} ± {se(warp):.1f} | "
              f"{statistics.mean(diff):+.1f} ± {se(diff):.1f} |", flush=True)


if __name__ == "__main__":
    main()
