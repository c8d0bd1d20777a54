"""Training from the command line: one run of an algorithm's Hydra config.

    python -m dcs_torchrl.training [--config-name=sac|qtopt] <overrides, e.g. algo.aug=rad env.benchmark=easy>

The configs are the package's (:data:`CONFIG_PATH`: ``sac.yaml``, ``qtopt.yaml`` over the shared
``base.yaml``), so an installed package trains without a clone; ``recipes/sac/sac.py`` and
``recipes/qtopt/qtopt.py`` are the same entry point for a clone, and the experiment launcher
(:mod:`dcs_torchrl.experiments.launch`) starts this module. Every output goes to Hydra's run
directory (``hydra.run.dir``).
"""
from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dcs_torchrl.methods import agent_class
from dcs_torchrl.modules import retain_freed_memory
from dcs_torchrl.training import conf as _conf  # noqa: F401  (importing it registers the env / eval_env groups)
from dcs_torchrl.training.loop import train

__all__ = ["CONFIG_PATH", "main", "recipe_main", "train_from_config"]

#: The package's Hydra configs: one per algorithm (its ``algo`` settings) over ``base.yaml``.
CONFIG_PATH = "pkg://dcs_torchrl.training.conf"


def train_from_config(cfg: DictConfig) -> dict:
    """Trains the agent of ``cfg.algo.name`` into Hydra's run directory; returns ``results.json``'s content."""
    retain_freed_memory()  # keep the update's large buffers between updates (dcs_torchrl.modules.allocator)
    return train(cfg, agent_class(cfg.algo.name), HydraConfig.get().runtime.output_dir)


def recipe_main(config_name: str):
    """The Hydra entry point that trains with the package's ``<config_name>.yaml`` (``sac``, ``qtopt``)."""
    return hydra.main(config_path=CONFIG_PATH, config_name=config_name, version_base=None)(train_from_config)


#: ``python -m dcs_torchrl.training``: SAC by default, ``--config-name=qtopt`` for QT-Opt.
main = recipe_main("sac")
