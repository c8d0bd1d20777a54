"""The QT-Opt, QT-Opt+RAD and QT-Opt+DrQ agent: its networks, loss, optimisers and one update.

The recipe ``recipes/qtopt/qtopt.py`` trains it with :func:`dcs_torchrl.training.train`.

QT-Opt (Kalashnikov et al. 2018) as the paper runs it (Stone et al. 2021, section 4): a
Q-function on DrQ's encoder and MLPs, the greedy action found by the cross-entropy method (CEM),
clipped double Q with target networks, QT-Opt's cross-entropy loss on a normalised value, and
DrQ's K = M augmented copies (``algo.aug``: none 0, rad 1, drq 2) averaged in the target and the
loss (:class:`dcs_torchrl.objectives.QTOptLoss`). The acting policy is CEM on the online Q head
(:class:`dcs_torchrl.objectives.CEMActor`). Everything around the update is
:func:`dcs_torchrl.training.train`.
"""
from __future__ import annotations

from omegaconf import DictConfig
from tensordict.nn import TensorDictSequential

from dcs_torchrl.objectives import CEMActor, QTOptLoss
from dcs_torchrl.training.agent import LossAgent, pixel_networks
from dcs_torchrl.training.envs import config_settings
from dcs_torchrl.training.execution import ExecutionOptions

__all__ = ["QTOptAgent"]


class QTOptAgent(LossAgent):
    """QT-Opt's update: the Q-function every step, its targets every second step."""

    def __init__(self, cfg: DictConfig, observation_shape: tuple, action_spec):
        algo = cfg.algo
        action_repeat = config_settings(cfg.env).action_repeat
        encoder, critics, augmentation, copies = pixel_networks(cfg, observation_shape, action_spec)
        cem = {"cem_iterations": algo.cem_iterations, "cem_samples": algo.cem_samples, "cem_elites": algo.cem_elites}
        loss = QTOptLoss(
            critics, encoder=encoder, action_spec=action_spec, augmentation=augmentation, num_augmentations=copies,
            loss_function=algo.loss_function, initial_value=algo.initial_value,
            reward_range=(0.0, float(action_repeat)),  # DM Control: [0, 1] per simulator step
            **cem,
        )
        loss.make_value_estimator(gamma=algo.discount)
        actor = CEMActor(
            loss.qvalue_network, loss.qvalue_network_params, action_spec=action_spec, iterations=algo.cem_iterations,
            num_samples=algo.cem_samples, num_elites=algo.cem_elites, noise_std=algo.noise_std, epsilon=algo.epsilon,
        )
        super().__init__(loss, TensorDictSequential(encoder, actor), tau=algo.critic_tau, device=cfg.device,
                         options=ExecutionOptions.from_config(cfg))
        self.add_optimiser("critic", self.critic_params(self.loss), cfg.optim.lr)
        self.target_every = algo.critic_target_update_frequency

    def schedule(self, index: int) -> tuple[bool]:
        """``(update_targets,)`` at update ``index``."""
        return (index % self.target_every == 0,)

    def update_step(self, batch, update_targets: bool) -> dict:
        out = self.loss(batch)  # augments, encodes once, CEM on the target heads
        self.step(out["loss_qvalue"], ["critic"], update_targets=update_targets)
        metrics = {
            "loss/critic": out["loss_qvalue"], "train/q_value": out["q_value"],
            "train/target_value": out["target_value"], "train/next_state_value": out["next_state_value"],
        }
        return {name: value.detach() for name, value in metrics.items()}
