"""Agent steps per second of the Gymnasium env (dcs_torchrl.gym_env) beside make_env's, side by side.

    python benchmarks/gym_speed.py [--steps 300] [--rounds 7] [--tasks cartpole:swingup cheetah:run]
                                   [--benchmark medium] [--static]

For each task, three envs of the same preset, seed and action sequence: make_env's TorchRL env
stepped as a TorchRL loop (``td = env.step(td.set("action", a))["next"]``, ``env.reset()`` when
done), the Gymnasium env (``DistractingControlEnv.step``, ``reset()`` at terminated or truncated)
and the same from ``gymnasium.make`` (with Gymnasium's order-enforcing and passive-checker
wrappers). They are stepped in interleaved rounds (every other round in reverse order), so that
machine noise hits them alike, and each env continues its episode from round to round: all three
do the same physics, distractions and renders. Only the steps are timed: a reset (which may
decode a background video) is not, and a warm-up has drawn every video before.

The adapter's cost is the median over rounds of (Gymnasium env's time per step) / (TorchRL
loop's) - 1. As that ratio moves with the machine's load, each Gymnasium step is also split, in
the same call, into the TorchRL env's ``step`` and the rest (the adapter: action to tensor,
tensors to arrays, flags), which load moves far less.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402
from machine import cpu_model  # noqa: E402
from dcs_torchrl.gym_env import DistractingControlEnv, env_id  # noqa: E402

BASE = "make_env, TorchRL step loop"




class TorchRLLoop:
    """make_env's env, stepped as a TorchRL loop would; :meth:`run` returns the seconds its steps took."""

    def __init__(self, env, actions):
        self.env, self.actions = env, [torch.as_tensor(a) for a in actions]
        self.td = env.reset()

    def reset(self) -> None:
        self.td = self.env.reset()

    def run(self, steps: int, start: int) -> float:
        env, td, actions, clock = self.env, self.td, self.actions, time.perf_counter
        seconds = 0.0
        for i in range(start, start + steps):
            t0 = clock()
            td = env.step(td.set("action", actions[i % len(actions)]))["next"]
            done = bool(td["done"].any())
            seconds += clock() - t0
            if done:
                td = env.reset()
        self.td = td
        return seconds


class TimedSteps:
    """Stands in for the TorchRL env under a Gymnasium env: the same env, its ``step`` calls timed."""

    def __init__(self, env):
        self.env, self.seconds = env, 0.0

    def step(self, td):
        start = time.perf_counter()
        out = self.env.step(td)
        self.seconds += time.perf_counter() - start
        return out

    def reset(self, *args, **kwargs):
        return self.env.reset(*args, **kwargs)

    def set_seed(self, seed):
        return self.env.set_seed(seed)

    def close(self):
        return self.env.close()


class GymLoop:
    """A Gymnasium env, stepped as a Gymnasium loop would; ``adapter_seconds``: its steps' time
    outside the TorchRL env's ``step``."""

    def __init__(self, env, actions):
        self.env, self.actions = env, actions
        self.inner = env.unwrapped.torchrl_env = TimedSteps(env.unwrapped.torchrl_env)
        self.adapter_seconds, self.steps = 0.0, 0
        env.reset(seed=0)

    def reset(self) -> None:
        self.env.reset()

    def run(self, steps: int, start: int) -> float:
        env, actions, clock = self.env, self.actions, time.perf_counter
        inner_before, seconds = self.inner.seconds, 0.0
        for i in range(start, start + steps):
            t0 = clock()
            _, _, terminated, truncated, _ = env.step(actions[i % len(actions)])
            seconds += clock() - t0
            if terminated or truncated:
                env.reset()
        self.adapter_seconds += seconds - (self.inner.seconds - inner_before)
        self.steps += steps
        return seconds


def measure(loops: dict, steps: int, rounds: int, warmup_resets: int) -> dict:
    """Seconds per step of each loop in each round, the loops timed in interleaved rounds."""
    for loop in loops.values():  # warm-up: render contexts, code paths, every background video decoded
        loop.run(60, 0)
        for _ in range(warmup_resets):
            loop.reset()
        if isinstance(loop, GymLoop):
            loop.adapter_seconds = loop.steps = 0
    per_step = {name: [] for name in loops}
    for round_ in range(rounds):
        for name in (list(loops) if round_ % 2 == 0 else list(loops)[::-1]):
            per_step[name].append(loops[name].run(steps, 60 + round_ * steps) / steps)
    return per_step


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--tasks", nargs="+", default=["cartpole:swingup", "cheetah:run"])
    parser.add_argument("--benchmark", default="medium")
    parser.add_argument("--static", action="store_true", help="static distractions (default: dynamic)")
    parser.add_argument("--warmup-resets", type=int, default=30)
    args = parser.parse_args()
    torch.set_num_threads(1)
    dynamic = not args.static
    print(f"CPU: {cpu_model()}; load average {os.getloadavg()[0]:.2f} (1 min) at start")
    for spec in args.tasks:
        domain, task = spec.split(":")
        settings = dict(benchmark=args.benchmark, dynamic=dynamic)
        probe = DistractingControlEnv(domain, task, **settings)
        rng = np.random.default_rng(0)
        actions = [rng.uniform(probe.action_space.low, probe.action_space.high) for _ in range(1000)]
        probe.close()
        loops = {
            BASE: TorchRLLoop(dcs.make_env(domain, task, seed=0, **settings), actions),
            "DistractingControlEnv.step": GymLoop(DistractingControlEnv(domain, task, **settings), actions),
            "gymnasium.make(...).step": GymLoop(gymnasium.make(env_id(domain, task, args.benchmark, dynamic)),
                                                actions),
        }
        per_step = measure(loops, args.steps, args.rounds, args.warmup_resets)
        print(f"\n{domain} {task}, {args.benchmark} {'dynamic' if dynamic else 'static'} "
              f"(action repeat {dcs.TASKS.get((domain, task), 4)}), median of {args.rounds} rounds x {args.steps} steps")
        print("| env | agent steps/s | ms/step | time vs TorchRL loop (median of per-round ratios) "
              "| adapter, in the same calls: us/step (% of the step) |")
        print("|---|---:|---:|---:|---:|")
        for name, times in per_step.items():
            ratio = statistics.median(t / b for t, b in zip(times, per_step[BASE]))
            median = statistics.median(times)
            loop = loops[name]
            adapter = "-"
            if isinstance(loop, GymLoop):
                seconds = loop.adapter_seconds / loop.steps
                adapter = f"{1e6 * seconds:.0f} ({100 * seconds / median:.1f}%)"
            print(f"| {name} | {1 / median:.0f} | {1e3 * median:.2f} | {ratio:.3f} ({100 * (ratio - 1):+.1f}%) "
                  f"| {adapter} |")
        for loop in loops.values():
            loop.env.close()
    print(f"\nload average {os.getloadavg()[0]:.2f} (1 min) at the end")


if __name__ == "__main__":
    main()
