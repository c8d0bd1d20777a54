"""A run directory belongs to one configuration: finished runs are skipped, others resume.

``run_config.json`` records the settings that define what is trained (everything but the
budget, evaluation, logging, checkpoint cadence and how the same math is run: device,
``network.channels_last``, ``network.compile``, ``optim.fused``, ``execution.*``,
``replay_buffer.device``). ``precision.tf32`` is part of it: TF32 rounds the matmuls' and
convolutions' inputs to 10 mantissa bits, other math than float32's. Launching again with the same
settings in the same directory resumes from the last checkpoint, or does nothing if
``results.json`` already holds a run of at least the requested budget. Different settings are
an error that names both values: nothing in the directory is overwritten.
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

__all__ = ["IDENTITY_EXCLUDED", "RunDirectory", "RunMismatchError", "finished_results", "flatten", "write_json_atomic"]

# Config entries (dotted for nested ones) that may change between launches of the same run: the
# budget, evaluation, logging and checkpoint cadence, and how the same math is run (device, NHWC
# convolutions, torch.compile, fused Adam, CUDA graphs, cuDNN's search, where the replay lives), so
# that a run started before a default changed, or on another machine, still resumes.
IDENTITY_EXCLUDED = ("total_frames", "eval", "logger", "checkpoint", "device", "experiment", "sweep", "progress",
                     "network.channels_last", "network.compile", "optim.fused", "execution", "replay_buffer.device")


# Settings added after runs were recorded: absent from an older run_config.json, they count as
# the value they had before they existed (the 2021 blend off, the 256-pixel sky, float32 math),
# under any section.
ADDED_SETTINGS = {"reference_blend": (False, None), "texture_size": (256, None), "tf32": (False,)}


def _added_later(key: str, value) -> bool:
    return value in ADDED_SETTINGS.get(key.rsplit(".", 1)[-1], ())


class RunMismatchError(ValueError):
    """The run directory holds a run of another configuration."""


def write_json_atomic(path: str | os.PathLike, data) -> None:
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n")
    os.replace(tmp, path)


def flatten(tree, prefix: str = "") -> dict[str, object]:
    """A nested mapping as dotted keys: ``{"eval": {"episodes": 2}}`` -> ``{"eval.episodes": 2}``."""
    if isinstance(tree, Mapping):
        out: dict[str, object] = {}
        for key, value in tree.items():
            out.update(flatten(value, f"{prefix}{key}."))
        return out
    return {prefix[:-1]: tree}


def _identity(tree: Mapping, prefix: str = "") -> dict:
    """``tree`` without its :data:`IDENTITY_EXCLUDED` entries (dotted paths, whole subtrees)."""
    return {key: _identity(value, f"{prefix}{key}.") if isinstance(value, Mapping) else value
            for key, value in tree.items() if f"{prefix}{key}" not in IDENTITY_EXCLUDED}


def finished_results(run_dir: str | os.PathLike, steps: int | None = None, episodes: int | None = None) -> dict | None:
    """The ``results.json`` of ``run_dir`` if it covers ``steps`` frames and ``episodes``
    evaluation episodes (``None``: any), else ``None`` (also when missing or unreadable)."""
    try:
        results = json.loads((Path(run_dir) / "results.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if steps is not None and results.get("steps", -1) < steps:
        return None
    if episodes is not None and results.get("eval", {}).get("episodes", -1) < episodes:
        return None
    return results


class RunDirectory:
    """The files of one run: ``run_config.json``, ``results.json``, ``checkpoints/``.

    Args:
        path: the run directory (Hydra's ``hydra.run.dir``), created if missing.
        config (dict): the run's full resolved config.
    """

    def __init__(self, path: str | os.PathLike, config: Mapping):
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=True)
        self.config = dict(config)
        self.identity = _identity(self.config)
        self.checkpoints = self.path / "checkpoints"
        self.results_path = self.path / "results.json"

    def claim(self) -> None:
        """Records this run's identity, or checks it against the one recorded (raises on mismatch)."""
        recorded_path = self.path / "run_config.json"
        if recorded_path.exists():
            recorded = json.loads(recorded_path.read_text())
            mine, theirs = flatten(self.identity), flatten(_identity(recorded))
            diff = sorted(k for k in set(mine) | set(theirs) if mine.get(k, "<unset>") != theirs.get(k, "<unset>")
                          and not (k not in theirs and _added_later(k, mine[k])))
            if diff:
                lines = ", ".join(f"{k}: {theirs.get(k, '<unset>')!r} there, {mine.get(k, '<unset>')!r} now" for k in diff)
                raise RunMismatchError(
                    f"{self.path} holds a run of another configuration ({lines}). Nothing was changed: choose another "
                    "directory (hydra.run.dir=...) or repeat the recorded settings to resume it."
                )
        elif any(self.path.glob("checkpoints/checkpoint_*.pt")) or (self.path / "metrics.csv").exists():
            raise RunMismatchError(f"{self.path} holds files of a run without run_config.json: choose another directory.")
        else:
            write_json_atomic(recorded_path, self.identity)

    def finished(self, total_frames: int, episodes: int | None = None) -> dict | None:
        """The recorded results if this run already trained ``total_frames`` or more (and was
        evaluated over ``episodes`` or more), else ``None``."""
        return finished_results(self.path, total_frames, episodes)

    def write_results(self, results: dict) -> None:
        write_json_atomic(self.results_path, results)
