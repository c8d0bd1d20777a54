"""Agent steps per second of the batched Warp env against one GL env and ParallelSuiteEnv(2), side by side.

    python benchmarks/batched_speed.py [--device cpu|cuda] [--sizes 1 4 16 64 256] [--rounds 3]
        [--seconds 4] [--tasks cartpole:swingup cheetah:run] [--presets none medium]

All in, as a user steps an env: distractions (``medium`` is the dynamic medium preset), uint8
pixels in a torch tensor, TorchRL's ``step`` with ``step_and_maybe_reset``, a random action per
env. Every env of a task and preset is built once, then they are timed in interleaved rounds (each
for about ``--seconds``), and the median round is reported, so that machine noise hits them alike;
the ratios are within this run. ``--device cuda`` renders the batch on the GPU (sizes up to 4096
make sense there) and prints the GPU model; the render's share of a batched step is printed beside
the physics' (the rest: TorchRL's step and the copies). The GL rows use Mesa's default threads.
"""
from __future__ import annotations

import argparse
import functools
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from machine import cpu_model  # noqa: E402  (benchmarks/ is the script's directory)

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl.batched import BatchedSuiteEnv  # noqa: E402

PRESETS = {"none": dict(benchmark="none"), "medium": dict(benchmark="medium", dynamic=True)}


class Timed:
    """An env and its running tensordict; ``run(seconds)`` steps it and returns agent steps/s."""

    def __init__(self, env):
        self.env = env
        self.env.set_seed(0)
        self.td = env.reset()
        self.n = max(1, env.batch_size.numel())
        self.render_s = self.total_s = 0.0
        self.run(0.0)  # one step: everything built and compiled

    def run(self, seconds: float) -> float:
        env, steps, start = self.env, 0, time.perf_counter()
        renderers = getattr(env, "renderers", None)
        render_before = _render_seconds(renderers)
        while True:
            self.td.set("action", env.action_spec.rand())
            _, self.td = env.step_and_maybe_reset(self.td)
            steps += 1
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                break
        self.render_s += _render_seconds(renderers) - render_before
        self.total_s += elapsed
        return steps * self.n / elapsed


def _render_seconds(renderers) -> float:
    return 0.0 if not renderers else sum(r.seconds for r in renderers)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--sizes", type=int, nargs="+", default=None)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--tasks", nargs="+", default=["cartpole:swingup", "cheetah:run"])
    parser.add_argument("--presets", nargs="+", default=list(PRESETS), choices=list(PRESETS))
    parser.add_argument("--no-gl", action="store_true", help="leave out the GL rows (a GPU box without EGL)")
    args = parser.parse_args()
    cuda = torch.device(args.device).type == "cuda"
    sizes = args.sizes or ([1, 16, 64, 256, 1024, 4096] if cuda else [1, 4, 16, 64, 256])
    if min(sizes) < 1 or args.rounds < 1 or args.seconds <= 0:
        parser.error("--sizes must be >= 1, --rounds >= 1, --seconds > 0")
    torch.set_num_threads(1)
    machine = cpu_model() + (f", {torch.cuda.get_device_name(args.device)}" if cuda else "")
    print(f"{machine}; torch {torch.__version__}, 1 torch thread; {args.rounds} rounds of ~{args.seconds:g} s, "
          f"interleaved; median agent steps/s (ratio to one GL env)")
    for spec in args.tasks:
        domain, task = spec.split(":")
        for preset in args.presets:
            options = dict(PRESETS[preset], seed=0)
            paths: dict[str, Timed] = {}
            if not args.no_gl:
                paths["one GL env"] = Timed(dcs.make_env(domain, task, **options))
                paths["ParallelSuiteEnv(2)"] = Timed(
                    dcs.ParallelSuiteEnv(2, functools.partial(dcs.make_env, domain, task, **PRESETS[preset])))
            for n in sizes:
                paths[f"warp N={n}"] = Timed(dcs.make_env(domain, task, num_envs=n, backend="warp",
                                                          device=args.device, **options))
            rates = {name: [] for name in paths}
            for _ in range(args.rounds):
                for name, timed in paths.items():
                    rates[name].append(timed.run(args.seconds))
            base = statistics.median(rates["one GL env"]) if "one GL env" in rates else None
            print(f"\n{domain} {task}, {preset}{' dynamic' if preset != 'none' else ''}")
            print("| path | agent steps/s | x one GL env | render share |")
            print("|---|---:|---:|---:|")
            for name, values in rates.items():
                rate = statistics.median(values)
                ratio = f"{rate / base:.2f}" if base else "n/a"
                timed = paths[name]
                share = f"{timed.render_s / timed.total_s:.0%}" if isinstance(timed.env, BatchedSuiteEnv) else ""
                print(f"| {name} | {rate:.0f} ({min(values):.0f}-{max(values):.0f}) | {ratio} | {share} |")
            for timed in paths.values():
                timed.env.close()


if __name__ == "__main__":
    main()
