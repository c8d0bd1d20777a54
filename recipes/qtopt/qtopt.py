"""QT-Opt, QT-Opt+RAD and QT-Opt+DrQ from pixels on the Distracting Control Suite.

    python recipes/qtopt/qtopt.py env.domain=cartpole env.task=swingup env.benchmark=easy algo.aug=rad

QT-Opt (Kalashnikov et al. 2018) as the paper runs it (Stone et al. 2021, section 4): a
Q-function on DrQ's encoder and MLPs, the greedy action found by the cross-entropy method (CEM),
clipped double Q with target networks, QT-Opt's cross-entropy loss on a normalised value, and
DrQ's K = M augmented copies (``algo.aug``: none 0, rad 1, drq 2) averaged in the target and the
loss (:class:`dcs_torchrl.objectives.QTOptLoss`). The acting policy is CEM on the online Q head
(:class:`dcs_torchrl.objectives.CEMActor`). Everything around the update is
:func:`dcs_torchrl.training.train`; the agent is
:class:`dcs_torchrl.algorithms.QTOptAgent`. Every output goes to Hydra's run directory.
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
