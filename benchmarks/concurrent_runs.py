"""How many recipe runs one machine holds at once: aggregate frames/s of 1, 2, 4, 8 runs side by side.

    python benchmarks/concurrent_runs.py [--runs 1 2 4 8] [--device cuda] [--method sac] [--batch-size 512]
        [--variant eager] [--seed-steps 600] [--loop-steps 300] [--hidden 1024] [--threads auto]

For each count N in ``--runs``, N copies of the recipe (``gpu_speed.py``'s loop: SAC+DrQ or
QT-Opt+DrQ on cartpole swingup, one env each, seeds 0..N-1, each in its own directory) start at
once and run to the end; each has ``--threads`` torch threads (``auto``: the machine's cores
divided by N, at least 1, as ``budget.threads`` sets them for the experiment launcher's ``jobs``).
Every run's frames/s is read from its ``metrics.csv`` over its learning steps (after a warm-up
interval); the table gives each count's slowest and fastest run, their sum (the machine's
aggregate) and the aggregate over one run's. A count is worth running while the aggregate
still grows; where each run slows as much as runs are added, the machine is full.

The experiment launcher runs that many at once with ``jobs=<N> budget.threads=<cores / N>``
(docs/experiments.md, "Budgets"). Runs share the one GPU (``device=cuda``) and the CPU cores;
nothing is pinned.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import tempfile
from pathlib import Path

import gpu_speed
from gpu_speed import REPEAT, ROOT, loop_command, loop_timing

from machine import child_env, cpu_model


def run_at_once(count: int, threads: int, args) -> list[dict]:
    """``count`` recipe runs started together; each one's loop timing (``gpu_speed.loop_timing``)."""
    with tempfile.TemporaryDirectory() as tmp:
        runs = []
        for seed in range(count):
            run_dir = Path(tmp) / f"run_{seed}"
            log = open(Path(tmp) / f"run_{seed}.log", "w")
            command = loop_command(args.method, args.batch_size, args.variant, args, run_dir, seed=seed)
            process = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                                       env=child_env(OMP_NUM_THREADS=str(threads)))
            runs.append((process, run_dir, log))
        failed = []
        for seed, (process, run_dir, log) in enumerate(runs):
            process.wait()
            log.close()
            if process.returncode != 0:
                failed.append(f"run {seed} (exit {process.returncode}):\n" + Path(log.name).read_text()[-2000:])
        if failed:
            raise SystemExit("a recipe run failed:\n" + "\n".join(failed))
        return [loop_timing(run_dir / "metrics.csv", args.seed_steps, args.loop_steps) for _, run_dir, _ in runs]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="+", default=[1, 2, 4, 8], help="run counts, each started together")
    parser.add_argument("--device", default="cuda" if gpu_speed.torch.cuda.is_available() else "cpu")
    parser.add_argument("--method", default="sac", choices=["sac", "qtopt"])
    parser.add_argument("--batch-size", type=int, default=512)
    parser.add_argument("--variant", default="eager", help="gpu_speed.py's variants: eager, cudagraph, cudagraph+tf32, ...")
    parser.add_argument("--seed-steps", type=int, default=600, help="random agent steps before each run learns")
    parser.add_argument("--loop-steps", type=int, default=300, help="learning agent steps of each run")
    parser.add_argument("--hidden", type=int, default=1024, help="MLP width (DrQ: 1024; smaller for a quick check)")
    parser.add_argument("--threads", default="auto", help="torch threads of each run; auto: cores / runs, at least 1")
    args = parser.parse_args(argv)
    if any(n < 1 for n in args.runs):
        parser.error("--runs: each count must be at least 1")
    if args.threads != "auto" and not (args.threads.isdigit() and int(args.threads) >= 1):
        parser.error(f"--threads must be auto or a positive integer, not {args.threads!r}")
    gpu_speed.variant_overrides(args.variant)  # an unknown variant is refused before anything starts
    if args.device.startswith("cuda") and not gpu_speed.torch.cuda.is_available():
        raise SystemExit("--device cuda but CUDA is not available: use --device cpu.")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1  # the cores this process may use
    line, _ = gpu_speed.device_line(gpu_speed.torch.device(args.device))
    if not line.startswith("CPU"):
        line += f"; CPU: {cpu_model()}, {cores} logical cores"
    print(line, flush=True)

    rows = []
    for count in args.runs:
        threads = max(1, cores // count) if args.threads == "auto" else int(args.threads)
        timings = run_at_once(count, threads, args)
        fps = sorted(REPEAT / t["step_s"] for t in timings)
        rows.append({"runs": count, "threads": threads, "fps": fps, "aggregate": sum(fps)})
        print(f"  {count} at once, {threads} torch thread{'s' if threads > 1 else ''} each: {sum(fps):.1f} frames/s together "
              f"({fps[0]:.1f} to {fps[-1]:.1f} each)", flush=True)

    one = rows[0]["aggregate"]
    method = gpu_speed.method_name(args.method, "drq")
    print(f"\n{line}; {method}, batch {args.batch_size}, {args.variant}, cartpole swingup (action repeat {REPEAT}); "
          f"frames/s of each run over its {args.loop_steps} learning steps")
    print(f"| runs at once | torch threads each | slowest run, frames/s | fastest run | together | x {args.runs[0]} run(s) |")
    print("|---:|---:|---:|---:|---:|---:|")
    for row in rows:
        print(f"| {row['runs']} | {row['threads']} | {row['fps'][0]:.1f} | {row['fps'][-1]:.1f} | {row['aggregate']:.1f} | "
              f"**{row['aggregate'] / one:.2f}** |")
    return rows


if __name__ == "__main__":
    main()
