"""Sizes and speeds of a dataset: generation agent steps/s, bytes per transition, load + sample time.

    python benchmarks/dataset_speed.py --episodes 10 --policy sac_rad_cartpole_swingup random \\
        --benchmark medium --dynamic
    python benchmarks/dataset_speed.py --episodes 100 --policy sac_rad_cartpole_swingup --backend gl warp \\
        --num-envs 16 --benchmark medium --dynamic        # the GL env and the Warp batch, side by side
    python benchmarks/dataset_speed.py --set data/cartpole_medium_expert   # an existing set: sizes and sampling

Generates ``--episodes`` episodes of cartpole swingup (``--domain``, ``--task``) with each
``--policy`` on each ``--backend`` (``warp``: ``--num-envs`` envs in one batch) into a temporary
folder (the whole ``generate`` call timed: the env's and the agent's construction included), then
for each set: its bytes on disk per transition (every file of the set, frames included), the time to
open it as a replay buffer (``dcs_torchrl.datasets.load``) and the median time to sample a batch of
``--batch-size`` (256): 3 stacked uint8 frames in the set's own layout, single float frames in
V-D4RL's. With two backends it prints the generation's speed-up of the Warp batch over the GL env
(the same episodes). Prints a markdown table and the CPU model.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine import cpu_model  # noqa: E402


def set_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def sampling(path: Path, batch_size: int, layout: str, rounds: int) -> tuple[float, float]:
    """Seconds to open the set as a buffer, and the median seconds of a sample (3 stacked frames in
    the set's layout, V-D4RL's single frames in its)."""
    from dcs_torchrl.datasets import load

    start = time.perf_counter()
    buffer = load(path, batch_size, 3 if layout == "ted" else 1, layout=layout)
    opened = time.perf_counter() - start
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        buffer.sample()
        times.append(time.perf_counter() - start)
    return opened, statistics.median(times)


def row(path: Path, label: str, seconds: float | None, batch_size: int, rounds: int) -> str:
    from dcs_torchrl.datasets.layout import METADATA, read_json

    record = read_json(path / METADATA)
    n = record["transitions"]
    steps = "" if seconds is None else f"{n / seconds:.1f} ({seconds:.0f} s)"
    opened, ted = sampling(path, batch_size, "ted", rounds)
    _, vd4rl = sampling(path, batch_size, "vd4rl", rounds)
    return (f"| {label} | {record['episodes']} | {n} | {set_bytes(path) / n / 1e3:.1f} KB | {steps} | "
            f"{opened * 1e3:.0f} ms | {ted * 1e3:.1f} ms | {vd4rl * 1e3:.1f} ms |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--set", nargs="*", default=[], help="existing sets to measure (no generation)")
    parser.add_argument("--policy", nargs="*", default=["sac_rad_cartpole_swingup", "random"])
    parser.add_argument("--domain", default="cartpole")
    parser.add_argument("--task", default="swingup")
    parser.add_argument("--benchmark", default="medium")
    parser.add_argument("--dynamic", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--max-steps", type=int, default=None, help="cut episodes (a quick check of the script)")
    parser.add_argument("--backend", nargs="+", default=["gl"], choices=["gl", "warp"])
    parser.add_argument("--num-envs", type=int, default=16, help="--backend warp: envs of the batch")
    parser.add_argument("--batch-size", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=20, help="samples timed per set and layout")
    args = parser.parse_args()
    from dcs_torchrl.datasets import generate

    print(f"CPU: {cpu_model()}")
    print("| set | episodes | transitions | disk / transition | generation: agent steps/s (wall) | open | "
          f"sample {args.batch_size} (ted, 3 frames) | sample {args.batch_size} (vd4rl, 1 frame) |")
    print("|---|---|---|---|---|---|---|---|")
    for path in args.set:
        print(row(Path(path), Path(path).name, None, args.batch_size, args.rounds), flush=True)
    if args.set:
        return
    with tempfile.TemporaryDirectory() as tmp:
        for policy in args.policy:
            seconds = {}
            for backend in args.backend:
                out = Path(tmp) / f"{Path(policy).name}-{backend}"
                batch = {"backend": backend, "num_envs": args.num_envs} if backend == "warp" else {}
                start = time.perf_counter()
                generate(out, domain=args.domain, task=args.task, episodes=args.episodes, policies=[policy],
                         benchmark=args.benchmark, dynamic=args.dynamic, max_steps=args.max_steps, **batch)
                seconds[backend] = time.perf_counter() - start
                label = (f"{args.domain} {args.task} {args.benchmark}{' dynamic' if args.dynamic else ''}, {policy}, "
                         + (f"warp, {args.num_envs} envs" if backend == "warp" else "gl"))
                print(row(out, label, seconds[backend], args.batch_size, args.rounds), flush=True)
            if len(seconds) == 2:
                print(f"generation, {policy}: the Warp batch {seconds['gl'] / seconds['warp']:.2f}x the GL env "
                      "(whole commands)", flush=True)


if __name__ == "__main__":
    main()
