"""SAC, SAC+RAD and SAC+DrQ from pixels on the Distracting Control Suite.

    python recipes/sac/sac.py env.domain=cartpole env.task=swingup env.benchmark=easy algo.aug=rad

The algorithm is DrQ's SAC (Kostrikov et al. 2020) as the paper runs it (Stone et al. 2021,
section 4): a shared pixel encoder trained through the critic only, twin critics, a learned
temperature, and K = M augmented copies (``algo.aug``: none 0, rad 1, drq 2) averaged in the
critic target and loss (:class:`dcs_torchrl.objectives.DrQSACLoss`). Everything around the
update (envs, replay, logging, evaluation, checkpoints) is :func:`dcs_torchrl.training.train`; the agent is
:class:`dcs_torchrl.algorithms.SACAgent`. Every output goes to Hydra's run directory (``hydra.run.dir=...``).
"""
from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dcs_torchrl.agents import retain_freed_memory
from dcs_torchrl.algorithms import SACAgent
from dcs_torchrl.training import train

__all__ = ["SACAgent", "main"]


@hydra.main(config_path=".", config_name="config", version_base=None)
def main(cfg: DictConfig) -> None:
    retain_freed_memory()  # keep the update's large buffers between updates (~3x faster on CPU)
    train(cfg, SACAgent, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
