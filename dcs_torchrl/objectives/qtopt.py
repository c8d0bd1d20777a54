"""QT-Opt (Kalashnikov et al. 2018) with DrQ's K = M augmented copies (Stone et al. 2021)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import dispatch, TensorDictModule
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.data.tensor_specs import Composite, TensorSpec
from torchrl.envs.transforms import Transform
from torchrl.objectives.common import LossModule
from torchrl.objectives.utils import dispatch_value_estimator, ValueEstimators

from dcs_torchrl._compat.private_api import build_default_value_estimator, priority_weight, reduce_loss, value_estimator_kwargs, vmap_func
from dcs_torchrl.modules.networks import action_bounds
from dcs_torchrl.objectives.cem import cem_maximize
from dcs_torchrl.objectives.drq import DrQEncoding

__all__ = ["QTOptLoss", "averaged_cross_entropy"]

LOSS_FUNCTIONS = ("cross_entropy", "l2")


def averaged_cross_entropy(logits: Tensor, target: Tensor, dim: int) -> tuple[Tensor, Tensor]:
    r"""Binary cross-entropy of ``target`` against the mean probability over ``dim``.

    :math:`\bar p = \frac{1}{M}\sum_m \sigma(\ell_m)` and
    :math:`-[t \log \bar p + (1 - t) \log (1 - \bar p)]`, with both logs computed as
    ``logsumexp(logsigmoid(+-l)) - log M`` (no ``log(0)`` for saturated logits). For
    ``M = 1`` this is ``binary_cross_entropy_with_logits``.

    Args:
        logits (Tensor): the M logits along ``dim``.
        target (Tensor): ``t`` in ``[0, 1]``, broadcastable to ``logits`` without ``dim``.
        dim (int): the copies dimension, reduced.

    Returns:
        ``(loss, p_mean)``, both shaped as ``logits`` without ``dim``.

    Examples:
        >>> logits, t = torch.tensor([[0.3], [-1.2]]), torch.tensor([0.6])
        >>> loss, p = averaged_cross_entropy(logits, t, dim=0)
        >>> bool(torch.allclose(p, torch.sigmoid(logits).mean(0)))
        True
    """
    log_copies = math.log(logits.shape[dim])
    log_p = torch.logsumexp(F.logsigmoid(logits), dim=dim) - log_copies
    log_not_p = torch.logsumexp(F.logsigmoid(-logits), dim=dim) - log_copies
    return -(target * log_p + (1.0 - target) * log_not_p), log_p.exp()


class QTOptLoss(DrQEncoding, LossModule):
    r"""QT-Opt's Q-learning loss: CEM for the max over actions, clipped double Q, cross-entropy,
    averaged over DrQ's K = M augmented copies.

    With ``N = max(1, K)`` copies of each transition (augmented by ``augmentation`` when
    ``K > 0``), the target and loss are those of Stone et al. (2021), section 4:

    .. math::

        y = r + \gamma (1 - d) \frac{1}{K} \sum_k V_{\bar\theta}(f(s', \nu_k)),
        \qquad
        J_Q = \sum_i D\Big(y, \frac{1}{M} \sum_m Q_{\theta_i}(f(s, \nu_m), a)\Big)

    * **Clipped double Q** (QT-Opt, after TD3): :math:`V_{\bar\theta}(s') = \min_i
      Q_{\bar\theta_i}(s', a^*)` with :math:`a^* = \mathrm{CEM}_a\, Q_{\bar\theta_1}(s', a)`,
      over ``num_qvalue_nets`` Q heads on one shared encoder, all with Polyak-averaged targets
      (encoder included; one :class:`~torchrl.objectives.SoftUpdate`). QT-Opt takes the two
      targets from one Q-function at two lags (Polyak 0.9999 and ~6000 steps); with twin heads
      the pair is decorrelated without a second, slower copy, which a 500K-step run cannot wait
      for.
    * **Cross-entropy** (QT-Opt's divergence ``D``, ``loss_function="cross_entropy"``): QT-Opt's
      Q is a probability (0/1 grasp rewards). DM Control rewards are in ``[r_min, r_max]`` per
      step (``reward_range``, e.g. ``(0, action_repeat)``), so values lie in
      ``[r_min, r_max] / (1 - gamma)``: the Q head's output is the logit of the value normalised
      to ``[0, 1]`` by that range, the target is normalised the same way, and
      :math:`D(y, \bar p) = -[t \log \bar p + (1 - t) \log(1 - \bar p)]` with ``t`` the
      normalised target and :math:`\bar p` the mean over the M copies of the predicted
      probabilities (computed in log space). ``loss_function="l2"`` uses the raw output as Q
      and :math:`(y - \frac{1}{M}\sum_m Q_m)^2`.
    * **CEM**: ``cem_iterations=2``, ``cem_samples=64``, ``cem_elites=6`` (QT-Opt), one batched
      Q-head call per iteration on ``[N * B, samples, A]``; the encoder runs once per state.

    With K = M = 0 the loss is plain QT-Opt (binary cross-entropy with logits per head).

    Args:
        qvalue_network (TensorDictModule or list of them): Q head(s) reading
            ``[embedding, action]``, writing ``"state_action_value"`` (the logit with
            cross-entropy). Pass ``num_qvalue_nets`` independently initialised heads to keep
            their initialisation.

    Keyword Args:
        encoder (TensorDictModule): observation -> embedding, trained by this loss.
        action_spec (Bounded): the action bounds searched by CEM.
        augmentation (Transform, optional): as in :class:`~dcs_torchrl.objectives.DrQSACLoss`.
        num_augmentations (int): K = M. Defaults to ``0``.
        num_qvalue_nets (int): Q heads for clipped double Q. Defaults to ``2``.
        loss_function (str): ``"cross_entropy"`` (default) or ``"l2"``.
        reward_range (tuple of float): per-transition reward bounds for the normalisation.
            Defaults to ``(0.0, 1.0)``; with action repeat ``k`` on DM Control, ``(0.0, k)``.
        cem_iterations, cem_samples, cem_elites (int): CEM for the target's max.
        initial_value (float): cross-entropy only: the value an untrained head (output near 0)
            predicts, as a fraction of ``[v_min, v_max]``; the outputs are offset by
            ``logit(initial_value)``. Defaults to ``0.01``, i.e. values start near ``v_min`` (as
            an MSE critic starts near 0). With the plain ``sigmoid(0) = 1/2`` every value starts
            mid-range (400 on cartpole, range 0..800) and the bootstrapped targets unlearn that
            offset only at rate ``1 - gamma``: on cartpole swingup from states it reached a
            return of ~210 after 32K frames against ~610-680 with 0.01.
        reduction (str): ``"mean"`` (default) or ``"sum"``.
        deactivate_vmap (bool): loop over the Q heads instead of ``vmap``.

    Input keys: the encoder's ``in_keys`` and their ``("next", ...)``, ``"action"``,
    ``("next", "reward")``, ``("next", "done")``, ``("next", "terminated")`` (only terminated
    stops bootstrapping). Writes ``"td_error"``. Returns ``loss_qvalue`` and detached
    ``q_value`` (mean predicted Q, in reward units), ``target_value`` and ``next_state_value``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded
        >>> from torchrl.objectives import SoftUpdate
        >>> from dcs_torchrl.modules import ObservationNoise, make_critic, make_encoder
        >>> spec = Bounded(-1.0, 1.0, shape=(2,))
        >>> encoder = make_encoder((5,))
        >>> heads = [make_critic(spec, encoder.feature_dim, hidden_dim=32) for _ in range(2)]
        >>> loss = QTOptLoss(heads, encoder=encoder, action_spec=spec, num_augmentations=2,
        ...                  augmentation=ObservationNoise(0.01, in_keys=["observation", ("next", "observation")]))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> data = TensorDict({
        ...     "observation": torch.randn(8, 5), "action": spec.rand((8,)),
        ...     ("next", "observation"): torch.randn(8, 5), ("next", "reward"): torch.rand(8, 1),
        ...     ("next", "done"): torch.zeros(8, 1, dtype=torch.bool),
        ...     ("next", "terminated"): torch.zeros(8, 1, dtype=torch.bool)}, [8])
        >>> out = loss(data)
        >>> out["loss_qvalue"].backward()
        >>> sorted(out.keys())
        ['loss_qvalue', 'next_state_value', 'q_value', 'target_value']
    """

    @dataclass
    class _AcceptedKeys:
        """Maintains default values for all configurable tensordict keys.

        The observation and embedding keys are the encoder's ``in_keys`` / ``out_keys``.

        Attributes:
            action (NestedKey): the action taken. Defaults to ``"action"``.
            state_action_value (NestedKey): the Q head's output. Defaults to
                ``"state_action_value"``.
            value (NestedKey): the next-state value given to the value estimator. Defaults to
                ``"state_value"``.
            reward (NestedKey): under ``"next"``. Defaults to ``"reward"``.
            done (NestedKey): under ``"next"``. Defaults to ``"done"``.
            terminated (NestedKey): under ``"next"``; stops bootstrapping. Defaults to
                ``"terminated"``.
            priority (NestedKey): where the TD error is written. Defaults to ``"td_error"``.
            priority_weight (NestedKey): importance weights, if present. Defaults to
                ``"priority_weight"``.
        """

        action: NestedKey = "action"
        state_action_value: NestedKey = "state_action_value"
        value: NestedKey = "state_value"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        priority: NestedKey = "td_error"
        priority_weight: NestedKey = "priority_weight"

    tensor_keys: _AcceptedKeys
    default_keys = _AcceptedKeys
    default_value_estimator = ValueEstimators.TD0
    out_keys = ["loss_qvalue", "q_value", "target_value", "next_state_value"]

    qvalue_network: TensorDictModule
    qvalue_network_params: TensorDictParams
    target_qvalue_network_params: TensorDictParams
    encoder_network: TensorDictModule
    encoder_network_params: TensorDictParams
    target_encoder_network_params: TensorDictParams

    def __init__(
        self,
        qvalue_network: TensorDictModule | list[TensorDictModule],
        *,
        encoder: TensorDictModule,
        action_spec: TensorSpec,
        augmentation: Transform | None = None,
        num_augmentations: int = 0,
        num_qvalue_nets: int = 2,
        loss_function: str = "cross_entropy",
        reward_range: tuple[float, float] = (0.0, 1.0),
        cem_iterations: int = 2,
        cem_samples: int = 64,
        cem_elites: int = 6,
        initial_value: float = 0.01,
        reduction: str = "mean",
        deactivate_vmap: bool = False,
    ) -> None:
        super().__init__()
        if loss_function not in LOSS_FUNCTIONS:
            raise ValueError(f"loss_function must be one of {LOSS_FUNCTIONS}, got {loss_function!r}.")
        if reduction not in ("mean", "sum"):
            raise ValueError(f"reduction must be 'mean' or 'sum', got {reduction!r}.")
        r_min, r_max = (float(r) for r in reward_range)
        if not r_min < r_max:
            raise ValueError(f"reward_range must be increasing, got {reward_range}.")
        if not 0.0 < initial_value < 1.0:
            raise ValueError(f"initial_value is a fraction of the value range in (0, 1), got {initial_value}.")
        if isinstance(action_spec, Composite):
            action_spec = action_spec[self.tensor_keys.action]
        low, high = action_bounds(action_spec)  # raises for unbounded specs
        first_q = qvalue_network[0] if isinstance(qvalue_network, (list, tuple)) else qvalue_network
        if isinstance(qvalue_network, (list, tuple)) and len(qvalue_network) != num_qvalue_nets:
            raise ValueError(f"got {len(qvalue_network)} Q heads for num_qvalue_nets={num_qvalue_nets}.")
        self.deactivate_vmap = deactivate_vmap
        self.num_qvalue_nets = num_qvalue_nets
        self.convert_to_functional(qvalue_network, "qvalue_network", num_qvalue_nets, create_target_params=True)
        self._init_encoding(encoder, augmentation, num_augmentations, list(first_q.in_keys))
        self.loss_function = loss_function
        self.reduction = reduction
        self.reward_range = (r_min, r_max)
        self.initial_value = float(initial_value)
        self._logit_offset = math.log(initial_value / (1.0 - initial_value))
        self.cem_kwargs = {"iterations": cem_iterations, "num_samples": cem_samples, "num_elites": cem_elites}
        self.register_buffer("action_low", low.clone())
        self.register_buffer("action_high", high.clone())
        self._make_vmap()
        # Built now rather than lazily, so that state_dict() has the same keys before and after
        # the first forward (a checkpoint loads into a freshly built loss).
        build_default_value_estimator(self)

    def _make_vmap(self):
        self._vmap_qnetworkN0 = vmap_func(
            self.qvalue_network, (None, 0), randomness=self.vmap_randomness, pseudo_vmap=self.deactivate_vmap
        )

    @property
    def in_keys(self):
        return self._loss_in_keys()

    def _forward_value_estimator_keys(self, **kwargs) -> None:
        if self._value_estimator is not None:
            self._value_estimator.set_keys(
                value=self.tensor_keys.value,
                reward=self.tensor_keys.reward,
                done=self.tensor_keys.done,
                terminated=self.tensor_keys.terminated,
            )

    def make_value_estimator(self, value_type: ValueEstimators = None, **hyperparams):
        value_type, hp = value_estimator_kwargs(self, value_type, **hyperparams)
        if value_type is None:
            self._gamma = float(self.value_estimator.gamma)
            return self
        dispatch_value_estimator(
            self,
            value_type,
            supported=(ValueEstimators.TD0,),
            tensor_keys={
                "value": self.tensor_keys.value,
                "reward": self.tensor_keys.reward,
                "done": self.tensor_keys.done,
                "terminated": self.tensor_keys.terminated,
            },
            value_network=None,
            **hp,
        )
        self._gamma = float(self.value_estimator.gamma)  # read once here, never in an update (a host sync on CUDA)

    def value_bounds(self) -> tuple[float, float]:
        """``(v_min, v_max) = reward_range / (1 - gamma)``: the cross-entropy normalisation, with
        the ``gamma`` of the last :meth:`make_value_estimator` (kept as a Python float)."""
        gamma = self._gamma
        if not 0.0 <= gamma < 1.0:
            raise ValueError(f"the cross-entropy normalisation needs 0 <= gamma < 1, got {gamma}.")
        r_min, r_max = self.reward_range
        return r_min / (1.0 - gamma), r_max / (1.0 - gamma)

    def _to_value(self, output: Tensor) -> Tensor:
        """Q head output -> Q value in reward units (identity for ``l2``)."""
        if self.loss_function == "l2":
            return output
        v_min, v_max = self.value_bounds()
        return v_min + (v_max - v_min) * torch.sigmoid(output + self._logit_offset)

    def _q_heads(self, embedding: Tensor, action: Tensor, params: TensorDictBase) -> Tensor:
        """All Q heads: ``[*S, F]`` and ``[*S, A]`` -> ``[num_qvalue_nets, *S]`` outputs."""
        td = TensorDict({self.embedding_key: embedding, self.tensor_keys.action: action}, batch_size=action.shape[:-1])
        return self._vmap_qnetworkN0(td, params).get(self.tensor_keys.state_action_value).squeeze(-1)

    def next_state_value(self, next_embedding: Tensor) -> Tensor:
        """:math:`\\min_i Q_{\\bar\\theta_i}(s', a^*)`, :math:`a^*` the CEM maximiser of the first target
        head, for target embeddings ``[*S, F]``; returns ``[*S]`` in reward units (no gradient)."""
        with torch.no_grad():
            lead = next_embedding.shape[:-1]
            flat = next_embedding.reshape(-1, next_embedding.shape[-1])
            samples = self.cem_kwargs["num_samples"]

            def first_target_head(actions: Tensor) -> Tensor:
                emb = flat.unsqueeze(1).expand(flat.shape[0], samples, flat.shape[-1])
                td = TensorDict({self.embedding_key: emb, self.tensor_keys.action: actions}, batch_size=actions.shape[:-1])
                return self.qvalue_network(td).get(self.tensor_keys.state_action_value)

            with self.target_qvalue_network_params[0].to_module(self.qvalue_network):
                best_action, _ = cem_maximize(
                    first_target_head, flat.shape[:1], self.action_low, self.action_high, **self.cem_kwargs
                )
            outputs = self._q_heads(flat, best_action, self.target_qvalue_network_params)
            return self._to_value(outputs).min(0).values.reshape(lead)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        keys = self.tensor_keys
        copies, embedding, _, next_target_embedding = self._encode(tensordict, online_next=False)
        num_copies = copies.batch_size[0]
        first = copies[0]

        # y = r + gamma (1 - terminated) (1/K) sum_k V(f(s', nu_k))
        with torch.no_grad():
            next_value = self.next_state_value(next_target_embedding).mean(0).unsqueeze(-1)
            value_td = TensorDict(
                {("next", key): first.get(("next", key)) for key in (keys.reward, keys.done, keys.terminated)},
                batch_size=first.batch_size,
            )
            value_td.set(("next", self.value_estimator.tensor_keys.value), next_value)
            target = self.value_estimator.value_estimate(value_td).squeeze(-1)  # [*B]

        outputs = self._q_heads(embedding, copies.get(keys.action), self.qvalue_network_params)  # [Q, N, *B]
        if self.loss_function == "cross_entropy":
            v_min, v_max = self.value_bounds()
            t = ((target - v_min) / (v_max - v_min)).clamp(0.0, 1.0)
            # log of the mean over the M copies of sigmoid(output), and of 1 - it
            loss, p_mean = averaged_cross_entropy(outputs + self._logit_offset, t, dim=1)  # [Q, *B]
            q_value = v_min + (v_max - v_min) * p_mean
        else:
            q_value = outputs.mean(1)
            loss = (q_value - target) ** 2
        weights = priority_weight(self, tensordict)
        loss_qvalue = reduce_loss(self, loss.sum(0), weights=weights)
        td_error = (q_value - target).abs().max(0).values
        tensordict.set(keys.priority, td_error.detach())
        return TensorDict(
            {
                "loss_qvalue": loss_qvalue,
                "q_value": q_value.detach().mean(),
                "target_value": target.mean(),
                "next_state_value": next_value.mean(),
            },
            batch_size=[],
        )
