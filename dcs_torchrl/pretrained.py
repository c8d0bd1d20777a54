"""Trained agents as networks only: export a finished run's acting networks, load them as a policy.

    python -m dcs_torchrl.pretrained <finished run directory> <out directory>

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
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Pretrained", "export_policy", "load_policy_state", "load_pretrained"]


def _results(run_dir: Path) -> dict:
    try:
        return json.loads((run_dir / "results.json").read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"{run_dir} has no results.json: point at a finished training run "
                                "(or an exported agent, e.g. recipes/pretrained/<name>).") from None


def _build_agent(results: dict, device: str = "cpu"):
    """The run's agent (untrained), from its config."""
    from omegaconf import OmegaConf

    from dcs_torchrl.methods import agent_class
    from dcs_torchrl.training.envs import env_options, env_settings, pixel_env, pixel_options

    cfg = OmegaConf.merge(OmegaConf.create(results["config"]), {"device": device})
    settings = env_settings(cfg.env.domain, cfg.env.task, env_options(cfg.env))
    env = pixel_env(settings, **pixel_options(cfg.pixels))  # the specs the networks are built from
    try:
        spec = env.action_spec
        agent = agent_class(cfg.algo.name)(cfg, tuple(env.observation_spec["pixels"].shape[-3:]), spec,
                                                settings.action_repeat)
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


def export_policy(run_dir: str | os.PathLike, out_dir: str | os.PathLike) -> Path:
    """Writes ``run_dir``'s final acting networks to ``out_dir`` (which must not exist yet)."""
    from dcs_torchrl.training.checkpoint import load_latest, save_checkpoint

    run_dir, out_dir = Path(run_dir), Path(out_dir)
    if out_dir.exists():
        raise FileExistsError(f"{out_dir} exists: export into a new directory (nothing is overwritten).")
    results = _results(run_dir)
    loaded = load_latest(run_dir / "checkpoints")
    if loaded is None or loaded[0] != results["steps"]:
        raise RuntimeError(f"{run_dir}: the newest checkpoint ({loaded and loaded[0]} frames) is not the final one "
                           f"({results['steps']} frames).")
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

    def make_env(self, *, seed: int | None = None, **settings):
        """A suite env on the agent's task with its pixel handling; ``settings`` are make_env's
        distraction settings (``benchmark``, ``dynamic``, ``camera_scale``, ``color_scale``,
        ``num_videos``, ``background_blend``, ``background_dir``, ...), over the training env's."""
        from dcs_torchrl.training.envs import env_options, env_settings, pixel_env, pixel_options

        cfg = self._cfg
        options = {**env_options(cfg.env), **settings}
        resolved = env_settings(cfg.env.domain, cfg.env.task, options)
        return pixel_env(resolved, seed=seed, **pixel_options(cfg.pixels))


def load_pretrained(path: str | os.PathLike, device: str = "cpu") -> Pretrained:
    """Loads an exported agent (or a finished run's final checkpoint) as a TorchRL policy."""
    from dcs_torchrl.training.checkpoint import load_latest

    path = Path(path)
    results = _results(path)
    loaded = load_latest(path / "checkpoints")
    if loaded is None:
        raise FileNotFoundError(f"{path}/checkpoints holds no checkpoint that verifies.")
    agent, cfg = _build_agent(results, device)
    load_policy_state(agent, loaded[1])
    return Pretrained(agent.policy, results, cfg)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description="Export a finished run's acting networks (no replay, no optimisers).")
    parser.add_argument("run_dir", help="a finished training run (results.json and its final checkpoint)")
    parser.add_argument("out_dir", help="a new directory, e.g. recipes/pretrained/<name>")
    args = parser.parse_args(argv)
    out = export_policy(args.run_dir, args.out_dir)
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"wrote {out} ({size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
