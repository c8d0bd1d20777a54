"""QT-Opt, QT-Opt+RAD and QT-Opt+DrQ from pixels on the Distracting Control Suite: the Hydra entry point.

    python recipes/qtopt/qtopt.py env.domain=cartpole env.task=swingup env.benchmark=easy algo.aug=rad

The algorithm is :class:`dcs_torchrl.algorithms.QTOptAgent` (its docstring: what the paper runs and
where each choice comes from); everything around the update (envs, replay, logging, evaluation,
checkpoints) is :func:`dcs_torchrl.training.train`. Settings: ``config.yaml`` beside this file
and ``dcs_torchrl/training/conf/base.yaml``. Every output goes to Hydra's run directory.
"""
from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dcs_torchrl.agents import retain_freed_memory
from dcs_torchrl.algorithms import QTOptAgent
from dcs_torchrl.training import train

__all__ = ["QTOptAgent", "main"]


@hydra.main(config_path=".", config_name="config", version_base=None)
def main(cfg: DictConfig) -> None:
    retain_freed_memory()  # keep the update's large buffers between updates (~3x faster on CPU)
    train(cfg, QTOptAgent, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
