"""Memory and sampling speed of the recipes' frame-stack replay against TorchRL's two ways.

    python benchmarks/replay_memory.py [--transitions 100000] [--naive-transitions 10000]

Fills :class:`dcs_torchrl.training.FrameStackReplayBuffer` with ``--transitions`` transitions of
DrQ's pixel setup (84x84 RGB, 3 stacked frames, episodes of 125 steps as cartpole at action
repeat 8) and TorchRL's ``ReplayBuffer(LazyTensorStorage)`` holding the stacked observation and
next observation with ``--naive-transitions`` (it needs 127 KB a transition, so 100K would take
12.7 GB: it is measured smaller and scaled), and TorchRL's own frame-stacking replay,
``CatFrames.make_rb_transform_and_sampler`` (single frames stored, a ``SliceSampler`` of 3
consecutive transitions, stacks rebuilt by ``CatFrames`` when sampled). Reports resident memory
growth per transition and the median time to sample a batch of 128 and of 512, each buffer
measured in its own subprocess.
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


def single_frames(data):
    """The same transitions as TorchRL's CatFrames replay stores them: the newest frame of each stack."""
    out = data.clone(False)
    out["pixels"], out["next", "pixels"] = data["pixels"][:, -C:], data["next", "pixels"][:, -C:]
    out["done"] = data["next", "done"].roll(1, 0)  # CatFrames restarts its stack after a done
    return out


def make_buffer(kind: str, transitions: int, batch_size: int):
    from torchrl.data import LazyTensorStorage, ReplayBuffer
    from torchrl.envs import CatFrames

    from dcs_torchrl.training import FrameStackReplayBuffer

    if kind == "frame_stack":
        return FrameStackReplayBuffer(transitions, S, (C, H, H), (A,), batch_size=batch_size, min_episode_steps=EPISODE)
    if kind == "torchrl_catframes":
        cat = CatFrames(N=S, dim=-3, in_keys=["pixels"], out_keys=["stack"], reset_key="_reset", done_key="done")
        transform, sampler = cat.make_rb_transform_and_sampler(batch_size=batch_size)
        return ReplayBuffer(storage=LazyTensorStorage(transitions), sampler=sampler, transform=transform, batch_size=batch_size)
    return ReplayBuffer(storage=LazyTensorStorage(transitions), batch_size=batch_size)


def measure(kind: str, transitions: int) -> dict:
    import warnings

    warnings.filterwarnings("ignore", message="The last dimension of the tensordict should be marked as 'time'")
    before = rss_bytes()
    rb = make_buffer(kind, transitions, 512)
    start = time.perf_counter()
    for t0 in range(0, transitions, 1000):
        data = batch(t0, min(1000, transitions - t0))
        rb.extend(single_frames(data) if kind == "torchrl_catframes" else data)
    fill = time.perf_counter() - start
    grown = rss_bytes() - before
    row = {"kind": kind, "transitions": transitions, "bytes_per_transition": grown / transitions,
           "fill_s_per_1k": fill / transitions * 1000}
    stacked = "stack" if kind == "torchrl_catframes" else "pixels"
    for size in (128, 512):
        times = []
        for _ in range(20):
            start = time.perf_counter()
            sample = rb.sample(size)
            times.append(time.perf_counter() - start)
        assert sample[stacked].shape == (size, S * C, H, H), sample[stacked].shape
        row[f"sample_{size}_ms"] = 1000 * sorted(times)[len(times) // 2]
    return row


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
    for kind, n in (("frame_stack", args.transitions), ("torchrl_stacked", args.naive_transitions),
                    ("torchrl_catframes", args.transitions)):
        out = subprocess.run([sys.executable, __file__, "--child", kind, str(n)], capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    ours = rows[0]
    print("| buffer | transitions measured | bytes / transition | at 100K transitions | x frame_stack bytes | "
          "sample 128 (ms) | x frame_stack | sample 512 (ms) | x frame_stack |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['kind']} | {r['transitions']} | {r['bytes_per_transition']:,.0f} | "
              f"{r['bytes_per_transition'] * 1e5 / 2**30:.1f} GiB | {r['bytes_per_transition'] / ours['bytes_per_transition']:.2f} | "
              f"{r['sample_128_ms']:.1f} | {r['sample_128_ms'] / ours['sample_128_ms']:.2f} | "
              f"{r['sample_512_ms']:.1f} | {r['sample_512_ms'] / ours['sample_512_ms']:.2f} |")


if __name__ == "__main__":
    main()
