"""Evidence that the six methods learn: DM Control cartpole swingup from states (slow).

Every method (SAC / QT-Opt x none / rad / drq) runs the same loss code as from pixels, with the
flat-vector encoder (identity) and, for RAD / DrQ, :class:`ObservationNoise` (std 0.01 on the
state vector) as the augmentation f(s, nu): K = M = 1 or 2 genuinely different copies. Budget:
action repeat 8, 10K agent steps (80K frames), batch 128, 256-unit MLPs (the paper's 1024-unit
MLPs and batch 512 are for pixels; at 1024 units QT-Opt's CEM alone costs ~0.5 s an update on
this 2-core CPU). Run with ``python -m pytest tests/objectives/test_learning_states.py -m slow -s``.
"""
from __future__ import annotations

import time

import pytest
import torch
from tensordict.nn import TensorDictSequential
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, ReplayBuffer
from torchrl.envs import CatTensors, Compose, DMControlEnv, DoubleToFloat, TransformedEnv
from torchrl.objectives import SoftUpdate

from dcs_torchrl.evaluation.protocol import EvalResult, evaluate
from dcs_torchrl.modules import ObservationNoise, augmentation_copies, make_critic, make_encoder, make_sac_actor, with_next_keys
from dcs_torchrl.objectives import CEMActor, DrQSACLoss, QTOptLoss

ACTION_REPEAT = 8  # PlaNet benchmark setting for cartpole swingup (the paper's Table 1)
STATE_OF_THE_ART = 850.0  # cartpole swingup, ~the best published returns (the paper's Table 2)
METHODS = [(algo, aug) for algo in ("sac", "qtopt") for aug in ("none", "rad", "drq")]


def make_states_env(seed: int) -> TransformedEnv:
    env = TransformedEnv(
        DMControlEnv("cartpole", "swingup", frame_skip=ACTION_REPEAT),
        Compose(CatTensors(in_keys=["position", "velocity"], out_key="observation"), DoubleToFloat()),
    )
    env.set_seed(seed)
    return env


def train_states(
    algo: str,
    aug: str,
    *,
    steps: int = 10_000,
    seed_steps: int = 1_000,
    batch_size: int = 128,
    hidden_dim: int = 256,
    lr: float = 1e-3,
    seed: int = 0,
    eval_episodes: int = 10,
    log_every: int | None = None,
    qtopt_kwargs: dict | None = None,
) -> tuple[EvalResult, int, float]:
    """Trains one method from states; returns (final evaluation, frames, wall seconds)."""
    torch.manual_seed(seed)
    start = time.perf_counter()
    env = make_states_env(seed)
    obs_dim = env.observation_spec["observation"].shape[-1]
    action_spec = env.action_spec

    copies = augmentation_copies(aug)
    augmentation = ObservationNoise(0.01, in_keys=with_next_keys(["observation"])) if copies else None
    encoder = make_encoder((obs_dim,))
    critics = [make_critic(action_spec, encoder.feature_dim, hidden_dim=hidden_dim) for _ in range(2)]
    if algo == "sac":
        actor = make_sac_actor(action_spec, encoder.feature_dim, hidden_dim=hidden_dim)
        loss = DrQSACLoss(actor, critics, encoder=encoder, augmentation=augmentation, num_augmentations=copies)
        policy = TensorDictSequential(encoder, actor)
        critic_optim = torch.optim.Adam([*loss.qvalue_network_params.values(True, True), *loss.encoder_network_params.values(True, True)], lr=lr)
        actor_optim = torch.optim.Adam(loss.actor_network_params.values(True, True), lr=lr)
        alpha_optim = torch.optim.Adam([loss.log_alpha], lr=lr)
    else:
        loss = QTOptLoss(
            critics, encoder=encoder, action_spec=action_spec, augmentation=augmentation,
            num_augmentations=copies, reward_range=(0.0, float(ACTION_REPEAT)), **(qtopt_kwargs or {}),
        )
        policy = TensorDictSequential(encoder, CEMActor(loss.qvalue_network, loss.qvalue_network_params, action_spec=action_spec))
        critic_optim = torch.optim.Adam([*loss.qvalue_network_params.values(True, True), *loss.encoder_network_params.values(True, True)], lr=lr)
    target_updater = SoftUpdate(loss, tau=0.01)

    collector = Collector(
        env, policy, frames_per_batch=10, total_frames=steps, init_random_frames=seed_steps,
        auto_register_policy_transforms=False,
    )
    buffer = ReplayBuffer(storage=LazyTensorStorage(100_000), batch_size=batch_size)
    updates = 0
    for i, data in enumerate(collector):
        buffer.extend(data.reshape(-1))
        if len(buffer) < seed_steps:
            continue
        for _ in range(data.numel()):
            updates += 1
            out = loss(buffer.sample())
            update_actor = algo == "sac" and updates % 2 == 0  # DrQ: actor_update_frequency 2
            total = out["loss_qvalue"]
            if update_actor:
                total = total + out["loss_actor"] + out["loss_alpha"]
            critic_optim.zero_grad()
            if algo == "sac":
                actor_optim.zero_grad()
                alpha_optim.zero_grad()
            total.backward()
            critic_optim.step()
            if update_actor:
                actor_optim.step()
                alpha_optim.step()
            if updates % 2 == 0:  # DrQ: critic_target_update_frequency 2
                target_updater.step()
        if log_every and (i + 1) % log_every == 0:
            result = evaluate(make_states_env(seed + 1000 + i), policy, 2)
            print(f"{algo}/{aug} step {(i + 1) * 10}: eval {result.mean:.0f}  "
                  f"{ {k: round(float(v), 3) for k, v in out.items()} }  {time.perf_counter() - start:.0f}s", flush=True)
    collector.shutdown()
    result = evaluate(make_states_env(seed + 10_000), policy, eval_episodes)
    return result, steps * ACTION_REPEAT, time.perf_counter() - start


@pytest.mark.slow
@pytest.mark.parametrize("algo,aug", METHODS)
def test_learns_cartpole_swingup_from_states(algo, aug):
    result, frames, wall = train_states(algo, aug)
    print(f"\n{algo}/{aug}: return {result.mean:.1f} +- {result.stderr:.1f} "
          f"({result.episodes} episodes) after {frames} frames, {wall:.0f} s")
    assert result.mean > 0.65 * STATE_OF_THE_ART, result.to_dict()
