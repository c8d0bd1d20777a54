"""The SAC, SAC+RAD and SAC+DrQ agent: its networks, loss, optimisers and one update.

The recipe ``recipes/sac/sac.py`` trains it with :func:`dcs_torchrl.training.train`.

The algorithm is DrQ's SAC (Kostrikov et al. 2020) as the paper runs it (Stone et al. 2021,
section 4): a shared pixel encoder trained through the critic only, twin critics, a learned
temperature, and K = M augmented copies (``algo.aug``: none 0, rad 1, drq 2) averaged in the
critic target and loss (:class:`dcs_torchrl.objectives.DrQSACLoss`). Everything around the
update (envs, replay, logging, evaluation, checkpoints) is :func:`dcs_torchrl.training.train`.
"""
from __future__ import annotations

from omegaconf import DictConfig
from tensordict.nn import TensorDictSequential

from dcs_torchrl.modules import make_sac_actor
from dcs_torchrl.objectives import DrQSACLoss
from dcs_torchrl.training.agent import LossAgent, pixel_networks
from dcs_torchrl.training.execution import ExecutionOptions

__all__ = ["SACAgent"]


class SACAgent(LossAgent):
    """DrQ's SAC update: critic every step; actor, temperature and targets every second step."""

    def __init__(self, cfg: DictConfig, observation_shape: tuple, action_spec):
        algo, net = cfg.algo, cfg.network
        encoder, critics, augmentation, copies = pixel_networks(cfg, observation_shape, action_spec)
        actor = make_sac_actor(action_spec, encoder.feature_dim, hidden_dim=net.hidden_dim, hidden_depth=net.hidden_depth)
        loss = DrQSACLoss(
            actor, critics, encoder=encoder, augmentation=augmentation, num_augmentations=copies,
            alpha_init=algo.init_temperature,
        )
        loss.make_value_estimator(gamma=algo.discount)
        super().__init__(loss, TensorDictSequential(encoder, actor), tau=algo.critic_tau, device=cfg.device,
                         options=ExecutionOptions.from_config(cfg))
        self.add_optimiser("critic", self.critic_params(self.loss), cfg.optim.lr)
        self.add_optimiser("actor", self.loss.actor_network_params.values(True, True), cfg.optim.lr)
        self.add_optimiser("alpha", [self.loss.log_alpha], cfg.optim.lr)
        self.actor_every, self.target_every = algo.actor_update_frequency, algo.critic_target_update_frequency

    def schedule(self, index: int) -> tuple[bool, bool]:
        """``(update_actor, update_targets)`` at update ``index``."""
        return index % self.actor_every == 0, index % self.target_every == 0

    def update_step(self, batch, update_actor: bool, update_targets: bool) -> dict:
        out = self.loss(batch)  # augments, encodes once, computes all three losses
        total = out["loss_qvalue"] + (out["loss_actor"] + out["loss_alpha"] if update_actor else 0.0)
        self.step(total, ["critic", "actor", "alpha"] if update_actor else ["critic"], update_targets=update_targets)
        metrics = {
            "loss/critic": out["loss_qvalue"], "loss/actor": out["loss_actor"], "loss/alpha": out["loss_alpha"],
            "train/alpha": out["alpha"], "train/entropy": out["entropy"], "train/target_value": out["target_value"],
        }
        return {name: value.detach() for name, value in metrics.items()}
