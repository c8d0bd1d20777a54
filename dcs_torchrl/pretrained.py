"""Trained agents as networks only: export a finished run's acting networks, load them as a policy.

    python -m dcs_torchrl.pretrained <finished run directory> <out directory>

The agents the project ships (``recipes/pretrained/<name>/`` in the clone, installed inside the
package by a wheel) load by name: ``load_pretrained("sac_rad_cartpole_swingup")``;
:func:`shipped_agents` lists them.

An exported agent is a directory with the run's ``results.json`` (its config: networks, pixels,
training env, seed, frames) and one checkpoint, ``checkpoints/checkpoint_<frames>.pt`` with its
SHA-256 file, holding ``{"policy": <state dict of the acting policy>}``: the encoder and the
actor (SAC) or the encoder and the Q head CEM maximises (QT-Opt), without critics' targets,
optimisers or replay. ``recipes/evaluate/evaluate.py train_dir=<it>`` evaluates it like any
finished run, and :func:`load_pretrained` gives the policy and envs it acts on:

>>> from dcs_torchrl.pretrained import load_pretrained
>>> agent = load_pretrained("recipes/pretrained/sac_rad_cartpole_swingup")  # doctest: +SKIP
>>> env = agent.make_env(camera_scale=0.3, dynamic=True, seed=0)  # doctest: +SKIP
>>> td = env.rollout(125, agent.policy)  # doctest: +SKIP

A checkpoint loads with ``torch.load(..., weights_only=True)``: an agent whose checkpoint holds
more than tensors, numbers and strings (unpickling it could run code) is refused with an
:class:`~dcs_torchrl.training.checkpoint.UntrustedCheckpointError`; ``trust_checkpoint=True``
(``--trust-checkpoint`` on the command lines) loads it, for an agent of a source you trust.
Exporting such a run with ``--trust-checkpoint`` writes an agent that loads without it.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Pretrained", "agent_checkpoint", "agent_directory", "agent_env_settings", "agent_results",
           "checkpoint_sha256", "export_policy", "load_policy_state", "load_pretrained", "shipped_agents"]

_PACKAGE = Path(__file__).resolve().parent
# Where the shipped agents are: inside an installed wheel (pyproject.toml maps recipes/pretrained
# there), or in the clone an editable install runs from.
_SHIPPED_PLACES = (_PACKAGE / "shipped_agents", _PACKAGE.parent / "recipes" / "pretrained")


def shipped_agents() -> dict[str, Path]:
    """The agents this project ships, by name (``{"sac_rad_cartpole_swingup": <its directory>}``)."""
    for place in _SHIPPED_PLACES:
        if place.is_dir():
            return {p.name: p for p in sorted(place.iterdir()) if (p / "results.json").is_file()}
    return {}


def agent_directory(agent: str | os.PathLike) -> Path:
    """The directory of ``agent``: an existing path (an exported agent or a finished run), else
    the name of a shipped agent (:func:`shipped_agents`)."""
    path = Path(agent)
    if path.exists():
        return path
    shipped = shipped_agents()
    if str(agent) in shipped:
        return shipped[str(agent)]
    raise FileNotFoundError(f"{str(agent)!r} is neither a directory nor a shipped agent: pass a finished run or an "
                            f"exported agent's directory, or one of {sorted(shipped)}.")


def agent_results(run_dir: Path) -> dict:
    """The ``results.json`` of a finished run or an exported agent."""
    try:
        return json.loads((run_dir / "results.json").read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"{run_dir} has no results.json: point at a finished training run "
                                "(or an exported agent, e.g. recipes/pretrained/<name>).") from None


def checkpoint_sha256(agent: str | os.PathLike) -> str:
    """The SHA-256 of the checkpoint :func:`load_pretrained` loads for ``agent``: the newest one
    whose bytes match its checksum file (:func:`~dcs_torchrl.training.checkpoint.load_latest`'s choice)."""
    import hashlib

    from dcs_torchrl.training.checkpoint import list_checkpoints

    path = agent_directory(agent)
    for _, checkpoint in reversed(list_checkpoints(path / "checkpoints")):
        sidecar = checkpoint.with_name(checkpoint.name + ".sha256")
        with open(checkpoint, "rb") as f:
            digest = hashlib.file_digest(f, "sha256").hexdigest()
        if sidecar.is_file() and sidecar.read_text().strip() == digest:
            return digest
    raise FileNotFoundError(f"{path}/checkpoints holds no checkpoint that verifies.")


def agent_env_settings(config: Mapping, settings: Mapping):
    """The resolved make_env settings (an :class:`~dcs_torchrl.envs.EnvSettings`) an agent of
    ``config`` (its run's config) acts in under ``settings``: these over its training env's."""
    from omegaconf import OmegaConf

    from dcs_torchrl.training.envs import config_settings

    return config_settings(OmegaConf.create(config).env, settings)


def _build_agent(results: dict, device: str = "cpu"):
    """The run's agent (untrained), from its config."""
    from omegaconf import OmegaConf

    from dcs_torchrl.methods import agent_class
    from dcs_torchrl.training.envs import config_settings, pixel_env, pixel_options

    cfg = OmegaConf.merge(OmegaConf.create(results["config"]), {"device": device})
    settings = config_settings(cfg.env)
    env = pixel_env(settings, **pixel_options(cfg.pixels))  # the specs the networks are built from
    try:
        spec = env.action_spec
        agent = agent_class(cfg.algo.name)(cfg, tuple(env.observation_spec["pixels"].shape[-3:]), spec)
    finally:
        env.close()
    return agent, cfg


def load_policy_state(agent, state: dict) -> None:
    """Loads a training checkpoint's agent state, or an exported agent's policy state."""
    if "agent" in state:
        agent.load_state_dict(state["agent"])
    elif "policy" in state:
        agent.policy.load_state_dict(state["policy"])
    else:
        raise KeyError(f"a checkpoint holds 'agent' (training) or 'policy' (exported), got {sorted(state)}.")


def agent_checkpoint(agent: str | os.PathLike, *, final: bool = False,
                     trust_checkpoint: bool = False) -> tuple[int, dict]:
    """The ``(frames, state)`` of the checkpoint :func:`load_pretrained` loads for ``agent``: the
    newest that verifies; ``final=True`` refuses one that is not the run's last (``results.json``'s
    frames). One that holds more than ``weights_only=True`` reads is refused
    (:class:`~dcs_torchrl.training.checkpoint.UntrustedCheckpointError`) unless ``trust_checkpoint``."""
    from dcs_torchrl.training.checkpoint import load_latest

    path = agent_directory(agent)
    results = agent_results(path)
    loaded = load_latest(path / "checkpoints", trust=trust_checkpoint)
    if loaded is None:
        raise FileNotFoundError(f"{path}/checkpoints holds no checkpoint that verifies.")
    if final and loaded[0] != results["steps"]:
        raise RuntimeError(f"{path}: the newest checkpoint ({loaded[0]} frames) is not the final one "
                           f"({results['steps']} frames, results.json).")
    return loaded


def export_policy(run_dir: str | os.PathLike, out_dir: str | os.PathLike, *, trust_checkpoint: bool = False) -> Path:
    """Writes ``run_dir``'s final acting networks to ``out_dir`` (which must not exist yet), as
    tensors only (it loads with ``weights_only=True`` even where ``run_dir``'s checkpoint needed
    ``trust_checkpoint=True``)."""
    from dcs_torchrl.training.checkpoint import save_checkpoint

    run_dir, out_dir = Path(run_dir), Path(out_dir)
    if out_dir.exists():
        raise FileExistsError(f"{out_dir} exists: export into a new directory (nothing is overwritten).")
    results = agent_results(run_dir)
    loaded = agent_checkpoint(run_dir, final=True, trust_checkpoint=trust_checkpoint)
    agent, _ = _build_agent(results)
    load_policy_state(agent, loaded[1])
    out_dir.mkdir(parents=True)
    save_checkpoint(out_dir / "checkpoints", results["steps"], {"policy": agent.policy.state_dict()}, keep=1)
    shutil.copyfile(run_dir / "results.json", out_dir / "results.json")
    return out_dir


@dataclass
class Pretrained:
    """A loaded agent: its TorchRL ``policy`` and how to build envs it can act on.

    Attributes:
        policy: a ``TensorDictModule`` reading ``"pixels"`` (uint8 ``[..., 3*S, H, W]``, the
            recipes' stacked channel-first frames) and writing ``"action"``; deterministic under
            ``set_exploration_type(ExplorationType.DETERMINISTIC)``.
        results: the training run's ``results.json`` (method, task, seed, frames, config).
    """

    policy: object
    results: dict
    _cfg: object

    @property
    def eval_seed(self) -> int:
        """The seed of the training run's final evaluation (its run seed + ``EVAL_SEED_OFFSET``)."""
        from dcs_torchrl.training.loop import EVAL_SEED_OFFSET

        return int(self._cfg.seed) + EVAL_SEED_OFFSET

    def evaluate(self, episodes: int, *, workers: int = 1, backend: str = "gl", num_envs: int | None = None,
                 **settings):
        """The recipes' final evaluation of this agent in an env of make_env ``settings``.

        ``episodes`` deterministic episodes (:func:`dcs_torchrl.evaluation.protocol.evaluate`) with the
        seeds of the training run's final evaluation (without settings it repeats that evaluation).
        With ``workers`` > 1 the episodes are spread over that many envs, seeded as the workers of a
        :class:`~dcs_torchrl.ParallelSuiteEnv` are (other seeds per env: other episodes than one
        env's), env i running episodes i, i + workers, ...:

        - policy on the CPU: each env in its own process with a copy of the policy
          (:func:`~dcs_torchrl.evaluation.protocol.evaluate_in_processes`); a batched policy there keeps
          the workers waiting (measured: docs/performance.md, "Evaluation on the CPU");
        - policy on a GPU: one :class:`~dcs_torchrl.ParallelSuiteEnv`, the policy acting on the
          batch in this process.

        Both give every episode the return of that episode run alone (up to the batch's float
        rounding on a GPU). ``backend="warp"``: ``num_envs`` envs (default: ``episodes``, all at
        once) in one batched env of this process, rendered by MuJoCo Warp on the policy's device,
        seeded as that many workers are (``workers`` is then unused). Returns an
        :class:`~dcs_torchrl.evaluation.protocol.EvalResult`.
        """
        import torch

        from dcs_torchrl.evaluation.protocol import evaluate, evaluate_in_processes
        from dcs_torchrl.training.envs import batched_pixel_env, close_env, pixel_env, pixel_env_factory, pixel_options

        cfg = self._cfg
        resolved = agent_env_settings(cfg, settings)
        if backend == "warp":
            env = pixel_env(resolved, backend="warp", num_envs=num_envs or episodes, device=cfg.device,
                            **pixel_options(cfg.pixels))
        elif backend != "gl":
            raise ValueError(f"unknown backend {backend!r}; choose 'gl' or 'warp'.")
        elif workers > 1 and torch.device(cfg.device).type == "cpu":
            return evaluate_in_processes(pixel_env_factory(resolved, cfg.pixels), self.policy, episodes, workers,
                                         seed=self.eval_seed)
        elif workers > 1:
            env = batched_pixel_env(resolved, num_workers=workers, seed=self.eval_seed, **pixel_options(cfg.pixels))
        else:  # in this process: no worker to start
            env = self.make_env(seed=self.eval_seed, **settings)
        try:
            return evaluate(env, self.policy, episodes, seed=self.eval_seed)
        finally:
            close_env(env)

    def evaluate_each(self, settings: Sequence[Mapping], episodes: int) -> list:
        """:meth:`evaluate` with ``backend="warp"`` under each of several make_env ``settings``, all
        at once: one batched env holding ``episodes`` envs per setting, each setting's envs seeded
        as its own batch, and the policy given each setting's observations apart, as a batch of
        their own. So each setting's returns are those of ``evaluate(episodes, backend="warp",
        **setting)`` (``tests/test_batched.py``). The settings must all show background videos or
        none (:func:`dcs_torchrl.make_grouped_env`; :func:`~dcs_torchrl.evaluation.scheduling.evaluate_settings` groups them so).
        Returns an :class:`~dcs_torchrl.evaluation.protocol.EvalResult` per setting, in order."""
        from dcs_torchrl.evaluation.protocol import EvalResult, evaluate
        from dcs_torchrl.training.envs import close_env, grouped_pixel_env, pixel_options

        cfg = self._cfg
        if not settings:
            return []
        groups = [(agent_env_settings(cfg, s), episodes) for s in settings]
        env = grouped_pixel_env(groups, device=cfg.device, **pixel_options(cfg.pixels))
        try:
            result = evaluate(env, _per_group(self.policy, [episodes] * len(groups)), episodes * len(groups),
                              seed=self.eval_seed)
        finally:
            close_env(env)
        returns = result.returns
        return [EvalResult(returns[k * episodes:(k + 1) * episodes]) for k in range(len(groups))]

    def make_env(self, *, seed: int | None = None, render_profile: str | None = None, **settings):
        """A suite env on the agent's task with its pixel handling; ``settings`` are make_env's
        distraction settings (``benchmark``, ``dynamic``, ``camera_scale``, ``color_scale``,
        ``num_videos``, ``background_blend``, ``background_dir``, ...), over the training env's;
        ``render_profile``: another render profile than the training run's (``"default"``, ``"fast"``)."""
        from dcs_torchrl.training.envs import pixel_env, pixel_options

        cfg = self._cfg
        pixels = pixel_options(cfg.pixels) | ({} if render_profile is None else {"render_profile": render_profile})
        return pixel_env(agent_env_settings(cfg, settings), seed=seed, **pixels)


def _per_group(policy, sizes: list[int]):
    """``policy`` acting on each group of consecutive rows of a batch apart (a group's actions are
    then those of a batch of that group alone: a batched forward's rounding can depend on the
    batch it runs in)."""
    import torch

    if len(sizes) == 1:
        return policy

    def act(td):
        return torch.cat([policy(part) for part in td.split(sizes, 0)], 0)

    return act


def load_pretrained(agent: str | os.PathLike, device: str = "cpu", *, final: bool = False,
                    trust_checkpoint: bool = False) -> Pretrained:
    """Loads an exported agent, a finished run's newest checkpoint or a shipped agent by name
    (:func:`agent_directory`) as a TorchRL policy; ``final=True`` refuses a checkpoint that is
    not the run's last (``results.json``'s frames). A checkpoint that holds more than tensors,
    numbers and strings is refused
    (:class:`~dcs_torchrl.training.checkpoint.UntrustedCheckpointError`): ``trust_checkpoint=True``
    unpickles it as it is, which runs whatever it names; only for an agent of a source you trust."""
    from dcs_torchrl.training.loop import acting_on

    path = agent_directory(agent)
    results = agent_results(path)
    loaded = agent_checkpoint(path, final=final, trust_checkpoint=trust_checkpoint)
    built, cfg = _build_agent(results, device)
    load_policy_state(built, loaded[1])
    return Pretrained(acting_on(built.policy, device), results, cfg)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description="Export a finished run's acting networks (no replay, no optimisers).")
    parser.add_argument("run_dir", help="a finished training run (results.json and its final checkpoint)")
    parser.add_argument("out_dir", help="a new directory, e.g. recipes/pretrained/<name>")
    parser.add_argument("--trust-checkpoint", action="store_true",
                        help="load a checkpoint that holds more than tensors, numbers and strings (unpickling it "
                             "can run code: only a run of a source you trust); the export holds tensors only "
                             "(default: refused)")
    args = parser.parse_args(argv)
    out = export_policy(args.run_dir, args.out_dir, trust_checkpoint=args.trust_checkpoint)
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"wrote {out} ({size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
