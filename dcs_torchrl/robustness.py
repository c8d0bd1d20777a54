"""An agent's robustness curves: its score as each distraction grows (the paper's Fig. 4, one agent).

    python -m dcs_torchrl.robustness sac_rad_cartpole_swingup --out robustness
    python -m dcs_torchrl.robustness <run or exported agent directory> --setting both --episodes 20 \\
        --intensities 0 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8 0.9 1

Each point sets one distraction alone over the agent's training env (camera β_cam, colour β_rgb,
or background blend β_bg with b = 60 videos, the paper's experiment 1, Stone et al. 2021, Sec. 5.1;
beyond the paper, lighting β_light and surface textures β_tex: docs/lighting_textures.md), static or
dynamic, and runs the recipes' final evaluation there (:meth:`dcs_torchrl.pretrained.Pretrained.evaluate`:
the deterministic policy, ``--episodes`` episodes in one env seeded as the training run's final
evaluation). Points are spread over ``--workers`` processes, one point per process at a time, so
every episode's return is the one a single-env evaluation gives. Intensity 0 is the same
undistracted env on every axis and is evaluated once. The texture axis is swept static only,
whatever ``--setting``: a texture is drawn once an episode in either setting (``dynamic`` has no
effect on it), so a dynamic texture curve would be the static one evaluated again.

The output directory gets ``points/`` (one JSON file per evaluated point: what defines it,
returns), ``robustness.csv`` (a row per point), ``robustness.md`` (the half-score intensity per
axis and the curves as a table) and ``robustness.png``. Run again, it evaluates only the points
it does not hold yet, so an interrupted sweep resumes. A stored point counts as held only where
everything that defines it matches this run: the episodes, the agent's checkpoint (its SHA-256),
every resolved env setting (a changed default included) and the videos shown (the embedded
stand-ins' version, or a ``--background-dir``'s path and a digest of its files' names and
sizes); otherwise the point is evaluated again, and the CSV, table and figure hold only this
run's points. An ``--out`` holding another agent's points, or this agent's from another
checkpoint (retrained under the same name), is refused: choose another ``--out``. An agent whose
checkpoint holds more than tensors, numbers and strings (unpickling it could run code) is refused
unless ``--trust-checkpoint`` (:func:`dcs_torchrl.pretrained.load_pretrained`).
:func:`robustness_sweep` does the same for any TorchRL policy and env factory.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from dcs_torchrl.training.rundir import write_json_atomic

__all__ = ["AXES", "STATIC_ONLY", "Point", "sweep_points", "robustness_sweep", "sweep_agent", "write_outputs", "main"]

#: The command's axis names -> the sweep axes of results.json and the report
#: (:data:`dcs_torchrl.report.experiments.SWEEP_AXES` says which make_env settings each sets).
AXES = {"camera": "camera", "color": "color", "background": "background_blend", "light": "light", "texture": "texture"}
#: The axes swept static only whatever the setting: their distraction is drawn once an episode either way
#: (:class:`dcs_torchrl.TextureDistraction`), so their dynamic points would repeat the static ones.
STATIC_ONLY = frozenset({"texture"})
QUICK_INTENSITIES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
SETTINGS = {"static": (False,), "dynamic": (True,), "both": (False, True)}
#: The renderers of ``--backend``, as the outputs name them: scores compare on one renderer only
#: (docs/results.md, "Warp backend").
RENDERERS = {"gl": "rendered by MuJoCo's OpenGL renderer (GL)", "warp": "rendered by MuJoCo Warp"}


@dataclass(frozen=True)
class Point:
    """One point of a sweep: a distraction axis at an intensity, static or dynamic.

    ``reference_blend`` (background axis only) blends as the authors' 2021 code does
    (:class:`dcs_torchrl.BackgroundDistraction`).
    """

    axis: str
    value: float
    dynamic: bool
    reference_blend: bool = False

    def __post_init__(self):
        if self.axis not in AXES:
            raise ValueError(f"unknown axis {self.axis!r}: choose among {list(AXES)}.")
        if self.dynamic and self.axis in STATIC_ONLY:
            raise ValueError(f"the {self.axis} axis is static only (its distraction is drawn once an episode "
                             "whatever the setting): give dynamic=False.")

    def overrides(self, background_dir: str | None = None, num_videos: int = 60,
                  texture_dir: str | None = None) -> dict:
        """The make_env settings of this point (none at intensity 0: the undistracted env);
        ``background_dir`` is the background axis' video folder (``None``: the embedded videos),
        ``num_videos`` how many of its videos it uses (the paper: b = 60), ``texture_dir`` the texture
        axis' image folder (``None``: the agent's own setting, by default the stand-in textures)."""
        from dcs_torchrl.report.experiments import SWEEP_AXES

        if self.value == 0:
            return {}
        axis = SWEEP_AXES[self.sweep_axis]
        out = {axis.key: float(self.value), **axis.fixed, "dynamic": self.dynamic}
        if "num_videos" in out:  # b = 60 (the paper's Sec. 5.1), or all of a folder that holds fewer
            out["num_videos"] = num_videos
        if background_dir is not None and self.axis == "background":
            out["background_dir"] = os.fspath(background_dir)
        if texture_dir is not None and self.axis == "texture":
            out["texture_dir"] = os.fspath(texture_dir)
        return out

    @property
    def sweep_axis(self) -> str:
        """The axis of results.json and the report (the 2021 code's blend is its own axis there)."""
        return "background_blend_2021" if self.reference_blend else AXES[self.axis]

    def key(self, background_dir: str | None = None, num_videos: int = 60, texture_dir: str | None = None) -> str:
        """The same for every point of the same env (all points at intensity 0 share one)."""
        return json.dumps(self.overrides(background_dir, num_videos, texture_dir), sort_keys=True)


def sweep_points(axes: Iterable[str] = tuple(AXES), intensities: Iterable[float] = QUICK_INTENSITIES,
                 setting: str = "static", reference_blend: bool | str = False) -> list[Point]:
    """The points of a sweep, axis by axis (``reference_blend``: ``False``, ``True`` or ``"both"``,
    for the background axis). The axes of :data:`STATIC_ONLY` (texture) get static points only,
    whatever ``setting``.

    Examples:
        >>> [(p.value, p.dynamic) for p in sweep_points(["camera"], [0.0, 0.5], "both")]
        [(0.0, False), (0.5, False), (0.0, True), (0.5, True)]
        >>> [p.sweep_axis for p in sweep_points(["background"], [0.5], reference_blend="both")]
        ['background_blend', 'background_blend_2021']
        >>> [(p.axis, p.dynamic) for p in sweep_points(["light", "texture"], [0.5], "both")]
        [('light', False), ('light', True), ('texture', False)]
    """
    unknown = sorted(set(axes) - set(AXES))
    if unknown:
        raise ValueError(f"unknown axes {unknown}: choose among {list(AXES)}.")
    if setting not in SETTINGS:
        raise ValueError(f"unknown setting {setting!r}: choose one of {list(SETTINGS)}.")
    values = [float(v) for v in intensities]
    bad = [v for v in values if not 0.0 <= v <= 1.0]
    if bad or not values:
        raise ValueError(f"intensities must be in [0, 1] (at least one), got {values}.")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise ValueError(f"intensities {repeated} are given more than once: give each once.")
    blends = {False: (False,), True: (True,), "both": (False, True)}[reference_blend]
    return [Point(axis, value, dynamic, blend) for axis in axes for blend in (blends if axis == "background" else (False,))
            for dynamic in _settings(axis, setting) for value in values]


def _settings(axis: str, setting: str) -> tuple[bool, ...]:
    """The ``dynamic`` values of ``axis``' points under ``setting`` (static only: :data:`STATIC_ONLY`)."""
    return (False,) if axis in STATIC_ONLY else SETTINGS[setting]


def _progress(items, enabled: bool, desc: str = "robustness"):
    """A bar over ``items``, the distinct envs evaluated (comparable work each: one setting's episodes).
    Its rate is the mean since the start and every update is drawn, so that points finishing together
    (a Warp batch) count at once."""
    from tqdm import tqdm

    return tqdm(items, unit="point", disable=not enabled or not items, desc=desc, smoothing=0, mininterval=0)


def robustness_sweep(policy, make_env: Callable[..., object], points: Sequence[Point], *, episodes: int = 10,
                     seed: int = 0, progress: bool = False) -> list[dict]:
    """Evaluates any TorchRL ``policy`` at every point, in this process.

    Args:
        policy: a TensorDict module writing ``"action"`` (run deterministically).
        make_env: called as ``make_env(**overrides)`` with a point's make_env settings
            (``camera_scale``, ``dynamic``, ...; none at intensity 0), returns the env to evaluate.
        points: :func:`sweep_points`.

    Keyword Args:
        episodes: episodes per point, in one env seeded with ``seed``
            (:func:`dcs_torchrl.evaluation.protocol.evaluate`).

    Returns:
        one row per point (:func:`write_outputs` reads them).

    Examples:
        >>> import dcs_torchrl as dcs
        >>> def make_env(**overrides):
        ...     return dcs.make_env("cartpole", "balance", height=32, width=32, **overrides)
        >>> policy = lambda td: td.set("action", td["pixels"].new_zeros(1).float())
        >>> rows = robustness_sweep(policy, make_env, sweep_points(["color"], [0.0, 1.0]), episodes=1)
        >>> [(r["axis"], r["value"], r["episodes"]) for r in rows]
        [('color', 0.0, 1), ('color', 1.0, 1)]
    """
    from dcs_torchrl.evaluation.protocol import evaluate

    def run(overrides: dict) -> dict:
        env = make_env(**overrides)
        try:
            return evaluate(env, policy, episodes, seed=seed).to_dict()
        finally:
            env.close(raise_if_closed=False)

    distinct = {p.key(): p for p in points}  # intensity 0 is one env on every axis
    done = {key: run(point.overrides()) for key, point in _progress(list(distinct.items()), progress)}
    return [_row(p, done[p.key()]) for p in points]


def _row(point: Point, result: dict, **extra) -> dict:
    return {**extra, **asdict(point), "setting": "dynamic" if point.dynamic else "static",
            "mean": result["mean"], "stderr": result["stderr"], "episodes": result["episodes"],
            "returns": result["returns"]}


# ------------------------------------------------------------------ a trained agent
#: What defines a stored point (:func:`_point_id`): it is reused only where all of it matches.
IDENTITY = ("agent", "env", "pixels", "episodes")
_WHO = ("method", "domain", "task", "seed", "steps")


def _agent_identity(directory: Path, results: dict) -> dict:
    """Whose points: the run's method, task, seed and frames, and the SHA-256 of the checkpoint
    evaluated (an agent retrained or exported again under the same name has another)."""
    from dcs_torchrl.pretrained import checkpoint_sha256

    return {key: results[key] for key in _WHO} | {"checkpoint_sha256": checkpoint_sha256(directory)}


def _listing_sha256(folder: Path) -> str:
    """A digest of the path and size of every file below ``folder``: another set of videos there changes it."""
    entries = []
    for root, _, files in os.walk(folder, followlinks=True):
        for name in files:
            path = Path(root, name)
            entries.append(f"{path.relative_to(folder).as_posix()}\t{path.stat().st_size}")
    return hashlib.sha256("\n".join(sorted(entries)).encode()).hexdigest()


def _point_env(config: dict, overrides: dict, listings: dict[str, str]) -> dict:
    """Every resolved make_env setting of a point, and the videos and textures it shows: the embedded
    stand-in videos' version (``embedded_videos``), or a folder's ``background_listing``
    (:func:`_listing_sha256`, computed once per folder in ``listings``); likewise the stand-in
    textures' version (``standin_textures``, :func:`~dcs_torchrl.results.with_videos_version`) or a
    ``texture_dir``'s ``texture_listing``. The folders
    stay as the user gave them (a record names no directory of this machine that the user did not
    write); the listings identify their files. The settings of lighting and textures are there only where
    their distraction is on (:meth:`dcs_torchrl.EnvSettings.as_dict`), so the points of the other axes
    keep the identity they had before lighting and textures existed."""
    from dcs_torchrl.pretrained import agent_env_settings
    from dcs_torchrl.results import shows_videos, with_videos_version

    env = with_videos_version(agent_env_settings(config, overrides).as_dict())
    if shows_videos(env) and env["background_dir"]:
        env |= {"background_listing": _listing(env["background_dir"], listings)}
    if env.get("texture_scale", 0.0) > 0 and env.get("texture_dir"):
        env |= {"texture_listing": _listing(env["texture_dir"], listings)}
    return env


def _listing(directory: str, listings: dict[str, str]) -> str:
    """:func:`_listing_sha256` of ``directory`` (as given: ``~`` or relative), once per folder in ``listings``."""
    folder = os.fspath(Path(directory).expanduser().resolve())
    if folder not in listings:
        listings[folder] = _listing_sha256(Path(folder))
    return listings[folder]


def _point_identities(agent: dict, results: dict, settings: dict[str, dict], episodes: int,
                      backend: str = "gl") -> dict[str, dict]:
    """Per point key, what defines its stored point (:data:`IDENTITY`); the pixels of another
    backend than GL's, the reference, name it (a GL point's identity is as it always was)."""
    from omegaconf import OmegaConf

    from dcs_torchrl.training.envs import pixel_options

    pixels = pixel_options(OmegaConf.create(results["config"]).pixels)
    if backend != "gl":
        pixels = {**pixels, "backend": backend}
    listings: dict[str, str] = {}
    return {key: {"agent": agent, "env": _point_env(results["config"], overrides, listings), "pixels": pixels,
                  "episodes": episodes} for key, overrides in settings.items()}


def _point_id(record: dict) -> str:
    """The SHA-256 of what defines a point (:data:`IDENTITY`), read from a record or an identity.

    A folder of videos (of textures) counts by its ``background_listing`` (``texture_listing``: its
    files' names and sizes), not by the path it was given as: the same folder by another path (relative,
    ``~``, absolute) is the same point, in records written before paths were kept as given too."""
    identity = {k: record.get(k) for k in IDENTITY}
    env = identity.get("env")
    if isinstance(env, dict):
        listed = {"background_dir": "background_listing", "texture_dir": "texture_listing"}
        identity["env"] = {k: v for k, v in env.items() if not env.get(listed.get(k, ""))}
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def _check_agent(theirs: dict, ours: dict, out: str | os.PathLike) -> None:
    """Refuses ``out`` holding the points of another agent, or of this one's name from another checkpoint."""
    if any(theirs.get(k) != ours[k] for k in _WHO):
        raise FileExistsError(f"{out} holds points of another agent ({theirs}); nothing was changed: "
                              "choose another --out for this one.")
    stored, loaded = str(theirs.get("checkpoint_sha256")), ours["checkpoint_sha256"]
    if stored != loaded:
        raise FileExistsError(
            f"{out} holds points of {ours['method']} {ours['domain']} {ours['task']} seed {ours['seed']} from another "
            f"checkpoint (SHA-256 {stored[:12]}…, this one {loaded[:12]}…: retrained or exported again under the same "
            "name); nothing was changed: choose another --out for this one.")


def _stored_points(stored: Path, agent: dict, out: str | os.PathLike) -> dict[str, dict]:
    """The evaluations in ``stored`` by point id (:func:`_point_id`), once every one is checked to be ``agent``'s."""
    records = [json.loads(path.read_text()) for path in sorted(stored.glob("*.json"))]
    for record in records:
        _check_agent(record.get("agent", {}), agent, out)
    return {_point_id(record): record["eval"] for record in records}


def _background(background_dir: str | os.PathLike | None, num_videos: int | None = None) -> tuple[str | None, int]:
    """The background axis' folder (``None``: the embedded videos) and its b: ``num_videos``, or
    by default 60 videos (the paper's, Sec. 5.1) or all of a folder that holds fewer."""
    from dcs_torchrl.distractions.background import as_video_source

    if num_videos is not None and num_videos < 1:
        raise ValueError(f"--num-videos must be >= 1 (the first b training videos), got {num_videos}.")
    if background_dir is not None:
        background_dir = os.fspath(background_dir)  # as given: the video sources expand ~ themselves
        if not Path(background_dir).expanduser().is_dir():
            raise FileNotFoundError(f"--background-dir {background_dir} is not a directory: point it at DAVIS 2017's "
                                    "JPEGImages/480p (or a folder of videos), or leave it out for the embedded videos.")
    available = len(as_video_source(background_dir, "train"))
    if num_videos is None:
        return background_dir, min(60, available)
    if num_videos > available:
        where = background_dir or "the embedded stand-in set"
        raise ValueError(f"--num-videos {num_videos}: {where} holds {available} training videos; "
                         f"choose at most {available}.")
    return background_dir, num_videos


def _textures(texture_dir: str | os.PathLike | None) -> str | None:
    """The texture axis' folder as given (``None``: the agent's setting), refused here, before anything is
    evaluated, where make_env would refuse it (missing, a file, no images, too few for a split)."""
    if texture_dir is None:
        return None
    from dcs_torchrl.textures import texture_set

    texture_set(texture_dir, "train")
    return os.fspath(texture_dir)


def sweep_agent(agent: str | os.PathLike, points: Sequence[Point], out: str | os.PathLike, *, episodes: int = 10,
                workers: int = 1, background_dir: str | os.PathLike | None = None, num_videos: int | None = None,
                progress: bool = True, render_devices: Sequence[int | str] | None = None,
                backend: str = "gl", trust_checkpoint: bool = False,
                texture_dir: str | os.PathLike | None = None) -> list[dict]:
    """Evaluates a trained agent (shipped name, exported agent or finished run) at every point.

    Each evaluated point is written to ``out/points/<id>.json`` as soon as it is done. A stored
    point is reused only where everything that defines it (:data:`IDENTITY`) matches: the
    episodes, the agent (method, task, seed, frames and its checkpoint's SHA-256), every resolved
    make_env setting and the pixels the policy sees, and the videos shown (the embedded
    stand-ins' version, or a digest of a folder's files' names and sizes; its path is kept as given). Other
    points are evaluated (stored ones that do not match stay, for a run that matches them).
    ``out`` holding another agent's points, or this agent's from another checkpoint, is refused
    before anything is evaluated. ``workers`` processes each evaluate whole points, worker ``i``
    rendering on ``render_devices[i % len]`` (EGL indices or ``"cuda:N"``; ``None``: this
    process's device; :func:`dcs_torchrl.evaluation.scheduling.evaluate_settings`). The background
    axis shows the first ``num_videos`` training videos (default: 60, the paper's b, or all of a
    folder that holds fewer); the texture axis the images of ``texture_dir`` (a folder of the user's,
    e.g. DTD's ``dtd/images``, its training split; ``None``: the agent's own env setting, by default
    the stand-in textures). ``backend="warp"``: several points' episodes all at once, in one batched
    env rendered by MuJoCo Warp (:meth:`~dcs_torchrl.pretrained.Pretrained.evaluate_each`: each point's
    returns those of its own ``evaluate(backend="warp")``); its points are stored apart from GL's.
    ``trust_checkpoint``: as :func:`~dcs_torchrl.pretrained.load_pretrained` (off: an agent whose
    checkpoint holds more than tensors, numbers and strings is refused).

    Returns:
        the rows of ``points`` only (:func:`write_outputs`).
    """
    from dcs_torchrl.evaluation.scheduling import evaluate_settings
    from dcs_torchrl.pretrained import agent_directory, agent_results
    from dcs_torchrl.render.egl_devices import render_device_indices

    directory = agent_directory(agent)
    results = agent_results(directory)
    if episodes < 1 or workers < 1:
        raise ValueError(f"episodes and workers must be >= 1, got {episodes} and {workers}.")
    devices = render_device_indices(render_devices)  # a device this machine lacks: refused before anything is written
    background_dir, num_videos = _background(background_dir, num_videos)
    texture_dir = _textures(texture_dir)
    keys = [p.key(background_dir, num_videos, texture_dir) for p in points]
    settings = {key: p.overrides(background_dir, num_videos, texture_dir) for key, p in zip(keys, points)}
    identity = _agent_identity(directory, results)
    if backend not in ("gl", "warp"):
        raise ValueError(f"unknown backend {backend!r}; choose 'gl' or 'warp'.")
    identities = _point_identities(identity, results, settings, episodes, backend)
    stored = Path(out) / "points"
    stored.mkdir(parents=True, exist_ok=True)
    done = _stored_points(stored, identity, out)
    todo = {key: overrides for key, overrides in settings.items() if _point_id(identities[key]) not in done}
    bar = _progress(list(todo), progress, f"robustness ({backend})")
    for key, result, _ in evaluate_settings(directory, todo, episodes, processes=workers, render_devices=devices,
                                            backend=backend, trust_checkpoint=trust_checkpoint):
        point_id = _point_id(identities[key])
        done[point_id] = result
        write_json_atomic(stored / f"{point_id[:16]}.json", {**identities[key], "overrides": todo[key], "eval": result})
        bar.update(1)
    bar.close()
    who = {k: identity[k] for k in ("method", "domain", "task", "seed")} | {"backend": backend}
    return [_row(p, done[_point_id(identities[key])], **who) for p, key in zip(points, keys)]


# --------------------------------------------------------------------------------- outputs
CSV_COLUMNS = ("method", "domain", "task", "seed", "backend", "axis", "setting", "reference_blend", "value", "mean",
               "stderr", "episodes")


def write_outputs(rows: Sequence[dict], out: str | os.PathLike, title: str = "", num_videos: int = 60) -> dict[str, Path]:
    """``robustness.csv``, ``robustness.md`` (half-score intensity per axis, curves) and
    ``robustness.png`` (one panel per axis, as the report's robustness figure) in ``out``;
    ``num_videos``: the background axis' b. Rows of :func:`sweep_agent` name their renderer
    (``backend``): the csv has it in a column, the table's heading and the figure's title say it;
    rows of two renderers are refused (compare scores on one renderer only)."""
    import pandas as pd

    from dcs_torchrl.report.curves import (BLEND_2021, beyond_paper_note, blend_suffix, half_score_table, half_text,
                                           paper_text)
    from dcs_torchrl.report.figures import curves_figure
    from dcs_torchrl.report.markdown import fmt_score, md_table
    from dcs_torchrl.report.tables import setting_name

    backends = {r.get("backend") for r in rows} - {None}
    if len(backends) > 1:
        raise ValueError(f"rows of renderers {sorted(backends)}: scores compare on one renderer only; write each "
                         "renderer's rows to its own directory.")
    renderer = RENDERERS.get(next(iter(backends), None), "")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / "robustness.csv", "md": out / "robustness.md", "png": out / "robustness.png"}
    with open(paths["csv"], "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    method = rows[0].get("method", "policy") if rows else "policy"
    curves = pd.DataFrame.from_records([
        {"experiment": "robustness", "axis": AXES[r["axis"]], "eval_split": "train", "dynamic": r["dynamic"],
         "method": method, "value": r["value"], "mean": r["mean"], "stderr": r["stderr"], "n": 1, "n_tasks": 1,
         "blend": BLEND_2021 if r["reference_blend"] else "paper"} for r in rows])
    half = half_score_table(curves)
    named = {report_axis: axis for axis, report_axis in AXES.items()}  # the command's names, as the CSV's and below
    half_rows = [[named[r.axis] + blend_suffix(r.blend), setting_name(r.dynamic), fmt_score(r.score_at_0),
                  half_text(r), paper_text(r.axis, r.paper)] for r in half.itertuples()]
    point_rows = [[r["axis"] + (" (2021 blend)" if r["reference_blend"] else ""), r["setting"], f"{r['value']:g}",
                   fmt_score(r["mean"], r["stderr"]), str(r["episodes"])] for r in rows]
    swept = [axis for axis in AXES if any(r["axis"] == axis for r in rows)]
    notes = [beyond_paper_note(AXES[axis] for axis in swept)]
    notes += [f"`{axis}` is swept static only: its distraction is drawn once an episode in either setting."
              for axis in swept if axis in STATIC_ONLY]
    text = [f"# Robustness of {_joined(title or method, renderer)}", "",
            "## Where the score falls to half", "",
            md_table(["axis", "setting", "score at 0", "half at", "paper (top methods)"], half_rows), "",
            "`half at`: the first intensity whose mean return is at most half the return at 0; "
            "`> x`: not within the sweep (up to x). The paper's values are over six tasks and 100 episodes."
            + "".join(f" {note}" for note in notes if note), "",
            "## Every point (mean ± s.e. over episodes)", "",
            md_table(["axis", "setting", "intensity", "return", "episodes"], point_rows), ""]
    paths["md"].write_text("\n".join(text))
    curves_figure(curves, "robustness", paths["png"], note=_joined(title, renderer), spread="mean ± s.e. over episodes",
                  axes_shown=[AXES[axis] for axis in swept], num_videos=num_videos)
    return paths


def _joined(*parts: str) -> str:
    return ", ".join(part for part in parts if part)


def _render_device(text: str) -> int | str:
    """``--render-devices``' items: an EGL device index (``2``) or a CUDA device (``cuda:1``)."""
    if text.isdigit():
        return int(text)
    if text == "cuda" or (text.startswith("cuda:") and text[5:].isdigit()):
        return text
    raise argparse.ArgumentTypeError(f"{text!r} is not a render device: give an EGL device index (0, 1, ...) or a "
                                     "CUDA device (cuda:0, cuda:1, ...).")


def _parser() -> argparse.ArgumentParser:
    """The command's options, each help naming its default."""
    parser = argparse.ArgumentParser(
        prog="python -m dcs_torchrl.robustness",
        description="An agent's score as each distraction grows: one distraction at a time, at each intensity.",
        epilog="Each evaluated point is stored in <out>/points/ as soon as it is done; run again, the command "
               "evaluates only the points it does not hold (an interrupted sweep resumes). A stored point is reused "
               "only where the episodes, the agent's checkpoint (SHA-256), every resolved env setting and the videos "
               "shown (stand-in version, or --background-dir's path and file listing; so too the textures and "
               "--texture-dir) all match; the CSV, table and "
               "figure hold this run's points only. An --out with another agent's points, or with this agent's from "
               "another checkpoint (retrained under the same name), is refused: choose another --out.")
    parser.add_argument("agent", help="a shipped agent's name (e.g. sac_rad_cartpole_swingup), an exported agent "
                                      "or a finished training run directory")
    parser.add_argument("--axes", nargs="+", default=list(AXES), choices=list(AXES),
                        help="the distractions swept, each alone: camera, color and background as the paper's "
                             "experiment 1; light and texture beyond the paper (texture static only, whatever "
                             f"--setting: a texture is drawn once an episode either way) (default: {' '.join(AXES)})")
    parser.add_argument("--intensities", nargs="+", type=float, default=list(QUICK_INTENSITIES), metavar="BETA",
                        help="the intensities of each axis, in [0, 1] "
                             f"(default: {' '.join(f'{v:g}' for v in QUICK_INTENSITIES)})")
    parser.add_argument("--setting", default="static", choices=list(SETTINGS),
                        help="distractions drawn once an episode (static), changing every step (dynamic), or a "
                             "curve of each; the texture axis is static in all three (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=10,
                        help="episodes per point (the paper: 100; default: %(default)s)")
    parser.add_argument("--reference-blend", nargs="?", const="on", default="off", choices=["off", "on", "both"],
                        help="background blend as the authors' 2021 code (accumulates over an env's episodes); "
                             "'both': a curve of each (default: %(default)s)")
    parser.add_argument("--background-dir", default=None, help="DAVIS 2017 JPEGImages/480p or a folder of videos "
                                                              "(default: the embedded stand-in videos)")
    parser.add_argument("--texture-dir", default=None,
                        help="a folder of images for the texture axis, e.g. DTD's dtd/images, its training split "
                             "(default: the agent's own setting, by default the stand-in textures)")
    parser.add_argument("--num-videos", type=int, default=None, metavar="B",
                        help="the background axis' b: its first B training videos (default: 60, the paper's, "
                             "or all of a --background-dir that holds fewer)")
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                        help="processes, a point (--backend warp: a batch of points) each "
                             "(default: 2, or 1 on a one-core machine: here %(default)s)")
    parser.add_argument("--render-devices", nargs="+", default=None, type=_render_device, metavar="DEVICE",
                        help="the GPUs the workers render on, worker i on the (i mod n)-th: EGL device indices or "
                             "cuda:N (default: this process's, MUJOCO_EGL_DEVICE_ID or the first)")
    parser.add_argument("--backend", default="gl", choices=["gl", "warp"],
                        help="gl: one env per point (the reference); warp: several points' episodes at once, in one "
                             "batched env rendered by MuJoCo Warp (pip install \"dcs-torchrl[warp]\"); the outputs "
                             "name it: compare scores on one renderer only (default: %(default)s)")
    parser.add_argument("--out", default=None, help="output directory (default: robustness/<agent name>); one "
                                                    "agent's checkpoint per directory")
    parser.add_argument("--trust-checkpoint", action="store_true",
                        help="load an agent whose checkpoint holds more than tensors, numbers and strings: unpickling "
                             "it can run code, so only for an agent of a source you trust (default: refused)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar (default: a bar on stderr)")
    return parser


def main(argv=None) -> dict[str, Path]:
    args = _parser().parse_args(argv)
    out = Path(args.out) if args.out else Path("robustness") / Path(args.agent).name
    blend = {"off": False, "on": True, "both": "both"}[args.reference_blend]
    points = sweep_points(args.axes, args.intensities, args.setting, blend)
    held = set((out / "points").glob("*.json"))
    started = time.time()
    rows = sweep_agent(args.agent, points, out, episodes=args.episodes, workers=args.workers,
                       background_dir=args.background_dir, num_videos=args.num_videos, progress=not args.no_progress,
                       render_devices=args.render_devices, backend=args.backend, trust_checkpoint=args.trust_checkpoint,
                       texture_dir=args.texture_dir)
    videos = f", backgrounds from {Path(args.background_dir).name}" if args.background_dir else ""
    videos += f", textures from {Path(args.texture_dir).name}" if args.texture_dir else ""
    videos += f", b = {args.num_videos} videos" if args.num_videos is not None else ""
    paths = write_outputs(rows, out, title=f"{rows[0]['method']} on {rows[0]['domain']} {rows[0]['task']} "
                                           f"(seed {rows[0]['seed']}), {args.episodes} episodes per point{videos}",
                          num_videos=_background(args.background_dir, args.num_videos)[1])
    print(paths["md"].read_text().split("## Every point")[0].rstrip())
    evaluated = len(set((out / "points").glob("*.json")) - held)
    envs = len({p.key() for p in points})
    print(f"\n{len(points)} points, {envs} distinct envs (intensity 0 is one env on every axis), {evaluated} evaluated "
          f"now ({RENDERERS[args.backend]}) in {time.time() - started:.0f} s; "
          f"wrote {', '.join(str(p) for p in paths.values())}")
    return paths


if __name__ == "__main__":
    main()
