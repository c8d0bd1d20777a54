"""The recipes' Hydra configs: ``base.yaml`` (shared), ``sac.yaml``, ``qtopt.yaml``, ``evaluate.yaml``.

The ``env`` and ``eval_env`` groups are not written out in YAML: they are structured configs made
here from :class:`dcs_torchrl.EnvSettings`, the one list of a suite env's settings, so that a new
setting reaches ``make_env``, the recipes' config and its validation at once (Hydra refuses an
unknown ``env.<key>`` or a value of the wrong type). ``None`` means the preset's (``env``) or the
training env's (``eval_env``). Importing this module registers them (the entry points do).

>>> from dcs_torchrl.training.conf import EnvConfig, EvalEnvConfig
>>> EnvConfig().benchmark, EnvConfig().camera_scale, EvalEnvConfig().benchmark
('none', None, None)
"""
from __future__ import annotations

import dataclasses
import typing
from typing import Optional

from hydra.core.config_store import ConfigStore

from dcs_torchrl.envs import ENV_OPTIONS, OPTION_DEFAULTS, EnvSettings

__all__ = ["EnvConfig", "EvalEnvConfig", "register"]

_TYPES = typing.get_type_hints(EnvSettings)


def _optional(name: str):
    kinds = [k for k in typing.get_args(_TYPES[name]) if k is not type(None)] or [_TYPES[name]]
    return Optional[kinds[0]]


#: The training env (``env.*``): the task, then every make_env setting with its default.
EnvConfig = dataclasses.make_dataclass("EnvConfig", [
    ("domain", str, dataclasses.field(default="cartpole")),
    ("task", str, dataclasses.field(default="swingup")),
    *[(name, _optional(name), dataclasses.field(default=OPTION_DEFAULTS.get(name))) for name in ENV_OPTIONS],
])
#: Evaluation overrides of the training env (``eval_env.*``): ``None`` keeps the training env's.
EvalEnvConfig = dataclasses.make_dataclass(
    "EvalEnvConfig", [(name, _optional(name), dataclasses.field(default=None)) for name in ENV_OPTIONS])


def register() -> None:
    """Stores the groups as ``env: suite`` and ``eval_env: overrides`` (idempotent)."""
    store = ConfigStore.instance()
    store.store(group="env", name="suite", node=EnvConfig)
    store.store(group="eval_env", name="overrides", node=EvalEnvConfig)


register()
