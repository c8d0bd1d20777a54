"""SAC, SAC+RAD and SAC+DrQ: TorchRL's SACLoss with a shared encoder and DrQ averaging."""
from __future__ import annotations

from dataclasses import dataclass

import torch
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import dispatch, ProbabilisticTensorDictSequential, TensorDictModule
from torch import Tensor
from torchrl.data.tensor_specs import TensorSpec
from torchrl.envs.transforms import Transform
from torchrl.envs.utils import ExplorationType, set_exploration_type
from torchrl.objectives import SACLoss
from torchrl.objectives.sac import compute_rsample_log_prob

from dcs_torchrl._compat.private_api import build_default_value_estimator, priority_weight, reduce_loss, sac_alpha_loss
from dcs_torchrl.objectives.drq import DrQEncoding

__all__ = ["DrQSACLoss"]

# The target-embedding entry of the internal next-state tensordict (never read from the input).
_TARGET_EMBEDDING = "_target_embedding"
_TARGET_VALUE = "_target_value"


class DrQSACLoss(DrQEncoding, SACLoss):
    r"""SAC (v2, twin critics, learned temperature) on a shared encoder, with DrQ's K = M copies.

    The extension of :class:`torchrl.objectives.SACLoss` is DrQ (Kostrikov et al. 2020) as used
    by Stone et al. (2021):

    * an ``encoder`` (pixels -> embedding) shared by the actor and the critics and trained by the
      critic loss only: the actor loss sees a detached embedding; the critic target uses a
      target copy of the encoder, soft-updated with the critic heads (one
      :class:`~torchrl.objectives.SoftUpdate` for both, as DrQ's ``critic_tau``);
    * ``num_augmentations`` K = M augmented copies (0: none, 1: RAD, 2: DrQ). The target is
      averaged over the K copies of the next observation,
      :math:`y = r + \gamma (1 - d) \frac{1}{K}\sum_k V(f(s', \nu_k))` with
      :math:`V(s') = \min_i \bar Q_i(s', a') - \alpha \log \pi(a'|s')`, :math:`a' \sim \pi(s')`,
      and the critic loss is averaged over the M copies of the observation,
      :math:`\frac{1}{M}\sum_m \sum_i (Q_i(f(s, \nu_m), a) - y)^2` (DrQ's Algorithm 1; DrQ's code
      sums the M terms instead, a constant factor that Adam removes). The actor and temperature
      losses use the first copy, as DrQ does. With K = M = 0 this is exactly ``SACLoss``.

    Everything else (actor loss, temperature loss, vmapped twin critics, value estimator) is
    ``SACLoss``'s: only the target (:meth:`_compute_target_v2`) and ``forward`` (encoding and
    copies) are extended.

    One update reads each image batch once per encoder: the critic's M copies are one encoder
    pass with gradient; the K next copies one pass of the online encoder (for the next actions)
    and one of the target encoder, without gradient; the actor loss reuses the critic's
    embedding of the first copy, detached. The reference DrQ code re-encodes the observation for
    the actor update *after* the critic's optimiser step and evaluates the critic there after
    that step; here all three losses are computed before any step (one backward pass of their
    sum), so the actor sees the pre-step encoder and critic, as in TorchRL's SAC recipe.

    Args:
        actor_network (ProbabilisticActor): the actor head, reading the encoder's embedding
            (e.g. :func:`~dcs_torchrl.modules.make_sac_actor`).
        qvalue_network (TensorDictModule or list of them): the critic head(s), reading
            ``[embedding, action]`` and writing ``"state_action_value"``. Pass a list of
            ``num_qvalue_nets`` independently initialised heads to keep their initialisation.

    Keyword Args:
        encoder (TensorDictModule): observation -> embedding (one out_key), e.g.
            :func:`~dcs_torchrl.modules.make_encoder`.
        augmentation (Transform, optional): applied to the encoder's inputs and their
            ``("next", ...)`` counterparts (e.g. ``RandomShift(4, in_keys=["pixels",
            ("next", "pixels")])``); ``None`` when ``num_augmentations == 0``.
        num_augmentations (int): K = M. Defaults to ``0``.
        num_qvalue_nets (int): critics. Defaults to ``2``.
        loss_function (str): critic distance. Defaults to ``"l2"`` (DrQ's MSE).
        alpha_init (float): initial temperature. Defaults to ``0.1`` (DrQ ``init_temperature``).
        target_entropy (float or "auto"): defaults to ``"auto"`` = ``-dim(A)`` (DrQ).
        action_spec (TensorSpec, optional): for ``target_entropy="auto"`` if the actor has no spec.
        fixed_alpha, min_alpha, max_alpha, deactivate_vmap: as in ``SACLoss``.
        reduction (str): ``"mean"`` (default) or ``"sum"``.

    The discount is the value estimator's (TorchRL's default TD(0), gamma 0.99 = DrQ's
    ``discount``; change it with ``make_value_estimator(gamma=...)``).

    Input keys: the encoder's ``in_keys`` (e.g. ``"pixels"``) and their ``("next", ...)``,
    ``"action"``, ``("next", "reward")``, ``("next", "done")``, ``("next", "terminated")``
    (only ``terminated`` stops bootstrapping: DM Control's time limit is a truncation). Writes
    ``"td_error"`` (priority) into the input. Returns ``loss_qvalue``, ``loss_actor``,
    ``loss_alpha`` and detached ``alpha``, ``entropy`` and ``target_value`` (mean target).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded
        >>> from torchrl.objectives import SoftUpdate
        >>> from dcs_torchrl.modules import RandomShift, make_critic, make_encoder, make_sac_actor
        >>> spec = Bounded(-1.0, 1.0, shape=(2,))
        >>> encoder = make_encoder((9, 84, 84))
        >>> actor = make_sac_actor(spec, encoder.feature_dim, hidden_dim=32)
        >>> critics = [make_critic(spec, encoder.feature_dim, hidden_dim=32) for _ in range(2)]
        >>> loss = DrQSACLoss(actor, critics, encoder=encoder, num_augmentations=2,
        ...                   augmentation=RandomShift(4, in_keys=["pixels", ("next", "pixels")]))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> B = 4
        >>> data = TensorDict({
        ...     "pixels": torch.randint(0, 256, (B, 9, 84, 84), dtype=torch.uint8),
        ...     "action": spec.rand((B,)),
        ...     ("next", "pixels"): torch.randint(0, 256, (B, 9, 84, 84), dtype=torch.uint8),
        ...     ("next", "reward"): torch.rand(B, 1),
        ...     ("next", "done"): torch.zeros(B, 1, dtype=torch.bool),
        ...     ("next", "terminated"): torch.zeros(B, 1, dtype=torch.bool),
        ... }, [B])
        >>> out = loss(data)
        >>> sorted(k for k in out.keys() if k.startswith("loss_"))
        ['loss_actor', 'loss_alpha', 'loss_qvalue']
        >>> (out["loss_qvalue"] + out["loss_actor"] + out["loss_alpha"]).backward()
    """

    @dataclass
    class _AcceptedKeys(SACLoss._AcceptedKeys):
        """Keys of :class:`~torchrl.objectives.SACLoss` (``action``, ``reward``, ``done``,
        ``terminated``, ``state_action_value``, ``value``, ``log_prob``, ``priority``,
        ``priority_weight``). The observation and embedding keys are the encoder's
        ``in_keys`` and ``out_keys``; the actor and critic heads must read the embedding.
        """

    default_keys = _AcceptedKeys
    out_keys = ["loss_actor", "loss_qvalue", "loss_alpha", "alpha", "entropy", "target_value"]

    encoder_network: TensorDictModule
    encoder_network_params: TensorDictParams
    target_encoder_network_params: TensorDictParams

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        qvalue_network: TensorDictModule | list[TensorDictModule],
        *,
        encoder: TensorDictModule,
        augmentation: Transform | None = None,
        num_augmentations: int = 0,
        num_qvalue_nets: int = 2,
        loss_function: str = "l2",
        alpha_init: float = 0.1,
        min_alpha: float | None = None,
        max_alpha: float | None = None,
        action_spec: TensorSpec | None = None,
        fixed_alpha: bool = False,
        target_entropy: str | float = "auto",
        reduction: str = "mean",
        deactivate_vmap: bool = False,
    ) -> None:
        if reduction not in ("mean", "sum"):
            raise ValueError(f"reduction must be 'mean' or 'sum', got {reduction!r}.")
        first_q = qvalue_network[0] if isinstance(qvalue_network, (list, tuple)) else qvalue_network
        super().__init__(
            actor_network,
            qvalue_network,
            num_qvalue_nets=num_qvalue_nets,
            loss_function=loss_function,
            alpha_init=alpha_init,
            min_alpha=min_alpha,
            max_alpha=max_alpha,
            action_spec=action_spec,
            fixed_alpha=fixed_alpha,
            target_entropy=target_entropy,
            delay_actor=False,
            delay_qvalue=True,
            reduction=reduction,
            deactivate_vmap=deactivate_vmap,
        )
        self._init_encoding(
            encoder, augmentation, num_augmentations, [*actor_network.in_keys, *first_q.in_keys]
        )
        # Built now rather than lazily, so that state_dict() has the same keys before and after
        # the first forward (a checkpoint loads into a freshly built loss).
        build_default_value_estimator(self)

    @property
    def in_keys(self):
        return self._loss_in_keys()

    @in_keys.setter
    def in_keys(self, values):
        self._in_keys = values

    def _compute_target_v2(self, tensordict: TensorDictBase) -> Tensor:
        """DrQ target: ``y`` averaged over the K next-observation copies, broadcast to ``[K, *B]``.

        ``tensordict`` is the ``[K, *B]`` batch of copies; its ``"next"`` holds the online
        embedding (for the next action) and the target encoder's (for the target critics).
        """
        with torch.no_grad():
            next_td = tensordict.get("next")
            with set_exploration_type(ExplorationType.RANDOM), self.actor_network_params.to_module(
                self.actor_network, preserve_module_state=False
            ):
                dist = self.actor_network.get_dist(next_td.select(*self.actor_network.in_keys))
                next_action, next_log_prob = compute_rsample_log_prob(dist)
            target_in = TensorDict(
                {self.embedding_key: next_td.get(_TARGET_EMBEDDING), self.tensor_keys.action: next_action},
                batch_size=next_td.batch_size,
            )
            next_q = self._vmap_qnetworkN0(target_in, self.target_qvalue_network_params).get(
                self.tensor_keys.state_action_value
            )  # [num_qvalue_nets, K, *B, 1]
            next_value = (next_q - self._alpha * next_log_prob.unsqueeze(-1)).min(0).values
            next_value = next_value.mean(0)  # (1 / K) sum_k V(f(s', nu_k))
            first = tensordict[0]
            value_td = TensorDict(
                {
                    ("next", key): first.get(("next", key))
                    for key in (self.tensor_keys.reward, self.tensor_keys.done, self.tensor_keys.terminated)
                },
                batch_size=first.batch_size,
            )
            value_td.set(("next", self.value_estimator.tensor_keys.value), next_value)
            target = self.value_estimator.value_estimate(value_td).squeeze(-1).expand(tensordict.batch_size)
        tensordict.set(_TARGET_VALUE, target)  # read back by forward for logging
        return target

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        copies, embedding, next_embedding, next_target_embedding = self._encode(tensordict, online_next=True)
        keys = self.tensor_keys
        critic_td = TensorDict(
            {
                self.embedding_key: embedding,
                keys.action: copies.get(keys.action),
                ("next", self.embedding_key): next_embedding,
                ("next", _TARGET_EMBEDDING): next_target_embedding,
                ("next", keys.reward): copies.get(("next", keys.reward)),
                ("next", keys.done): copies.get(("next", keys.done)),
                ("next", keys.terminated): copies.get(("next", keys.terminated)),
            },
            batch_size=copies.batch_size,
        )
        weights = priority_weight(self, tensordict)
        if weights is not None:
            critic_td.set(keys.priority_weight, weights.expand(copies.batch_size))
        loss_qvalue, value_metadata = self.qvalue_v2_loss(critic_td)

        actor_td = TensorDict({self.embedding_key: embedding[0].detach()}, batch_size=tensordict.batch_size)
        if weights is not None:
            actor_td.set(keys.priority_weight, weights)
        loss_actor, actor_metadata = self.actor_loss(actor_td)
        loss_alpha = reduce_loss(self, sac_alpha_loss(self, actor_metadata["log_prob"]), weights=weights)
        tensordict.set(keys.priority, value_metadata["td_error"].mean(0))
        return TensorDict(
            {
                "loss_actor": loss_actor,
                "loss_qvalue": loss_qvalue,
                "loss_alpha": loss_alpha,
                "alpha": self._alpha,
                "entropy": -actor_metadata["log_prob"].mean(),
                "target_value": critic_td.get(_TARGET_VALUE)[0].mean(),
            },
            batch_size=[],
        )
