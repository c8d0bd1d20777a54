"""Seconds per agent step of the whole recipe loop against seconds per update of the same agent alone.

    python benchmarks/loop_speed.py [--methods rad drq] [--batch-sizes 128] [--steps 150] [--updates 20] [--rounds 3]

For each method and batch size, in one run:

* **loop**: the recipe itself, as a user runs it (``python recipes/sac/sac.py ...``: cartpole
  swingup, one train env, one eval env, ``fast`` render profile off, the default ``default``
  profile), ``--seed-steps`` random agent steps, then ``--steps`` agent steps with one update
  each. Seconds per agent step are taken from ``metrics.csv`` between the first log row after
  the seed steps and the last one; its ``time/<phase>_ms`` rows say where the time went.
* **update alone**: the same agent class and config in a fresh process with no env, ``--updates``
  timed updates (after 2 warm-up updates) on batches sampled from a replay buffer of random frames.

Both run in their own subprocess with the machine's default threads (set ``OMP_NUM_THREADS`` to
change them for both) and ``retain_freed_memory`` as the recipe does. ``--rounds`` alternates the
two measurements (update, loop, update, loop, ...) and reports the median of each: one update
measurement alone has varied by ~15% between runs on these machines. The ratio loop / update is
the claim; absolute figures depend on the CPU (printed with them).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from dcs_torchrl.methods import method_name  # noqa: E402  (pure data: no torch import)
from machine import child_env, cpu_model  # noqa: E402

LOOP_ROWS = ("collect", "extend", "sample", "update")
REPEAT = 8  # cartpole swingup's action repeat




def recipe_overrides(method: str, batch: int, seed_steps: int, steps: int) -> list[str]:
    return [
        f"algo.aug={method}", f"algo.batch_size={batch}", f"collector.seed_steps={seed_steps}",
        f"total_frames={(seed_steps + steps) * REPEAT}", f"logger.interval={25 * REPEAT}",
        "eval.interval=100000000", "eval.episodes=1", "eval.video=false", "checkpoint.interval=100000000",
        "progress=false",
    ]


def measure_loop(method: str, batch: int, seed_steps: int, steps: int) -> dict:
    """Runs the recipe; seconds per agent step after the seed steps, and the phase breakdown."""
    from dcs_torchrl.training import read_metrics

    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, str(ROOT / "recipes/sac/sac.py"), *recipe_overrides(method, batch, seed_steps, steps),
               f"hydra.run.dir={tmp}/run"]
        process = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL)
        cpu = thread_cpu_while(process)
        if process.returncode != 0:
            raise subprocess.CalledProcessError(process.returncode, cmd)
        rows = read_metrics(Path(tmp) / "run/metrics.csv")
    repeat = REPEAT
    logged = sorted({r["frames"] for r in rows if r["name"] == "time/fps"})
    after = [f for f in logged if f // repeat >= seed_steps + 25]  # rows covering only learning steps
    first, last = after[0], after[-1]
    wall = {r["frames"]: r["wall_time"] for r in rows if r["name"] == "time/fps"}
    per_step = (wall[last] - wall[first]) / ((last - first) / repeat)
    phases = {}
    for phase in LOOP_ROWS:
        values = [r["value"] for r in rows if r["name"] == f"time/{phase}_ms" and first < r["frames"] <= last]
        phases[phase] = sum(values) / len(values) / 1000 if values else 0.0
    return {"loop_s_per_step": per_step, "phases_s": phases, "steps_timed": (last - first) // repeat, "cpu_s": cpu,
            "wall_s": wall[last]}


def _stat(path: Path) -> tuple[str, int, float]:
    """(comm, ppid, CPU seconds) of a /proc stat file."""
    text = path.read_text()
    comm = text[text.index("(") + 1:text.rindex(")")]
    fields = text[text.rindex(")") + 2:].split()
    return comm, int(fields[1]), (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def thread_cpu_while(process: subprocess.Popen) -> dict[str, float]:
    """Waits for ``process``; CPU seconds of its threads and its children's, by process and thread name."""
    last: dict[tuple[int, int], tuple[str, float]] = {}
    while process.poll() is None:
        family = {process.pid}
        try:
            for entry in Path("/proc").iterdir():
                if entry.name.isdigit() and _stat(entry / "stat")[1] in family:
                    family.add(int(entry.name))
            for pid in family:
                for task in Path(f"/proc/{pid}/task").iterdir():
                    comm, _, seconds = _stat(task / "stat")
                    kind = "main" if pid == process.pid else "child"
                    last[(pid, int(task.name))] = (f"{kind}: {comm}", seconds)
        except (FileNotFoundError, ProcessLookupError, ValueError):
            pass
        time.sleep(0.5)
    by_name: dict[str, float] = {}
    for name, seconds in last.values():
        by_name[name] = by_name.get(name, 0.0) + seconds
    return dict(sorted(by_name.items(), key=lambda kv: -kv[1]))


def build_agent(method: str, batch: int):
    """The SAC recipe's agent for ``method`` at ``batch`` and a replay buffer of 8 episodes of random frames."""
    import torch
    from hydra import compose, initialize_config_module
    from tensordict import TensorDict
    from torchrl.data import Bounded

    from dcs_torchrl.methods import agent_class
    from dcs_torchrl.training import FrameStackReplayBuffer

    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("sac", overrides=recipe_overrides(method, batch, 1, 1))
    torch.manual_seed(0)
    agent = agent_class("sac")(cfg, (9, 84, 84), Bounded(-1.0, 1.0, shape=(1,)))
    buffer = FrameStackReplayBuffer(2000, 3, (3, 84, 84), (1,), batch_size=batch, min_episode_steps=125)
    steps = 125
    for _ in range(8):
        frames = torch.randint(0, 256, (steps, 9, 84, 84), dtype=torch.uint8)
        done = torch.zeros(steps, 1, dtype=torch.bool)
        done[-1] = True
        buffer.extend(TensorDict({
            "pixels": frames, "action": torch.rand(steps, 1) * 2 - 1,
            "next": {"pixels": frames.roll(-1, 0), "reward": torch.rand(steps, 1), "done": done,
                     "terminated": torch.zeros(steps, 1, dtype=torch.bool)},
        }, batch_size=[steps]))
    return agent, buffer


def measure_update(method: str, batch: int, updates: int) -> dict:
    """The recipe's agent alone: seconds per update on replay samples of random frames."""
    import torch

    from dcs_torchrl.modules import retain_freed_memory

    retain_freed_memory()
    agent, buffer = build_agent(method, batch)
    for i in range(2):
        agent.update(buffer.sample(), i)
    start = time.perf_counter()
    for i in range(updates):
        agent.update(buffer.sample(), i)
    return {"update_s": (time.perf_counter() - start) / updates, "threads": torch.get_num_threads()}


def median(results: list[dict], key: str) -> dict:
    """The result whose ``key`` is the median (the lower middle one of an even count)."""
    return sorted(results, key=lambda r: r[key])[(len(results) - 1) // 2]


def child(args) -> None:
    if args.child == "update":
        print(json.dumps(measure_update(args.methods[0], args.batch_sizes[0], args.updates)))
    else:
        print(json.dumps(measure_loop(args.methods[0], args.batch_sizes[0], args.seed_steps, args.steps)))


def run_child(kind: str, method: str, batch: int, args) -> dict:
    cmd = [sys.executable, __file__, "--child", kind, "--methods", method, "--batch-sizes", str(batch),
           "--steps", str(args.steps), "--seed-steps", str(args.seed_steps), "--updates", str(args.updates)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT, env=child_env())
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--methods", nargs="+", default=["rad", "drq"], choices=["none", "rad", "drq"])
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[128])
    parser.add_argument("--steps", type=int, default=150, help="timed agent steps of the loop (after the seed steps)")
    parser.add_argument("--seed-steps", type=int, default=200, help="random agent steps before learning")
    parser.add_argument("--updates", type=int, default=20, help="timed updates of the agent alone")
    parser.add_argument("--rounds", type=int, default=1, help="alternating measurements of each; medians are reported")
    parser.add_argument("--child", choices=["loop", "update"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(args)
    import torch

    print(f"CPU: {cpu_model()}, {os.cpu_count()} logical cores, torch {torch.__version__}, "
          f"{torch.get_num_threads()} torch threads (OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')})")
    rows = []
    for batch in args.batch_sizes:
        for method in args.methods:
            updates, loops = [], []
            for _ in range(args.rounds):
                updates.append(run_child("update", method, batch, args))
                loops.append(run_child("loop", method, batch, args))
                print(f"  {method_name('sac', method)} batch {batch}: loop {loops[-1]['loop_s_per_step']:.3f} s/step, "
                      f"update alone {updates[-1]['update_s']:.3f} s", flush=True)
            rows.append((method, batch, median(loops, "loop_s_per_step"), median(updates, "update_s")))
    print("\n| method | batch | whole loop s/agent step | update alone s | loop / update | "
          "in the loop: collect | sample | update (ms/step) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for method, batch, loop, update in rows:
        name = method_name("sac", method)
        ph = loop["phases_s"]
        print(f"| {name} | {batch} | {loop['loop_s_per_step']:.3f} | {update['update_s']:.3f} | "
              f"**{loop['loop_s_per_step'] / update['update_s']:.3f}** | {1000 * ph['collect']:.1f} | "
              f"{1000 * ph['sample']:.1f} | {1000 * ph['update']:.0f} |")
    print("\nCPU seconds of the recipe's threads over the whole run (wall seconds in brackets), by process and thread name:")
    for method, batch, loop, _ in rows:
        shown = ", ".join(f"{name} {seconds:.0f}" for name, seconds in list(loop["cpu_s"].items())[:8])
        print(f"  {method_name('sac', method)} batch {batch} ({loop['wall_s']:.0f} s): {shown}")


if __name__ == "__main__":
    main()
