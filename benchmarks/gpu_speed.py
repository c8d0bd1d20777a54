"""The recipes on a GPU, in one command: each phase's milliseconds, the update against the
plain-PyTorch reference DrQ update, and the update's achieved TFLOP/s beside the card's.

    python benchmarks/gpu_speed.py [--device cuda] [--methods sac qtopt] [--batch-sizes 512 128]
        [--variants eager cudagraph cudagraph+tf32] [--updates 20] [--warmup 5]
        [--loop-steps 200] [--seed-steps 600] [--hidden 1024] [--matmul-size 8192]

For SAC+DrQ and QT-Opt+DrQ (``--methods``) at each batch size and each execution variant, in one
process (the device's math flags set per variant):

* **sample**: ``FrameStackReplayBuffer.sample`` from the storage the recipes pick
  (``replay_buffer.device=auto``: on the GPU) of 1000 transitions of random frames;
* **update**: the recipe's agent (``dcs_torchrl.algorithms``) on fresh samples, after ``--warmup``
  updates (which also capture the CUDA graphs, compile);
* **act**: the acting policy on one observation from the host, the action back on the host
  (``DevicePolicy``: one copy each way);
* **reference**: the reference DrQ update rebuilt in plain PyTorch (``update_speed.py``'s
  ``reference`` variant; QT-Opt's: ``qtopt reference``), eager, on the same device and math
  flags; ``x ref`` is its time over ours (> 1: ours is faster);
* **FLOPs** of one update (mean of the two schedules; ``update_flops.py``'s counter, any device)
  and the achieved TFLOP/s, beside a large matmul's on the same device (float32 without TF32, with
  TF32, bfloat16: the ceiling each precision reaches here) and the datasheet's dense peaks of
  known cards;
* **loop** (unless ``--loop-steps 0``): the recipe itself (``python -m dcs_torchrl.training``,
  cartpole swingup, one env) for ``--seed-steps`` random steps and ``--loop-steps`` learning
  steps: milliseconds per agent step, all in, from its ``metrics.csv``.

Each phase alone is timed with the device synchronised around it; in the loop the phases
overlap (an update runs on the GPU while the next env step renders), so its phase rows
(``time/<phase>_ms``) say where the host waited, not what each costs.

Variants are ``+``-joined execution settings: ``eager`` (the recipe's default: fused Adam on
CUDA, cuDNN's search, float32), ``compile`` (``execution.compile``), ``cudagraph``
(``execution.cudagraph``), ``tf32`` (``precision.tf32``), ``nofused`` (``optim.fused=false``),
``nchw`` (``network.channels_last=false``: the encoder's convolutions in NCHW, as the
reference's; on an H200 in float32 the reference, NCHW, took 29.6 ms where ours, NHWC, took 36.9
eager and 29.2 with graphs, and with TF32 20.8 against 15.1: which layout cuDNN runs faster may
depend on the precision).
``--device cpu`` runs the same command on the CPU (the variants that need CUDA are refused), so
that it is tested where there is no GPU.
"""
from __future__ import annotations

import argparse
import gc
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from loop_speed import LOOP_ROWS, cpu_model  # noqa: E402
from machine import child_env  # noqa: E402
from update_flops import FlopCount  # noqa: E402
from update_speed import ACTION_DIM, ReferenceQTOpt, ReferenceSAC, make_batch  # noqa: E402

from dcs_torchrl.methods import method_name  # noqa: E402

FRAME_STACK, IMAGE = 3, 84
REPEAT = 8  # cartpole swingup's action repeat (the loop)
VARIANT_SETTINGS = {
    "eager": [],
    "compile": ["execution.compile=true"],
    "cudagraph": ["execution.cudagraph=true"],
    "tf32": ["precision.tf32=true"],
    "nofused": ["optim.fused=false"],
    "nchw": ["network.channels_last=false"],
}
#: Dense datasheet peaks in TFLOP/s (float32 without tensor cores, TF32, BF16), by name fragment.
DATASHEET = {
    "H200": (67.0, 494.7, 989.4),
    "H100 SXM": (67.0, 494.7, 989.4),
    "H100 PCIe": (51.2, 378.0, 756.0),
    "H100": (67.0, 494.7, 989.4),
    "A100": (19.5, 156.0, 312.0),
    "L40S": (91.6, 183.0, 362.0),
    "L4": (30.3, 60.0, 121.0),
    "A10": (31.2, 62.5, 125.0),
}


def variant_overrides(variant: str) -> list[str]:
    """The recipe overrides of a ``+``-joined variant name."""
    parts = variant.split("+")
    unknown = [p for p in parts if p not in VARIANT_SETTINGS]
    if unknown:
        raise SystemExit(f"unknown variant part(s) {unknown}: use {sorted(VARIANT_SETTINGS)} joined by '+'.")
    return [o for part in parts for o in VARIANT_SETTINGS[part]]


def config(algo: str, batch: int, device: str, variant: str, hidden: int):
    from hydra import compose, initialize_config_module

    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        return compose(algo, overrides=["algo.aug=drq", f"algo.batch_size={batch}", f"device={device}",
                                        f"network.hidden_dim={hidden}", *variant_overrides(variant)])


def synchronize(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def timed(fn, repeats: int, device: torch.device) -> float:
    """Seconds per call of ``fn`` (device synchronised before and after)."""
    synchronize(device)
    start = time.perf_counter()
    for _ in range(repeats):
        fn()
    synchronize(device)
    return (time.perf_counter() - start) / repeats


def random_buffer(batch: int, device: torch.device | None):
    """1000 transitions (8 episodes of 125) of random frames, as loop_speed.build_agent."""
    from tensordict import TensorDict

    from dcs_torchrl.training import FrameStackReplayBuffer

    buffer = FrameStackReplayBuffer(2000, FRAME_STACK, (3, IMAGE, IMAGE), (ACTION_DIM,), batch_size=batch,
                                    min_episode_steps=125, device=device)
    gen = torch.Generator().manual_seed(0)
    for _ in range(8):
        frames = torch.randint(0, 256, (125, 3 * FRAME_STACK, IMAGE, IMAGE), generator=gen, dtype=torch.uint8)
        done = torch.zeros(125, 1, dtype=torch.bool)
        done[-1] = True
        buffer.extend(TensorDict({
            "pixels": frames, "action": torch.rand(125, ACTION_DIM, generator=gen) * 2 - 1,
            "next": {"pixels": frames.roll(-1, 0), "reward": torch.rand(125, 1, generator=gen), "done": done,
                     "terminated": torch.zeros(125, 1, dtype=torch.bool)},
        }, batch_size=[125]))
    return buffer


def update_flops(agent, buffer) -> float:
    """FLOPs of one update: the mean of the two schedules (index 0: all parts, 1: the critic)."""
    counter = FlopCount()
    with counter:
        agent.update(buffer.sample(), 0)
        agent.update(buffer.sample(), 1)
    return sum(counter.by_op.values()) / 2


def measure_phases(algo: str, batch: int, variant: str, args) -> dict:
    """Sample, update, act and the reference update, each alone, synchronised."""
    from tensordict import TensorDict
    from torchrl.data import Bounded

    from dcs_torchrl.methods import agent_class
    from dcs_torchrl.training import FrameStackReplayBuffer
    from dcs_torchrl.training.execution import ExecutionOptions, apply_math_settings, on_device, replay_device

    cfg = config(algo, batch, args.device, variant, args.hidden)
    options = ExecutionOptions.from_config(cfg)
    apply_math_settings(options)
    device = options.device
    torch.manual_seed(0)
    agent = agent_class(algo)(cfg, (3 * FRAME_STACK, IMAGE, IMAGE), Bounded(-1.0, 1.0, shape=(ACTION_DIM,)))
    storage = replay_device(cfg, FrameStackReplayBuffer.storage_bytes(2000, FRAME_STACK, (3, IMAGE, IMAGE), (ACTION_DIM,), 125))
    buffer = random_buffer(batch, None if storage.type == "cpu" else storage)
    index = iter(range(10**9))
    warmup_start = time.perf_counter()
    for _ in range(args.warmup):
        agent.update(buffer.sample(), next(index))
    synchronize(device)
    warmup_s = time.perf_counter() - warmup_start
    sample_s = timed(buffer.sample, args.updates, device)
    samples = [buffer.sample() for _ in range(args.updates)]  # the update timed alone
    update_s = timed(lambda: agent.update(samples.pop(), next(index)), args.updates, device)
    policy = on_device(agent.policy, device)
    obs = TensorDict({"pixels": torch.randint(0, 256, (1, 3 * FRAME_STACK, IMAGE, IMAGE), dtype=torch.uint8)}, [1])
    policy(obs.clone())
    act_s = timed(lambda: policy(obs.clone()), args.updates, device)
    reference = (ReferenceSAC if algo == "sac" else ReferenceQTOpt)(3 * FRAME_STACK, args.hidden, device=device)
    ref_batch = tuple(t.to(device) for t in make_batch(batch, 3 * FRAME_STACK, "tensors"))
    for _ in range(2):
        reference.update(ref_batch)
    ref_s = timed(lambda: reference.update(ref_batch), max(2, args.updates - args.updates % 2), device)
    del agent, buffer, reference, ref_batch, samples
    release(device)
    return {"sample_s": sample_s, "update_s": update_s, "act_s": act_s, "ref_s": ref_s, "warmup_s": warmup_s,
            "replay": str(storage)}


def count_flops(algo: str, batch: int, args) -> float:
    """FLOPs of one update of the eager agent (a replayed graph or compiled code hides its ops
    from the counter; the math, and so the count, is the same in every variant)."""
    from torchrl.data import Bounded

    from dcs_torchrl.methods import agent_class

    if not args.flops:
        return float("nan")
    torch.manual_seed(0)
    agent = agent_class(algo)(config(algo, batch, args.device, "eager", args.hidden), (3 * FRAME_STACK, IMAGE, IMAGE),
                              Bounded(-1.0, 1.0, shape=(ACTION_DIM,)))
    device = agent.device
    buffer = random_buffer(batch, None if device.type == "cpu" else device)
    flops = update_flops(agent, buffer)
    del agent, buffer
    release(device)
    return flops


def release(device: torch.device) -> None:
    gc.collect()
    if device.type == "cuda":
        torch.cuda.empty_cache()


LOOP_INTERVAL = 25  # agent steps between the loop's log rows


def loop_command(algo: str, batch: int, variant: str, args, run_dir: str | Path, seed: int = 0) -> list[str]:
    """The recipe (cartpole swingup, one env) for ``args.seed_steps`` random and ``args.loop_steps``
    learning agent steps, on ``args.device``, with ``variant``'s settings."""
    return [sys.executable, "-m", "dcs_torchrl.training", f"--config-name={algo}", "algo.aug=drq",
            f"algo.batch_size={batch}", f"device={args.device}", f"network.hidden_dim={args.hidden}",
            f"collector.seed_steps={args.seed_steps}", f"total_frames={(args.seed_steps + args.loop_steps) * REPEAT}",
            f"logger.interval={LOOP_INTERVAL * REPEAT}", "eval.interval=100000000", "eval.episodes=1", "eval.video=false",
            "checkpoint.interval=100000000", "progress=false", f"seed={seed}", f"hydra.run.dir={run_dir}",
            *variant_overrides(variant)]


def loop_timing(metrics_csv: Path, seed_steps: int, loop_steps: int) -> dict:
    """Seconds per learning agent step, all in, between the first log row after a warm-up interval
    of learning and the last row, and the mean of each phase row in between."""
    from dcs_torchrl.training import read_metrics

    rows = read_metrics(metrics_csv)
    logged = sorted({r["frames"] for r in rows if r["name"] == "time/fps"})
    after = [f for f in logged if f // REPEAT >= seed_steps + LOOP_INTERVAL]  # rows of learning steps only (after warm-up)
    if len(after) < 2:
        raise SystemExit(f"--loop-steps {loop_steps} is too short to time: use at least {3 * LOOP_INTERVAL}.")
    first, last = after[0], after[-1]
    wall = {r["frames"]: r["wall_time"] for r in rows if r["name"] == "time/fps"}
    phases = {}
    for phase in LOOP_ROWS:
        values = [r["value"] for r in rows if r["name"] == f"time/{phase}_ms" and first < r["frames"] <= last]
        phases[phase] = sum(values) / len(values) if values else 0.0
    return {"step_s": (wall[last] - wall[first]) / ((last - first) / REPEAT), "phases_ms": phases}


def measure_loop(algo: str, batch: int, variant: str, args) -> dict | None:
    """The recipe itself (``loop_command``): seconds per learning agent step, all in, and its phase rows."""
    if args.loop_steps <= 0:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "recipe.log"
        try:
            with open(log, "w") as out:
                subprocess.run(loop_command(algo, batch, variant, args, f"{tmp}/run"), cwd=ROOT, check=True,
                               stdout=out, stderr=subprocess.STDOUT, env=child_env())
        except (subprocess.CalledProcessError, KeyboardInterrupt):
            report_progress(log, Path(tmp) / "run/metrics.csv")
            raise
        return loop_timing(Path(tmp) / "run/metrics.csv", args.seed_steps, args.loop_steps)


def report_progress(log: Path, metrics_csv: Path) -> None:
    """Where a recipe run that failed or was interrupted had got to: its output's last lines and
    its last ``time/`` rows (frames, wall time), on stderr."""
    lines = log.read_text(errors="replace").splitlines() if log.exists() else []
    rows = metrics_csv.read_text().splitlines()[1:] if metrics_csv.exists() else []
    times = [row for row in rows if ",time/" in row]
    print("the recipe run stopped; its last output:\n" + "\n".join(lines[-20:])
          + f"\nits last time rows (frames,name,value,wall_time), of {len(rows)} rows:\n" + "\n".join(times[-8:]),
          file=sys.stderr, flush=True)


def matmul_tflops(device: torch.device, size: int, dtype: torch.dtype, tf32: bool) -> float:
    """A ``size`` square matmul's TFLOP/s on ``device`` (median of 5)."""
    from dcs_torchrl.training.execution import ExecutionOptions, apply_math_settings

    apply_math_settings(ExecutionOptions(device=device, tf32=tf32))
    a = torch.randn(size, size, device=device, dtype=dtype)
    b = torch.randn(size, size, device=device, dtype=dtype)
    torch.matmul(a, b)
    times = [timed(lambda: torch.matmul(a, b), 1, device) for _ in range(5)]
    return 2 * size**3 / statistics.median(times) / 1e12


def device_line(device: torch.device) -> tuple[str, tuple | None]:
    if device.type != "cuda":
        return f"CPU: {cpu_model()}, {os.cpu_count()} logical cores, {torch.get_num_threads()} torch threads", None
    name = torch.cuda.get_device_name(device)
    props = torch.cuda.get_device_properties(device)
    peaks = next((p for key, p in DATASHEET.items() if key in name), None)
    line = (f"GPU: {name} ({props.multi_processor_count} SMs, {props.total_memory / 2**30:.1f} GiB), "
            f"CUDA {torch.version.cuda}, cuDNN {torch.backends.cudnn.version()}")
    return line, peaks


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--methods", nargs="+", default=["sac", "qtopt"], choices=["sac", "qtopt"])
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[512, 128])
    parser.add_argument("--variants", nargs="+", default=None,
                        help="default: eager cudagraph cudagraph+tf32 on CUDA, eager on the CPU")
    parser.add_argument("--updates", type=int, default=20, help="timed calls of each phase")
    parser.add_argument("--warmup", type=int, default=8, help="updates before timing (graph capture: 3 per schedule)")
    parser.add_argument("--loop-steps", type=int, default=200, help="learning agent steps of the recipe run (0: no loop)")
    parser.add_argument("--seed-steps", type=int, default=600, help="random agent steps before the loop learns")
    parser.add_argument("--hidden", type=int, default=1024, help="MLP width (DrQ: 1024; smaller for a quick check)")
    parser.add_argument("--matmul-size", type=int, default=8192)
    parser.add_argument("--no-flops", dest="flops", action="store_false", help="skip the FLOP count")
    args = parser.parse_args(argv)
    device = torch.device(args.device)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise SystemExit("--device cuda but CUDA is not available: use --device cpu.")
    variants = args.variants or (["eager", "cudagraph", "cudagraph+tf32"] if device.type == "cuda" else ["eager"])
    for variant in variants:
        variant_overrides(variant)
        if device.type != "cuda" and ("cudagraph" in variant or "tf32" in variant):
            raise SystemExit(f"variant {variant!r} needs CUDA: use --device cuda, or the variants eager / compile.")

    line, peaks = device_line(device)
    print(f"{line}; torch {torch.__version__}", flush=True)
    ceilings = {
        "fp32": matmul_tflops(device, args.matmul_size, torch.float32, tf32=False),
        "tf32": matmul_tflops(device, args.matmul_size, torch.float32, tf32=True) if device.type == "cuda" else float("nan"),
        "bf16": matmul_tflops(device, args.matmul_size, torch.bfloat16, tf32=False) if device.type == "cuda" else float("nan"),
    }
    print(f"matmul {args.matmul_size}x{args.matmul_size} here: float32 {ceilings['fp32']:.2f}, TF32 {ceilings['tf32']:.1f}, "
          f"bf16 {ceilings['bf16']:.1f} TFLOP/s"
          + (f"; datasheet (dense): float32 {peaks[0]:g}, TF32 {peaks[1]:g}, bf16 {peaks[2]:g}" if peaks else ""), flush=True)

    rows = []
    for algo in args.methods:
        for batch in args.batch_sizes:
            flops = count_flops(algo, batch, args)
            for variant in variants:
                phases = measure_phases(algo, batch, variant, args)
                loop = measure_loop(algo, batch, variant, args)
                rows.append({"method": method_name(algo, "drq"), "batch": batch, "variant": variant, "flops": flops,
                             **phases, "loop": loop})
                print(f"  {rows[-1]['method']} batch {batch} {variant}: update {1000 * phases['update_s']:.2f} ms, "
                      f"sample {1000 * phases['sample_s']:.2f} ms, act {1000 * phases['act_s']:.2f} ms"
                      + (f", loop {1000 * loop['step_s']:.1f} ms/step" if loop else ""), flush=True)

    print(f"\n{line}; each phase alone, device synchronised, mean of {args.updates} calls after {args.warmup} warm-up "
          f"updates; x ref = reference DrQ update's time / ours (same device, same math flags, eager)")
    print("| method | batch | variant | replay | sample ms | update ms | act ms | loop ms/agent step "
          "(its phase rows: collect / extend / sample / update) | reference ms | x ref | GFLOP / update | TFLOP/s | "
          "x matmul (its precision) |")
    print("|---|---:|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|")
    for row in rows:
        tflops = row["flops"] / row["update_s"] / 1e12
        ceiling = ceilings["tf32" if "tf32" in row["variant"] else "fp32"]
        loop = row["loop"]
        loop_cell = "-" if loop is None else (f"{1000 * loop['step_s']:.1f} ("
                                              + " / ".join(f"{loop['phases_ms'][p]:.1f}" for p in LOOP_ROWS) + ")")
        print(f"| {row['method']} | {row['batch']} | {row['variant']} | {row['replay']} | {1000 * row['sample_s']:.2f} | "
              f"{1000 * row['update_s']:.2f} | {1000 * row['act_s']:.2f} | {loop_cell} | {1000 * row['ref_s']:.2f} | "
              f"**{row['ref_s'] / row['update_s']:.2f}** | {row['flops'] / 1e9:.1f} | {tflops:.3f} | {tflops / ceiling:.3f} |")
    return rows


if __name__ == "__main__":
    main()
