"""What the SAC and QT-Opt recipes share: the pixel networks and a checkpointable optimiser step.

:func:`pixel_networks` builds DrQ's encoder, the twin Q heads and the augmentation from a
recipe config; :class:`LossAgent` holds a loss module, its named Adam optimisers and the soft
target update, does one backward pass per update (:meth:`LossAgent.step`) and saves / loads all
of it for checkpoints. A recipe subclasses it and writes ``update`` (the algorithm).
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

import torch
from omegaconf import DictConfig
from tensordict.nn import TensorDictModuleBase
from torchrl.objectives import LossModule, SoftUpdate

from dcs_torchrl.methods import augmentation_copies
from dcs_torchrl.modules import RandomShift, make_critic, make_encoder, with_next_keys

__all__ = ["LossAgent", "pixel_networks"]


def pixel_networks(cfg: DictConfig, observation_shape: Sequence[int], action_spec) -> tuple:
    """``(encoder, critics, augmentation, copies)`` for a recipe config.

    ``copies`` is DrQ's K = M from ``algo.aug`` (none 0, rad 1, drq 2); the augmentation is
    DrQ's :class:`~dcs_torchrl.modules.RandomShift` (pad ``algo.image_pad``) on the observation
    and the next observation, ``None`` for ``none``.
    """
    copies = augmentation_copies(cfg.algo.aug)
    augmentation = RandomShift(cfg.algo.image_pad, in_keys=with_next_keys(["pixels"])) if copies else None
    net = cfg.network
    encoder = make_encoder(observation_shape, feature_dim=net.feature_dim, channels_last=net.channels_last, compile=net.compile)
    critics = [
        make_critic(action_spec, encoder.feature_dim, hidden_dim=net.hidden_dim, hidden_depth=net.hidden_depth)
        for _ in range(2)  # independently initialised twin heads
    ]
    return encoder, critics, augmentation, copies


class LossAgent:
    """A loss, its optimisers and target updates, as one checkpointable object.

    Args:
        loss (LossModule): the loss (holds every network and target).
        policy (TensorDictModuleBase): the acting policy (sharing the loss's parameters).

    Keyword Args:
        tau (float): soft target update rate (:class:`~torchrl.objectives.SoftUpdate`).
        device (str): where the networks live; batches are moved there.
    """

    def __init__(self, loss: LossModule, policy: TensorDictModuleBase, *, tau: float, device: str = "cpu"):
        self.device = torch.device(device)
        self.loss = loss.to(self.device)
        self.policy = policy.to(self.device)  # what acts too: e.g. CEM's action bounds (buffers)
        self.target_updater = SoftUpdate(self.loss, tau=tau)
        self.optimisers: dict[str, torch.optim.Optimizer] = {}

    def add_optimiser(self, name: str, params: Iterable[torch.Tensor], lr: float) -> None:
        self.optimisers[name] = torch.optim.Adam(list(params), lr=lr)

    @staticmethod
    def critic_params(loss: LossModule) -> list[torch.Tensor]:
        """The Q heads and the encoder: the encoder is trained by the critic loss only (DCS)."""
        return [*loss.qvalue_network_params.values(True, True), *loss.encoder_network_params.values(True, True)]

    def step(self, total: torch.Tensor, optimisers: Sequence[str], *, update_targets: bool) -> None:
        """One backward pass of ``total``, a step of the named optimisers, then the soft target update."""
        for optimiser in self.optimisers.values():
            optimiser.zero_grad(set_to_none=True)
        total.backward()
        for name in optimisers:
            self.optimisers[name].step()
        if update_targets:
            self.target_updater.step()

    def state_dict(self) -> dict:
        return {"loss": self.loss.state_dict(), "optimisers": {k: o.state_dict() for k, o in self.optimisers.items()}}

    def load_state_dict(self, state: dict) -> None:
        self.loss.load_state_dict(state["loss"])
        for name, optimiser in self.optimisers.items():
            optimiser.load_state_dict(state["optimisers"][name])

