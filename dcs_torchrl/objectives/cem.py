"""Cross-entropy method (Rubinstein 1999) over continuous actions, as in QT-Opt.

QT-Opt (Kalashnikov et al. 2018) has no actor network: the greedy action is
``argmax_a Q(s, a)``, found by CEM. Its defaults here are QT-Opt's: 2 iterations of 64
Gaussian samples, refitting mean and standard deviation to the best 6 (the top 10%).

:func:`cem_maximize` is batched and vectorised: every iteration draws ``[*B, N, A]`` candidates
and makes one call of the objective on all of them. :class:`CEMActor` wraps it as a TorchRL policy
head over a Q-network (for data collection and evaluation).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModule, TensorDictModuleBase
from tensordict.utils import NestedKey
from torchrl.data.tensor_specs import TensorSpec
from torchrl.envs.utils import ExplorationType, exploration_type

from dcs_torchrl.modules.networks import action_bounds

__all__ = ["CEMActor", "cem_maximize"]


def cem_maximize(
    objective: Callable[[torch.Tensor], torch.Tensor],
    batch_shape: Sequence[int],
    low: torch.Tensor,
    high: torch.Tensor,
    *,
    iterations: int = 2,
    num_samples: int = 64,
    num_elites: int = 6,
    generator: torch.Generator | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Maximises ``objective`` over actions in the box ``[low, high]`` by the cross-entropy method.

    The search starts from a Gaussian centred in the box with a standard deviation of half its
    width; each iteration samples ``num_samples`` actions per batch element (clipped to the box),
    scores them with **one** call ``objective(actions)`` (``actions`` of shape
    ``[*batch_shape, num_samples, A]``, returning ``[*batch_shape, num_samples]`` or
    ``[..., num_samples, 1]``), and refits the Gaussian to the ``num_elites`` best.

    Returns:
        ``(action, value)``: the best action scored over all iterations, ``[*batch_shape, A]``,
        and its score, ``[*batch_shape]`` (the maximum over the evaluated candidates, so no
        extra call is needed to value it).

    Examples:
        >>> import torch
        >>> _ = torch.manual_seed(0)
        >>> optimum = torch.tensor([[0.3, -0.5], [-0.7, 0.1]])
        >>> f = lambda a: -((a - optimum.unsqueeze(-2)) ** 2).sum(-1)
        >>> best, value = cem_maximize(f, [2], -torch.ones(2), torch.ones(2), iterations=6)
        >>> bool((best - optimum).abs().max() < 0.05)
        True
    """
    if iterations < 1 or num_samples < 1 or not 1 <= num_elites <= num_samples:
        raise ValueError(
            f"need iterations >= 1 and 1 <= num_elites <= num_samples, got iterations={iterations}, "
            f"num_samples={num_samples}, num_elites={num_elites}."
        )
    batch_shape = tuple(batch_shape)
    low = torch.as_tensor(low)
    high = torch.as_tensor(high, device=low.device, dtype=low.dtype)
    mean = ((low + high) / 2).expand(*batch_shape, low.shape[-1])
    std = ((high - low) / 2).expand(*batch_shape, low.shape[-1])
    best_action = best_value = None
    for _ in range(iterations):
        noise = torch.randn(
            (*batch_shape, num_samples, low.shape[-1]), generator=generator, dtype=low.dtype,
            device=generator.device if generator is not None else low.device,
        ).to(low.device)
        actions = torch.maximum(torch.minimum(mean.unsqueeze(-2) + std.unsqueeze(-2) * noise, high), low)
        values = objective(actions)
        if values.shape == actions.shape[:-1] + (1,):
            values = values.squeeze(-1)
        if values.shape != actions.shape[:-1]:
            raise ValueError(
                f"the objective must return [*batch, num_samples] values, got {tuple(values.shape)} "
                f"for actions {tuple(actions.shape)}."
            )
        top_values, top_index = values.topk(num_elites, dim=-1)
        elites = actions.gather(-2, top_index.unsqueeze(-1).expand(*top_index.shape, actions.shape[-1]))
        mean, std = elites.mean(-2), elites.std(-2, correction=0)
        value, action = top_values[..., 0], elites[..., 0, :]
        if best_value is None:
            best_value, best_action = value, action
        else:
            better = value > best_value
            best_value = torch.where(better, value, best_value)
            best_action = torch.where(better.unsqueeze(-1), action, best_action)
    return best_action, best_value


class CEMActor(TensorDictModuleBase):
    """QT-Opt's policy: ``argmax_a Q(s, a)`` by CEM, plus exploration when sampling.

    In ``ExplorationType.RANDOM`` (collection) the CEM action gets Gaussian noise of
    ``noise_std`` (clipped to the bounds) and, with probability ``epsilon``, is replaced by a
    uniformly random action (QT-Opt's epsilon-greedy). In any other exploration type
    (``DETERMINISTIC`` for evaluation) the CEM action is returned as is.

    Args:
        qvalue_network (TensorDictModule): Q head reading ``[embedding_key, action_key]`` and
            writing ``value_key``.
        qvalue_params (TensorDictBase, optional): parameters to run it with, stacked along a
            first dimension (e.g. :attr:`QTOptLoss.qvalue_network_params`); the ``head``-th is
            used. ``None`` uses the module's own parameters.

    Keyword Args:
        action_spec (Bounded): the action bounds.
        head (int): which stacked Q head to maximise. Defaults to ``0``.
        in_keys (sequence of NestedKey): ``[embedding_key]``. Defaults to ``["embedding"]``.
        action_key, value_key (NestedKey): Q head's action input and output entries.
        iterations, num_samples, num_elites (int): CEM settings (QT-Opt: 2, 64, 6).
        noise_std (float): exploration noise. Defaults to ``0.1``.
        epsilon (float): probability of a uniformly random action. Defaults to ``0.0``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded
        >>> from dcs_torchrl.modules import make_critic
        >>> spec = Bounded(-1.0, 1.0, shape=(2,))
        >>> actor = CEMActor(make_critic(spec, 5, hidden_dim=16), action_spec=spec)
        >>> actor(TensorDict({"embedding": torch.zeros(3, 5)}, [3]))["action"].shape
        torch.Size([3, 2])
    """

    def __init__(
        self,
        qvalue_network: TensorDictModule,
        qvalue_params: TensorDictBase | None = None,
        *,
        action_spec: TensorSpec,
        head: int = 0,
        in_keys: Sequence[NestedKey] = ("embedding",),
        action_key: NestedKey = "action",
        value_key: NestedKey = "state_action_value",
        iterations: int = 2,
        num_samples: int = 64,
        num_elites: int = 6,
        noise_std: float = 0.1,
        epsilon: float = 0.0,
    ):
        super().__init__()
        low, high = action_bounds(action_spec)
        if not 0.0 <= epsilon <= 1.0 or noise_std < 0:
            raise ValueError(f"need 0 <= epsilon <= 1 and noise_std >= 0, got {epsilon}, {noise_std}.")
        self.in_keys = list(in_keys)
        self.out_keys = [action_key]
        self.qvalue_network = qvalue_network
        self.qvalue_params = qvalue_params
        self.head = head
        self.action_key = action_key
        self.value_key = value_key
        self.register_buffer("low", low.clone())
        self.register_buffer("high", high.clone())
        self.cem_kwargs = {"iterations": iterations, "num_samples": num_samples, "num_elites": num_elites}
        self.noise_std = float(noise_std)
        self.epsilon = float(epsilon)

    def _q(self, embedding: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        samples = actions.shape[-2]
        emb = embedding.unsqueeze(-2).expand(*embedding.shape[:-1], samples, embedding.shape[-1])
        td = TensorDict({self.in_keys[0]: emb, self.action_key: actions}, batch_size=actions.shape[:-1])
        return self.qvalue_network(td).get(self.value_key)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        embedding = tensordict.get(self.in_keys[0])
        batch = embedding.shape[:-1]
        with torch.no_grad():
            if self.qvalue_params is not None:
                with self.qvalue_params[self.head].to_module(self.qvalue_network):
                    action, _ = cem_maximize(lambda a: self._q(embedding, a), batch, self.low, self.high, **self.cem_kwargs)
            else:
                action, _ = cem_maximize(lambda a: self._q(embedding, a), batch, self.low, self.high, **self.cem_kwargs)
            if exploration_type() == ExplorationType.RANDOM:
                if self.noise_std > 0:
                    noise = self.noise_std * (self.high - self.low) / 2 * torch.randn_like(action)
                    action = torch.maximum(torch.minimum(action + noise, self.high), self.low)
                if self.epsilon > 0:
                    random = self.low + (self.high - self.low) * torch.rand_like(action)
                    pick = torch.rand(batch, device=action.device) < self.epsilon
                    action = torch.where(pick.unsqueeze(-1), random, action)
        tensordict.set(self.action_key, action)
        return tensordict
