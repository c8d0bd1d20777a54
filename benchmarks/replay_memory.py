"""Memory and sampling speed of the recipes' frame-stack replay against storing stacks as they are.

    python benchmarks/replay_memory.py [--transitions 100000] [--naive-transitions 10000]

Fills :class:`dcs_torchrl.training.FrameStackReplayBuffer` with ``--transitions`` transitions of
DrQ's pixel setup (84x84 RGB, 3 stacked frames, episodes of 125 steps as cartpole at action
repeat 8) and TorchRL's ``ReplayBuffer(LazyTensorStorage)`` holding the stacked observation and
next observation with ``--naive-transitions`` (it needs 127 KB a transition, so 100K would take
12.7 GB: it is measured smaller and scaled). Reports resident memory growth per transition and
the time to sample a batch of 512, each measured in its own subprocess.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

S, C, H, A, EPISODE = 3, 3, 84, 1, 125


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        import os

        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def batch(t0: int, steps: int):
    import torch
    from tensordict import TensorDict

    frames = torch.randint(0, 256, (steps + S, C, H, H), dtype=torch.uint8)
    stacks = torch.stack([frames[i:i + S].reshape(S * C, H, H) for i in range(steps + 1)])
    done = torch.tensor([(t0 + i + 1) % EPISODE == 0 for i in range(steps)]).unsqueeze(-1)
    return TensorDict({"pixels": stacks[:-1], "action": torch.zeros(steps, A), "next": {
        "pixels": stacks[1:], "reward": torch.zeros(steps, 1), "done": done, "terminated": torch.zeros_like(done)}}, [steps])


def measure(kind: str, transitions: int) -> dict:
    import torch
    from torchrl.data import LazyTensorStorage, ReplayBuffer

    from dcs_torchrl.training import FrameStackReplayBuffer

    before = rss_bytes()
    if kind == "frame_stack":
        rb = FrameStackReplayBuffer(transitions, S, (C, H, H), (A,), batch_size=512, min_episode_steps=EPISODE)
    else:
        rb = ReplayBuffer(storage=LazyTensorStorage(transitions), batch_size=512)
    start = time.perf_counter()
    for t0 in range(0, transitions, 1000):
        data = batch(t0, min(1000, transitions - t0))
        rb.extend(data)
    fill = time.perf_counter() - start
    grown = rss_bytes() - before
    times = []
    for _ in range(20):
        start = time.perf_counter()
        sample = rb.sample()
        times.append(time.perf_counter() - start)
    assert sample["pixels"].shape == (512, S * C, H, H)
    return {"kind": kind, "transitions": transitions, "bytes_per_transition": grown / transitions,
            "fill_s_per_1k": fill / transitions * 1000, "sample_512_ms": 1000 * sorted(times)[len(times) // 2]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--transitions", type=int, default=100_000)
    parser.add_argument("--naive-transitions", type=int, default=10_000)
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.child[0], int(args.child[1]))))
        return
    rows = []
    for kind, n in (("frame_stack", args.transitions), ("torchrl_stacked", args.naive_transitions)):
        out = subprocess.run([sys.executable, __file__, "--child", kind, str(n)], capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    base = rows[1]["bytes_per_transition"]
    print("| buffer | transitions measured | bytes / transition | at 100K transitions | ratio | sample 512 (ms) |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['kind']} | {r['transitions']} | {r['bytes_per_transition']:,.0f} | "
              f"{r['bytes_per_transition'] * 1e5 / 2**30:.1f} GiB | {r['bytes_per_transition'] / base:.2f} | {r['sample_512_ms']:.1f} |")


if __name__ == "__main__":
    main()
