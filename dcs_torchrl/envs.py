"""make_env: one line from a task and a benchmark preset to a distracting pixel env."""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import os
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import torch
from dm_control import suite
from torchrl.envs import Compose, DMControlEnv, EnvBase, ExcludeTransform, TransformedEnv

from dcs_torchrl import presets
from dcs_torchrl.distractions import (BackgroundDistraction, CameraDistraction, ColorDistraction, LightingDistraction,
                                      TextureDistraction)
from dcs_torchrl.distractions.background import as_video_source
from dcs_torchrl.distractions.base import check_scale
from dcs_torchrl.distractions.texture import surface_slot
from dcs_torchrl.textures import TEXTURE_SPLITS
from dcs_torchrl.render.gl import RenderPixels, check_profile


def _option(default, meaning: str, *, scene: bool = True):
    """A field of :class:`EnvOptions`: its default and its one-line meaning (make_env's docstring);
    ``scene=False`` for an option of how the env is built and rendered, not of what it shows."""
    return dataclasses.field(default=default, metadata={"meaning": meaning, "scene": scene})


@dataclass(frozen=True)
class EnvOptions:
    """The options of a suite env, each declared once: name, type, default and meaning.

    :func:`make_env`'s keywords (its signature and docstring are made from these fields), the
    Gymnasium env's keywords (:class:`dcs_torchrl.gym_env.DistractingControlEnv`) and, for the
    scene options (:data:`SCENE_OPTIONS`), the recipes' ``env`` / ``eval_env`` config
    (``dcs_torchrl/training/conf/base.yaml``, checked against these fields by a test) and the
    resolved record :class:`EnvSettings`. ``None`` means the preset's, or the task's.

    Examples:
        >>> EnvOptions().benchmark, EnvOptions().camera_scale, "camera_scale" in SCENE_OPTIONS
        ('none', None, True)
    """

    # The scene: resolved into EnvSettings (what results.json records), a recipe's env config.
    benchmark: str = _option("none", '``"none"``, ``"easy"``, ``"medium"``, ``"blind"`` or ``"hard"`` '
                                     "(:data:`dcs_torchrl.BENCHMARKS`).")
    dynamic: bool = _option(False, "distractions change every control step (else once per episode).")
    camera_scale: float | None = _option(None, "β_cam override (``None`` = the preset's).")
    color_scale: float | None = _option(None, "β_rgb override (``None`` = the preset's).")
    num_videos: int | None = _option(None, "b override (``None`` = the preset's; every video of the split "
                                           "where the preset has none).")
    background_blend: float | None = _option(None, "β_bg override (``None`` = the preset's).")
    blind: bool | None = _option(None, "turn the camera backwards (the ``blind`` preset sets it).")
    background_split: str = _option("train", '``"train"`` (the first b videos) or ``"val"`` (held out).')
    background_dir: str | os.PathLike | None = _option(
        None, "a DAVIS 2017 ``JPEGImages/480p`` folder or any supported video folder; ``None`` uses the "
              "embedded default videos.")
    ground_alpha: float | None = _option(None, "floor opacity; defaults to the task's when videos are shown.")
    action_repeat: int | None = _option(None, "frame skip; defaults to the paper's (its Table 1).")
    camera_id: int | None = _option(None, "the camera to distract and render; defaults to the suite's.")
    reference_blend: bool = _option(
        False, "blend each episode's video onto the sky as this env last showed it, as the authors' 2021 code "
               "does (see :class:`BackgroundDistraction`), instead of onto the original sky as the paper "
               "describes. Only matters for β_bg < 1.")
    texture_size: int = _option(256, "side of the background texture.")
    light_scale: float = _option(0.0, "β_light in [0, 1]: the scene's lights turned, dimmed and tinted "
                                      "(:class:`LightingDistraction`; beyond the paper, docs/lighting_textures.md). "
                                      "0: the task's lighting.")
    texture_scale: float = _option(0.0, "β_tex in [0, 1]: the floor and the bodies textured from a set, blended "
                                        "with their own look by β_tex (:class:`TextureDistraction`; beyond the "
                                        "paper). 0: the task's surfaces.")
    texture_dir: str | os.PathLike | None = _option(
        None, "a folder of texture images (e.g. the Describable Textures Dataset's ``images``); ``None`` uses the "
              "stand-in textures made on first use.")
    texture_split: str = _option("train", '``"train"`` or ``"val"`` (held-out textures: every fifth image).')
    # How the env is built and rendered: make_env's (and the Gymnasium env's) only.
    seed: int | None = _option(None, "seeds the physics and every distraction (``env.set_seed``); the pixel "
                                     "sequence is then reproducible bit for bit.", scene=False)
    expose_distractions: bool = _option(False, 'add ``("distractions", "camera" | "color" | "background" | "lighting" | "texture")`` '
                                               "to every observation, with specs.", scene=False)
    height: int = _option(84, "image height.", scene=False)
    width: int = _option(84, "image width.", scene=False)
    render_profile: str = _option("default", '``"default"`` or ``"fast"`` (see :class:`RenderPixels`).',
                                  scene=False)
    pixels_only: bool = _option(True, "drop the state observations (TorchRL's ``ExcludeTransform`` after the "
                                      'render); ``False`` keeps them next to ``"pixels"``.', scene=False)
    device: torch.device | str | None = _option(
        None, 'TorchRL device of the env; with ``backend="warp"`` also where Warp renders (``"cpu"``, the '
              'default, or ``"cuda"``).', scene=False)
    num_envs: int | None = _option(None, "``N`` envs in one env of batch size ``[N]`` (pixels ``[N, H, W, 3]``), env "
                                         "``i`` seeded as TorchRL seeds its batched envs' workers: "
                                         '``backend="gl"``, one process each (:class:`dcs_torchrl.ParallelSuiteEnv`); '
                                         '``backend="warp"``, in this process (or ``processes``), rendered in one batch '
                                         "(required there). ``None``: one env, batch size ``[]`` (GL).", scene=False)
    backend: str = _option(
        "gl", '``"gl"`` (default): one env, rendered by MuJoCo\'s OpenGL renderer, the reference the paper\'s '
              'numbers are compared with. ``"warp"``: ``num_envs`` envs in this process (or ``processes``), each '
              "with its own physics, task and distractions as on GL, rendered in one batch by MuJoCo Warp "
              '(:class:`dcs_torchrl.vector.batched.BatchedSuiteEnv`; ``pip install "dcs-torchrl[warp]"``; '
              "docs/batched.md).", scene=False)
    processes: int | None = _option(
        None, '``backend="warp"``: step the ``num_envs`` envs in this many processes, each a Warp batch of '
              "its share (contiguous, near-equal) with its own physics, distractions and render, the first in "
              "this process (:class:`dcs_torchrl.ParallelSuiteEnv` with ``envs_per_worker``): the episodes and "
              "pixels of one batch, for a machine whose cores one process's Python cannot keep busy (a GPU box). "
              "``None`` or 1: one batch, in this process.", scene=False)
    masks: bool = _option(False, 'add ``"masks"``, a uint8 label per pixel (0 background, 1 floor, 2 agent: '
                                 ":data:`dcs_torchrl.render.warp.MASK_LABELS`) from the render's segmentation; "
                                 '``backend="warp"`` only.', scene=False)


#: The scene options of :class:`EnvOptions` (what :func:`resolve_settings` resolves, a recipe's
#: ``env`` / ``eval_env`` config holds and :class:`EnvSettings` records, after the task), in order.
SCENE_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(EnvOptions) if f.metadata["scene"])


def scene_options(settings) -> dict:
    """make_env's scene keyword arguments (:data:`SCENE_OPTIONS`) of resolved ``settings``
    (an :class:`EnvSettings`)."""
    return {k: getattr(settings, k) for k in SCENE_OPTIONS}


#: The settings of the distractions beyond the paper, each with the value at which its distraction is off:
#: :meth:`EnvSettings.as_dict` records them where their distraction is on, so that the record of an env
#: of the paper's settings (results.json, a dataset's metadata, a robustness point's identity) is what
#: it was before they existed.
BEYOND_PAPER = {"light_scale": ("light_scale", 0.0), "texture_scale": ("texture_scale", 0.0),
                "texture_dir": ("texture_scale", 0.0), "texture_split": ("texture_scale", 0.0)}


def _as_dict(self) -> dict:
    """The settings as a dict: what results.json's ``train_env`` / ``eval_env`` and a dataset's metadata
    record (the settings of :data:`BEYOND_PAPER` only where their distraction is on)."""
    return {k: v for k, v in dataclasses.asdict(self).items()
            if k not in BEYOND_PAPER or getattr(self, BEYOND_PAPER[k][0]) != BEYOND_PAPER[k][1]}


EnvSettings = dataclasses.make_dataclass(
    "EnvSettings",
    [("domain", str), ("task", str),
     *[(f.name, f.type) for f in dataclasses.fields(EnvOptions) if f.name in SCENE_OPTIONS]],
    frozen=True,
    namespace={"__module__": __name__, "as_dict": _as_dict, "__doc__": """\
Every setting of a suite env, resolved from a preset plus overrides (:func:`resolve_settings`):
the task, then each of :data:`SCENE_OPTIONS` (fields of :class:`EnvOptions`) with its value.

``num_videos`` is the number of videos actually used (a preset's ``None`` resolved to the size
of the split). :meth:`as_dict` is what recipes record in ``results.json``.
"""},
)


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


def resolve_settings(domain: str, task: str, **options) -> EnvSettings:
    """The :class:`EnvSettings` :func:`make_env` builds from a preset and ``options`` (any of
    :data:`SCENE_OPTIONS`; ``None`` or missing = the preset's, or the task's).

    Examples:
        >>> resolve_settings("cartpole", "swingup", benchmark="easy", dynamic=True).camera_scale
        0.1
    """
    unknown = sorted(set(options) - set(SCENE_OPTIONS))
    if unknown:
        raise ValueError(f"unknown env setting(s) {unknown}: choose among {list(SCENE_OPTIONS)}.")
    given = {k: v for k, v in options.items() if v is not None}
    defaults = {f.name: f.default for f in dataclasses.fields(EnvOptions) if f.name in SCENE_OPTIONS}
    o = {**{k: v for k, v in defaults.items() if v is not None}, **given}
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
        light_scale=check_scale("light_scale", o["light_scale"]),
        texture_scale=check_scale("texture_scale", o["texture_scale"]),
        texture_dir=None if o.get("texture_dir") is None else os.fspath(o["texture_dir"]),
        texture_split=_texture_split(o["texture_split"]),
    )


def _texture_split(split: str) -> str:
    if split not in TEXTURE_SPLITS:
        raise ValueError(f"unknown texture_split {split!r}; choose one of {list(TEXTURE_SPLITS)}.")
    return split


def make_env(domain: str, task: str, **options) -> EnvBase:
    """A Distracting Control Suite env: dm_control physics, distractions, then one render.

    Builds ``TransformedEnv(DMControlEnv(domain, task, from_pixels=False,
    frame_skip=action_repeat), Compose(CameraDistraction, ColorDistraction,
    BackgroundDistraction, [LightingDistraction], [TextureDistraction], RenderPixels,
    ExcludeTransform(<state keys>)))``, the lighting and texture distractions (beyond the paper) only where
    ``light_scale`` / ``texture_scale`` is not 0 from a benchmark preset
    (:data:`dcs_torchrl.BENCHMARKS`) and the paper's action repeat
    (:data:`dcs_torchrl.TASKS`); every setting can be overridden.

    Args:
        domain, task (str): a dm_control suite task, e.g. ``"cheetah", "run"``.

    Keyword Args:
        <the fields of EnvOptions>

    Examples:
        >>> import dcs_torchrl as dcs
        >>> env = dcs.make_env("cheetah", "run", benchmark="medium", dynamic=True, seed=0)
        >>> env.rollout(10)["next", "pixels"].shape
        torch.Size([10, 84, 84, 3])
    """
    unknown = sorted(set(options) - {f.name for f in dataclasses.fields(EnvOptions)})
    if unknown:
        raise TypeError(f"make_env() got unknown keyword argument(s) {unknown}: choose among "
                        f"{[f.name for f in dataclasses.fields(EnvOptions)]} (dcs_torchrl.EnvOptions).")
    o = EnvOptions(**options)
    _check_options(o)
    s = resolve_settings(domain, task, **{k: v for k, v in options.items() if k in SCENE_OPTIONS})
    if o.backend == "gl" and o.masks:
        raise ValueError("masks=True needs backend='warp' (its render gives the segmentation at no second "
                         "render); the GL backend has no masks.")
    if o.backend == "warp" and o.num_envs is None:
        raise ValueError("backend='warp' renders a batch: pass num_envs=N (an env of batch size [N]; N=1 for one "
                         "env), or backend='gl' (the default) for one unbatched env.")
    if o.backend == "warp" and (o.processes or 1) > 1:  # P batches, one per process: a chain of batches
        from dcs_torchrl.vector._batching import shares
        from dcs_torchrl.vector.batch_physics import threads_among
        from dcs_torchrl.vector.parallel import ParallelSuiteEnv

        sizes = [len(part) for part in shares(o.num_envs, o.processes)]
        threads = threads_among(o.processes)
        share = dataclasses.replace(o, seed=None, processes=None)
        env = ParallelSuiteEnv(o.processes, [functools.partial(_warp_share, s, share, k, threads) for k in sizes],
                               envs_per_worker=sizes, device=o.device)
    elif o.backend == "warp":
        env = _warp_env([(s, o.num_envs)], o)
    elif o.num_envs is not None:  # N GL envs, one process each: env i is make_env(...) seeded by the chain
        from dcs_torchrl.vector.parallel import ParallelSuiteEnv

        one = {k: v for k, v in options.items() if k not in ("num_envs", "seed", "device")}
        env = ParallelSuiteEnv(o.num_envs, functools.partial(make_env, domain, task, **one), device=o.device)
    else:
        render = RenderPixels(o.height, o.width, s.camera_id, profile=o.render_profile)
        env = _distracted_env(s, bool(o.expose_distractions), o.device, render, o.pixels_only)
    if o.seed is not None:
        env.set_seed(o.seed)
    return env


def make_grouped_env(domain: str, task: str, groups: Sequence[tuple[Mapping, int]], **options) -> EnvBase:
    """One batched env (``backend="warp"``) holding several settings' envs: ``groups`` is a sequence of
    ``(settings, num_envs)``, ``settings`` make_env's scene settings (``{"camera_scale": 0.4}``, ``{}``:
    the preset's), ``options`` make_env's others (``height``, ``device``, ``seed``, ...).

    The envs lie group after group (batch size ``[sum of num_envs]``); ``set_seed`` seeds each group
    from the same seed, as a batch of its own, so each group runs the episodes and distraction draws of
    ``make_env(domain, task, **settings, num_envs=num_envs, backend="warp")`` seeded alike, with the
    same pixels. What one render of the batch cannot mix is refused: groups that show background
    videos beside groups that show none (build them apart), or videos at two ``texture_size``.

    Examples:
        >>> import dcs_torchrl as dcs
        >>> env = dcs.make_grouped_env("cartpole", "swingup", [({"camera_scale": 0.2}, 2), ({"color_scale": 0.5}, 3)],
        ...                            height=32, width=32, seed=0)
        >>> env.rollout(2)["next", "pixels"].shape
        torch.Size([5, 2, 32, 32, 3])
    """
    given = sorted(set(options) & (set(SCENE_OPTIONS) | {"backend", "num_envs"}))
    if given:
        raise TypeError(f"make_grouped_env() got {given}: scene settings go in each group's settings, and the "
                        "backend ('warp') and the envs per group are the groups' (settings, num_envs).")
    o = EnvOptions(**options, backend="warp")
    _check_options(o)
    if (o.processes or 1) > 1:
        raise ValueError("make_grouped_env renders its groups in one batch, in this process: leave processes out "
                         "(or build each group with make_env(..., num_envs=n, backend='warp', processes=p)).")
    resolved = []
    for group in groups:
        if not (isinstance(group, tuple) and len(group) == 2 and isinstance(group[0], Mapping)):
            raise TypeError(f"each group is a (settings dict, num_envs) pair, got {group!r}.")
        settings, count = group
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"each group's num_envs must be a positive integer, got {count!r}.")
        resolved.append((resolve_settings(domain, task, **settings), count))
    if not resolved:
        raise ValueError("make_grouped_env needs at least one (settings, num_envs) group.")
    if len({s.camera_id for s, _ in resolved}) > 1:
        raise ValueError("the groups render different cameras (camera_id): one batch renders one camera; "
                         "build them in separate batches.")
    env = _warp_env(resolved, o)
    if o.seed is not None:
        env.set_seed(o.seed)
    return env


def _check_options(o: EnvOptions) -> None:
    check_profile(o.render_profile)
    if o.seed is not None and (isinstance(o.seed, bool) or not isinstance(o.seed, int) or not 0 <= o.seed < 2**32):
        raise ValueError(f"seed must be a non-negative integer below 2**32 (or None), got {o.seed!r}.")
    if o.backend not in BACKENDS:
        raise ValueError(f"unknown backend {o.backend!r}; choose one of {list(BACKENDS)}.")
    if o.num_envs is not None and (isinstance(o.num_envs, bool) or not isinstance(o.num_envs, int) or o.num_envs < 1):
        raise ValueError(f"num_envs must be a positive integer (or None), got {o.num_envs!r}.")
    if o.processes is not None:
        if isinstance(o.processes, bool) or not isinstance(o.processes, int) or o.processes < 1:
            raise ValueError(f"processes must be a positive integer (or None), got {o.processes!r}.")
        if o.backend != "warp":
            raise ValueError("processes splits a Warp batch (backend='warp'); the GL backend already steps each of "
                             "its num_envs envs in a process of its own: leave processes out.")
        if o.num_envs is not None and o.processes > o.num_envs:
            raise ValueError(f"processes={o.processes} is more than the num_envs={o.num_envs} envs to share among "
                             "them: pass processes <= num_envs.")


def _warp_share(s: EnvSettings, o: EnvOptions, num_envs: int, physics_threads: int | None) -> EnvBase:
    """One process's batch of ``make_env(..., processes=P)``: ``num_envs`` envs of settings ``s``, their
    physics on ``physics_threads`` threads (``None``: every core), unseeded (the chain through the batches seeds it)."""
    return _warp_env([(s, num_envs)], o, physics_threads)


def _warp_env(groups: list[tuple[EnvSettings, int]], o: EnvOptions, physics_threads: int | None = None) -> EnvBase:
    """The :class:`~dcs_torchrl.vector.batched.BatchedSuiteEnv` of ``groups`` (settings, envs), unseeded."""
    from dcs_torchrl.render.warp import import_warp
    from dcs_torchrl.vector.batched import BatchedSuiteEnv, compact_skies

    import_warp()  # the extra's error first
    expose = bool(o.expose_distractions)
    first = groups[0][0]
    # every world has the distractions beyond the paper that any group uses: one set of states for all
    beyond = (any(s.light_scale > 0 for s, _ in groups), any(s.texture_scale > 0 for s, _ in groups))
    worlds = [_distracted_env(first, expose, beyond=beyond)]  # the batch renders from its model
    for s, count in groups:
        with compact_skies(s):  # the others' skies are never rendered: their models hold a small one
            worlds += [_distracted_env(s, expose, beyond=beyond) for _ in range(count - (s is first))]
    return BatchedSuiteEnv(worlds, height=o.height, width=o.width, camera_id=first.camera_id,
                           device="cpu" if o.device is None else o.device, pixels_only=o.pixels_only,
                           masks=o.masks, render_profile=o.render_profile, groups=[count for _, count in groups],
                           physics_threads=physics_threads)


def _keyword_docs() -> str:
    """make_env's "Keyword Args" entries: each field of :class:`EnvOptions` with its type and meaning."""
    lines = []
    for f in dataclasses.fields(EnvOptions):
        lines += textwrap.wrap(f"{f.name} ({f.type}): {f.metadata['meaning']}", 100, initial_indent=" " * 8,
                               subsequent_indent=" " * 12, break_on_hyphens=False)
    return "\n".join(lines).lstrip()


if make_env.__doc__:  # None under python -OO
    make_env.__doc__ = make_env.__doc__.replace("<the fields of EnvOptions>", _keyword_docs())
make_env.__signature__ = inspect.Signature(
    [inspect.Parameter("domain", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation="str"),
     inspect.Parameter("task", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation="str"),
     *[inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=f.type)
       for f in dataclasses.fields(EnvOptions)]],
    return_annotation="EnvBase")


def _distracted_env(s: EnvSettings, expose: bool, device=None, render: RenderPixels | None = None,
                    pixels_only: bool = False, beyond: tuple[bool, bool] | None = None) -> TransformedEnv:
    """The suite's env of settings ``s``: the paper's three distractions, the lighting and texture ones where
    ``beyond`` (``(lighting, texture)``; ``None``: where their scale is not 0, so that an env of the paper's
    settings is today's, transform for transform), then ``render`` (if any), then the state observations
    dropped (``pixels_only``)."""
    lighting, texture = (s.light_scale > 0, s.texture_scale > 0) if beyond is None else beyond
    kwargs = {} if device is None else {"device": device}
    with surface_slot() if s.texture_scale > 0 else contextlib.nullcontext():  # the bodies' texture
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
    if lighting:
        transforms.append(LightingDistraction(s.light_scale, s.dynamic, expose=expose))
    if texture:
        transforms.append(TextureDistraction(s.texture_scale, texture_dir=s.texture_dir, split=s.texture_split,
                                             expose=expose))
    if render is not None:
        transforms.append(render)
    if pixels_only:
        transforms.append(ExcludeTransform(*base.observation_spec.keys(True, True)))
    return TransformedEnv(base, transforms)
