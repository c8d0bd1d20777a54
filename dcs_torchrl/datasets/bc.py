"""The offline baseline: behaviour cloning from pixels on a dataset, scored with the suite's evaluation.

    python -m dcs_torchrl.datasets bc --data data/cartpole_none_expert --out runs/bc_cartpole \\
        --updates 3000 --batch-size 128 --eval-episodes 20 --eval none medium --expert

The policy is DrQ's pixel encoder (:func:`dcs_torchrl.modules.networks.make_encoder`, the agents'
own) and a 2-layer MLP with a tanh output, trained to regress the set's actions (mean squared
error, Adam) on stacked frames sampled by :func:`dcs_torchrl.datasets.load`, with DrQ's random
shift (V-D4RL's DrQ+BC uses the same augmentation). It is then evaluated as the recipes evaluate an
agent (:func:`dcs_torchrl.evaluation.protocol.evaluate`: deterministic episodes of the recipes' pixel env,
one torch thread) in each ``--eval`` setting (a benchmark, ``:dynamic`` for its dynamic setting),
with ``--expert`` the set's first agent beside it on the same episodes (the same seed). Writes
``<out>/policy.pt`` and ``<out>/results.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import torch
from tensordict.nn import TensorDictModule, TensorDictSequential
from torch import nn

__all__ = ["add_arguments", "bc_policy", "evaluation_settings", "score", "train_bc"]


def bc_policy(frame_stack: int, image_size: int, action_dim: int, *, hidden_dim: int = 256) -> TensorDictSequential:
    """``"pixels"`` (uint8 ``[..., 3*S, H, W]``) -> ``"embedding"`` -> ``"action"`` in [-1, 1]."""
    from dcs_torchrl.modules.networks import make_encoder, mlp

    encoder = make_encoder((3 * frame_stack, image_size, image_size))
    head = nn.Sequential(mlp(encoder.feature_dim, hidden_dim, action_dim, 2), nn.Tanh())
    return TensorDictSequential(encoder, TensorDictModule(head, in_keys=["embedding"], out_keys=["action"]))


def evaluation_settings(text: str) -> dict:
    """make_env settings of an ``--eval`` value: ``medium`` (static), ``medium:dynamic``.

    >>> evaluation_settings("medium:dynamic")
    {'benchmark': 'medium', 'dynamic': True}
    """
    benchmark, _, kind = text.partition(":")
    if kind not in ("", "static", "dynamic"):
        raise ValueError(f"--eval {text}: write a benchmark, optionally ':dynamic' or ':static' (e.g. medium:dynamic).")
    return {"benchmark": benchmark, "dynamic": kind == "dynamic"}


def score(policy, domain: str, task: str, settings: dict, pixels: dict, episodes: int, seed: int) -> dict:
    """The recipes' evaluation of ``policy`` in the pixel env of ``settings``: ``EvalResult.to_dict()``."""
    from dcs_torchrl.evaluation.protocol import evaluate
    from dcs_torchrl.training.envs import close_env, config_settings, pixel_env

    env = pixel_env(config_settings({"domain": domain, "task": task}, settings), seed=seed, **pixels)
    try:
        return evaluate(env, policy, episodes, seed=seed).to_dict()
    finally:
        close_env(env)


def train_bc(data: str | os.PathLike, *, updates: int, batch_size: int, frame_stack: int, lr: float = 3e-4,
             seed: int = 0, shift: int = 4, log_every: int = 500) -> tuple[TensorDictSequential, list[float]]:
    """Trains :func:`bc_policy` on the set ``data``; returns it (in eval mode) and the loss every ``log_every`` updates."""
    from dcs_torchrl.datasets.layout import load_data
    from dcs_torchrl.datasets.loading import load
    from dcs_torchrl.modules.augment import RandomShift

    torch.manual_seed(seed)
    buffer = load(data, batch_size, frame_stack)
    stored = load_data(data)
    policy = bc_policy(frame_stack, stored["frames", "pixels"].shape[1], stored["transitions", "action"].shape[-1])
    augment = RandomShift(shift, in_keys=["pixels"])
    optimiser = torch.optim.Adam(policy.parameters(), lr=lr)
    losses = []
    for update in range(1, updates + 1):
        batch = augment(buffer.sample().select("pixels", "action"))
        target = batch["action"].to(torch.float32)
        loss = nn.functional.mse_loss(policy(batch.exclude("action"))["action"], target)
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        if update % log_every == 0 or update == updates:
            losses.append(float(loss.detach()))
            print(f"update {update}/{updates}: loss {losses[-1]:.4f}", flush=True)
    return policy.eval(), losses


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", required=True, help="a dataset (python -m dcs_torchrl.datasets generate)")
    parser.add_argument("--out", required=True, help="where policy.pt and results.json go")
    parser.add_argument("--updates", type=int, default=3000)
    parser.add_argument("--batch-size", type=int, default=128)
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--frame-stack", type=int, default=3, help="frames per observation (the agents': 3)")
    parser.add_argument("--seed", type=int, default=0, help="the training's seed")
    parser.add_argument("--threads", type=int, default=1, help="torch threads while training")
    parser.add_argument("--eval", nargs="+", default=["none", "medium"], metavar="BENCHMARK[:dynamic]",
                        help="settings to score in (default: none medium)")
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--eval-seed", type=int, default=10_000,
                        help="seed of the evaluation episodes (default: the shipped agents' final evaluation's)")
    parser.add_argument("--expert", action="store_true", help="also score the set's first agent on the same episodes")


def main(args: argparse.Namespace) -> dict:
    from dcs_torchrl.datasets.layout import METADATA, read_json
    from dcs_torchrl.datasets.policies import load_behaviour

    record = read_json(Path(args.data) / METADATA)
    env, pixels = record["env"], record["pixels"]
    evals = {text: evaluation_settings(text) for text in args.eval}
    agents = [p for p in record["policies"] if p["kind"] == "agent"]
    if args.expert and not agents:
        raise ValueError(f"--expert: {args.data} was made by the random policy alone; leave --expert out.")
    torch.set_num_threads(args.threads)
    start = time.time()
    policy, losses = train_bc(args.data, updates=args.updates, batch_size=args.batch_size, frame_stack=args.frame_stack,
                              lr=args.lr, seed=args.seed)
    seconds = time.time() - start
    act = {"frame_stack": args.frame_stack, "image_size": pixels["image_size"], "render_profile": pixels["render_profile"]}
    result = {"data": os.fspath(args.data), "set": {k: record[k] for k in ("episodes", "transitions", "returns")},
              "updates": args.updates, "batch_size": args.batch_size, "lr": args.lr, "seed": args.seed,
              "train_seconds": seconds, "losses": losses, "eval_seed": args.eval_seed, "bc": {}, "expert": {}}
    for text, settings in evals.items():
        result["bc"][text] = score(policy, env["domain"], env["task"], settings, act, args.eval_episodes, args.eval_seed)
        print(f"BC {text}: {result['bc'][text]['mean']:.1f} ± {result['bc'][text]['stderr']:.1f}", flush=True)
    if args.expert:
        expert = load_behaviour(agents[0]["name"])
        for text, settings in evals.items():
            result["expert"][text] = score(expert.agent.policy, env["domain"], env["task"], settings, expert.pixels,
                                           args.eval_episodes, args.eval_seed)
            print(f"expert {text}: {result['expert'][text]['mean']:.1f} ± {result['expert'][text]['stderr']:.1f}",
                  flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    torch.save({"policy": policy.state_dict(), **act}, out / "policy.pt")
    (out / "results.json").write_text(json.dumps(result, indent=2) + "\n")
    return result
