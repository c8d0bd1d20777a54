"""The training loop both recipes share: collect, store, update, log, evaluate, checkpoint.

A recipe supplies the algorithm as an :class:`Agent` (its networks, loss, optimisers and one
``update``); :func:`train` does the rest, in the order of TorchRL's ``sota-implementations``:
logger -> envs -> agent -> replay buffer -> collector, then one loop. Units: ``total_frames``,
``eval.interval`` and ``checkpoint.interval`` count environment steps including the action
repeat (as the paper's "500K environment steps"); the collector and the update counter work in
agent steps (one action = ``action_repeat`` frames); DrQ's one update per agent step.
"""
from __future__ import annotations

import logging
import random
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.checkpoint import GlobalRNGState
from torchrl.collectors import Collector
from torchrl.envs.utils import ExplorationType, set_exploration_type
from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from dcs_torchrl.envs import BACKENDS
from dcs_torchrl.evaluation.protocol import EvalResult, evaluate, evaluate_in_processes
from dcs_torchrl.methods import method_name
from dcs_torchrl.results import RunResults
from dcs_torchrl.training.checkpoint import load_latest, save_checkpoint
from dcs_torchrl.training.envs import (batched_pixel_env, close_env, pixel_env_factory, pixel_options, render_device,
                                      train_eval_settings)
from dcs_torchrl.training.execution import ExecutionOptions, apply_math_settings, check_execution, on_device, replay_device
from dcs_torchrl.training.media import plot_learning_curve, write_mp4
from dcs_torchrl.training.metrics import MetricsLogger, RunningMeans, read_metrics
from dcs_torchrl.training.replay import FrameStackReplayBuffer
from dcs_torchrl.training.rundir import RunDirectory
from dcs_torchrl.training.timing import PhaseTimer

__all__ = ["Agent", "Workspace", "acting_on", "train"]

EVAL_SEED_OFFSET = 10_000  # the evaluation envs' own seeds start at seed + 10_000 (their workers': derived from it)
log = logging.getLogger(__name__)  # a recipe's console and <recipe>.log in its run directory (Hydra)


class Agent(Protocol):
    """What a recipe hands to :func:`train`."""

    policy: TensorDictModuleBase  # pixels -> action; explores under ExplorationType.RANDOM

    def update(self, batch: TensorDictBase, index: int) -> dict[str, torch.Tensor]:
        """One gradient update on a replay sample (``index`` counts updates from 0); its metrics as
        0-d tensors, left where they are (the loop reads them once per logging row)."""

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


AgentBuilder = Callable[[DictConfig, tuple, object], Agent]


def _scene_label(s) -> str:
    """What the agent was trained on, for a plot's title: ``"easy, dynamic"``, ``"camera 0.3, static"``."""
    parts = [f"camera {s.camera_scale:g}"] if s.camera_scale > 0 else []
    parts += [f"colour {s.color_scale:g}"] if s.color_scale > 0 else []
    parts += [f"{s.num_videos} videos"] if s.num_videos > 0 else []
    parts += ["blind"] if s.blind else []
    beyond = [f"light {s.light_scale:g}"] if s.light_scale > 0 else []  # beyond the paper: named beside a benchmark
    beyond += [f"texture {s.texture_scale:g}"] if s.texture_scale > 0 else []
    if not parts + beyond:
        return "no distractions"
    what = s.benchmark if s.benchmark != "none" else ", ".join(parts)  # resolved settings: always a name
    what = ", ".join(([what] if parts else []) + beyond)
    return f"{what}, {'dynamic' if s.dynamic else 'static'}"


def _set_rng_state(state: dict) -> None:
    """Restores a checkpoint's global RNG state (TorchRL's ``GlobalRNGState``, CUDA's included;
    checkpoints written before it hold ``torch`` / ``numpy`` / ``python`` only)."""
    if "torch" in state:
        torch.set_rng_state(state["torch"])
        np.random.set_state(state["numpy"])
        random.setstate(state["python"])
    else:
        GlobalRNGState().load_state_dict(state)


def _check_config(cfg: DictConfig) -> None:
    """Refuses bad settings before anything is written (the env settings: :func:`train_eval_settings`)."""
    method_name(cfg.algo.name, cfg.algo.aug)
    for name in ("total_frames", "replay_buffer.size", "algo.batch_size", "eval.episodes", "eval.interval", "checkpoint.interval"):
        value = OmegaConf.select(cfg, name)
        if not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be a positive integer, got {value!r}.")
    if cfg.algo.batch_size > cfg.replay_buffer.size:
        raise ValueError(
            f"algo.batch_size={cfg.algo.batch_size} is larger than the replay buffer (replay_buffer.size="
            f"{cfg.replay_buffer.size}): lower the batch or enlarge the buffer."
        )
    if cfg.device != "cpu" and not torch.cuda.is_available():
        raise ValueError(f"device={cfg.device!r} but CUDA is not available: use device=cpu.")
    check_execution(cfg)
    render_device(cfg)  # an EGL device this machine lacks is refused here
    backend = collector_backend(cfg)
    if backend not in BACKENDS:
        raise ValueError(f"collector.backend={backend!r}: choose one of {list(BACKENDS)} (gl: one env per process; "
                         "warp: collector.num_workers envs in this process, rendered in one batch).")
    if backend == "warp":
        from dcs_torchrl.render.warp import import_warp

        import_warp()  # the extra's error, naming it, before anything is written


def collector_backend(cfg: DictConfig) -> str:
    """``collector.backend``: the renderer of the training envs (``gl`` where a stored config has none)."""
    return OmegaConf.select(cfg, "collector.backend", default="gl")


def acting_on(policy, device: str):
    """The policy for CPU envs: itself on the CPU; on another device a
    :class:`~dcs_torchrl.training.execution.DevicePolicy` (its inputs there and the action back,
    one copy each way per step)."""
    return on_device(policy, device)


def _record_episode(env, policy, path: Path, max_steps: int) -> None:
    """One deterministic episode of the first evaluation env, as an mp4 of its newest frames."""
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        rollout = env.rollout(max_steps, policy, break_when_any_done=True)
    pixels = rollout["next", "pixels"][0, :, -3:]  # first worker; the newest frame of each stack
    write_mp4(pixels.permute(0, 2, 3, 1).contiguous().numpy(), path)


def train(cfg: DictConfig, build_agent: AgentBuilder, run_dir: str | Path) -> dict:
    """Trains ``build_agent``'s agent as ``cfg`` says, writing every output into ``run_dir``.

    Set up (or skip a finished run), resume from the last checkpoint, collect and update, then
    evaluate and write ``results.json`` (see ``docs/results_format.md``), which is returned.
    """
    _check_config(cfg)
    train_eval_settings(cfg)  # bad env settings fail here, before the run directory is touched
    run = RunDirectory(run_dir, OmegaConf.to_container(cfg, resolve=True))
    run.claim()
    done = run.finished(cfg.total_frames)
    if done is not None:
        log.info(f"{run.path}: already finished ({done['steps']} frames, eval {done['eval']['mean']:.1f}); nothing to do.")
        return done
    with Workspace(cfg, build_agent, run) as workspace:
        workspace.resume()
        workspace.collect_and_update()
        results = workspace.finish()
    run.write_results(results)
    return results


class Workspace:
    """One training run's live parts (envs, agent, replay, logger), as DrQ-v2's ``Workspace``.

    A context manager: leaving it closes the envs (spawned env workers must not outlive an error).
    """

    def __init__(self, cfg: DictConfig, build_agent: AgentBuilder, run: RunDirectory):
        self.cfg, self.run = cfg, run
        self.method = method_name(cfg.algo.name, cfg.algo.aug)
        self.train_settings, self.eval_settings = train_eval_settings(cfg)
        self.repeat = self.train_settings.action_repeat
        self.total_steps = -(-cfg.total_frames // self.repeat)  # agent steps, rounded up
        self.options = ExecutionOptions.from_config(cfg)
        apply_math_settings(self.options)  # TF32 on or off, cuDNN's search: CUDA only
        torch.manual_seed(cfg.seed)
        np.random.seed(cfg.seed % 2**32)
        random.seed(cfg.seed)

        pixels = pixel_options(cfg.pixels)
        self.render_device = render_device(cfg)
        pixels["render_device"] = self.render_device
        self.env = self.eval_env = None
        # eval.num_workers > 1 with the policy on the CPU: each evaluation env in a process of its own with a
        # copy of the policy (evaluate_in_processes; a batched CPU policy makes the workers wait), the env
        # here only for the video; elsewhere one ParallelSuiteEnv, the policy acting on its batch
        self.eval_make = None
        if cfg.eval.num_workers > 1 and torch.device(cfg.device).type == "cpu" and self.render_device is None:
            self.eval_make = pixel_env_factory(self.eval_settings, cfg.pixels)
        self.env = batched_pixel_env(self.train_settings, num_workers=cfg.collector.num_workers, seed=cfg.seed,
                                     backend=collector_backend(cfg), **pixels)
        try:
            self.eval_env = batched_pixel_env(self.eval_settings, num_workers=1 if self.eval_make else cfg.eval.num_workers,
                                              seed=cfg.seed + EVAL_SEED_OFFSET, **pixels)
            observation_shape = tuple(self.env.observation_spec["pixels"].shape[-3:])
            action_spec = self.env.action_spec[0] if self.env.batch_size else self.env.action_spec
            self.agent = build_agent(cfg, observation_shape, action_spec)
            layout = (cfg.replay_buffer.size, cfg.pixels.frame_stack, (3, *observation_shape[1:]), tuple(action_spec.shape))
            min_episode_steps = max(1, 1000 // self.repeat)
            self.replay_device = replay_device(cfg, FrameStackReplayBuffer.storage_bytes(*layout, min_episode_steps))
            self.buffer = FrameStackReplayBuffer(
                *layout, batch_size=cfg.algo.batch_size, min_episode_steps=min_episode_steps,
                device=None if self.replay_device.type == "cpu" else self.replay_device,
            )
        except BaseException:
            self.close()
            raise
        self.policy = on_device(self.agent.policy, cfg.device)  # the collector's and the evaluations' (one copy each way)
        self.eval_policy = self.policy
        self.counters = {"steps": 0, "updates": 0, "episodes": 0, "wall_time": 0.0, "metrics_rows": 0,
                         "next_eval": cfg.eval.interval, "next_checkpoint": cfg.checkpoint.interval}
        self.timer = PhaseTimer()  # time/<phase>_ms rows: where each agent step's wall time goes

    def __enter__(self) -> "Workspace":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for env in (self.env, self.eval_env):
            close_env(env)

    @property
    def frames(self) -> int:
        return self.counters["steps"] * self.repeat

    # ------------------------------------------------------------------------------ resume
    def resume(self) -> None:
        """Loads the last checkpoint (agent, replay, counters, RNG) if any, and opens the logger
        at the matching row of ``metrics.csv``. A checkpoint that holds more than tensors, numbers
        and strings (one written before RNG states were tensors, or not by the suite) is refused
        unless ``checkpoint.trust=true``; the run's next checkpoints are in the safe format."""
        cfg, run = self.cfg, self.run
        wandb_id = None
        resumed = load_latest(run.checkpoints, trust=OmegaConf.select(cfg, "checkpoint.trust", default=False))
        if resumed is not None:
            frames, state = resumed
            self.agent.load_state_dict(state["agent"])
            self.buffer.load_state_dict(state["buffer"])
            self.counters, wandb_id = state["counters"], state.get("wandb_id")
            _set_rng_state(state["rng"])
            log.info(f"{run.path}: resuming from the checkpoint at {frames} frames.")
            resume = (self.counters["metrics_rows"], frames)
        elif (run.path / "metrics.csv").exists():  # this run (claim() checked), stopped before its first checkpoint
            log.info(f"{run.path}: restarting from frame 0 (stopped before its first checkpoint).")
            resume = (0, 0)
        else:
            resume = None
        self.logger = MetricsLogger(
            run.path, backend=cfg.logger.backend, resume=resume, project=cfg.logger.project,
            run_name=f"{self.method} {cfg.env.domain}-{cfg.env.task} seed {cfg.seed}",
            wandb_id=wandb_id, config=run.config, wall_offset=self.counters["wall_time"],
        )
        self.start_time = time.time() - self.counters["wall_time"]

    def checkpoint(self) -> None:
        """Saves everything a resumed run needs to continue as if never stopped."""
        self.counters["wall_time"], self.counters["metrics_rows"] = time.time() - self.start_time, self.logger.rows
        state = {"agent": self.agent.state_dict(), "buffer": self.buffer.state_dict(), "counters": dict(self.counters),
                 "rng": GlobalRNGState().state_dict(), "wandb_id": self.logger.wandb_id, "config": self.run.identity}
        save_checkpoint(self.run.checkpoints, self.frames, state, keep=self.cfg.checkpoint.keep)

    # ------------------------------------------------------------------- collect and update
    def collect_and_update(self) -> None:
        """DrQ's loop: one agent step, into the replay, then ``updates_per_step`` updates (after
        the random seed steps); logging, periodic evaluation and checkpoints on their cadence."""
        cfg, counters = self.cfg, self.counters
        start = counters["steps"]
        collector = Collector(  # envs, policy (a DevicePolicy on CUDA) and data on the host, as the collector sees them
            self.env, self.policy, frames_per_batch=cfg.collector.num_workers * cfg.collector.steps_per_batch,
            total_frames=max(self.total_steps - start, 1), init_random_frames=max(cfg.collector.seed_steps - start, 0),
            auto_register_policy_transforms=False,
        )
        self.losses = RunningMeans()  # on the update's device until a logging row
        self.last_log, self.tick = start, time.time()
        bar = tqdm(total=self.total_steps * self.repeat, initial=start * self.repeat, unit="frame",
                   disable=not cfg.progress, dynamic_ncols=True, mininterval=1.0 if sys.stderr.isatty() else 30.0)
        with logging_redirect_tqdm():  # log lines above the progress bar
            batches = iter(collector)
            while counters["steps"] < self.total_steps:
                with self.timer("collect"):  # the policy's actions and the env steps
                    data = next(batches, None)
                if data is None:
                    break
                with self.timer("extend"):
                    self.buffer.extend(data)
                counters["steps"] += data.numel()
                returns = self._log_episodes(data)
                if counters["steps"] >= cfg.collector.seed_steps:
                    self._update(data.numel() * cfg.algo.updates_per_step)
                bar.update(data.numel() * self.repeat)
                if returns:
                    bar.set_postfix(ret=f"{returns[-1]:.0f}", upd=counters["updates"], refresh=False)
                self._log_progress()
                if self.frames >= counters["next_eval"] and counters["steps"] < self.total_steps:
                    with self.timer("eval"):
                        self._evaluate_periodically()
                if self.frames >= counters["next_checkpoint"] and counters["steps"] < self.total_steps:
                    # the next one is due before this one is saved: a run resumed from it does not save again at once
                    counters["next_checkpoint"] = _next_due(self.frames, counters["next_checkpoint"], cfg.checkpoint.interval)
                    with self.timer("checkpoint"):
                        self.checkpoint()
        bar.close()
        collector.shutdown()

    def _log_episodes(self, data: TensorDictBase) -> list[float]:
        """One ``train/episode_return`` row per episode that ended in ``data``; their returns."""
        finished = data["next", "done"].squeeze(-1)
        returns = data["next", "episode_reward"].squeeze(-1)[finished].tolist()
        for episode_return in returns:
            self.counters["episodes"] += 1
            self.logger.log(self.frames, {"train/episode_return": episode_return, "train/episodes": self.counters["episodes"]})
        return returns

    def _update(self, updates: int) -> None:
        for _ in range(updates):
            with self.timer("sample"):
                batch = self.buffer.sample()
            with self.timer("update"):
                self.losses.add(self.agent.update(batch, self.counters["updates"]))
            self.counters["updates"] += 1

    def _log_progress(self) -> None:
        """Every ``logger.interval`` frames (and at the end): mean losses, phase times, fps."""
        steps = self.counters["steps"]
        if self.frames - self.last_log * self.repeat < self.cfg.logger.interval and steps < self.total_steps:
            return
        elapsed = max(time.time() - self.tick, 1e-9)
        self.logger.log(self.frames, {
            **self.losses.means(),  # the one host read of the update's metrics per row
            **self.timer.report(steps - self.last_log),
            "time/fps": (steps - self.last_log) * self.repeat / elapsed,
            "time/elapsed": time.time() - self.start_time, "train/updates": self.counters["updates"],
            "train/buffer_gb": self.buffer.nbytes() / 1e9,
        })
        self.last_log, self.tick = steps, time.time()

    def _evaluation(self, episodes: int, seed: int) -> EvalResult:
        """``episodes`` deterministic episodes over ``eval.num_workers`` envs seeded from ``seed``: the
        same episodes either way (up to a batched policy's float rounding)."""
        if self.eval_make is not None:
            return evaluate_in_processes(self.eval_make, self.eval_policy, episodes, self.cfg.eval.num_workers, seed=seed)
        return evaluate(self.eval_env, self.eval_policy, episodes, seed=seed)

    def _evaluate_periodically(self) -> None:
        cfg, frames = self.cfg, self.frames
        result = self._evaluation(cfg.eval.periodic_episodes, seed=cfg.seed + EVAL_SEED_OFFSET + frames)
        self.logger.log(frames, {"eval/return_mean": result.mean, "eval/return_stderr": result.stderr})
        log.info(f"[{frames} frames] eval return {result.mean:.1f} ± {result.stderr:.1f} over {result.episodes} episodes")
        self.counters["next_eval"] = _next_due(frames, self.counters["next_eval"], cfg.eval.interval)

    # ------------------------------------------------------------------------------ finish
    def finish(self) -> dict:
        """The final checkpoint, evaluation, video and learning curve; the ``results.json`` record."""
        cfg, frames = self.cfg, self.frames
        self.checkpoint()  # before the final evaluation's rows: a resumed run logs them once
        result = self._evaluation(cfg.eval.episodes, seed=cfg.seed + EVAL_SEED_OFFSET)
        self.logger.log(frames, {"eval/return_mean": result.mean, "eval/return_stderr": result.stderr})
        log.info(f"final evaluation after {frames} frames: {result.mean:.1f} ± {result.stderr:.1f} over {result.episodes} episodes")
        if cfg.eval.video:
            _record_episode(self.eval_env, self.eval_policy, self.run.path / "eval_episode.mp4", max_steps=-(-1000 // self.repeat))
        self.logger.close()
        plot_learning_curve(read_metrics(self.logger.path), self.run.path / "learning_curve.png",
                            title=f"{self.method} {cfg.env.domain} {cfg.env.task} ({_scene_label(self.train_settings)}, seed {cfg.seed})")
        return RunResults.from_config(
            self.options.recorded(self.run.config, self.replay_device, self.render_device),  # what ran for each `auto`
            experiment=cfg.experiment, steps=frames, wall_time=time.time() - self.start_time,
            train_env=self.train_settings.as_dict(), eval_env=self.eval_settings.as_dict(),
            sweep=self.run.config.get("sweep"), eval=result.to_dict(),
        ).as_dict()


def _next_due(frames: int, due: int, interval: int) -> int:
    """The next multiple of ``interval`` after ``due`` that lies beyond ``frames``."""
    return due + interval * (1 + (frames - due) // interval)
