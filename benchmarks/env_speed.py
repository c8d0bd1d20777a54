"""Agent steps per second of the suite's envs against TorchRL's own pixel env, side by side.

    python benchmarks/env_speed.py [--steps 300] [--rounds 5] [--tasks cartpole:swingup cheetah:run]

Every env of a task is built once and then stepped in interleaved rounds (env A, B, C,
... then again), and the median round is reported, so that machine noise hits all of
them alike; ratios are taken within the run. Resets are timed the same way, after a
warm-up that has decoded every background video the env can draw (the frame cache).
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from dm_control import suite  # noqa: E402
from torchrl.envs import DMControlWrapper  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402


def torchrl_pixel_env(domain, task, frame_skip):
    return DMControlWrapper(
        suite.load(domain, task), from_pixels=True, frame_skip=frame_skip, render_kwargs=dict(height=84, width=84)
    )


def candidates(domain, task):
    k = dcs.TASKS[domain, task]
    return {
        "torchrl from_pixels": lambda: torchrl_pixel_env(domain, task, k),
        "none / default": lambda: dcs.make_env(domain, task, seed=0),
        "none / fast": lambda: dcs.make_env(domain, task, seed=0, render_profile="fast"),
        "medium dynamic / default": lambda: dcs.make_env(domain, task, benchmark="medium", dynamic=True, seed=0),
        "medium dynamic / fast": lambda: dcs.make_env(
            domain, task, benchmark="medium", dynamic=True, seed=0, render_profile="fast"
        ),
    }


def time_steps(env, td, steps):
    action = torch.zeros(env.action_spec.shape, dtype=env.action_spec.dtype)
    start = time.perf_counter()
    for _ in range(steps):
        td = env.step(td.set("action", action))["next"]
        if td["done"].any():
            td = env.reset()
    return time.perf_counter() - start, td


def time_resets(env, resets):
    start = time.perf_counter()
    for _ in range(resets):
        env.reset()
    return (time.perf_counter() - start) / resets


def interleaved_rounds(envs: dict, steps: int, rounds: int, resets: int) -> tuple[dict, dict]:
    """Seconds per step and per reset of each env in each round, the envs timed in interleaved rounds
    (every other round in reverse order, so that no env always follows the same one)."""
    tds = {name: env.reset() for name, env in envs.items()}
    for _ in range(60):  # warm-up: contexts, code paths, and every background video decoded once
        for name, env in envs.items():
            tds[name] = env.reset()
    per_step = {name: [] for name in envs}
    per_reset = {name: [] for name in envs}
    for round_ in range(rounds):
        for name in (list(envs) if round_ % 2 == 0 else list(envs)[::-1]):
            env = envs[name]
            seconds, tds[name] = time_steps(env, tds[name], steps)
            per_step[name].append(seconds / steps)
            per_reset[name].append(time_resets(env, resets))
            tds[name] = env.reset()
    return per_step, per_reset


def interleaved_medians(envs: dict, steps: int, rounds: int, resets: int) -> tuple[dict, dict]:
    """Median seconds per step and per reset of each env, timed in interleaved rounds."""
    per_step, per_reset = interleaved_rounds(envs, steps, rounds, resets)
    return ({name: statistics.median(v) for name, v in per_step.items()},
            {name: statistics.median(v) for name, v in per_reset.items()})


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--resets", type=int, default=20)
    parser.add_argument("--tasks", nargs="+", default=["cartpole:swingup", "cheetah:run"])
    args = parser.parse_args()
    torch.set_num_threads(1)
    for spec in args.tasks:
        domain, task = spec.split(":")
        envs = {name: make() for name, make in candidates(domain, task).items()}
        step, reset = interleaved_medians(envs, args.steps, args.rounds, args.resets)
        base = step["torchrl from_pixels"]
        print(f"\n{domain} {task} (action repeat {dcs.TASKS[domain, task]}), median of {args.rounds} rounds x {args.steps} steps")
        print(f"| env | agent steps/s | ms/step | speed-up vs torchrl | reset ms |")
        print("|---|---:|---:|---:|---:|")
        for name in envs:
            print(
                f"| {name} | {1 / step[name]:.0f} | {1e3 * step[name]:.2f} | {base / step[name]:.1f}x "
                f"| {1e3 * reset[name]:.2f} |"
            )
        for profile in ("default", "fast"):
            extra = step[f"medium dynamic / {profile}"] / step[f"none / {profile}"] - 1
            extra_reset = reset[f"medium dynamic / {profile}"] - reset[f"none / {profile}"]
            print(
                f"medium dynamic vs none ({profile}): {100 * extra:+.1f}% per step, "
                f"{1e3 * extra_reset:+.2f} ms per reset"
            )
        for env in envs.values():
            env.close()


if __name__ == "__main__":
    main()
