"""Generating a dataset: episodes of a behaviour policy in suite envs, every frame and its ground truth.

:func:`generate` runs the set's episodes in waves: a wave is ``N`` consecutive episodes, one per env
of ``make_env(..., expose_distractions=True, pixels_only=False)`` (``backend="gl"``: one env, so
``N = 1``; ``backend="warp"``: ``num_envs`` envs rendered in one batch), each episode written whole
(layout.py) when its wave ends. Episode ``k`` is seeded with
:func:`~dcs_torchrl.datasets.metadata.episode_seed` ``(seed, k)``, the ``k``-th seed of TorchRL's
chain from the set's seed (the env, torch's generator and the policy's noise), which is the seed a
batch seeded with episode ``j``'s seed gives its env ``k - j``. So episode ``k`` is the same whether
or not a run was cut before it, and the same on both backends wherever the renderer does not enter
(states, actions of a policy that does not look at the pixels, rewards, distraction states) and for
any ``num_envs``. A killed run, started again with the same command, skips the episodes it wrote and
makes the others as an uncut run would have. Generating into a set made with other settings is
refused, naming them (metadata.py); so is a second run writing the same set at once.

An agent acts on frames at its own image size (84 for the shipped agents). Where the set asks for
another size, the GL env renders the scene twice per step, once at the set's size (stored: what an
env of that size shows) and once at the agent's (acted on, not stored); the Warp batch renders one
size, so there the set's size must be the agent's.

With ``reference_blend=True`` (the 2021 code's background blend, which accumulates over an env's
episodes) each GL episode runs in a new env, so that it too does not depend on the episodes before
it; the Warp backend refuses it.
"""
from __future__ import annotations

import os
import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.envs.utils import step_mdp

from dcs_torchrl.datasets import layout, metadata
from dcs_torchrl.datasets.policies import BehaviourPolicy, Mixing, load_behaviour
from dcs_torchrl.envs import make_env, resolve_settings, scene_options

__all__ = ["BACKENDS", "DEFAULT_NUM_ENVS", "generate"]

BACKENDS = ("gl", "warp")
#: ``--num-envs`` when ``--backend warp`` is asked without it (at most the episodes to make).
DEFAULT_NUM_ENVS = 16
#: The key of the frames an agent acts on when they are rendered apart from the set's.
_AGENT_PIXELS = "agent_pixels"
#: Entries of the env's observations that are not the task's state.
_NOT_STATE = ("pixels", "masks", _AGENT_PIXELS, "distractions", "done", "terminated", "truncated")


def _pixels(behaviours: Sequence[BehaviourPolicy], image_size: int | None, render_profile: str | None) -> dict:
    """The set's image size and render profile: the agents' (all must agree; each stacks its own
    frames) unless asked, else 84 and ``default``."""
    theirs = _agent_pixels(behaviours) or {}
    if render_profile is not None and theirs and render_profile != theirs["render_profile"]:
        raise ValueError(f"--render-profile {render_profile}: the agents were trained on {theirs['render_profile']!r}; "
                         "leave --render-profile out.")
    size = int(image_size or theirs.get("image_size", 84))
    if size < 1:
        raise ValueError(f"--image-size must be >= 1, got {size}.")
    return {"image_size": size, "render_profile": render_profile or theirs.get("render_profile", "default")}


def _agent_pixels(behaviours: Sequence[BehaviourPolicy]) -> dict | None:
    """The image size and render profile the set's agents act on (``None``: no agent)."""
    agents = {(b.pixels["image_size"], b.pixels["render_profile"]) for b in behaviours if b.agent is not None}
    if len(agents) > 1:
        raise ValueError(f"the --policy agents act on different pixels ((image size, render profile): {sorted(agents)}): "
                         "mix agents of one pixel setting in a set.")
    if not agents:
        return None
    size, profile = agents.pop()
    return {"image_size": size, "render_profile": profile}


@dataclass(frozen=True)
class _Plan:
    """How the episodes are made: the env's settings and what each step renders."""

    settings: object
    pixels: dict
    agent_size: int | None  # the agents' image size where it differs from the set's (rendered apart)
    num_envs: int
    max_steps: int | None

    @property
    def frame_keys(self) -> list[str]:
        return ["pixels"] + (["masks"] if self.pixels["masks"] else [])

    @property
    def agent_key(self) -> str:
        return "pixels" if self.agent_size is None else _AGENT_PIXELS

    def check(self) -> None:
        """Refuses what the backend cannot render, naming the fix, before an env is built."""
        backend, masks = self.pixels["backend"], self.pixels["masks"]
        if backend == "gl" and masks:
            raise ValueError("--masks needs --backend warp (its render gives the segmentation; the GL backend has "
                             "none): add --backend warp, or leave --masks out.")
        if backend == "warp" and self.agent_size is not None:
            raise ValueError(f"--backend warp renders one image size, and the agents act on {self.agent_size}-pixel "
                             f"frames: ask --image-size {self.agent_size}, or use --backend gl, which renders the "
                             f"agents' frames beside the set's {self.pixels['image_size']}-pixel ones.")
        if backend == "warp" and self.settings.reference_blend:
            raise ValueError("--reference-blend runs each episode in a new env (its blend accumulates over an env's "
                             "episodes): use --backend gl for it.")

    def make_env(self):
        from dcs_torchrl.render.gl import RenderPixels

        size, profile = self.pixels["image_size"], self.pixels["render_profile"]
        batch = {"backend": "warp", "num_envs": self.num_envs, "masks": self.pixels["masks"]} \
            if self.pixels["backend"] == "warp" else {}
        env = make_env(self.settings.domain, self.settings.task, expose_distractions=True, pixels_only=False,
                       height=size, width=size, render_profile=profile, **scene_options(self.settings), **batch)
        if self.agent_size is not None:  # the agents' frames: the same scene, rendered again at their size
            render = RenderPixels(self.agent_size, self.agent_size, self.settings.camera_id, profile=profile,
                                  out_keys=[_AGENT_PIXELS])
            # the larger render first: the physics' one render context is then made at its size, and
            # each render gives the frame an env of its size alone gives (test_datasets.py)
            first = next(i for i, t in enumerate(env.transform) if isinstance(t, RenderPixels))
            if self.agent_size > size:
                env.transform.insert(first, render)
            else:
                env.append_transform(render)
        return env


class _Actor:
    """One env's episode: its policy, the policy's frame stack, its generators."""

    def __init__(self, behaviour: BehaviourPolicy, seed: int, frame: torch.Tensor):
        self.behaviour = behaviour
        self.generator = torch.Generator().manual_seed(seed)  # --epsilon, --action-noise, the random policy
        self.torch_state = None
        if behaviour.agent is not None:  # an agent's sampled actions (--exploration random): torch's generator
            torch.manual_seed(seed)
            self.torch_state = torch.get_rng_state()
        self.stack = behaviour.start_episode(frame)

    def act(self, low: torch.Tensor, high: torch.Tensor, mixing: Mixing) -> torch.Tensor:
        if self.torch_state is not None:
            torch.set_rng_state(self.torch_state)
        action = self.behaviour.act(self.stack, low, high, mixing, self.generator)
        if self.torch_state is not None:
            self.torch_state = torch.get_rng_state()
        return action


def _run_wave(env, plan: _Plan, first: int, count: int, seed: int, behaviours: Sequence[BehaviourPolicy],
              mixing: Mixing) -> list[tuple[TensorDict, TensorDict, dict]]:
    """Episodes ``first .. first + count - 1`` (``count <= num_envs``), episode ``first + i`` in env
    ``i``, from the envs seeded with ``seed`` (episode ``first``'s): each episode's transitions (TED,
    no frames), frames and summary."""
    batched = bool(env.batch_size)
    env.set_seed(seed)  # env i of a batch: the chain's i-th seed from it, episode first + i's
    seeds = metadata.episode_seeds(seed, 0, count) if batched else [seed]
    td = env.reset()
    if not batched:
        td = td.unsqueeze(0)
    state = [k for k in td.keys() if k not in _NOT_STATE]
    n = td.shape[0]
    active = torch.zeros(n, dtype=torch.bool)
    active[:count] = True
    actors = [_Actor(behaviours[(first + i) % len(behaviours)], seeds[i], td[plan.agent_key][i]) for i in range(count)]
    low, high = env.action_spec.space.low, env.action_spec.space.high
    if batched:
        low, high = low[0], high[0]
    frames, rows, steps = [td.select(*plan.frame_keys)], [], [0] * count
    while active.any():
        action = torch.zeros(n, *low.shape, dtype=low.dtype)
        for i in active.nonzero().flatten().tolist():
            action[i] = actors[i].act(low, high, mixing)
        td["action"] = action
        if batched:
            td["_step"] = active.clone()
            td = env.step(td)
        else:
            td = env.step(td[0]).unsqueeze(0)
        if plan.max_steps is not None and len(rows) + 1 >= plan.max_steps:  # cut: truncated, as StepCounter
            td["next", "truncated"] = td["next", "truncated"] | active.unsqueeze(-1)
            td["next", "done"] = td["next", "done"] | td["next", "truncated"]
        rows.append(td.exclude(*plan.frame_keys, _AGENT_PIXELS, "_step", *[("next", k) for k in plan.frame_keys],
                               ("next", _AGENT_PIXELS)))
        frames.append(td["next"].select(*plan.frame_keys))
        ended = active & td["next", "done"].reshape(n)
        for i in active.nonzero().flatten().tolist():
            steps[i] += 1
            if not ended[i]:
                BehaviourPolicy.observe(actors[i].stack, td["next", plan.agent_key][i])
        active &= ~ended
        td = step_mdp(td)
    rows, frames = torch.stack(rows), torch.stack(frames)  # [T, n], [T + 1, n]
    return [_episode(rows[:steps[i], i], frames[:steps[i] + 1, i], state, first + i, seeds[i],
                     (first + i) % len(behaviours)) for i in range(count)]


def _episode(transitions: TensorDict, frames: TensorDict, state: list[str], episode: int, seed: int,
             policy: int) -> tuple[TensorDict, TensorDict, dict]:
    """One env's episode as the set stores it: the state under ``"state"``, its ids, its summary."""
    transitions, frames = transitions.contiguous(), frames.contiguous()
    for key in state:
        transitions.rename_key_(key, ("state", key))
        transitions.rename_key_(("next", key), ("next", "state", key))
    steps = transitions.shape[0]
    index = torch.arange(steps)
    transitions.update({"episode": torch.full((steps,), episode), "step": index, "frame": index,
                        "first_frame": torch.zeros(steps, dtype=torch.int64), "policy": torch.full((steps,), policy)})
    summary = {"seed": seed, "policy": policy, "return": float(transitions["next", "reward"].sum()), "steps": steps}
    return transitions, frames, summary


def _check_out(out: Path, record: dict) -> None:
    """Refuses to write into a set of another identity, or into a folder that is not a set."""
    layout.check_folder(out)
    if (out / layout.METADATA).is_file():
        stored = layout.read_json(out / layout.METADATA)
        diff = metadata.differences(stored, record)
        if diff:
            raise FileExistsError(f"{out} holds a dataset made with other settings; nothing was written. "
                                  f"Differences: {'; '.join(diff)}. Choose another --out, or ask for the set's own "
                                  "settings (its metadata.json) to resume or extend it.")
    elif out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out} exists and is not a dataset (no {layout.METADATA}): choose a new or empty --out.")


def _check_writable(out: Path, episodes: int, held: int) -> None:
    """Refuses, before anything is simulated, a set that has to be written and cannot be."""
    if not out.exists():
        parent = next(p for p in out.absolute().parents if p.exists())
        if not os.access(parent, os.W_OK):
            raise PermissionError(f"--out {out}: {parent} is read-only; choose an --out in a writable folder.")
        return
    folders = [out] + [p for p in (out / layout.DATA, out / layout.EPISODES) if p.exists()]
    if not all(os.access(p, os.W_OK) for p in folders):
        raise PermissionError(f"{out} is read-only and holds {held} whole episodes, {episodes} asked: copy it to a "
                              f"writable folder (cp -r {shlex.quote(os.fspath(out))} NEW) and generate into that "
                              f"one, or ask for --episodes {held} or fewer (nothing to write).")


def _record(record: dict, table: list[dict], data: TensorDict | None, asked: dict) -> dict:
    from dcs_torchrl.evaluation.protocol import EvalResult

    returns = EvalResult(tuple(e["return"] for e in table)) if table else None
    return {**record, "versions": metadata.versions(), "episode_seeds": metadata.EPISODE_SEEDS,
            "episodes": len(table), "transitions": sum(e["steps"] for e in table),
            "frames": sum(e["steps"] + 1 for e in table),
            "returns": None if returns is None else {"mean": returns.mean, "stderr": returns.stderr},
            "keys": None if data is None else {"transitions": metadata.describe_keys(data["transitions"]),
                                               "frames": metadata.describe_keys(data["frames"])},
            "asked": asked, "episode_table": table}


def _command(out: Path, *, domain: str, task: str, episodes: int, policies: Sequence[str], seed: int, mixing: Mixing,
             pixels: dict, max_steps: int | None, num_envs: int | None, options: dict) -> str:
    """The ``generate`` command line that makes (and resumes) this set."""
    words = ["python", "-m", "dcs_torchrl.datasets", "generate", "--policy", *policies, "--domain", domain,
             "--task", task, "--episodes", str(episodes), "--seed", str(seed), "--out", os.fspath(out),
             "--image-size", str(pixels["image_size"]), "--render-profile", pixels["render_profile"]]
    defaults = Mixing()
    for flag, value, default in (("--epsilon", mixing.epsilon, defaults.epsilon),
                                 ("--action-noise", mixing.action_noise, defaults.action_noise),
                                 ("--exploration", mixing.exploration, defaults.exploration),
                                 ("--max-steps", max_steps, None)):
        if value != default:
            words += [flag, str(value)]
    if pixels["backend"] != "gl":
        words += ["--backend", pixels["backend"]] + ([] if num_envs is None else ["--num-envs", str(num_envs)])
    if pixels["masks"]:
        words.append("--masks")
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        words += ([flag if value else "--no-" + flag[2:]] if isinstance(value, bool) else [flag, os.fspath(value)]
                  if isinstance(value, os.PathLike) else [flag, str(value)])
    return shlex.join(words)


def generate(out: str | os.PathLike, *, domain: str, task: str, episodes: int,
             policies: Sequence[str | BehaviourPolicy] = ("random",),
             seed: int = 0, mixing: Mixing = Mixing(), masks: bool = False, image_size: int | None = None,
             render_profile: str | None = None, max_steps: int | None = None, backend: str = "gl",
             num_envs: int | None = None, progress: bool = False, **options) -> dict:
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
        masks: store make_env's ``"masks"`` (``backend="warp"``).
        image_size, render_profile: default to the agents' (else 84, ``"default"``); an agent acts on
            its own image size whatever the set's (module text).
        max_steps: cut episodes after that many steps (``truncated``), e.g. for short test sets.
        backend: ``"gl"`` (one env) or ``"warp"`` (``num_envs`` envs in one batch,
            :class:`dcs_torchrl.vector.batched.BatchedSuiteEnv`); part of the set's identity.
        num_envs: ``backend="warp"``: envs of the batch (default :data:`DEFAULT_NUM_ENVS`, at most the
            episodes to make). Not part of the identity: the episodes are the same for any value.
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
    if backend not in BACKENDS:
        raise ValueError(f"unknown --backend {backend!r}: choose one of {list(BACKENDS)}.")
    if num_envs is not None and (backend != "warp" or isinstance(num_envs, bool) or not isinstance(num_envs, int)
                                 or num_envs < 1):
        raise ValueError(f"--num-envs {num_envs!r}: a positive integer, with --backend warp (the GL backend runs one "
                         "env).")
    if not policies:
        raise ValueError("give at least one --policy (random, a shipped agent's name or a run directory).")
    out = Path(out)
    layout.check_folder(out)
    settings = resolve_settings(domain, task, **options)
    behaviours = [p if isinstance(p, BehaviourPolicy) else load_behaviour(p) for p in policies]
    for b in behaviours:
        b.check_task(domain, task)
    pixels = _pixels(behaviours, image_size, render_profile) | {"masks": bool(masks), "backend": backend}
    agents = _agent_pixels(behaviours)
    agent_size = agents["image_size"] if agents and agents["image_size"] != pixels["image_size"] else None
    record = metadata.identity(settings, pixels=pixels, max_steps=max_steps, policies=[b.record() for b in behaviours],
                               mixing=mixing.as_dict(), seed=seed)
    _check_out(out, record)
    held = len(layout.stored_episodes(out)) if out.exists() else 0
    if (out / layout.METADATA).is_file() and not layout.pending(out) and len(layout.episode_table(out)) >= episodes:
        return layout.read_json(out / layout.METADATA)  # nothing to do: nothing written (a read-only set too)
    _check_writable(out, episodes, held)
    todo = max(episodes - held, 0)
    plan = _Plan(settings, pixels, agent_size, min(num_envs or DEFAULT_NUM_ENVS, max(todo, 1))
                 if backend == "warp" else 1, max_steps)
    plan.check()
    asked = {"episodes": max(episodes, held), "command": _command(
        out, domain=domain, task=task, episodes=max(episodes, held), policies=[b.name for b in behaviours], seed=seed,
        mixing=mixing, pixels=pixels, max_steps=max_steps, num_envs=num_envs, options=options)}
    env = plan.make_env() if todo else None  # refused settings: before anything is written
    try:
        out.mkdir(parents=True, exist_ok=True)
        with layout.writing(out):
            _check_out(out, record)  # another run may have made it meanwhile
            layout.recover(out)
            if not (out / layout.METADATA).is_file():
                layout.write_json(out / layout.METADATA, _record(record, [], None, asked))
            done = layout.stored_episodes(out)
            handed, env = env, None  # _write_episodes closes it
            _write_episodes(out, handed, plan, [k for k in range(episodes) if k not in done], behaviours, mixing, seed,
                            progress, episodes)
            table = layout.merge_episodes(out, max(episodes, len(layout.episode_table(out))))
            result = _record(record, table, layout.load_data(out), asked)
            layout.write_json(out / layout.METADATA, result)
    finally:
        if env is not None:
            env.close()
    return result


def _waves(todo: list[int], size: int) -> list[tuple[int, int]]:
    """``(first, count)`` of each wave: ``size`` consecutive episodes from the first not yet made."""
    waves, remaining = [], sorted(todo)
    while remaining:
        first = remaining[0]
        count = min(size, remaining[-1] - first + 1)
        waves.append((first, count))
        remaining = [e for e in remaining if e >= first + count]
    return waves


def _write_episodes(out: Path, env, plan: _Plan, todo: list[int], behaviours, mixing: Mixing, seed: int,
                    progress: bool, episodes: int) -> None:
    """Makes and writes the episodes ``todo`` wave by wave in ``env`` (``None`` where there is none
    to make), which it closes."""
    if not todo:
        if env is not None:
            env.close()
        return
    from dcs_torchrl.evaluation.protocol import torch_threads

    bar = None
    if progress:
        try:
            from tqdm import tqdm
        except ModuleNotFoundError:  # the recipes extra's; no bar without it
            tqdm = None
        if tqdm is not None:
            bar = tqdm(total=episodes, initial=episodes - len(todo), unit="episode", desc=f"generate {out.name}")
    try:
        with torch_threads(1):  # the agents act on one observation: one thread is the fastest, and deterministic
            todo = set(todo)
            for w, (first, count) in enumerate(_waves(todo, plan.num_envs)):
                if w > 0 and plan.settings.reference_blend:  # each episode the first of its env
                    env.close()
                    env = plan.make_env()
                made = _run_wave(env, plan, first, count, metadata.episode_seed(seed, first), behaviours, mixing)
                for k, (transitions, frames, summary) in enumerate(made, start=first):
                    if k in todo:
                        layout.write_episode(out, k, transitions, frames, summary)
                if bar is not None:
                    bar.set_postfix(last_return=f"{made[-1][2]['return']:.1f}")
                    bar.update(sum(first <= k < first + count for k in todo))
    finally:
        env.close()
        if bar is not None:
            bar.close()
