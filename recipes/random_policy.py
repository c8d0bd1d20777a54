"""The return of a uniformly random policy: the floor a learning curve must rise above.

    python recipes/random_policy.py --domain cartpole --task swingup --episodes 100 --seed 0

Rewards do not depend on what is rendered, so this runs the task's physics with the paper's
action repeat and no rendering; the numbers hold for every distraction setting.
"""
from __future__ import annotations

import argparse

import torch

from torchrl.envs import DMControlEnv

from dcs_torchrl.evaluation.protocol import evaluate
from dcs_torchrl.presets import action_repeat


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--domain", default="cartpole")
    parser.add_argument("--task", default="swingup")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.manual_seed(args.seed)  # the random actions come from torch's generator
    env = DMControlEnv(args.domain, args.task, frame_skip=action_repeat(args.domain, args.task))
    result = evaluate(env, lambda td: td.set("action", env.action_spec.rand()), args.episodes, seed=args.seed)
    print(f"random policy, {args.domain} {args.task}: {result.mean:.1f} ± {result.stderr:.1f} "
          f"(standard error, {result.episodes} episodes, seed {args.seed})")


if __name__ == "__main__":
    main()
