"""Exporting a dataset in the two on-disk layouts V-D4RL's code reads (Lu et al. 2022, github.com/conglu1997/v-d4rl).

    python -m dcs_torchrl.datasets export data/cartpole_medium_expert --format vd4rl-npz --out vd4rl/npz
    python -m dcs_torchrl.datasets export data/cartpole_medium_expert --format vd4rl-hdf5 --out vd4rl/hdf5

Both hold each episode of ``T`` steps as ``T + 1`` rows in dm_env's order, as V-D4RL recorded them:
row 0 is the reset (its observation, a dummy all-zero action, reward 0, discount 1), row ``t >= 1``
the observation step ``t`` reached with the action taken before it, that step's reward and its
discount (0 where the episode terminated there, else 1: a time limit is not a termination).

- ``vd4rl-npz``, for its offline DreamerV2 (``offlinedv2``'s ``load_episodes``: ``*.npz`` in the
  folder, ``np.load`` and every key): one file per episode, ``<timestamp>-<episode>-<T>.npz``
  (``np.savez_compressed``; the loaders read the length after the last ``-``, as DreamerV2's
  ``save_episode`` writes it), holding ``image`` uint8 ``[T + 1, H, W, 3]``, ``action`` float32
  ``[T + 1, A]``, ``reward``, ``discount`` float32 ``[T + 1]``, ``is_first``, ``is_last``,
  ``is_terminal`` bool ``[T + 1]``.
- ``vd4rl-hdf5``, for its DrQ+BC (``drqbc``'s ``load_offline_dataset_into_buffer``: ``*.hdf5`` in
  the folder, sorted, every key read whole, episodes split by ``step_type``): one file per episode,
  ``<episode>.hdf5``, holding ``observation`` uint8 ``[T + 1, 3, H, W]`` (channel-first),
  ``action`` float32 ``[T + 1, A]``, ``reward``, ``discount`` float32 ``[T + 1]`` and ``step_type``
  uint8 ``[T + 1]`` (0 first, 1 mid, 2 last), gzip-compressed as V-D4RL's (needs ``h5py``).

The frames are the set's, at its size: V-D4RL's DreamerV2 sets are 64 pixels, its DrQ+BC sets 84;
generate the set at the size the reader expects (``--image-size 64``). Nothing else is converted.
"""
from __future__ import annotations

import datetime
import os
from pathlib import Path

import numpy as np

from dcs_torchrl.datasets.layout import check_folder, episode_table, load_data

__all__ = ["FORMATS", "episode_rows", "export_vd4rl"]

FORMATS = ("vd4rl-npz", "vd4rl-hdf5")
#: dm_env's step types as V-D4RL's ``step_type`` stores them.
FIRST, MID, LAST = 0, 1, 2


def episode_rows(data, episode: dict) -> dict[str, np.ndarray]:
    """The ``T + 1`` rows of one episode (``episode``: a row of the set's episode table), as V-D4RL's
    DreamerV2 files hold them (module text)."""
    t0, f0, steps = episode["first_transition"], episode["first_frame"], episode["steps"]
    rows = data["transitions"][t0:t0 + steps]
    action = rows["action"].numpy().astype(np.float32)
    terminated = rows["next", "terminated"].reshape(-1).numpy()
    first = np.zeros(steps + 1, bool)
    first[0] = True
    last = np.zeros(steps + 1, bool)
    last[-1] = True
    return {"image": data["frames", "pixels"][f0:f0 + steps + 1].numpy(),
            "action": np.concatenate([np.zeros_like(action[:1]), action]),
            "reward": np.concatenate([[0.0], rows["next", "reward"].reshape(-1).numpy()]).astype(np.float32),
            "discount": np.concatenate([[1.0], 1.0 - terminated]).astype(np.float32),
            "is_first": first, "is_last": last, "is_terminal": np.concatenate([[False], terminated])}


def _write_npz(path: Path, rows: dict) -> None:
    with open(path, "wb") as f:  # a file object: np.savez would append .npz to the temporary name
        np.savez_compressed(f, **rows)


def _write_hdf5(path: Path, rows: dict) -> None:
    import h5py

    step_type = np.full(len(rows["reward"]), MID, np.uint8)
    step_type[0], step_type[-1] = FIRST, LAST
    columns = {"observation": rows["image"].transpose(0, 3, 1, 2), "action": rows["action"],
               "reward": rows["reward"], "discount": rows["discount"], "step_type": step_type}
    with h5py.File(path, "w") as f:
        for key, value in columns.items():
            f.create_dataset(key, data=value, compression="gzip")


def export_vd4rl(path: str | os.PathLike, out: str | os.PathLike, fmt: str) -> list[Path]:
    """Writes the set ``path`` into the new (or empty) folder ``out`` in V-D4RL's layout ``fmt``
    (:data:`FORMATS`); returns the files, in episode order. Each file is written under a temporary
    name and renamed, so a killed export leaves whole files only."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown V-D4RL format {fmt!r}: choose one of {list(FORMATS)}.")
    if fmt == "vd4rl-hdf5":
        try:
            import h5py  # noqa: F401
        except ModuleNotFoundError as error:
            raise ModuleNotFoundError(f"export --format vd4rl-hdf5 needs h5py: pip install h5py ({error})",
                                      name=error.name) from None
    out = Path(out)
    check_folder(out, "--out", "a new folder's path")
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"--out {out} is not empty: give a new or empty folder (the export writes one file per "
                              "episode, and V-D4RL's loaders read every file of the folder).")
    data = load_data(path)
    out.mkdir(parents=True, exist_ok=True)
    stamp = datetime.datetime.now().strftime("%Y%m%dT%H%M%S")
    files = []
    for e in episode_table(Path(path)):
        rows = episode_rows(data, e)
        if fmt == "vd4rl-npz":
            name, write = f"{stamp}-{e['episode']:06d}-{e['steps']}.npz", _write_npz
        else:
            name, write = f"{e['episode']:06d}.hdf5", _write_hdf5
        tmp = out / f".{name}.tmp"
        write(tmp, rows)
        os.rename(tmp, out / name)
        files.append(out / name)
    return files
