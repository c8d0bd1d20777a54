"""Exporting a dataset to Minari (``pip install "minari[hdf5]"``, not a dependency of the suite).

    python -m dcs_torchrl.datasets export data/cartpole_medium_expert --dataset-id dcs/cartpole-swingup-medium-expert-v0

Each episode becomes a Minari episode: ``observations`` a dict of ``"pixels"`` (uint8
``[T + 1, H, W, 3]``, stored losslessly, not JPEG-encoded) and each state entry (float64),
``actions``, ``rewards``, ``terminations``, ``truncations``, and ``infos`` holding the distractions'
state (``infos["distractions"][<kind>]``, ``[T + 1, ...]``). The set's ``metadata.json`` is the Minari
dataset's ``description``; its seeds are the episodes' ``seed``.
"""
from __future__ import annotations

import json
import os
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from dcs_torchrl.datasets.layout import METADATA, episode_table, load_data, read_json

__all__ = ["export_minari"]


def _import_minari():
    try:
        import gymnasium
        import minari
        from minari.data_collector import EpisodeBuffer
    except ModuleNotFoundError as error:
        raise ModuleNotFoundError(f"export --format minari needs Minari: pip install 'minari[hdf5]' ({error})",
                                  name=error.name) from None
    return gymnasium, minari, EpisodeBuffer


@contextmanager
def _datasets_root(root):
    if root is None:
        yield
        return
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = os.fspath(root)
    try:
        yield
    finally:
        if before is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def _box(gymnasium, value, low=-np.inf, high=np.inf):
    return gymnasium.spaces.Box(low, high, tuple(value.shape[1:]), dtype=value.dtype)


def _check_dataset_id(minari, dataset_id: str) -> None:
    """Refuses, before anything is written, an id Minari cannot parse or one it holds already."""
    from minari.dataset.minari_dataset import parse_dataset_id
    from minari.storage import get_dataset_path

    try:
        parse_dataset_id(dataset_id)
    except (ValueError, TypeError):  # Minari 0.5.4 raises a TypeError where the version is missing
        raise ValueError(f"--dataset-id {dataset_id!r}: Minari's ids are (namespace/)name-v<version>, e.g. "
                         "dcs/cartpole-swingup-medium-expert-v0.") from None
    if dataset_id in minari.list_local_datasets():
        raise FileExistsError(f"--dataset-id {dataset_id}: Minari holds that dataset already "
                              f"({get_dataset_path(dataset_id)}): give another version (-v1, ...), or delete it "
                              f"first (minari.delete_dataset({dataset_id!r})).")


def export_minari(path: str | os.PathLike, dataset_id: str, *, root: str | os.PathLike | None = None):
    """Writes the set ``path`` as the Minari dataset ``dataset_id`` (under ``root``, else Minari's
    folder); returns the ``MinariDataset``."""
    gymnasium, minari, EpisodeBuffer = _import_minari()
    data, record = load_data(path), read_json(Path(path) / METADATA)
    with _datasets_root(root):
        _check_dataset_id(minari, dataset_id)
    transitions, frames = data["transitions"], data["frames"]
    buffers = []
    for e in episode_table(Path(path)):
        rows = transitions[e["first_transition"]:e["first_transition"] + e["steps"]].to_tensordict()
        seen = frames[e["first_frame"]:e["first_frame"] + e["steps"] + 1].to_tensordict()
        observations = {"pixels": seen["pixels"].numpy()}
        for key in rows["state"].keys():
            observations[key] = np.concatenate([rows["state", key][:1].numpy(), rows["next", "state", key].numpy()])
        infos = {"distractions": {key: np.concatenate([rows["distractions", key][:1].numpy(),
                                                        rows["next", "distractions", key].numpy()])
                                  for key in rows["distractions"].keys()}} if "distractions" in rows.keys() else {}
        buffers.append(EpisodeBuffer(
            id=e["episode"], seed=e["seed"], observations=observations, actions=rows["action"].numpy(),
            rewards=rows["next", "reward"].reshape(-1).numpy(), terminations=rows["next", "terminated"].reshape(-1).numpy(),
            truncations=rows["next", "truncated"].reshape(-1).numpy(), infos=infos))
    first = buffers[0]
    observation_space = gymnasium.spaces.Dict(
        {key: _box(gymnasium, value, 0, 255) if key == "pixels" else _box(gymnasium, value)
         for key, value in first.observations.items()})
    from dm_control import suite

    spec = suite.load(record["env"]["domain"], record["env"]["task"]).action_spec()
    action_space = gymnasium.spaces.Box(spec.minimum, spec.maximum, spec.shape, dtype=first.actions.dtype)
    policies = ", ".join(p["name"] for p in record["policies"])
    with _datasets_root(root), warnings.catch_warnings():
        # judged: Minari warns that no Gymnasium env spec is given (the suite's envs are TorchRL envs;
        # the description holds every setting to rebuild one with make_env), and that no author,
        # e-mail or code link is (the description names the suite's version, which is the code)
        warnings.filterwarnings("ignore", message=r"(`eval_env` is set to None|env_spec is None|`code_permalink` is set "
                                                  r"to None|`author` is set to None|`author_email` is set to None)",
                                category=UserWarning)
        return minari.create_dataset_from_buffers(
            dataset_id, buffers, observation_space=observation_space, action_space=action_space,
            algorithm_name=policies, description=json.dumps({k: v for k, v in record.items() if k != "episode_table"}),
            jpeg_encoding=False)
