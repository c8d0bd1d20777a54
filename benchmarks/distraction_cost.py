"""What each distraction of the medium dynamic benchmark adds to an agent step (default profile).

    python benchmarks/distraction_cost.py cheetah run [--steps 150] [--rounds 5]

The medium dynamic env against the undistracted one, and against the same env with only one
distraction switched on (the others at scale 0), stepped in interleaved rounds like
``env_speed.py``; per-step cost in ms and relative to the undistracted env.
"""
from __future__ import annotations

import argparse
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from env_speed import interleaved_medians  # noqa: E402  (benchmarks/ is the script's directory)

import dcs_torchrl as dcs  # noqa: E402

OFF = dict(camera_scale=0.0, color_scale=0.0, num_videos=0)


def variants(domain: str, task: str) -> dict:
    medium = dict(benchmark="medium", seed=0)
    only = lambda key, dynamic: {**OFF, key: None, "dynamic": dynamic}  # None: the benchmark's value
    return {
        "none": lambda: dcs.make_env(domain, task, seed=0),
        "camera only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("camera_scale", True)),
        "colour only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("color_scale", True)),
        "background only, static": lambda: dcs.make_env(domain, task, **medium, **only("num_videos", False)),
        "background only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("num_videos", True)),
        "medium static": lambda: dcs.make_env(domain, task, **medium, dynamic=False),
        "medium dynamic": lambda: dcs.make_env(domain, task, **medium, dynamic=True),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("domain")
    parser.add_argument("task")
    parser.add_argument("--steps", type=int, default=150)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    envs = {name: make() for name, make in variants(args.domain, args.task).items()}
    step, _ = interleaved_medians(envs, args.steps, args.rounds, resets=1)
    print(f"{args.domain} {args.task}, default profile, median of {args.rounds} rounds x {args.steps} steps")
    print("| env | ms/step | vs none |")
    print("|---|---:|---:|")
    for name in envs:
        print(f"| {name} | {1e3 * step[name]:.2f} | {100 * (step[name] / step['none'] - 1):+.1f}% |")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()
