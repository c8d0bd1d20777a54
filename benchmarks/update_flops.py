"""How far the recipe's update is from what this CPU can do: achieved FLOP/s against a large matmul's.

    python benchmarks/update_flops.py [--methods drq] [--batch-sizes 128 512] [--updates 6]

For the SAC recipe's agent (``recipes/sac``, DrQ's networks) at each batch size, in one process:

* the FLOPs of one update, counted with PyTorch's flop formulas (``torch.utils.flop_counter``) on
  every aten op of the update: forward and backward convolutions and matrix products;
* its wall time (median of ``--updates`` timed updates after two warm-up updates, on replay
  samples of random frames, ``retain_freed_memory`` as the recipe does), and the time spent in
  convolution and matmul kernels (``torch.profiler``, self CPU time of those ops);
* a large ``torch.matmul`` (``--matmul-size``, float32) on the same threads: the ceiling.

The table gives GFLOP/s of the whole update, of its convolution and matmul kernels alone, and
each as a fraction of the matmul's rate. Absolute figures depend on the CPU (printed).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import torch
from torch.profiler import ProfilerActivity, profile
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils.flop_counter import flop_registry

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from loop_speed import build_agent, cpu_model, method_name  # noqa: E402

CONV_OPS = ("convolution", "conv2d", "mkldnn_convolution", "convolution_backward")
MATMUL_OPS = ("aten::mm", "aten::addmm", "aten::bmm", "aten::matmul", "aten::linear")


class FlopCount(TorchDispatchMode):
    """FLOPs of the aten ops PyTorch's flop counter knows (convolutions forward and backward, matrix
    products), by op. ``FlopCounterMode`` itself walks the module tree, which TensorDict modules break."""

    def __init__(self):
        super().__init__()
        self.by_op: dict[str, int] = {}

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        out = func(*args, **kwargs)
        count = flop_registry.get(func._overloadpacket)
        if count is not None:
            name = str(func._overloadpacket)
            self.by_op[name] = self.by_op.get(name, 0) + count(*args, **kwargs, out_val=out)
        return out


def matmul_gflops(size: int, repeats: int = 5) -> float:
    a, b = torch.randn(size, size), torch.randn(size, size)
    torch.matmul(a, b)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        torch.matmul(a, b)
        times.append(time.perf_counter() - start)
    return 2 * size**3 / statistics.median(times) / 1e9


def measure(method: str, batch: int, updates: int) -> dict:
    agent, buffer = build_agent(method, batch)
    for i in range(2):
        agent.update(buffer.sample(), i)
    counter = FlopCount()
    with counter:  # an update with the actor step (index 0) and one without (index 1): their mean
        agent.update(buffer.sample(), 0)
        agent.update(buffer.sample(), 1)
    by_op = counter.by_op
    total = sum(by_op.values()) / 2
    conv_flops = sum(n for op, n in by_op.items() if "conv" in op) / 2
    times = []
    for i in range(updates):
        start = time.perf_counter()
        agent.update(buffer.sample(), i)
        times.append(time.perf_counter() - start)
    start = time.perf_counter()
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for i in range(2):
            agent.update(buffer.sample(), i)
    profiled_s = (time.perf_counter() - start) / 2  # the profiler slows the update: shares are of this
    conv_s = matmul_s = 0.0
    for event in prof.key_averages():
        if any(op in event.key for op in CONV_OPS):
            conv_s += event.self_cpu_time_total / 1e6 / 2
        elif event.key in MATMUL_OPS:
            matmul_s += event.self_cpu_time_total / 1e6 / 2
    return {"flops": total, "conv_flops": conv_flops, "update_s": statistics.median(times),
            "conv_s": conv_s, "matmul_s": matmul_s, "profiled_s": profiled_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--methods", nargs="+", default=["drq"], choices=["none", "rad", "drq"])
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[128, 512])
    parser.add_argument("--updates", type=int, default=6)
    parser.add_argument("--matmul-size", type=int, default=4096)
    args = parser.parse_args()
    from dcs_torchrl.modules import retain_freed_memory

    retain_freed_memory()
    print(f"CPU: {cpu_model()}, {os.cpu_count()} logical cores, torch {torch.__version__}, {torch.get_num_threads()} threads")
    peak = matmul_gflops(args.matmul_size)
    print(f"torch.matmul {args.matmul_size}x{args.matmul_size} float32: {peak:.1f} GFLOP/s\n")
    print("| update | batch | GFLOP / update | s / update | GFLOP/s (whole update) | x matmul | "
          "conv GFLOP/s (in conv kernels) | x matmul | share of time in conv + matmul kernels |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for method in args.methods:
        for batch in args.batch_sizes:
            m = measure(method, batch, args.updates)
            rate = m["flops"] / m["update_s"] / 1e9
            conv_rate = m["conv_flops"] / max(m["conv_s"], 1e-9) / 1e9
            share = (m["conv_s"] + m["matmul_s"]) / m["profiled_s"]
            name = method_name("sac", method)
            print(f"| {name} | {batch} | {m['flops'] / 1e9:.1f} | {m['update_s']:.3f} | {rate:.1f} | {rate / peak:.2f} | "
                  f"{conv_rate:.1f} | {conv_rate / peak:.2f} | {share:.0%} |", flush=True)


if __name__ == "__main__":
    main()
