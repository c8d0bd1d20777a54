"""Resident memory of the suite: all 60 default videos, per extra env, and a long soak.

    python benchmarks/memory.py [--soak-steps 20000] [--reset-every 25] [--domain cartpole --task swingup]
    python benchmarks/memory.py --batched 256 --domain cheetah --task run   # backend="warp" only
    python benchmarks/memory.py --rebuild 16 [--batched 8]                   # envs built and closed in turn

1. a process holding all 60 embedded training videos (decoded at 256x256);
2. resident memory added by each further env with dynamic backgrounds (frames shared);
3. resident memory over ``--soak-steps`` agent steps of the hard dynamic benchmark with a
   reset every ``--reset-every`` steps: it must stay flat after warm-up (texture uploads
   and frame caches must not leak).

With ``--batched N``: instead, the resident memory of one ``make_env(..., num_envs=N, backend="warp")``
env of the medium dynamic benchmark after 20 agent steps, and the process's peak.

With ``--rebuild K``: instead, K envs of the medium dynamic benchmark (seed 0: the same videos, so that the frame
cache holds what the first one decoded) built, stepped 5 times, closed and dropped one after another (a sweep,
an evaluation); the resident memory each leaves behind, after the collector and glibc's ``malloc_trim``, over
the second half (the first fills caches). With ``--batched N`` each is a batch of N
(``backend="warp"``), else one GL env.
"""
from __future__ import annotations

import argparse
import ctypes
import gc
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl.videos import cache_info  # noqa: E402


def _status_mb(field: str) -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(f"{field}:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no {field} in /proc/self/status (Linux only)")


def rss_mb() -> float:
    return _status_mb("VmRSS")


def peak_mb() -> float:
    return _status_mb("VmHWM")


def trimmed_rss_mb() -> float:
    """The resident memory once the collector has run and glibc has given its free pages back."""
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    return rss_mb()


def rebuild(args) -> None:
    kind = "GL env" if args.batched is None else f"batch of {args.batched} (backend='warp')"
    options = {} if args.batched is None else dict(num_envs=args.batched, backend="warp")
    samples = []
    for i in range(args.rebuild):
        env = dcs.make_env(args.domain, args.task, benchmark="medium", dynamic=True, seed=0, **options)
        action = torch.zeros(env.action_spec.shape, dtype=env.action_spec.dtype)
        td = env.reset()
        for _ in range(5):
            td = env.step(td.set("action", action))["next"]
        env.close()
        del env, td
        samples.append(trimmed_rss_mb())
    half = samples[len(samples) // 2:]
    kept = (half[-1] - half[0]) / max(1, len(half) - 1)
    print(f"{args.rebuild} {args.domain} {args.task} {kind}s built, stepped, closed one after another: "
          f"resident MB after each {[round(mb) for mb in samples]}; kept per closed env over the second half: "
          f"{kept:+.1f} MB (frame cache {cache_info().bytes / 2**20:.0f} MB)")


def batched(args) -> None:
    start = rss_mb()
    env = dcs.make_env(args.domain, args.task, benchmark="medium", dynamic=True, seed=0, num_envs=args.batched,
                       backend="warp")
    td = env.reset()
    for _ in range(20):
        td = env.step(td.set("action", env.action_spec.rand()))["next"]
    print(f"backend='warp', {args.batched} {args.domain} {args.task} envs, medium dynamic, after 20 steps: "
          f"{rss_mb():.0f} MB resident ({rss_mb() - start:+.0f} MB over the imports), peak {peak_mb():.0f} MB")
    env.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--domain", default="cartpole")
    parser.add_argument("--task", default="swingup")
    parser.add_argument("--soak-steps", type=int, default=20_000)
    parser.add_argument("--reset-every", type=int, default=25)
    parser.add_argument("--envs", type=int, default=4)
    parser.add_argument("--batched", type=int, default=None, metavar="N",
                        help="only the resident memory of N envs of backend='warp' (medium dynamic)")
    parser.add_argument("--rebuild", type=int, default=None, metavar="K",
                        help="only what K envs (batches with --batched) built and closed in turn leave behind")
    args = parser.parse_args()
    torch.set_num_threads(1)
    start = rss_mb()
    print(f"python + torch + dm_control imported: {start:.0f} MB")
    if args.rebuild is not None:
        return rebuild(args)
    if args.batched is not None:
        return batched(args)

    env = dcs.make_env(args.domain, args.task, benchmark="hard", dynamic=True, seed=0, render_profile="fast")
    env.reset()
    background = env.transform[2]
    for index in range(len(background.videos)):
        background.videos.frames(index, background.texture_size)
    info = cache_info()
    print(
        f"one hard dynamic env, all {len(background.videos)} videos decoded: {rss_mb():.0f} MB resident "
        f"(frame cache {info.bytes / 2**20:.0f} MB in {info.entries} videos)"
    )

    envs = [env]
    before = rss_mb()
    for i in range(1, args.envs):
        envs.append(dcs.make_env(args.domain, args.task, benchmark="hard", dynamic=True, seed=i, render_profile="fast"))
        envs[-1].rollout(5, break_when_any_done=False)
    per_env = (rss_mb() - before) / max(1, args.envs - 1)
    print(f"each further env (frames shared through the cache): {per_env:.0f} MB")
    del envs[1:]
    gc.collect()

    td = env.reset()
    action = torch.zeros(env.action_spec.shape, dtype=env.action_spec.dtype)
    samples = []
    started = time.perf_counter()
    for step in range(1, args.soak_steps + 1):
        td = env.step(td.set("action", action))["next"]
        if step % args.reset_every == 0 or td["done"].any():
            td = env.reset()
        if step % 1000 == 0:
            samples.append((step, rss_mb()))
    elapsed = time.perf_counter() - started
    print(f"soak: {args.soak_steps} agent steps, a reset every {args.reset_every}, {elapsed:.0f} s")
    print("| agent step | resident MB |\n|---:|---:|")
    for step, mb in samples:
        print(f"| {step} | {mb:.1f} |")
    warm = [mb for step, mb in samples if step >= min(2000, args.soak_steps)]
    print(f"growth after warm-up (step {samples[1][0] if len(samples) > 1 else 0} to the end): {warm[-1] - warm[0]:+.1f} MB")


if __name__ == "__main__":
    main()
