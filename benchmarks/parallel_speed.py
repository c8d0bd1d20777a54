"""Agent steps per second of one suite env against n workers, through each parallel path, side by side.

    python benchmarks/parallel_speed.py [--workers 2] [--steps 200] [--rounds 5] [--benchmarks none medium]

Paths (cartpole swingup by default, default render profile, seeded random actions):

- ``one env``: one ``make_env`` env stepped in this process (the baseline, 1x);
- ``ParallelEnv``: TorchRL's ``ParallelEnv(n, partial(make_env, ...))`` as it comes (shared-memory
  buffers; this process spin-polls its workers' done flags while they step);
- ``ParallelEnv, pipes``: the same with ``use_buffers=False`` (results come back through the
  pipes, and this process sleeps in ``select`` until they do);
- ``ParallelSuiteEnv``: the suite's parallel env (:class:`dcs_torchrl.ParallelSuiteEnv`) as it
  comes: its first env stepped in this process while n - 1 workers step theirs (``first_here``);
- ``ParallelSuiteEnv, spin_s=0``: the same, each waiting process sleeping in ``select`` at once
  instead of polling its pipes for ``spin_s`` (3 ms) first;
- ``ParallelSuiteEnv, all in workers``: the same with ``first_here=False``: every env in a worker,
  this process sleeping in ``select`` while they step;
- ``ParallelSuiteEnv, unlocked``: every env in a worker, each sent its next action as soon as it is
  done instead of when both are (what lock-step costs; not an API: it is driven through the env's
  pipes here, one env's observation at a time, and its episodes' order depends on timing);
- ``n processes``: n independent processes stepping one env each, nothing shared: the ceiling;
- with ``--inline``, ``one env`` and ``ParallelSuiteEnv`` again, each in a process of its own
  started with ``LP_NUM_THREADS=0`` (Mesa's llvmpipe renders in the calling thread, in that process
  and its workers: no raster threads), to weigh Mesa's setting against its default.

First it prints the cores' own ceiling: n processes each running a one-thread float32 matmul at
once, against one alone (about n on n real, idle cores; less where the cores are shared or busy).

Every path is built once, then stepped in interleaved rounds (each round in the other order to
the last), and the median round is reported with the main process's CPU use (``process_time``
over wall time: a process that waits by spinning shows it). Ratios are taken round by round
(each path against the one env of the same round), their median and range printed.
"""
from __future__ import annotations

import argparse
import functools
import multiprocessing as mp
import os
import statistics
import time
from multiprocessing.connection import wait

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from torchrl.envs import ParallelEnv  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl.render.egl_devices import spawn_environment  # noqa: E402
from dcs_torchrl.vector import parallel  # noqa: E402
from machine import cpu_model  # noqa: E402




def time_env(env, td, steps: int, generator: torch.Generator):
    """Seconds (wall, this process's CPU) for ``steps`` batched steps of random actions."""
    spec = env.action_spec
    actions = torch.rand((steps, *spec.shape), generator=generator) * (spec.high - spec.low) + spec.low
    wall, cpu = time.perf_counter(), time.process_time()
    for action in actions:
        _, td = env.step_and_maybe_reset(td.set("action", action))
    return time.perf_counter() - wall, time.process_time() - cpu, td


class Stepped:
    """A TorchRL env (single or batched) stepped in this process."""

    def __init__(self, env, seed: int):
        self.env = env
        env.set_seed(seed)
        self.td = env.reset()
        self.generator = torch.Generator().manual_seed(seed)
        self.batch = max(1, env.batch_size.numel())

    def run(self, steps: int):
        wall, cpu, self.td = time_env(self.env, self.td, steps, self.generator)
        return wall, cpu

    def close(self):
        self.env.close()


def _driver(make, pipe) -> None:
    """A process running one path (``make()``) on command: the number of steps in, (wall, CPU) out."""
    runner = make()
    pipe.send(runner.batch)
    while (steps := pipe.recv()) is not None:
        pipe.send(runner.run(steps))
    runner.close()


class InProcess:
    """A path run in a spawned process whose environment adds ``variables`` from its start (Mesa
    reads ``LP_NUM_THREADS`` when dm_control first loads EGL, before any code of the path runs);
    ``daemon``: ended with this process (a path with workers of its own cannot be)."""

    def __init__(self, make, variables: dict[str, str] | None = None, daemon: bool = False):
        ctx = mp.get_context("spawn")
        self.pipe, there = ctx.Pipe()
        with spawn_environment(variables or {}):
            self.proc = ctx.Process(target=_driver, args=(make, there), daemon=daemon)
            self.proc.start()
        self.batch = self.pipe.recv()

    def start(self, steps: int) -> None:
        self.pipe.send(steps)

    def result(self):
        return self.pipe.recv()

    def run(self, steps: int):
        self.start(steps)
        return self.result()

    def close(self):
        self.pipe.send(None)
        self.proc.join(timeout=60)


class Processes:
    """n processes, each stepping its own env; a round's rate is n * steps / the slowest's time."""

    def __init__(self, factory, n: int, seed: int):
        self.procs = [InProcess(functools.partial(_one, factory, seed + i), daemon=True) for i in range(n)]
        self.batch = n

    def run(self, steps: int):
        for proc in self.procs:
            proc.start(steps)
        return max(proc.result()[0] for proc in self.procs), 0.0

    def close(self):
        for proc in self.procs:
            proc.close()


def _one(factory, seed: int) -> Stepped:
    return Stepped(factory(), seed)


def _suite(factory, n: int, seed: int, **options) -> Stepped:
    return Stepped(dcs.ParallelSuiteEnv(n, factory, **options), seed)


class Unlocked:
    """A :class:`~dcs_torchrl.ParallelSuiteEnv` whose workers each step as soon as they are done
    (random actions; a done episode resets at once): a round is ``n * steps`` single-env steps."""

    def __init__(self, factory, n: int, seed: int):
        self.env = dcs.ParallelSuiteEnv(n, factory, first_here=False)
        self.env.set_seed(seed)
        self.env.reset()
        self.batch, self.generator = n, torch.Generator().manual_seed(seed)
        spec = self.env.action_spec[0]
        self.low, self.high = spec.low, spec.high
        self.worker = {pipe: i for i, pipe in enumerate(self.env._pipes)}

    def _step(self, i: int) -> None:
        action = torch.rand(self.low.shape, generator=self.generator) * (self.high - self.low) + self.low
        self.env._buffers["action"][i]["action"].copy_(action)
        self.env._pipes[i].send_bytes(parallel._STEP)

    def run(self, steps: int):
        env, left = self.env, self.batch * steps
        wall, cpu = time.perf_counter(), time.process_time()
        for i in range(self.batch):
            self._step(i)
        while left > 0:
            for pipe in wait(env._pipes):
                i = self.worker[pipe]
                env._answer(i)
                out = env._buffers["next"][i]
                out["pixels"].numpy().copy()  # what a consumer of the observation copies
                if bool(out["done"].any()):
                    env._command(parallel._RESET, [i])
                left -= 1
                self._step(i)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        for i in range(self.batch):  # the steps still running are neither counted nor timed
            env._answer(i)
        return wall, cpu

    def close(self):
        self.env.close()


def paths(factory, n: int, seed: int, render_threads: list[int], inline: bool = False) -> dict:
    suite = {f"ParallelSuiteEnv, render_threads={k}": functools.partial(_suite, factory, n, seed, render_threads=k)
             for k in render_threads}
    lp0 = {"LP_NUM_THREADS": "0"}
    inline_paths = {
        "one env, LP_NUM_THREADS=0": lambda: InProcess(functools.partial(_one, factory, seed), lp0),
        "ParallelSuiteEnv, LP_NUM_THREADS=0": lambda: InProcess(functools.partial(_suite, factory, n, seed), lp0),
    } if inline else {}
    return {
        "one env": lambda: _one(factory, seed),
        "ParallelEnv": lambda: Stepped(ParallelEnv(n, factory, mp_start_method="spawn"), seed),
        "ParallelEnv, pipes": lambda: Stepped(ParallelEnv(n, factory, mp_start_method="spawn", use_buffers=False), seed),
        "ParallelSuiteEnv": lambda: _suite(factory, n, seed),
        "ParallelSuiteEnv, spin_s=0": lambda: _suite(factory, n, seed, spin_s=0),
        "ParallelSuiteEnv, all in workers": lambda: _suite(factory, n, seed, first_here=False),
        "ParallelSuiteEnv, unlocked": lambda: Unlocked(factory, n, seed),
        **suite,
        f"{n} processes": lambda: Processes(factory, n, seed),
        **inline_paths,
    }


def _matmul_seconds(barrier, results) -> None:
    """Puts the seconds of a fixed one-thread float32 matmul chain (no env, no render), started
    when every process of the round is ready."""
    torch.set_num_threads(1)
    a = torch.randn(256, 256, generator=torch.Generator().manual_seed(0))
    barrier.wait()
    start = time.perf_counter()
    for _ in range(600):
        a = (a @ a) * 0.004
    results.put(time.perf_counter() - start)


def _matmul_round(ctx, n: int) -> float:
    """The slowest of n processes running the matmul chain at once (seconds)."""
    barrier, results = ctx.Barrier(n), ctx.Queue()
    procs = [ctx.Process(target=_matmul_seconds, args=(barrier, results)) for _ in range(n)]
    for proc in procs:
        proc.start()
    seconds = [results.get(timeout=300) for _ in procs]
    for proc in procs:
        proc.join()
    return max(seconds)


def compute_ceiling(n: int, rounds: int = 3) -> list[float]:
    """Per round, n processes' matmul throughput at once over one process's alone."""
    ctx = mp.get_context("spawn")
    return [n * _matmul_round(ctx, 1) / _matmul_round(ctx, n) for _ in range(rounds)]


def interleaved(runners: dict, steps: int, rounds: int) -> dict:
    """Per path, (agent steps/s, main CPU share) of each round; every other round in reverse order."""
    for runner in runners.values():
        runner.run(max(10, steps // 10))  # warm-up: contexts, videos, code paths
    out = {name: [] for name in runners}
    for round_ in range(rounds):
        for name in (list(runners) if round_ % 2 == 0 else list(runners)[::-1]):
            wall, cpu = runners[name].run(steps)
            out[name].append((runners[name].batch * steps / wall, cpu / wall))
    return out


def main(argv: list[str] | None = None) -> dict:
    """Runs the benchmark; returns each benchmark's per-path rounds of (agent steps/s, main CPU share)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--steps", type=int, default=200, help="batched steps per path per round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--task", default="cartpole:swingup")
    parser.add_argument("--benchmarks", nargs="+", default=["none", "medium"], help="each dynamic")
    parser.add_argument("--render-threads", type=int, nargs="*", default=[],
                        help="also ParallelSuiteEnv with these render_threads (Mesa llvmpipe threads per worker)")
    parser.add_argument("--inline", action="store_true",
                        help="also one env and ParallelSuiteEnv in processes started with LP_NUM_THREADS=0")
    parser.add_argument("--only", nargs="+", help="path names to run (default: all)")
    parser.add_argument("--ceiling-rounds", type=int, default=3, help="rounds of the cores' ceiling (0: skip it)")
    args = parser.parse_args(argv)
    known = paths(None, args.workers, seed=0, render_threads=args.render_threads, inline=args.inline)
    unknown = sorted(set(args.only or ()) - set(known))
    if unknown:
        parser.error(f"unknown path(s) {unknown}; the paths: {list(known)}")
    domain, task = args.task.split(":")
    print(f"{cpu_model()}, {os.cpu_count()} cores; {domain} {task}, {args.workers} workers, "
          f"median of {args.rounds} rounds x {args.steps} batched steps")
    if args.ceiling_rounds > 0:
        ceiling = compute_ceiling(args.workers, args.ceiling_rounds)
        print(f"the cores' ceiling: {args.workers} one-thread matmul processes at once = "
              f"{statistics.median(ceiling):.2f}x one ({min(ceiling):.2f}–{max(ceiling):.2f}, {len(ceiling)} rounds)")
    results = {}
    for benchmark in args.benchmarks:
        factory = functools.partial(dcs.make_env, domain, task, benchmark=benchmark, dynamic=True)
        made = paths(factory, args.workers, seed=0, render_threads=args.render_threads, inline=args.inline)
        runners = {name: make() for name, make in made.items() if not args.only or name in args.only}
        try:
            rates = results[benchmark] = interleaved(runners, args.steps, args.rounds)
        finally:
            for runner in runners.values():
                runner.close()
        base = rates.get("one env")
        print(f"\n{benchmark} dynamic\n| path | agent steps/s | vs one env, median (range) of the rounds' ratios "
              "| main process CPU |\n|---|---:|---:|---:|")
        for name, values in rates.items():
            rate = statistics.median(r for r, _ in values)
            cpu = statistics.median(c for _, c in values)
            ratios = [r / b for (r, _), (b, _) in zip(values, base)] if base else []
            ratio = f"{statistics.median(ratios):.2f} ({min(ratios):.2f}–{max(ratios):.2f})" if ratios else "-"
            print(f"| {name} | {rate:.0f} | {ratio} | {'-' if name.endswith('processes') else f'{100 * cpu:.0f}%'} |")
    return results


if __name__ == "__main__":
    main()
