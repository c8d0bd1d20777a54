"""The recipes' pixel envs: suite envs in ``ParallelEnv`` workers, channel-first, frame-stacked.

Each worker builds the whole suite env (:func:`dcs_torchrl.make_env`) and its pixel handling
(DrQ's: HWC uint8 -> CHW uint8, ``S`` frames stacked on the channels, the first frame repeated
at a reset) inside its own process (``spawn``: EGL contexts do not survive ``fork``), so only the
stacked uint8 observation crosses the process boundary. The batched env gets a ``RewardSum``
(``"episode_reward"``) for logging.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping
from pathlib import Path

from omegaconf import OmegaConf
from torchrl.envs import CatFrames, Compose, ParallelEnv, PermuteTransform, RewardSum, TransformedEnv

from dcs_torchrl.envs import EnvSettings, make_env, resolve_settings

__all__ = ["ENV_KEYS", "env_options", "env_settings", "make_pixel_env", "pixel_env", "pixel_options"]

# The make_env settings a recipe's ``env`` / ``eval_env`` config groups may set.
ENV_KEYS = (
    "benchmark", "dynamic", "background_dir", "background_split", "camera_scale", "color_scale", "num_videos",
    "background_blend", "blind", "ground_alpha", "action_repeat", "camera_id",
)


def env_options(section) -> dict:
    """The make_env settings of a recipe's ``env`` / ``eval_env`` config section."""
    return {k: v for k, v in OmegaConf.to_container(section, resolve=True).items() if k in ENV_KEYS}


def pixel_options(pixels) -> dict:
    """The keyword arguments of :func:`pixel_env` / :func:`make_pixel_env` from a recipe's ``pixels`` section."""
    return dict(frame_stack=pixels.frame_stack, image_size=pixels.image_size, render_profile=pixels.render_profile)


def env_settings(domain: str, task: str, options: Mapping) -> EnvSettings:
    """Resolves (and so validates, in this process) a recipe's env options.

    Raises a clear error for unknown options, tasks or presets and for a background folder that
    does not exist, before any worker starts.
    """
    unknown = sorted(set(options) - set(ENV_KEYS))
    if unknown:
        raise ValueError(f"unknown env option(s) {unknown}: the env config accepts {list(ENV_KEYS)}.")
    folder = options.get("background_dir")
    if folder is not None and not Path(folder).expanduser().exists():
        raise FileNotFoundError(
            f"env.background_dir={folder!r} does not exist: point it at a DAVIS 2017 folder (or a folder of "
            "videos), or leave it null for the embedded default videos."
        )
    return resolve_settings(domain, task, **options)


def pixel_env(settings: EnvSettings, *, frame_stack: int, image_size: int, render_profile: str, seed: int | None = None) -> TransformedEnv:
    """One suite env with the recipes' pixel handling (``"pixels"``: uint8 ``[3*S, H, W]``)."""
    env = make_env(
        settings.domain, settings.task, seed=seed, height=image_size, width=image_size, render_profile=render_profile,
        **{k: getattr(settings, k) for k in ENV_KEYS},
    )
    env.append_transform(
        Compose(
            PermuteTransform((-1, -3, -2), in_keys=["pixels"]),
            CatFrames(frame_stack, dim=-3, in_keys=["pixels"]),
        )
    )
    return env


def make_pixel_env(
    settings: EnvSettings,
    *,
    num_workers: int,
    seed: int,
    frame_stack: int = 3,
    image_size: int = 84,
    render_profile: str = "default",
) -> TransformedEnv:
    """``num_workers`` suite envs in a ``ParallelEnv`` (spawned workers), seeded ``seed, seed + 1, ...``."""
    if num_workers < 1:
        raise ValueError(f"num_workers must be >= 1, got {num_workers}.")
    make = functools.partial(pixel_env, settings, frame_stack=frame_stack, image_size=image_size, render_profile=render_profile)
    env = TransformedEnv(ParallelEnv(num_workers, make, mp_start_method="spawn"), RewardSum())
    env.set_seed(seed)
    return env
