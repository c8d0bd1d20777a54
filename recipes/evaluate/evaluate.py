"""Evaluation only: a trained run's final checkpoint evaluated under other env settings.

    python recipes/evaluate/evaluate.py train_dir=<a finished run of recipes/sac or recipes/qtopt> \\
        eval_env.camera_scale=0.3 eval_env.dynamic=true [eval.episodes=100] [experiment=robustness \\
        'sweep={axis:camera,value:0.3,dynamic:true}'] [hydra.run.dir=...]

The env is the training env with the ``eval_env`` overrides; the networks, pixels and seed are
the trained run's; the episodes run with the seeds of its final evaluation, so an evaluation
without overrides reproduces it. ``results.json`` goes to Hydra's run directory. The experiment
sweeps (recipes/experiments) call the same code (:mod:`dcs_torchrl.experiments.evaluate`).
"""
from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from dcs_torchrl.experiments.evaluate import evaluate_checkpoint
from dcs_torchrl.experiments.grid import Evaluation

# The default run directory: named after the overrides, `as_trained` without any.
OmegaConf.register_new_resolver("or_default", lambda value, default: value or default, replace=True)

# What may be set here; the rest of the config is the trained run's.
SETTABLE = ("train_dir", "eval_env.", "eval.episodes", "eval.num_workers", "device", "experiment", "sweep", "progress", "hydra.")


@hydra.main(config_path=".", config_name="config", version_base=None)
def main(cfg: DictConfig) -> None:
    given = {o.split("=", 1)[0].lstrip("+~") for o in HydraConfig.get().overrides.task}
    fixed = sorted(k for k in given if not k.startswith(SETTABLE))
    if fixed:
        raise SystemExit(f"{fixed}: these come from the trained run ({cfg.train_dir}/results.json); "
                         "here only eval_env.*, eval.episodes, eval.num_workers, device, experiment and sweep.")
    settings = {k: OmegaConf.select(cfg, k) for k in ("eval.episodes", "eval.num_workers", "device") if k in given}
    eval_env = {k: v for k, v in OmegaConf.to_container(cfg.eval_env, resolve=True).items() if v is not None}
    sweep = OmegaConf.to_container(cfg.sweep, resolve=True) if cfg.sweep is not None else None
    evaluation = Evaluation("", cfg.experiment, eval_env, sweep)
    (results,) = evaluate_checkpoint(cfg.train_dir, [(HydraConfig.get().runtime.output_dir, evaluation)], settings=settings)
    print(f"{results['method']} {results['domain']} {results['task']} seed {results['seed']} ({results['steps']} frames) "
          f"under {eval_env or 'the training env'}: {results['eval']['mean']:.1f} ± {results['eval']['stderr']:.1f} "
          f"over {results['eval']['episodes']} episodes")


if __name__ == "__main__":
    main()
