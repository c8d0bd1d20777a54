"""A dataset's ``metadata.json``: what made the set (its identity, fixed when the set is created)
and what it holds (episodes, returns, keys), and the refusal of a set made otherwise.

The identity (:data:`IDENTITY`) is every setting that changes what an episode holds: the format,
the suite's version, every resolved env setting (:meth:`dcs_torchrl.EnvSettings.as_dict`) with the
videos shown (the embedded stand-ins' version, or a folder's absolute path and a digest of its
listing), the pixels (image size, render profile, masks, backend), the episode cut
(``max_steps``), the policies (name, method, task, seed, frames, checkpoint SHA-256), their
mixing and the seed. Generating into a set whose identity differs is refused, naming each
difference; the number of episodes is not part of it (asking for more extends the set).
"""
from __future__ import annotations

import importlib.metadata
import os
from pathlib import Path

from dcs_torchrl.envs import EnvSettings

__all__ = ["FORMAT", "IDENTITY", "describe_keys", "differences", "episode_seed", "episode_seeds", "identity",
           "versions"]

#: The version of the files' layout (layout.py) and of the episodes' seeds (2: TorchRL's chain).
FORMAT = 2
IDENTITY = ("format", "suite_version", "env", "pixels", "max_steps", "policies", "mixing", "seed")
#: How episode k's seed is derived: the same for episode k of every run of a set, cut or not, on
#: either backend.
EPISODE_SEEDS = "episode 0: seed; episode k: what env.set_seed(seed of episode k - 1) returns (TorchRL's chain)"


def episode_seeds(seed: int, first: int, count: int) -> list[int]:
    """The seeds of episodes ``first .. first + count - 1`` of a set of ``seed`` (:data:`EPISODE_SEEDS`).

    TorchRL seeds the envs of a batch by a chain: env ``i`` gets what env ``i - 1``'s ``set_seed``
    returns. Episode ``k`` of a set gets the ``k``-th seed of that chain from ``seed``, so that a batch
    of ``N`` envs seeded with episode ``k``'s seed runs episodes ``k .. k + N - 1`` in its envs, and
    one env seeded with it runs episode ``k``: the same episodes on the GL and the Warp backend, for
    any number of envs. Each episode's env, policy noise and torch generator are seeded with its seed.

    >>> episode_seeds(0, 0, 3)[1:] == episode_seeds(0, 1, 2) and episode_seeds(7, 0, 1) == [7]
    True
    """
    from dcs_torchrl._compat.private_api import seed_generator  # what EnvBase.set_seed returns

    chained = seed
    for _ in range(first):
        chained = seed_generator(chained)
    seeds = []
    for _ in range(count):
        seeds.append(int(chained))
        chained = seed_generator(chained)
    return seeds


def episode_seed(seed: int, episode: int) -> int:
    """The seed of episode ``episode`` of a set of ``seed`` (:func:`episode_seeds`).

    >>> episode_seed(0, 3) == episode_seed(0, 3) != episode_seed(0, 4)
    True
    """
    return episode_seeds(seed, episode, 1)[0]


def _version(package: str) -> str | None:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return None


def versions() -> dict:
    """The versions of the packages that made the set (recorded, not compared)."""
    return {name: _version(name) for name in ("torch", "torchrl", "tensordict", "mujoco", "dm-control", "numpy")}


def env_record(settings: EnvSettings) -> dict:
    """The resolved env settings and the videos they show: the embedded stand-ins' version
    (``embedded_videos``), or a folder's absolute path and ``background_listing`` (a digest of its
    files' paths and sizes), as the robustness command records a point's env."""
    from dcs_torchrl.results import shows_videos, with_videos_version
    from dcs_torchrl.robustness import _listing_sha256

    env = with_videos_version(settings.as_dict())
    if shows_videos(env) and env["background_dir"]:
        folder = Path(env["background_dir"]).expanduser().resolve()
        env |= {"background_dir": os.fspath(folder), "background_listing": _listing_sha256(folder)}
    return env


def identity(settings: EnvSettings, *, pixels: dict, max_steps: int | None, policies: list[dict], mixing: dict,
             seed: int) -> dict:
    """What defines a set (:data:`IDENTITY`)."""
    return {"format": FORMAT, "suite_version": _version("dcs-torchrl"), "env": env_record(settings), "pixels": pixels,
            "max_steps": max_steps, "policies": policies, "mixing": mixing, "seed": seed}


def _indexed(record):
    """``record`` with its lists as mappings by index (so that each policy's entries are named)."""
    if isinstance(record, dict):
        return {key: _indexed(value) for key, value in record.items()}
    if isinstance(record, list):
        return {str(i): _indexed(value) for i, value in enumerate(record)} or []
    return record


def differences(stored: dict, asked: dict) -> list[str]:
    """Each setting of the identity where ``stored`` (a set's metadata) and ``asked`` differ.

    >>> differences({"seed": 0, "env": {"benchmark": "none"}}, {"seed": 0, "env": {"benchmark": "medium"}})
    ["env.benchmark: 'none' in the set, 'medium' asked"]
    """
    from dcs_torchrl.training.rundir import flatten

    theirs = flatten(_indexed({k: stored.get(k) for k in IDENTITY if k in stored or k in asked}))
    ours = flatten(_indexed({k: asked.get(k) for k in IDENTITY if k in stored or k in asked}))
    return [f"{key}: {theirs.get(key)!r} in the set, {ours.get(key)!r} asked"
            for key in sorted(set(theirs) | set(ours)) if theirs.get(key) != ours.get(key)]


def describe_keys(td) -> dict:
    """Every entry of a TensorDict with its dtype and per-row shape: ``{"next.reward": "float64 [1]"}``."""
    return {".".join((key,) if isinstance(key, str) else key):
            f"{str(value.dtype).removeprefix('torch.')} {list(value.shape[td.ndim:])}"
            for key, value in sorted(td.items(include_nested=True, leaves_only=True), key=lambda kv: str(kv[0]))}
