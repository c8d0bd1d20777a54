"""The recipes' pixel envs: suite envs, channel-first, frame-stacked, batched.

Each env is the whole suite env (:func:`dcs_torchrl.make_env`) and its pixel handling (DrQ's:
HWC uint8 -> CHW uint8, ``S`` frames stacked on the channels, the first frame repeated at a
reset). One env runs in this process (a ``SerialEnv`` of one); several run in a
:class:`~dcs_torchrl.ParallelSuiteEnv`, each worker building its env in its own process
(``spawn``: EGL contexts do not survive ``fork``), so only the stacked uint8 observation crosses
the process boundary, through shared memory. The batched env gets a ``RewardSum``
(``"episode_reward"``) for logging.

Threads: the suite's parallel env leaves this process's torch threads as they are (TorchRL's
``ParallelEnv``, which the recipes used before, lowers them to ``threads - workers`` while its
workers live: the recipes' update then ran on one of two cores, docs/agents.md, "Where the
loop's time goes"), so whatever the user chose (``OMP_NUM_THREADS``, ``torch.set_num_threads``)
stays in force; :func:`close_env` keeps it too, whatever env it closes.

The GPU that renders (``execution.render_device``, :func:`render_device`): by default the GPU the
policy runs on (``device=cuda:N``), where NVIDIA's EGL driver says which EGL device that is. An
env that must render on another EGL device than this process's (``MUJOCO_EGL_DEVICE_ID``, read
once when dm_control is imported) runs in a worker spawned with that device, so that eight runs
on an eight-GPU node do not all render on GPU 0.
"""
from __future__ import annotations

import functools
import logging
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path

import torch
from omegaconf import DictConfig, OmegaConf
from torchrl.envs import CatFrames, Compose, EnvBase, PermuteTransform, RewardSum, SerialEnv, TransformedEnv

from dcs_torchrl.render.egl_devices import egl_device_of_cuda, process_render_device, render_device_index
from dcs_torchrl.envs import (SCENE_OPTIONS, EnvOptions, EnvSettings, make_env, make_grouped_env, resolve_settings,
                              scene_options)
from dcs_torchrl.vector.parallel import ParallelSuiteEnv

__all__ = ["batched_pixel_env", "close_env", "config_settings", "grouped_pixel_env", "pixel_env", "pixel_env_factory",
           "pixel_options", "render_device", "train_eval_settings"]

log = logging.getLogger(__name__)

# The type(s) each scene option's value may have in a config (None is always allowed: the preset's).
_KINDS = {name: tuple(k for k in typing.get_args(kind) or (kind,) if k is not type(None))
          for name, kind in typing.get_type_hints(EnvOptions).items() if name in SCENE_OPTIONS}


def _section_options(section) -> dict:
    """The options a config's env section sets (all its keys but the task), each of its option's type."""
    values = OmegaConf.to_container(section, resolve=True) if isinstance(section, DictConfig) else dict(section)
    options = {k: v for k, v in values.items() if k not in ("domain", "task")}
    for name, value in options.items():
        kinds = _KINDS.get(name)  # an unknown name: resolve_settings names the choices
        if value is None or kinds is None:
            continue
        number = float in kinds and isinstance(value, int)  # an int where a float is wanted
        if isinstance(value, bool) is not (bool in kinds) or not (isinstance(value, kinds) or number):
            raise ValueError(f"env setting {name}={value!r} ({type(value).__name__}): give a value of type "
                             f"{' or '.join(k.__name__ for k in kinds)}, or null for the preset's.")
    return options


def config_settings(section, overrides: Mapping | None = None) -> EnvSettings:
    """The :class:`EnvSettings` of a config's env section (a recipe's ``env``, a trained run's
    stored ``env``, any mapping of ``domain``, ``task`` and options), ``overrides`` over its options.

    Resolved, so validated in this process: a clear error for unknown options, values of the wrong
    type, tasks or presets and for a background folder that does not exist, before any worker starts.
    """
    options = {**_section_options(section), **(overrides or {})}
    folder = options.get("background_dir")
    if folder is not None and not Path(folder).expanduser().exists():
        raise FileNotFoundError(
            f"env.background_dir={folder!r} does not exist: point it at a DAVIS 2017 folder (or a folder of "
            "videos), or leave it null for the embedded default videos."
        )
    return resolve_settings(section["domain"], section["task"], **options)


def train_eval_settings(cfg) -> tuple[EnvSettings, EnvSettings]:
    """The training env and the evaluation env of a recipe config (``eval_env``: the non-null
    overrides of ``env``), resolved and so validated."""
    overrides = {k: v for k, v in _section_options(cfg.eval_env).items() if v is not None}
    return config_settings(cfg.env), config_settings(cfg.env, overrides)


def pixel_options(pixels) -> dict:
    """The keyword arguments of :func:`pixel_env` / :func:`batched_pixel_env` from a recipe's ``pixels`` section."""
    return dict(frame_stack=pixels.frame_stack, image_size=pixels.image_size, render_profile=pixels.render_profile)


def pixel_env(settings: EnvSettings, *, frame_stack: int, image_size: int, render_profile: str, seed: int | None = None,
              backend: str = "gl", num_envs: int | None = None, device=None) -> TransformedEnv:
    """One suite env with the recipes' pixel handling (``"pixels"``: uint8 ``[3*S, H, W]``); with
    ``backend="warp"``, ``num_envs`` of them in one batched env (batch size ``[num_envs]``) on ``device``."""
    env = make_env(
        settings.domain, settings.task, seed=seed, height=image_size, width=image_size, render_profile=render_profile,
        backend=backend, num_envs=num_envs, **({} if device is None else {"device": device}),
        **scene_options(settings),
    )
    return _with_pixel_handling(env, frame_stack)


def grouped_pixel_env(groups: Sequence[tuple[EnvSettings, int]], *, frame_stack: int, image_size: int,
                      render_profile: str, device=None) -> TransformedEnv:
    """:func:`pixel_env` of several settings of one task in one batched env (``backend="warp"``):
    ``groups`` is ``(settings, num_envs)`` pairs, each group seeded as a batch of its own
    (:func:`dcs_torchrl.make_grouped_env`)."""
    first = groups[0][0]
    env = make_grouped_env(first.domain, first.task, [(scene_options(s), n) for s, n in groups], height=image_size,
                           width=image_size, render_profile=render_profile,
                           **({} if device is None else {"device": device}))
    return _with_pixel_handling(env, frame_stack)


def _with_pixel_handling(env, frame_stack: int) -> TransformedEnv:
    pixels = Compose(
        PermuteTransform((-1, -3, -2), in_keys=["pixels"]),
        CatFrames(frame_stack, dim=-3, in_keys=["pixels"]),
    )
    if isinstance(env, TransformedEnv):
        env.append_transform(pixels)
        return env
    return TransformedEnv(env, pixels)


def pixel_env_factory(settings: EnvSettings, pixels) -> functools.partial:
    """A builder of one :func:`pixel_env` of ``settings`` with a config's ``pixels`` handling,
    picklable: what a spawned process builds its env with."""
    return functools.partial(pixel_env, settings, **pixel_options(pixels))


def render_device(cfg, choice=None) -> int | None:
    """The EGL device a recipe's envs render on, from ``execution.render_device`` (or ``choice``
    where given, for the device of ``cfg.device``): an EGL device index as given (checked against
    the machine's); ``auto`` (default): with ``device=cuda[:N]`` the EGL device of that GPU where
    NVIDIA's EGL driver names one, else ``None`` (this process's device: ``MUJOCO_EGL_DEVICE_ID``
    or dm_control's default, the first), as on the CPU."""
    if choice is None:
        choice = OmegaConf.select(cfg, "execution.render_device", default="auto")
    if choice != "auto":
        if isinstance(choice, bool) or not isinstance(choice, int) or choice < 0:
            raise ValueError(f"execution.render_device must be auto or an EGL device index (an int >= 0), got {choice!r}.")
        return render_device_index(choice)
    device = torch.device(OmegaConf.select(cfg, "device", default="cpu"))
    if device.type != "cuda":
        return None
    try:
        return egl_device_of_cuda(device)
    except (ValueError, RuntimeError) as error:  # Mesa, no NVIDIA EGL: render where this process renders
        log.info(f"execution.render_device=auto: rendering on this process's EGL device ({error})")
        return None


def batched_pixel_env(
    settings: EnvSettings,
    *,
    num_workers: int,
    seed: int,
    frame_stack: int = 3,
    image_size: int = 84,
    render_profile: str = "default",
    render_device: int | None = None,
    backend: str = "gl",
) -> TransformedEnv:
    """``num_workers`` suite envs, batch size ``[num_workers]``, seeded from ``seed`` (the first
    worker ``seed``, each next one the seed TorchRL's ``set_seed`` derives from the previous one's).

    ``backend="warp"``: the ``num_workers`` envs in this process, rendered in one batch by MuJoCo
    Warp on the CPU (:class:`~dcs_torchrl.vector.batched.BatchedSuiteEnv`; the same episodes as the GL
    envs' for the same seed); ``render_device`` is then unused.

    One env runs in this process (``SerialEnv``): no worker to wake while it renders. Several are
    ``make_env(..., num_envs=num_workers)``: a :class:`~dcs_torchrl.ParallelSuiteEnv` (the first stepped
    in this process while spawned workers step the others), the pixel handling over the batch.
    ``render_device`` (an EGL device index, :func:`render_device`): the device every env renders on;
    envs that must render on another device than this process's all run in workers.
    """
    if num_workers < 1:
        raise ValueError(f"num_workers must be >= 1, got {num_workers}.")
    make = functools.partial(pixel_env, settings, frame_stack=frame_stack, image_size=image_size, render_profile=render_profile)
    elsewhere = render_device is not None and render_device != process_render_device()
    if backend == "warp" or (num_workers > 1 and not elsewhere):  # make_env's N envs: the batch, or a process each
        batched = make(backend=backend, num_envs=num_workers)
    elif num_workers == 1 and not elsewhere:
        batched = SerialEnv(1, make)
    else:  # every env in a worker that renders on the device asked
        batched = ParallelSuiteEnv(num_workers, make, render_devices=[render_device])
    if isinstance(batched, TransformedEnv):  # the warp batch and its pixel handling: one TransformedEnv
        batched.append_transform(RewardSum())
        env = batched
    else:
        env = TransformedEnv(batched, RewardSum())
    env.set_seed(seed)
    return env


def close_env(env: EnvBase | None) -> None:
    """Closes ``env`` (if any and not closed) and keeps this process's torch thread count
    (TorchRL's ``ParallelEnv.close`` raises it by the number of workers, up to torch's initial pool)."""
    if env is None:
        return
    threads = torch.get_num_threads()
    env.close(raise_if_closed=False)
    torch.set_num_threads(threads)
