"""Evaluation-only runs: a trained run's final checkpoint evaluated under other env settings.

The trained run's ``results.json`` gives its config (networks, pixels, seed, training env) and
its step count; its newest checkpoint (which must be the final one) gives the weights. Each
evaluation resolves its env as the training env plus its ``eval_env`` overrides, runs the
deterministic policy for ``eval.episodes`` episodes with the seeds of the training's final
evaluation, and writes a ``results.json`` (``docs/results_format.md``) into its own directory.
An evaluation directory belongs to one trained run and one setting (``run_config.json``, as
for training runs): a finished evaluation is skipped, another one is refused. A finished one is
evaluated again when it no longer holds (:func:`stale_reason`: another checkpoint of the run, other
stand-in videos), its old ``results.json`` kept beside it as ``results.stale-<k>.json``.

From the command line (Hydra; config ``dcs_torchrl/training/conf/evaluate.yaml``)::

    python -m dcs_torchrl.experiments.evaluate train_dir=<a finished training run> \\
        eval_env.camera_scale=0.3 eval_env.dynamic=true [eval.episodes=100] [experiment=robustness \\
        'sweep={axis:camera,value:0.3,dynamic:true}'] [hydra.run.dir=...]

The env is the training env with the ``eval_env`` overrides; the networks, pixels and seed are
the trained run's; the episodes run with the seeds of its final evaluation, so an evaluation
without overrides reproduces it. ``results.json`` goes to Hydra's run directory (by default
``<train_dir>/evaluations/<the overrides>``). ``recipes/evaluate/evaluate.py`` is the same entry
point for a clone; the experiment sweeps call :func:`evaluate_checkpoint` directly.
"""
from __future__ import annotations

import json
import logging
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from dcs_torchrl.experiments.grid import Evaluation
from dcs_torchrl.methods import agent_class
from dcs_torchrl.results import RunResults, with_videos_version
from dcs_torchrl.training import conf as _conf  # noqa: F401  (importing it registers the env / eval_env groups)

__all__ = ["SETTABLE", "evaluate_checkpoint", "evaluate_from_config", "main", "stale_reason"]

log = logging.getLogger(__name__)

#: What the command line may set; the rest of the config is the trained run's.
SETTABLE = ("train_dir", "eval_env.", "eval.episodes", "eval.num_workers", "device", "execution.render_device",
            "checkpoint.trust", "experiment", "sweep", "progress", "hydra.")

# The default run directory (evaluate.yaml): named after the overrides, `as_trained` without any.
OmegaConf.register_new_resolver("or_default", lambda value, default: value or default, replace=True)

def _trained_results(train_dir: Path) -> dict:
    try:
        return json.loads((train_dir / "results.json").read_text())
    except FileNotFoundError:
        raise FileNotFoundError(
            f"{train_dir} has no results.json: train this run first (its final checkpoint is evaluated)."
        ) from None


def stale_reason(done: Mapping, digest: str, eval_env: Mapping) -> str | None:
    """Why a finished evaluation's ``results.json`` (``done``) no longer holds for the agent whose
    checkpoint has SHA-256 ``digest`` in ``eval_env`` (resolved settings), or ``None`` if it holds.

    It does not hold when it evaluated another checkpoint (an agent retrained under the same run
    directory) or showed other stand-in videos than today's (``embedded_videos``; a record that
    shows them without a version was made on version 1). A record without a checkpoint digest (made
    before digests were recorded) is taken as this checkpoint's: nothing says otherwise.
    """
    stored = done.get("config", {}).get("evaluated_from", {}).get("checkpoint_sha256")
    if stored is not None and stored != digest:
        return f"it evaluated another checkpoint (SHA-256 {stored[:12]}…, now {digest[:12]}…)"
    today = with_videos_version(eval_env).get("embedded_videos")  # None: no stand-ins shown
    if today is not None:
        shown = done.get("eval_env", {}).get("embedded_videos", 1)
        if shown != today:
            return f"it showed stand-in videos version {shown}, today's are version {today}"
    return None


def _set_aside(path: Path) -> Path:
    """Renames ``path`` to the first free ``<stem>.stale-<k><suffix>`` beside it (nothing is lost)."""
    k = 1
    while (kept := path.with_name(f"{path.stem}.stale-{k}{path.suffix}")).exists():
        k += 1
    path.rename(kept)
    return kept


def evaluate_checkpoint(
    train_dir: str | os.PathLike,
    targets: Sequence[tuple[str | os.PathLike, Evaluation]],
    *,
    settings: Mapping[str, object] | None = None,
    threads: int | None = None,
    processes: int = 1,
    trust_checkpoint: bool = False,
) -> list[dict]:
    """Evaluates the final checkpoint of ``train_dir`` once per ``(directory, evaluation)``.

    Args:
        train_dir: a finished training run (``results.json`` and its checkpoints), an exported
            agent, or a shipped agent's name (:func:`dcs_torchrl.pretrained.shipped_agents`).
        targets: where each evaluation writes, and what it evaluates.
        settings: ``eval.episodes``, ``eval.num_workers``, ``device`` overriding the trained run's;
            ``execution.render_device`` (default ``auto``: the GPU of ``device`` where NVIDIA's EGL
            driver maps it, as in training; not the trained run's, which names its own machine).
        threads: torch threads (``None``: torch's default).
        processes: evaluations run at once, each in its own process and one env per evaluation
            (:func:`dcs_torchrl.evaluation.scheduling.evaluate_settings`); every return is the one a lone
            evaluation gives.
        trust_checkpoint: load a checkpoint that holds more than tensors, numbers and strings
            (:func:`dcs_torchrl.pretrained.load_pretrained`; unpickling it can run code).

    Returns:
        the ``results.json`` content of every target, in order.
    """
    import torch

    from dcs_torchrl.evaluation.scheduling import evaluate_settings
    from dcs_torchrl.pretrained import agent_directory, checkpoint_sha256
    from dcs_torchrl.training import RunDirectory
    from dcs_torchrl.training.envs import config_settings, render_device

    train_dir = agent_directory(train_dir)  # a run, an exported agent, or a shipped agent's name
    trained = _trained_results(train_dir)
    cfg = OmegaConf.create(trained["config"])
    settings = dict(settings or {})
    episodes = int(settings.get("eval.episodes", cfg.eval.episodes))
    workers = int(settings.get("eval.num_workers", cfg.eval.num_workers))
    device = str(settings.get("device", cfg.device))
    # not the trained run's execution.render_device, which names the machine it trained on; a bad index is refused here
    render = render_device(OmegaConf.create({"device": device}), settings.get("execution.render_device", "auto"))

    digest = checkpoint_sha256(train_dir)
    results: list[dict | None] = []
    todo = []
    for out_dir, evaluation in targets:
        eval_settings = config_settings(cfg.env, evaluation.eval_env)
        run = RunDirectory(out_dir, {"trained": os.path.relpath(train_dir, out_dir), "eval_env": eval_settings.as_dict()})
        run.claim()
        done = run.finished(trained["steps"], episodes)
        reason = None if done is None else stale_reason(done, digest, eval_settings.as_dict())
        if reason is not None:
            kept = _set_aside(run.results_path)
            log.warning(f"{run.path}: evaluated again, {reason}; the old results are kept in {kept.name}")
        if done is not None and reason is None:
            results.append(done)
        else:
            results.append(None)
            todo.append((len(results) - 1, run, evaluation, eval_settings))
    if not todo:
        return results

    if threads is not None:
        torch.set_num_threads(threads)
    pending = {index: (run, evaluation, eval_settings) for index, run, evaluation, eval_settings in todo}
    for index, result, seconds in evaluate_settings(train_dir, {i: e.eval_env for i, (_, e, _) in pending.items()},
                                                    episodes, processes=processes, workers=workers, device=device,
                                                    render_devices=None if render is None else [render],
                                                    final=True,  # a training checkpoint or an exported agent
                                                    trust_checkpoint=trust_checkpoint):
        run, evaluation, eval_settings = pending[index]
        config = OmegaConf.to_container(cfg)
        config.update(
            experiment=evaluation.experiment, sweep=evaluation.sweep, device=device,
            eval_env={**config["eval_env"], **evaluation.eval_env},
            eval={**config["eval"], "episodes": episodes, "num_workers": workers},
            execution={**config.get("execution", {}), "render_device": "process" if render is None else render},
            evaluated_from={"train_dir": os.path.relpath(train_dir, run.path), "checkpoint_frames": trained["steps"],
                            "checkpoint_sha256": digest},
        )
        results[index] = RunResults.from_config(
            config, experiment=evaluation.experiment, steps=trained["steps"], wall_time=seconds,
            train_env=trained["train_env"], eval_env=eval_settings.as_dict(), sweep=evaluation.sweep, eval=result,
            trained=False,  # the trained run's train_env record: the videos it recorded, not today's
        ).as_dict()
        run.write_results(results[index])
    return results


def evaluate_from_config(cfg: DictConfig) -> dict:
    """The command line's evaluation: ``cfg`` is ``evaluate.yaml`` with the given overrides (inside Hydra).

    Refuses overrides of what the trained run fixes; returns the ``results.json`` content.
    """
    given = {o.split("=", 1)[0].lstrip("+~") for o in HydraConfig.get().overrides.task}
    fixed = sorted(k for k in given if not k.startswith(SETTABLE))
    if fixed:
        raise SystemExit(f"{fixed}: these come from the trained run ({cfg.train_dir}/results.json); "
                         "here only eval_env.*, eval.episodes, eval.num_workers, device, "
                         "execution.render_device, checkpoint.trust, experiment and sweep.")
    settings = {k: OmegaConf.select(cfg, k) for k in ("eval.episodes", "eval.num_workers", "device",
                                                       "execution.render_device") if k in given}
    eval_env = {k: v for k, v in OmegaConf.to_container(cfg.eval_env, resolve=True).items() if v is not None}
    sweep = OmegaConf.to_container(cfg.sweep, resolve=True) if cfg.sweep is not None else None
    evaluation = Evaluation("", cfg.experiment, eval_env, sweep)
    trust = bool(OmegaConf.select(cfg, "checkpoint.trust", default=False))
    (results,) = evaluate_checkpoint(cfg.train_dir, [(HydraConfig.get().runtime.output_dir, evaluation)],
                                     settings=settings, trust_checkpoint=trust)
    print(f"{results['method']} {results['domain']} {results['task']} seed {results['seed']} ({results['steps']} frames) "
          f"under {eval_env or 'the training env'}: {results['eval']['mean']:.1f} ± {results['eval']['stderr']:.1f} "
          f"over {results['eval']['episodes']} episodes")
    return results


@hydra.main(config_path="pkg://dcs_torchrl.training.conf", config_name="evaluate", version_base=None)
def main(cfg: DictConfig) -> None:
    """``python -m dcs_torchrl.experiments.evaluate train_dir=... [eval_env.*=...]``."""
    evaluate_from_config(cfg)


if __name__ == "__main__":
    main()
