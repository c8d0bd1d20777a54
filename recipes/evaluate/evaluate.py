"""Evaluation only: a trained run's final checkpoint evaluated under other env settings.

    python recipes/evaluate/evaluate.py train_dir=<a finished run of recipes/sac or recipes/qtopt> \\
        eval_env.camera_scale=0.3 eval_env.dynamic=true [eval.episodes=100] [experiment=robustness \\
        'sweep={axis:camera,value:0.3,dynamic:true}'] [hydra.run.dir=...]

The same as ``python -m dcs_torchrl.experiments.evaluate ...`` (an installed package needs no clone).
The env is the training env with the ``eval_env`` overrides; the networks, pixels and seed are
the trained run's; the episodes run with the seeds of its final evaluation, so an evaluation
without overrides reproduces it. ``results.json`` goes to Hydra's run directory. Settings:
``dcs_torchrl/training/conf/evaluate.yaml``. The experiment sweeps (recipes/experiments) call the
same code (:mod:`dcs_torchrl.experiments.evaluate`).
"""
from __future__ import annotations

import hydra
from omegaconf import DictConfig

from dcs_torchrl.experiments.evaluate import evaluate_from_config


@hydra.main(config_path="pkg://dcs_torchrl.training.conf", config_name="evaluate", version_base=None)
def main(cfg: DictConfig) -> None:
    evaluate_from_config(cfg)


if __name__ == "__main__":
    main()
