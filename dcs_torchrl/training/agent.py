"""What the SAC and QT-Opt recipes share: the pixel networks and a checkpointable optimiser step.

:func:`pixel_networks` builds DrQ's encoder, the twin Q heads and the augmentation from a
recipe config; :class:`LossAgent` holds a loss module, its named Adam optimisers and the soft
target update, does one backward pass per update (:meth:`LossAgent.step`), runs the update as the
run's execution options say (:mod:`dcs_torchrl.training.execution`) and saves / loads all of it
for checkpoints. A recipe subclasses it and writes ``schedule`` and ``update_step`` (the algorithm).
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

import torch
from omegaconf import DictConfig
from tensordict import TensorDictBase
from tensordict.nn import ProbabilisticTensorDictModule, TensorDictModuleBase
from torchrl.objectives import LossModule, SoftUpdate

from dcs_torchrl.methods import augmentation_copies
from dcs_torchrl.modules import RandomShift, make_critic, make_encoder, with_next_keys
from dcs_torchrl.training.execution import ExecutionOptions, UpdateRunner

__all__ = ["LossAgent", "pixel_networks", "place_distribution_bounds"]


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

    A recipe's agent writes two methods: :meth:`schedule` (which parts of the update run at an
    update index, e.g. SAC's actor every second update) and :meth:`update_step` (the whole
    update for a schedule: losses, :meth:`step`, metrics). :meth:`update` runs it as the
    agent's :class:`~dcs_torchrl.training.execution.ExecutionOptions` say: eager by default,
    compiled and/or replayed as CUDA graphs (``execution.compile``, ``execution.cudagraph``).
    Its metrics stay on the device (0-d tensors; nothing in an update reads the device from
    the host).

    Args:
        loss (LossModule): the loss (holds every network and target).
        policy (TensorDictModuleBase): the acting policy (sharing the loss's parameters).

    Keyword Args:
        tau (float): soft target update rate (:class:`~torchrl.objectives.SoftUpdate`).
        device (str): where the networks live; batches are moved there.
        options (ExecutionOptions, optional): how the update runs and which Adam it uses;
            ``None``: eager, torch's default Adam (the CPU's behaviour).
    """

    def __init__(self, loss: LossModule, policy: TensorDictModuleBase, *, tau: float, device: str = "cpu",
                 options: ExecutionOptions | None = None):
        self.device = torch.device(device)
        self.options = options if options is not None else ExecutionOptions(device=self.device)
        self.loss = loss.to(self.device)
        self.policy = policy.to(self.device)  # what acts too: e.g. CEM's action bounds (buffers)
        for module in (self.loss, self.policy):
            place_distribution_bounds(module, self.device)
        self.target_updater = SoftUpdate(self.loss, tau=tau)
        self.optimisers: dict[str, torch.optim.Optimizer] = {}
        self.runner: UpdateRunner | None = None  # built at the first update

    def add_optimiser(self, name: str, params: Iterable[torch.Tensor], lr: float) -> None:
        self.optimisers[name] = torch.optim.Adam(list(params), lr=lr, **self.options.adam_kwargs())

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

    def schedule(self, index: int) -> tuple:
        """Which parts of the update run at update ``index`` (flags passed to :meth:`update_step`)."""
        return ()

    def update_step(self, batch: TensorDictBase, *schedule: bool) -> dict[str, torch.Tensor]:
        """The whole update of ``batch`` (on the agent's device) for ``schedule``; its metrics,
        detached 0-d tensors. Written by a recipe's agent."""
        raise NotImplementedError

    def update(self, batch: TensorDictBase, index: int) -> dict[str, torch.Tensor]:
        """One gradient update on a replay sample (``index`` counts updates from 0); its metrics
        as detached 0-d tensors on the device (read them at logging time)."""
        if self.runner is None:
            self.runner = UpdateRunner(self.update_step, self.options)
        return self.runner(batch.to(self.device), self.schedule(index))

    def state_dict(self) -> dict:
        return {"loss": self.loss.state_dict(), "optimisers": {k: o.state_dict() for k, o in self.optimisers.items()}}

    def load_state_dict(self, state: dict) -> None:
        self.loss.load_state_dict(state["loss"])
        for name, optimiser in self.optimisers.items():
            optimiser.load_state_dict(_with_flags_of(optimiser, state["optimisers"][name]))
        self.runner = None  # new optimiser state tensors: graphs and compiled code are made again


def _with_flags_of(optimiser: torch.optim.Optimizer, saved: dict) -> dict:
    """``saved`` (an optimiser state) with ``optimiser``'s own ``fused`` / ``capturable`` flags, so
    that a checkpoint written under other execution options loads with this run's (Adam's step
    counts go to the device or stay on the host by these flags)."""
    groups = [{**group, **{k: mine[k] for k in ("fused", "capturable") if k in mine}}
              for group, mine in zip(saved["param_groups"], optimiser.param_groups)]
    return {**saved, "param_groups": groups}


def place_distribution_bounds(module: torch.nn.Module, device: torch.device) -> None:
    """Moves the tensors of every probabilistic module's ``distribution_kwargs`` (e.g. the SAC
    actor's ``TanhNormal`` bounds) to ``device``: ``Module.to`` does not (they are not buffers),
    and bounds on the host would be copied to the device each time a distribution is built,
    which a CUDA graph cannot hold."""
    for sub in module.modules():
        kwargs = getattr(sub, "distribution_kwargs", None)
        if isinstance(sub, ProbabilisticTensorDictModule) and kwargs:
            sub.distribution_kwargs = {k: v.to(device) if isinstance(v, torch.Tensor) else v for k, v in kwargs.items()}
