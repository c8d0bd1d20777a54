"""make_env: one line from a task and a benchmark preset to a distracting pixel env."""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from types import MappingProxyType

from dm_control import suite
from torchrl.envs import Compose, DMControlEnv, EnvBase, ExcludeTransform, TransformedEnv

from dcs_torchrl import presets
from dcs_torchrl.distractions import BackgroundDistraction, CameraDistraction, ColorDistraction
from dcs_torchrl.distractions.background import as_video_source
from dcs_torchrl.render import PROFILES, RenderPixels


@dataclass(frozen=True)
class EnvSettings:
    """Every setting of a suite env, resolved from a preset plus overrides.

    ``num_videos`` is the number of videos actually used (a preset's ``None`` resolved
    to the size of the split). :meth:`as_dict` is what recipes record in ``results.json``.
    """

    domain: str
    task: str
    benchmark: str
    dynamic: bool
    camera_scale: float
    color_scale: float
    num_videos: int
    background_blend: float
    blind: bool
    background_split: str
    background_dir: str | None
    ground_alpha: float | None
    action_repeat: int
    camera_id: int
    reference_blend: bool
    texture_size: int

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


#: The renderers of :func:`make_env` (``backend``).
BACKENDS = ("gl", "warp")


def _check_task(domain: str, task: str) -> None:
    by_domain: dict[str, list[str]] = {}
    for d, t in suite.ALL_TASKS:
        by_domain.setdefault(d, []).append(t)
    if domain not in by_domain:
        raise ValueError(f"unknown dm_control domain {domain!r}; choose one of {sorted(by_domain)}.")
    if task not in by_domain[domain]:
        raise ValueError(f"unknown task {task!r} of domain {domain!r}; choose one of {by_domain[domain]}.")


#: The settings a user chooses (make_env's keywords, a recipe's ``env`` / ``eval_env`` groups):
#: every field of :class:`EnvSettings` but the task. ``None`` means the preset's / the task's.
ENV_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(EnvSettings) if f.name not in ("domain", "task"))
#: The options whose default is not ``None``.
OPTION_DEFAULTS = MappingProxyType(
    {"benchmark": "none", "dynamic": False, "background_split": "train", "reference_blend": False, "texture_size": 256})


def resolve_settings(domain: str, task: str, **options) -> EnvSettings:
    """The :class:`EnvSettings` :func:`make_env` builds from a preset and ``options`` (any of
    :data:`ENV_OPTIONS`; ``None`` or missing = the preset's, or the task's).

    Examples:
        >>> resolve_settings("cartpole", "swingup", benchmark="easy", dynamic=True).camera_scale
        0.1
    """
    unknown = sorted(set(options) - set(ENV_OPTIONS))
    if unknown:
        raise ValueError(f"unknown env setting(s) {unknown}: choose among {list(ENV_OPTIONS)}.")
    given = {k: v for k, v in options.items() if v is not None}
    o = {**OPTION_DEFAULTS, **given}
    _check_task(domain, task)
    if o["benchmark"] not in presets.BENCHMARKS:
        raise ValueError(f"unknown benchmark {o['benchmark']!r}; choose one of {list(presets.BENCHMARKS)}.")
    preset = presets.BENCHMARKS[o["benchmark"]]
    pick = lambda name, default: given.get(name, default)  # noqa: E731
    repeat = int(pick("action_repeat", presets.action_repeat(domain, task)))
    if repeat < 1:
        raise ValueError(f"action_repeat must be a positive integer, got {given['action_repeat']}.")
    videos = pick("num_videos", preset.num_videos)
    if videos is None:  # all videos of the split
        videos = len(as_video_source(o.get("background_dir"), o["background_split"]))
    blend = float(pick("background_blend", preset.background_blend))
    shows_videos = videos > 0 and blend > 0
    folder = o.get("background_dir")
    texture_size = int(o["texture_size"])
    if texture_size < 1:
        raise ValueError(f"texture_size must be a positive number of pixels, got {o['texture_size']!r}.")
    return EnvSettings(
        domain=domain,
        task=task,
        benchmark=o["benchmark"],
        dynamic=bool(o["dynamic"]),
        camera_scale=float(pick("camera_scale", preset.camera_scale)),
        color_scale=float(pick("color_scale", preset.color_scale)),
        num_videos=videos,
        background_blend=blend,
        blind=bool(pick("blind", preset.blind)),
        background_split=o["background_split"],
        background_dir=None if folder is None else os.fspath(folder),
        ground_alpha=pick("ground_alpha", presets.ground_alpha(domain) if shows_videos else None),
        action_repeat=repeat,
        camera_id=int(pick("camera_id", presets.default_camera(domain))),
        reference_blend=bool(o["reference_blend"]),
        texture_size=texture_size,
    )


def make_env(
    domain: str,
    task: str,
    *,
    benchmark: str = "none",
    dynamic: bool = False,
    seed: int | None = None,
    background_dir: str | os.PathLike | None = None,
    background_split: str = "train",
    expose_distractions: bool = False,
    camera_scale: float | None = None,
    color_scale: float | None = None,
    num_videos: int | None = None,
    background_blend: float | None = None,
    blind: bool | None = None,
    ground_alpha: float | None = None,
    action_repeat: int | None = None,
    camera_id: int | None = None,
    height: int = 84,
    width: int = 84,
    render_profile: str = "default",
    pixels_only: bool = True,
    texture_size: int = 256,
    reference_blend: bool = False,
    device=None,
    num_envs: int | None = None,
    backend: str = "gl",
    masks: bool = False,
) -> EnvBase:
    """A Distracting Control Suite env: dm_control physics, distractions, then one render.

    Builds ``TransformedEnv(DMControlEnv(domain, task, from_pixels=False,
    frame_skip=action_repeat), Compose(CameraDistraction, ColorDistraction,
    BackgroundDistraction, RenderPixels, ExcludeTransform(<state keys>)))`` from a benchmark preset
    (:data:`dcs_torchrl.BENCHMARKS`) and the paper's action repeat
    (:data:`dcs_torchrl.TASKS`); every setting can be overridden.

    Args:
        domain, task (str): a dm_control suite task, e.g. ``"cheetah", "run"``.

    Keyword Args:
        benchmark (str): ``"none"``, ``"easy"``, ``"medium"``, ``"blind"`` or ``"hard"``.
        dynamic (bool): distractions change every control step (else once per episode).
        seed (int, optional): seeds the physics and every distraction (``env.set_seed``);
            the pixel sequence is then reproducible bit for bit.
        background_dir (path, optional): a DAVIS 2017 ``JPEGImages/480p`` folder or any
            supported video folder; ``None`` uses the embedded default videos.
        background_split (str): ``"train"`` (the first b videos) or ``"val"`` (held out).
        expose_distractions (bool): add ``("distractions", "camera" | "color" |
            "background")`` to every observation, with specs.
        camera_scale, color_scale (float): β_cam, β_rgb overrides.
        num_videos (int): b override (``None`` = the preset's).
        background_blend (float): β_bg override.
        blind (bool): turn the camera backwards (the ``blind`` preset sets it).
        ground_alpha (float): floor opacity; defaults to the task's when videos are shown.
        action_repeat (int): frame skip; defaults to the paper's (its Table 1).
        camera_id (int): the camera to distract and render; defaults to the suite's.
        height, width (int): image size. Defaults to 84x84.
        render_profile (str): ``"default"`` or ``"fast"`` (see :class:`RenderPixels`).
        pixels_only (bool): drop the state observations (TorchRL's ``ExcludeTransform``
            after the render); ``False`` keeps them next to ``"pixels"``.
        texture_size (int): side of the background texture.
        reference_blend (bool): blend each episode's video onto the sky as this env last
            showed it, as the authors' 2021 code does (see :class:`BackgroundDistraction`),
            instead of onto the original sky as the paper describes. Only matters for β_bg < 1.
        device: TorchRL device of the env; with ``backend="warp"`` also where Warp renders
            (``"cpu"``, the default, or ``"cuda"``).
        num_envs (int, optional): with ``backend="warp"``, the number of envs of the batch
            (default 1); the env's batch size is then ``[num_envs]``.
        backend (str): ``"gl"`` (default): one env, rendered by MuJoCo's OpenGL renderer, the
            reference the paper's numbers are compared with. ``"warp"``: ``num_envs`` envs in this
            process, each with its own physics, task and distractions as on GL, rendered in one
            batch by MuJoCo Warp (:class:`dcs_torchrl.batched.BatchedSuiteEnv`; ``pip install
            "dcs-torchrl[warp]"``; docs/batched.md).
        masks (bool): add ``"masks"``, a uint8 label per pixel (0 background, 1 floor, 2 agent:
            :data:`dcs_torchrl.warp_render.MASK_LABELS`) from the render's segmentation;
            ``backend="warp"`` only.

    Examples:
        >>> import dcs_torchrl as dcs
        >>> env = dcs.make_env("cheetah", "run", benchmark="medium", dynamic=True, seed=0)
        >>> env.rollout(10)["next", "pixels"].shape
        torch.Size([10, 84, 84, 3])
    """
    if render_profile not in PROFILES:
        raise ValueError(f"unknown render_profile {render_profile!r}; choose one of {sorted(PROFILES)}.")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32):
        raise ValueError(f"seed must be a non-negative integer below 2**32 (or None), got {seed!r}.")
    s = resolve_settings(
        domain, task, benchmark=benchmark, dynamic=dynamic, camera_scale=camera_scale, color_scale=color_scale,
        num_videos=num_videos, background_blend=background_blend, blind=blind, background_split=background_split,
        background_dir=background_dir, ground_alpha=ground_alpha, action_repeat=action_repeat, camera_id=camera_id,
        reference_blend=reference_blend, texture_size=texture_size,
    )
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {list(BACKENDS)}.")
    if num_envs is not None and (isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1):
        raise ValueError(f"num_envs must be a positive integer (or None), got {num_envs!r}.")
    if backend == "gl":
        if num_envs is not None:
            raise ValueError(
                "num_envs is for backend='warp' (N envs in this process, rendered in one batch): pass "
                "backend='warp', or run GL envs in processes with "
                "dcs_torchrl.ParallelSuiteEnv(n, functools.partial(dcs_torchrl.make_env, domain, task, ...)).")
        if masks:
            raise ValueError("masks=True needs backend='warp' (its render gives the segmentation at no second "
                             "render); the GL backend has no masks.")
    expose = bool(expose_distractions)
    if backend == "warp":
        from dcs_torchrl.batched import WARP_PROFILES, BatchedSuiteEnv
        from dcs_torchrl.warp_render import import_warp

        import_warp()  # the extra's error first
        if render_profile not in WARP_PROFILES:
            raise ValueError(f"unknown render_profile {render_profile!r} for backend='warp'; choose one of "
                             f"{sorted(WARP_PROFILES)}.")
        worlds = [_distracted_env(s, expose) for _ in range(1 if num_envs is None else num_envs)]
        env = BatchedSuiteEnv(worlds, height=height, width=width, camera_id=s.camera_id,
                              device="cpu" if device is None else device, pixels_only=pixels_only, masks=masks,
                              render_profile=render_profile)
    else:
        env = _distracted_env(s, expose, device, RenderPixels(height, width, s.camera_id, profile=render_profile),
                              pixels_only)
    if seed is not None:
        env.set_seed(seed)
    return env


def _distracted_env(s: EnvSettings, expose: bool, device=None, render: RenderPixels | None = None,
                    pixels_only: bool = False) -> TransformedEnv:
    """The suite's env of settings ``s``: the three distractions, then ``render`` (if any), then the
    state observations dropped (``pixels_only``)."""
    kwargs = {} if device is None else {"device": device}
    base = DMControlEnv(s.domain, s.task, from_pixels=False, frame_skip=s.action_repeat, **kwargs)
    transforms = Compose(
        CameraDistraction(s.camera_scale, s.dynamic, camera_id=s.camera_id, blind=s.blind, expose=expose),
        ColorDistraction(s.color_scale, s.dynamic, expose=expose),
        BackgroundDistraction(
            s.background_dir, s.dynamic, num_videos=s.num_videos, blend=s.background_blend,
            ground_alpha=s.ground_alpha, split=s.background_split, texture_size=s.texture_size,
            reference_blend=s.reference_blend, expose=expose,
        ),
    )
    if render is not None:
        transforms.append(render)
    if pixels_only:
        transforms.append(ExcludeTransform(*base.observation_spec.keys(True, True)))
    return TransformedEnv(base, transforms)
