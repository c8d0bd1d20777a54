"""The ``results.json`` record: one typed definition that runs write and the report reads.

A training run (:func:`dcs_torchrl.training.train`) and an evaluation-only run
(:func:`dcs_torchrl.experiments.evaluate.evaluate_checkpoint`) both build a :class:`RunResults`
with :meth:`RunResults.from_config` and write its :meth:`~RunResults.as_dict` (``RunDirectory.write_results``); :mod:`dcs_torchrl.report.load` validates a
decoded file against :data:`JSON_TYPES`, which is derived from the same fields. The format:
``docs/results_format.md``. Pure data: no torch, no pandas.

>>> record = RunResults.from_config(
...     {"seed": 0, "algo": {"name": "sac", "aug": "rad"}, "env": {"domain": "cartpole", "task": "swingup"}},
...     experiment="benchmarks", steps=100000, wall_time=1.0, train_env={}, eval_env={},
...     sweep={"axis": "benchmark", "value": "none", "dynamic": False},
...     eval={"mean": 800.0, "stderr": 1.0, "episodes": 20, "returns": []})
>>> record.method, list(record.as_dict())[:3]
('SAC+RAD', ['schema', 'experiment', 'method'])
>>> JSON_TYPES["sweep"], JSON_TYPES["wall_time"]
((<class 'dict'>, None), (<class 'int'>, <class 'float'>))
"""
from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Optional

from dcs_torchrl.methods import method_name

__all__ = ["JSON_TYPES", "RESULTS_FILE", "RunResults", "SCHEMA", "shows_videos", "with_videos_version"]

RESULTS_FILE = "results.json"
SCHEMA = 1


@dataclass(frozen=True)
class RunResults:
    """One run's outcome. Field order is the file's key order.

    Attributes:
        schema: the format version (:data:`SCHEMA`).
        experiment: ``robustness``, ``training``, ``benchmarks``, ``interactions`` or ``None``.
        method, algo, aug: the paper's method name and the recipe's ``algo.name`` / ``algo.aug``.
        domain, task, seed: what was trained.
        steps: frames trained (counting action repeat).
        wall_time: seconds.
        train_env, eval_env: the resolved env settings (``EnvSettings.as_dict()``), plus
            ``embedded_videos``, the version of the embedded stand-in videos
            (:data:`dcs_torchrl.videos.EMBEDDED_VERSION`) where the env shows them. An
            evaluation-only run's ``train_env`` is the trained run's record as it is: without
            ``embedded_videos`` where that record has none (recorded before versions were: version 1).
            Likewise ``standin_textures`` (:data:`dcs_torchrl.textures.STANDIN_VERSION`) where the
            env textures its surfaces with the stand-in textures.
        sweep: what the run varies in its experiment (``axis``, ``value``, ``dynamic``[, ``eval_split``]).
        eval: the final deterministic evaluation (``EvalResult.to_dict()``).
        config: the run's full resolved config.
    """

    schema: int
    experiment: Optional[str]
    method: str
    algo: str
    aug: str
    domain: str
    task: str
    seed: int
    steps: int
    wall_time: float
    train_env: dict
    eval_env: dict
    sweep: Optional[dict]
    eval: dict
    config: dict

    @classmethod
    def from_config(cls, config: Mapping, *, experiment: str | None, steps: int, wall_time: float,
                    train_env: Mapping, eval_env: Mapping, sweep: Mapping | None, eval: Mapping,
                    trained: bool = True) -> "RunResults":
        """The record of a run of ``config`` (a recipe's resolved config, as a dict).

        ``eval_env``, evaluated by this run, gets the current stand-in videos' version where it
        shows them (:func:`with_videos_version`); so does ``train_env`` if this run ``trained``.
        An evaluation-only run (``trained=False``) passes the trained run's ``train_env`` record,
        kept as it is: the version that run recorded, or none where it recorded none.
        """
        algo, aug = config["algo"]["name"], config["algo"]["aug"]
        return cls(
            schema=SCHEMA, experiment=experiment, method=method_name(algo, aug), algo=algo, aug=aug,
            domain=config["env"]["domain"], task=config["env"]["task"], seed=int(config["seed"]), steps=int(steps),
            wall_time=float(wall_time), train_env=with_videos_version(train_env) if trained else dict(train_env),
            eval_env=with_videos_version(eval_env),
            sweep=None if sweep is None else dict(sweep), eval=dict(eval), config=dict(config),
        )

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


def shows_videos(env: Mapping) -> bool:
    """Whether an env record (resolved settings) shows background videos: some, blended in."""
    return (env.get("num_videos") or 0) > 0 and env.get("background_blend", 1.0) > 0


def with_videos_version(env: Mapping) -> dict:
    """``env`` (resolved settings) with the embedded videos' version if it shows them, and the stand-in
    textures' version (``standin_textures``) if it textures its surfaces with them.

    >>> from dcs_torchrl.videos import EMBEDDED_VERSION
    >>> with_videos_version({"num_videos": 8, "background_blend": 1.0, "background_dir": None})["embedded_videos"] == EMBEDDED_VERSION
    True
    >>> "embedded_videos" in with_videos_version({"num_videos": 0, "background_blend": 1.0, "background_dir": None})
    False
    >>> from dcs_torchrl.textures import STANDIN_VERSION
    >>> with_videos_version({"num_videos": 0, "texture_scale": 0.5, "texture_dir": None})["standin_textures"] == STANDIN_VERSION
    True
    >>> "standin_textures" in with_videos_version({"num_videos": 0, "texture_scale": 0.5, "texture_dir": "dtd/images"})
    False
    """
    from dcs_torchrl.textures import STANDIN_VERSION
    from dcs_torchrl.videos.embedded import EMBEDDED_VERSION

    env = dict(env)
    if shows_videos(env) and not env.get("background_dir"):
        env.setdefault("embedded_videos", EMBEDDED_VERSION)
    if env.get("texture_scale", 0.0) > 0 and not env.get("texture_dir"):
        env.setdefault("standin_textures", STANDIN_VERSION)
    return env


def _json_types(annotation) -> tuple:
    """The JSON types a field of ``annotation`` may hold (``None``: null); a float may be written as an int."""
    args = typing.get_args(annotation)
    if args:  # Optional[X]
        return tuple(t for a in args if a is not type(None) for t in _json_types(a)) + (None,)
    return (int, float) if annotation is float else (annotation,)


#: Every key of the file and the JSON types it may hold.
JSON_TYPES: dict[str, tuple] = {name: _json_types(kind) for name, kind in typing.get_type_hints(RunResults).items()}
