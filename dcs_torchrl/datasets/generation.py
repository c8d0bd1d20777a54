"""Generating a dataset: episodes of a behaviour policy in a suite env, every frame and its ground truth.

:func:`generate` runs ``episodes`` episodes of one env (:func:`dcs_torchrl.make_env` with
``expose_distractions=True, pixels_only=False``) and writes each, when whole, to the set
(layout.py). Episode ``k`` is seeded with :func:`~dcs_torchrl.datasets.metadata.episode_seed`
``(seed, k)`` (the env, torch's generator and the policy's noise), so it is the same episode
whether or not a run was cut before it: a killed run, started again with the same command, skips
the episodes it wrote and makes the others as an uncut run would have. Generating into a set
made with other settings is refused, naming them (metadata.py).

With ``reference_blend=True`` (the 2021 code's background blend, which accumulates over an env's
episodes) each episode runs in a new env, so that it too does not depend on the episodes before it.
"""
from __future__ import annotations

import inspect
import os
from collections.abc import Sequence
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.envs import StepCounter
from torchrl.envs.utils import step_mdp

from dcs_torchrl.datasets import layout, metadata
from dcs_torchrl.datasets.policies import BehaviourPolicy, Mixing, load_behaviour
from dcs_torchrl.envs import make_env, resolve_settings, scene_options

__all__ = ["generate"]

#: Entries of the env's observations that are not the task's state.
_NOT_STATE = ("pixels", "masks", "distractions", "step_count")


def _pixels(behaviours: Sequence[BehaviourPolicy], image_size: int | None, render_profile: str | None) -> dict:
    """The set's image size and render profile: the agents' (all must agree; each stacks its own
    frames), else 84 and ``default``."""
    agents = {(("image_size", b.pixels["image_size"]), ("render_profile", b.pixels["render_profile"]))
              for b in behaviours if b.agent is not None}
    if len(agents) > 1:
        raise ValueError(f"the --policy agents act on different pixels ({sorted(agents)}): mix agents of one pixel "
                         "setting in a set.")
    theirs = dict(agents.pop()) if agents else {}
    if render_profile is not None and theirs and render_profile != theirs["render_profile"]:
        raise ValueError(f"--render-profile {render_profile}: the agents were trained on {theirs['render_profile']!r}; "
                         "leave --render-profile out.")
    return {"image_size": int(image_size or theirs.get("image_size", 84)),
            "render_profile": render_profile or theirs.get("render_profile", "default")}


def _make_env(settings, pixels: dict, max_steps: int | None):
    options = scene_options(settings)
    extra, masks = {}, pixels["masks"]
    if masks:
        if "masks" not in inspect.signature(make_env).parameters:
            raise ValueError("--masks: this version of make_env renders no masks; leave --masks out.")
        extra["masks"] = True
    try:
        env = make_env(settings.domain, settings.task, expose_distractions=True, pixels_only=False,
                       height=pixels["image_size"], width=pixels["image_size"], render_profile=pixels["render_profile"],
                       **options, **extra)
    except ValueError as error:
        if masks and "masks" in str(error):
            raise ValueError(f"--masks: {error} Generate without --masks on this backend.") from None
        raise
    if max_steps is not None:
        env.append_transform(StepCounter(max_steps))
    return env


def _run_episode(env, behaviour: BehaviourPolicy, mixing: Mixing, seed: int, policy_index: int, episode: int,
                 masks: bool) -> tuple[TensorDict, TensorDict, dict]:
    """One episode from a reset seeded with ``seed``: its transitions (TED, no pixels), its frames and a summary."""
    torch.manual_seed(seed)  # an agent's sampled actions (--exploration random)
    generator = torch.Generator().manual_seed(seed)
    env.set_seed(seed)
    td = env.reset()
    frame_keys = ["pixels"] + (["masks"] if masks else [])
    state = [k for k in td.keys() if k not in _NOT_STATE and k not in ("done", "terminated", "truncated")]
    frames = [td.select(*frame_keys)]
    behaviour.start_episode(td["pixels"])
    rows = []
    while True:
        td["action"] = behaviour.act(env.action_spec, mixing, generator)
        td = env.step(td)
        rows.append(td.exclude(*frame_keys, *[("next", k) for k in frame_keys], "step_count", ("next", "step_count")))
        frames.append(td["next"].select(*frame_keys))
        behaviour.observe(td["next", "pixels"])
        if bool(td["next", "done"].any()):
            break
        td = step_mdp(td)
    transitions = torch.stack(rows)
    for key in state:
        transitions.rename_key_(key, ("state", key))
        transitions.rename_key_(("next", key), ("next", "state", key))
    steps = transitions.shape[0]
    index = torch.arange(steps)
    transitions.update({"episode": torch.full((steps,), episode), "step": index, "frame": index,
                        "first_frame": torch.zeros(steps, dtype=torch.int64),
                        "policy": torch.full((steps,), policy_index)})
    summary = {"seed": seed, "policy": policy_index, "return": float(transitions["next", "reward"].sum()), "steps": steps}
    return transitions, torch.stack(frames), summary


def _check_out(out: Path, record: dict) -> None:
    """Refuses to write into a set of another identity, or into a folder that is not a set."""
    if (out / layout.METADATA).is_file():
        stored = layout.read_json(out / layout.METADATA)
        diff = metadata.differences(stored, record)
        if diff:
            raise FileExistsError(f"{out} holds a dataset made with other settings; nothing was written. "
                                  f"Differences: {'; '.join(diff)}. Choose another --out, or ask for the set's own "
                                  "settings (its metadata.json) to resume or extend it.")
    elif out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out} exists and is not a dataset (no {layout.METADATA}): choose a new or empty --out.")


def _record(record: dict, table: list[dict], data: TensorDict | None) -> dict:
    from dcs_torchrl.evaluation import EvalResult

    returns = EvalResult(tuple(e["return"] for e in table)) if table else None
    return {**record, "versions": metadata.versions(), "episode_seeds": metadata.EPISODE_SEEDS,
            "episodes": len(table), "transitions": sum(e["steps"] for e in table),
            "frames": sum(e["steps"] + 1 for e in table),
            "returns": None if returns is None else {"mean": returns.mean, "stderr": returns.stderr},
            "keys": None if data is None else {"transitions": metadata.describe_keys(data["transitions"]),
                                               "frames": metadata.describe_keys(data["frames"])},
            "episode_table": table}


def generate(out: str | os.PathLike, *, domain: str, task: str, episodes: int,
             policies: Sequence[str | BehaviourPolicy] = ("random",),
             seed: int = 0, mixing: Mixing = Mixing(), masks: bool = False, image_size: int | None = None,
             render_profile: str | None = None, max_steps: int | None = None, progress: bool = False,
             **options) -> dict:
    """Writes (or resumes, or extends) the dataset ``out``; returns its metadata.

    Args:
        out: the set's folder (created).

    Keyword Args:
        domain, task: a dm_control task.
        episodes: episodes the set holds when done (a set holding more is left as it is).
        policies: behaviour policies: names for :func:`~dcs_torchrl.datasets.policies.load_behaviour`,
            or loaded :class:`~dcs_torchrl.datasets.policies.BehaviourPolicy`; episode ``k`` is
            acted by ``policies[k % len(policies)]``.
        seed: the set's seed (episode ``k``'s: :func:`~dcs_torchrl.datasets.metadata.episode_seed`).
        mixing: epsilon-random actions, action noise, the agents' exploration.
        masks: store make_env's ``"masks"`` (where the backend renders them).
        image_size, render_profile: default to the agents' (else 84, ``"default"``).
        max_steps: cut episodes after that many steps (``truncated``), e.g. for short test sets.
        progress: a progress bar (tqdm) over the episodes.
        **options: make_env's scene options (:data:`dcs_torchrl.envs.SCENE_OPTIONS`: ``benchmark``,
            ``dynamic``, ``camera_scale``, ...).
    """
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"--episodes must be an integer >= 1, got {episodes!r}.")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {seed!r}.")
    if max_steps is not None and max_steps < 1:
        raise ValueError(f"--max-steps must be >= 1 (or left out: the task's time limit), got {max_steps}.")
    if not policies:
        raise ValueError("give at least one --policy (random, a shipped agent's name or a run directory).")
    settings = resolve_settings(domain, task, **options)
    behaviours = [p if isinstance(p, BehaviourPolicy) else load_behaviour(p) for p in policies]
    pixels = _pixels(behaviours, image_size, render_profile) | {"masks": bool(masks), "backend": "gl"}
    for b in behaviours:
        b.check_task(domain, task, pixels["image_size"])
    out = Path(out)
    record = metadata.identity(settings, pixels=pixels, max_steps=max_steps, policies=[b.record() for b in behaviours],
                               mixing=mixing.as_dict(), seed=seed)
    _check_out(out, record)
    if out.exists():
        layout.recover(out)
    done = layout.stored_episodes(out)
    todo = [k for k in range(episodes) if k not in done]
    env = _make_env(settings, pixels, max_steps) if todo else None  # refused settings: before anything is written
    out.mkdir(parents=True, exist_ok=True)
    if not (out / layout.METADATA).is_file():
        layout.write_json(out / layout.METADATA, _record(record, [], None))
    _write_episodes(out, env, todo, settings, pixels, max_steps, behaviours, mixing, seed, progress, episodes)
    table = layout.merge_episodes(out, max(episodes, len(layout.episode_table(out))))
    result = _record(record, table, layout.load_data(out))
    layout.write_json(out / layout.METADATA, result)
    return result


def _write_episodes(out: Path, env, todo: list[int], settings, pixels: dict, max_steps, behaviours, mixing: Mixing,
                    seed: int, progress: bool, episodes: int) -> None:
    if not todo:
        return
    from dcs_torchrl.evaluation import torch_threads

    bar = None
    if progress:
        try:
            from tqdm import tqdm
        except ModuleNotFoundError:  # the recipes extra's; no bar without it
            tqdm = None
    if progress and tqdm is not None:
        bar = tqdm(total=episodes, initial=episodes - len(todo), unit="episode", desc=f"generate {out.name}")
    try:
        with torch_threads(1):  # the agents act on one observation: one thread is the fastest, and deterministic
            for i, k in enumerate(todo):
                if i > 0 and settings.reference_blend:  # each episode the first of its env
                    env.close()
                    env = _make_env(settings, pixels, max_steps)
                p = k % len(behaviours)
                transitions, frames, summary = _run_episode(env, behaviours[p], mixing, metadata.episode_seed(seed, k),
                                                            p, k, pixels["masks"])
                layout.write_episode(out, k, transitions, frames, summary)
                if bar is not None:
                    bar.set_postfix(last_return=f"{summary['return']:.1f}")
                    bar.update()
    finally:
        if env is not None:
            env.close()
        if bar is not None:
            bar.close()
