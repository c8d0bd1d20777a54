"""Agent steps per second of the batched Warp env against one GL env and ParallelSuiteEnv(2), side by side.

    python benchmarks/batched_speed.py [--device cpu|cuda] [--sizes 1 4 16 64 256] [--rounds 3]
        [--seconds 4] [--tasks cartpole:swingup cheetah:run] [--presets none medium]
    python benchmarks/batched_speed.py --physics-only [--sizes 64] [--tasks ...]
    either with [--processes P]: beside the batch in this process, the batch shared among P processes

All in, as a user steps an env: distractions (``medium`` is the dynamic medium preset), uint8
pixels in a torch tensor, TorchRL's ``step`` with ``step_and_maybe_reset``, a random action per
env. Every env of a task and preset is built once, then they are timed in interleaved rounds (each
for about ``--seconds``), and the median round is reported, so that machine noise hits them alike;
the ratios are within this run. ``--device cuda`` renders the batch on the GPU (sizes up to 4096
make sense there) and prints the GPU model. Beside each batch: where its step's time goes, as shares
of the wall time: the physics (MuJoCo's C over threads and the task over arrays), the distractions'
``step_scene`` with the copy of each world's scene into the render's arrays, and the render (its
threads run beside the next part's physics, so the shares can add up to more than 100%); the rest is
TorchRL's step and the output copies. The GL rows use Mesa's default threads.

``--physics-only``: no render, no distractions: N dm_control envs of each task stepped with random
actions (episodes reset as they end), env-agent steps/s of today's per-env path (dm_control's
``Environment.step`` action-repeat times, env after env, as :class:`~dcs_torchrl.vector.batched.BatchedSuiteEnv`
steps a task that is not over arrays) beside :class:`~dcs_torchrl.vector.batch_physics.BatchPhysics` (MuJoCo's
C, the task over arrays) on one thread and on every core, with the state observations computed; and
the bound of any path that steps MuJoCo: ``mujoco.rollout`` of every env's state on every core, the
physics alone (no task, no reward, no observation, no state carried into the env: its warmstart is
not returned, so it is not the episodes of dm_control's step).

``--processes P``: all in, a row ``warp N=n, P processes`` per size (``make_env(..., processes=P)``: P Warp
batches of the n envs, one per process, the first in this one; their shares are the workers' own, not
printed); with ``--physics-only``, a column with the N envs' BatchPhysics shared among P processes (N/P
envs each, one thread each where P is the core count or more, else every core), stepped at once, their rates summed: the
physics of ``processes=P``.
"""
from __future__ import annotations

import argparse
import functools
import os
import statistics
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from machine import cpu_model  # noqa: E402  (benchmarks/ is the script's directory)

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl.presets import action_repeat  # noqa: E402
from dcs_torchrl.vector._batching import shares  # noqa: E402
from dcs_torchrl.vector.batch_physics import BatchPhysics, physics_threads, threads_among  # noqa: E402
from dcs_torchrl.vector.batched import BatchedSuiteEnv  # noqa: E402
from dcs_torchrl.vector.task_arrays import TASKS, task_arrays  # noqa: E402

PRESETS = {"none": dict(benchmark="none"), "medium": dict(benchmark="medium", dynamic=True)}


class Timed:
    """An env and its running tensordict; ``run(seconds)`` steps it and returns agent steps/s."""

    def __init__(self, env):
        self.env = env
        self.env.set_seed(0)
        self.td = env.reset()
        self.n = max(1, env.batch_size.numel())
        self.render_s = self.total_s = self.physics_s = self.scene_s = 0.0
        self.run(0.0)  # one step: everything built and compiled

    def run(self, seconds: float) -> float:
        env, steps, start = self.env, 0, time.perf_counter()
        renderers = getattr(env, "renderers", None)
        render_before = _render_seconds(renderers)
        seconds_before = dict(getattr(env, "seconds", {}))
        while True:
            self.td.set("action", env.action_spec.rand())
            _, self.td = env.step_and_maybe_reset(self.td)
            steps += 1
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                break
        self.render_s += _render_seconds(renderers) - render_before
        if seconds_before:
            self.physics_s += env.seconds["physics"] - seconds_before["physics"]
            self.scene_s += env.seconds["scene"] - seconds_before["scene"]
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
    parser.add_argument("--processes", type=int, default=None, help="also the batch shared among this many processes")
    parser.add_argument("--processes-only", action="store_true", help="with --processes: leave out the batch in one "
                        "process (all in), for sizes an earlier run measured")
    parser.add_argument("--no-gl", action="store_true", help="leave out the GL rows (a GPU box without EGL)")
    parser.add_argument("--physics-only", action="store_true", help="no render: today's per-env physics beside "
                        "BatchPhysics (MuJoCo's C over threads, the task over arrays)")
    args = parser.parse_args()
    if args.physics_only:
        return physics_only(args)
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
                if not (args.processes_only and args.processes):
                    paths[f"warp N={n}"] = Timed(dcs.make_env(domain, task, num_envs=n, backend="warp",
                                                              device=args.device, **options))
                if args.processes and 1 < args.processes <= n:
                    paths[f"warp N={n}, {args.processes} processes"] = Timed(dcs.make_env(
                        domain, task, num_envs=n, backend="warp", device=args.device, processes=args.processes, **options))
            rates = {name: [] for name in paths}
            for _ in range(args.rounds):
                for name, timed in paths.items():
                    rates[name].append(timed.run(args.seconds))
            base = statistics.median(rates["one GL env"]) if "one GL env" in rates else None
            print(f"\n{domain} {task}, {preset}{' dynamic' if preset != 'none' else ''}")
            print("| path | agent steps/s | x one GL env | physics | step_scene + copy | render |")
            print("|---|---:|---:|---:|---:|---:|")
            for name, values in rates.items():
                rate = statistics.median(values)
                ratio = f"{rate / base:.2f}" if base else "n/a"
                timed = paths[name]
                where = " | " * 2
                if isinstance(timed.env, BatchedSuiteEnv):
                    where = " | ".join(f"{part / timed.total_s:.0%}"
                                        for part in (timed.physics_s, timed.scene_s, timed.render_s))
                print(f"| {name} | {rate:.0f} ({min(values):.0f}-{max(values):.0f}) | {ratio} | {where} |")
            for timed in paths.values():
                timed.env.close()


class PhysicsTimed:
    """N dm_control envs of one task stepped by one path; ``run(seconds)`` returns env-agent steps/s."""

    def __init__(self, domain: str, task: str, n: int, threads: int | None | bool | str):
        """``threads``: ``False`` for today's per-env path, ``"rollout"`` for the bound (mujoco.rollout),
        else BatchPhysics's (``None``: every core)."""
        from dm_control import suite

        self.envs = [suite.load(domain, task, task_kwargs={"random": i}) for i in range(n)]
        self.k = action_repeat(domain, task)
        for env in self.envs:
            env.reset()
        spec = self.envs[0].action_spec()
        self.low, self.high = spec.minimum, spec.maximum
        self.rng = np.random.default_rng(0)
        self.batch = self.rollout = None
        if threads == "rollout":
            self.rollout = _Rollout(self.envs, self.k)
        elif threads is not False:
            arrays = task_arrays(domain, task, self.envs[0].task)
            self.batch = BatchPhysics(self.envs, arrays, self.k, threads)
        self.all = np.arange(n)
        for _ in range(40):  # built and compiled
            self.step()

    def step(self) -> None:
        actions = self.rng.uniform(self.low, self.high, (len(self.envs), len(self.low)))
        if self.rollout is not None:
            self.rollout.step(actions)
            return
        if self.batch is None:  # today's per-env path: dm_control's step, action-repeat times
            for env, action in zip(self.envs, actions):
                for _ in range(self.k):
                    if env.step(action).last():
                        env.reset()
                        break
            return
        _, ended, _ = self.batch.step(self.all, actions, observe=True)
        for i in np.flatnonzero(ended):
            self.envs[i].reset()
            self.batch.after_reset(i)

    def run(self, seconds: float) -> float:
        steps, start = 0, time.perf_counter()
        while True:
            self.step()
            steps += 1
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                return steps * len(self.envs) / elapsed


class _Rollout:
    """The envs' physics alone in ``mujoco.rollout``: their full states stepped action-repeat x
    substeps on every core in C, the last state kept for the next call."""

    def __init__(self, envs, k: int):
        import mujoco

        physics = envs[0].physics
        self.model = physics.model.ptr
        self.steps = k * round(envs[0].control_timestep() / physics.timestep())
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.stack([np.empty(mujoco.mj_stateSize(self.model, spec)) for _ in envs])
        for row, env in zip(self.state, envs):
            mujoco.mj_getState(env.physics.model.ptr, env.physics.data.ptr, row, spec)
        self.datas = [mujoco.MjData(self.model) for _ in range(physics_threads())]
        self.out = np.empty((len(envs), self.steps, self.state.shape[1]))

    def step(self, actions: np.ndarray) -> None:
        from mujoco import rollout

        controls = np.repeat(actions[:, None], self.steps, axis=1)
        rollout.rollout(self.model, self.datas, self.state, controls, nstep=self.steps, state=self.out,
                        persistent_pool=True)
        self.state[:] = self.out[:, -1]


def physics_only(args) -> None:
    sizes = args.sizes or [64]
    cores = physics_threads()
    print(f"{cpu_model()}; {cores} cores; {args.rounds} rounds of ~{args.seconds:g} s, interleaved; median "
          "env-agent steps/s (ratio to today's per-env path); no render, random actions")
    apart = args.processes if args.processes and args.processes > 1 else None
    print("| task (action repeat) | N | dm_control step, env by env | BatchPhysics, 1 thread | "
          f"BatchPhysics, {cores} threads | BatchPhysics, default threads (count) | "
          + (f"BatchPhysics in {apart} processes | " if apart else "")
          + f"bound: mujoco.rollout, {cores} threads, physics alone |")
    print("|---|--:|--:|--:|--:|--:|--:|" + ("--:|" if apart else ""))
    for spec in args.tasks:
        domain, task = spec.split(":")
        if (domain, task) not in TASKS:
            raise SystemExit(f"{domain}:{task} is not over arrays; choose among {[':'.join(t) for t in TASKS]}")
        for n in sizes:
            paths = {"today": PhysicsTimed(domain, task, n, False), "1": PhysicsTimed(domain, task, n, 1),
                     "all": PhysicsTimed(domain, task, n, cores), "chosen": PhysicsTimed(domain, task, n, None)}
            if apart:
                paths["apart"] = ProcessesTimed(domain, task, n, apart)
            paths["bound"] = PhysicsTimed(domain, task, n, "rollout")
            rates = {name: [] for name in paths}
            for _ in range(args.rounds):
                for name, timed in paths.items():
                    rates[name].append(timed.run(args.seconds))
            base = statistics.median(rates["today"])
            cells = [f"{statistics.median(v):.0f} ({statistics.median(v) / base:.1f}x)" for v in rates.values()]
            cells[3] += f" ({paths['chosen'].batch.threads})"
            print(f"| {domain} {task} ({paths['today'].k}) | {n} | {' | '.join(cells)} |")
            if apart:
                paths["apart"].close()


class ProcessesTimed:
    """N envs' BatchPhysics shared among ``processes`` spawned processes (contiguous, near-equal shares, threads
    as ``make_env(..., processes=P)`` gives each), stepped at once; ``run(seconds)`` returns their env-agent steps/s summed."""

    def __init__(self, domain: str, task: str, n: int, processes: int):
        import multiprocessing as mp

        ctx = mp.get_context("spawn")
        self.pipes, self.procs = [], []
        for share in shares(n, processes):
            here, there = ctx.Pipe()
            proc = ctx.Process(target=_physics_share, args=(domain, task, len(share), threads_among(processes), there),
                               daemon=True)
            proc.start()
            self.pipes.append(here)
            self.procs.append(proc)
        for pipe in self.pipes:
            pipe.recv()  # built

    def run(self, seconds: float) -> float:
        for pipe in self.pipes:
            pipe.send(seconds)
        return sum(pipe.recv() for pipe in self.pipes)

    def close(self) -> None:
        for pipe, proc in zip(self.pipes, self.procs):
            pipe.send(None)
            proc.join()


def _physics_share(domain: str, task: str, n: int, threads: int | None, pipe) -> None:
    """A process of :class:`ProcessesTimed`: its share's BatchPhysics, run for the seconds it is sent."""
    timed = PhysicsTimed(domain, task, n, threads)
    pipe.send(True)
    while (seconds := pipe.recv()) is not None:
        pipe.send(timed.run(seconds))


if __name__ == "__main__":
    main()
