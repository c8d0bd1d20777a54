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
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.collectors import Collector
from torchrl.envs.utils import ExplorationType, set_exploration_type
from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from dcs_torchrl.evaluation import evaluate
from dcs_torchrl.methods import method_name
from dcs_torchrl.training.checkpoint import load_latest, save_checkpoint
from dcs_torchrl.training.envs import ENV_KEYS, close_env, env_options, env_settings, make_pixel_env, pixel_options
from dcs_torchrl.training.media import plot_learning_curve, write_mp4
from dcs_torchrl.training.metrics import MetricsLogger, read_metrics
from dcs_torchrl.training.replay import FrameStackReplayBuffer
from dcs_torchrl.training.rundir import RunDirectory
from dcs_torchrl.training.timing import PhaseTimer

__all__ = ["Agent", "acting_on", "train"]

EVAL_SEED_OFFSET = 10_000  # the evaluation envs' own seeds: seed + 10_000, + 1, ...
log = logging.getLogger(__name__)  # a recipe's console and <recipe>.log in its run directory (Hydra)


class Agent(Protocol):
    """What a recipe hands to :func:`train`."""

    policy: TensorDictModuleBase  # pixels -> action; explores under ExplorationType.RANDOM

    def update(self, batch: TensorDictBase, index: int) -> dict[str, torch.Tensor]:
        """One gradient update on a replay sample (``index`` counts updates from 0)."""

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


AgentBuilder = Callable[[DictConfig, tuple, object, int], Agent]


def _rng_state() -> dict:
    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}


def _set_rng_state(state: dict) -> None:
    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])


def _check_config(cfg: DictConfig) -> None:
    unknown = sorted(set(cfg.env) - set(ENV_KEYS) - {"domain", "task"}) + sorted(f"eval_{k}" for k in set(cfg.eval_env) - set(ENV_KEYS))
    if unknown:
        raise ValueError(f"unknown env setting(s) {unknown}: env and eval_env accept {list(ENV_KEYS)}.")
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


def acting_on(policy, device: str):
    """The policy for CPU envs: on another device, observations go there and actions come back."""
    if torch.device(device).type == "cpu":
        return policy

    def act(tensordict: TensorDictBase) -> TensorDictBase:
        return tensordict.update(policy(tensordict.to(device)).select("action").to("cpu"))

    return act


def _record_episode(env, policy, path: Path, max_steps: int) -> None:
    """One deterministic episode of the first evaluation env, as an mp4 of its newest frames."""
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        rollout = env.rollout(max_steps, policy, break_when_any_done=True)
    pixels = rollout["next", "pixels"][0, :, -3:]  # first worker; the newest frame of each stack
    write_mp4(pixels.permute(0, 2, 3, 1).contiguous().numpy(), path)


def train(cfg: DictConfig, build_agent: AgentBuilder, run_dir: str | Path) -> dict:
    """Trains ``build_agent``'s agent as ``cfg`` says, writing every output into ``run_dir``.

    Returns the ``results.json`` content (see ``docs/results_format.md``).
    """
    method = method_name(cfg.algo.name, cfg.algo.aug)
    _check_config(cfg)
    config = OmegaConf.to_container(cfg, resolve=True)
    train_settings = env_settings(cfg.env.domain, cfg.env.task, env_options(cfg.env))
    eval_options = {**env_options(cfg.env), **{k: v for k, v in env_options(cfg.eval_env).items() if v is not None}}
    eval_settings = env_settings(cfg.env.domain, cfg.env.task, eval_options)
    run = RunDirectory(run_dir, config)
    run.claim()
    done = run.finished(cfg.total_frames)
    if done is not None:
        log.info(f"{run.path}: already finished ({done['steps']} frames, eval {done['eval']['mean']:.1f}); nothing to do.")
        return done

    repeat = train_settings.action_repeat
    total_steps = -(-cfg.total_frames // repeat)  # agent steps, rounded up
    torch.manual_seed(cfg.seed)
    np.random.seed(cfg.seed % 2**32)
    random.seed(cfg.seed)

    pixels = pixel_options(cfg.pixels)
    env = make_pixel_env(train_settings, num_workers=cfg.collector.num_workers, seed=cfg.seed, **pixels)
    eval_env = None
    try:
        eval_env = make_pixel_env(eval_settings, num_workers=cfg.eval.num_workers, seed=cfg.seed + EVAL_SEED_OFFSET, **pixels)
        observation_shape = tuple(env.observation_spec["pixels"].shape[-3:])
        action_spec = env.action_spec[0] if env.batch_size else env.action_spec
        agent = build_agent(cfg, observation_shape, action_spec, repeat)
        eval_policy = acting_on(agent.policy, cfg.device)
        buffer = FrameStackReplayBuffer(
            cfg.replay_buffer.size, cfg.pixels.frame_stack, (3, *observation_shape[1:]), tuple(action_spec.shape),
            batch_size=cfg.algo.batch_size, min_episode_steps=max(1, 1000 // repeat),
        )

        counters = {"steps": 0, "updates": 0, "episodes": 0, "wall_time": 0.0, "metrics_rows": 0, "next_eval": cfg.eval.interval, "next_checkpoint": cfg.checkpoint.interval}
        wandb_id = None
        resumed = load_latest(run.checkpoints)
        if resumed is not None:
            frames, state = resumed
            agent.load_state_dict(state["agent"])
            buffer.load_state_dict(state["buffer"])
            counters, wandb_id = state["counters"], state.get("wandb_id")
            _set_rng_state(state["rng"])
            log.info(f"{run.path}: resuming from the checkpoint at {frames} frames.")
            resume = (counters["metrics_rows"], resumed[0])
        elif (run.path / "metrics.csv").exists():  # this run (claim() checked), stopped before its first checkpoint
            log.info(f"{run.path}: restarting from frame 0 (stopped before its first checkpoint).")
            resume = (0, 0)
        else:
            resume = None
        logger = MetricsLogger(
            run.path, backend=cfg.logger.backend, resume=resume,
            project=cfg.logger.project, run_name=f"{method} {cfg.env.domain}-{cfg.env.task} seed {cfg.seed}",
            wandb_id=wandb_id, config=config, wall_offset=counters["wall_time"],
        )
        start, start_time = counters["steps"], time.time() - counters["wall_time"]

        def checkpoint() -> None:
            counters["wall_time"], counters["metrics_rows"] = time.time() - start_time, logger.rows
            state = {"agent": agent.state_dict(), "buffer": buffer.state_dict(), "counters": dict(counters),
                     "rng": _rng_state(), "wandb_id": logger.wandb_id, "config": run.identity}
            save_checkpoint(run.checkpoints, counters["steps"] * repeat, state, keep=cfg.checkpoint.keep)

        collector = Collector(
            env, agent.policy, frames_per_batch=cfg.collector.num_workers * cfg.collector.steps_per_batch,
            total_frames=max(total_steps - start, 1), init_random_frames=max(cfg.collector.seed_steps - start, 0),
            auto_register_policy_transforms=False,
            **({} if cfg.device == "cpu" else {"policy_device": cfg.device, "env_device": "cpu", "storing_device": "cpu"}),
        )
        losses: dict[str, list[float]] = defaultdict(list)
        timer = PhaseTimer()  # time/<phase>_ms rows: where each agent step's wall time goes
        last_log, tick = counters["steps"], time.time()
        bar = tqdm(total=total_steps * repeat, initial=start * repeat, unit="frame", disable=not cfg.progress,
                    dynamic_ncols=True, mininterval=1.0 if sys.stderr.isatty() else 30.0)
        with logging_redirect_tqdm():  # log lines above the progress bar
            batches = iter(collector)
            while counters["steps"] < total_steps:
                with timer("collect"):  # the policy's actions and the env steps
                    data = next(batches, None)
                if data is None:
                    break
                with timer("extend"):
                    buffer.extend(data)
                counters["steps"] += data.numel()
                frames = counters["steps"] * repeat
                finished = data["next", "done"].squeeze(-1)
                returns = data["next", "episode_reward"].squeeze(-1)[finished].tolist()
                for episode_return in returns:
                    counters["episodes"] += 1
                    logger.log(frames, {"train/episode_return": episode_return, "train/episodes": counters["episodes"]})
                if counters["steps"] >= cfg.collector.seed_steps:
                    for _ in range(data.numel() * cfg.algo.updates_per_step):
                        with timer("sample"):
                            batch = buffer.sample()
                        with timer("update"):
                            for name, value in agent.update(batch, counters["updates"]).items():
                                losses[name].append(float(torch.as_tensor(value).detach()))
                        counters["updates"] += 1
                bar.update(data.numel() * repeat)
                if returns:
                    bar.set_postfix(ret=f"{returns[-1]:.0f}", upd=counters["updates"], refresh=False)
                if frames - last_log * repeat >= cfg.logger.interval or counters["steps"] >= total_steps:
                    elapsed = max(time.time() - tick, 1e-9)
                    logger.log(frames, {
                        **{name: sum(v) / len(v) for name, v in losses.items()},
                        **timer.report(counters["steps"] - last_log),
                        "time/fps": (counters["steps"] - last_log) * repeat / elapsed,
                        "time/elapsed": time.time() - start_time, "train/updates": counters["updates"],
                        "train/buffer_gb": buffer.nbytes() / 1e9,
                    })
                    losses.clear()
                    last_log, tick = counters["steps"], time.time()
                if frames >= counters["next_eval"] and counters["steps"] < total_steps:
                    with timer("eval"):
                        result = evaluate(eval_env, eval_policy, cfg.eval.periodic_episodes, seed=cfg.seed + EVAL_SEED_OFFSET + frames)
                    logger.log(frames, {"eval/return_mean": result.mean, "eval/return_stderr": result.stderr})
                    log.info(f"[{frames} frames] eval return {result.mean:.1f} ± {result.stderr:.1f} over {result.episodes} episodes")
                    counters["next_eval"] += cfg.eval.interval * (1 + (frames - counters["next_eval"]) // cfg.eval.interval)
                if frames >= counters["next_checkpoint"] and counters["steps"] < total_steps:
                    with timer("checkpoint"):
                        checkpoint()
                    counters["next_checkpoint"] += cfg.checkpoint.interval * (1 + (frames - counters["next_checkpoint"]) // cfg.checkpoint.interval)
        bar.close()
        collector.shutdown()

        frames = counters["steps"] * repeat
        checkpoint()  # before the final evaluation's rows: a resumed run logs them once
        result = evaluate(eval_env, eval_policy, cfg.eval.episodes, seed=cfg.seed + EVAL_SEED_OFFSET)
        logger.log(frames, {"eval/return_mean": result.mean, "eval/return_stderr": result.stderr})
        log.info(f"final evaluation after {frames} frames: {result.mean:.1f} ± {result.stderr:.1f} over {result.episodes} episodes")
        if cfg.eval.video:
            _record_episode(eval_env, eval_policy, run.path / "eval_episode.mp4", max_steps=-(-1000 // repeat))
        logger.close()
        plot_learning_curve(read_metrics(logger.path), run.path / "learning_curve.png", title=f"{method} {cfg.env.domain} {cfg.env.task} ({cfg.env.benchmark}, seed {cfg.seed})")
        results = {
            "schema": 1, "experiment": cfg.experiment, "method": method, "algo": cfg.algo.name, "aug": cfg.algo.aug,
            "domain": cfg.env.domain, "task": cfg.env.task, "seed": cfg.seed, "steps": frames,
            "wall_time": time.time() - start_time, "train_env": train_settings.as_dict(), "eval_env": eval_settings.as_dict(),
            "sweep": config.get("sweep"), "eval": result.to_dict(), "config": config,
        }
    finally:  # an error must not leave spawned env workers behind (the process would never exit)
        for e in (env, eval_env):
            close_env(e)
    run.write_results(results)
    return results
