"""DrQ's augmented copies and the shared-encoder pass, common to the SAC and QT-Opt losses.

DrQ (Kostrikov et al. 2020) regularises a Q-learning loss with K augmented copies of the next
observation (the target is averaged over them) and M augmented copies of the observation (the
Q estimate is averaged over them). Stone et al. (2021) use K = M in {0, 1, 2}: 0 is the plain
loss, 1 is RAD, 2 is DrQ.

:class:`DrQEncoding` is the mixin both losses use. It owns

* the encoder (``pixels -> embedding``) as functional parameters of the loss, plus a target
  copy (soft-updated by TorchRL's :class:`~torchrl.objectives.SoftUpdate` with the critic);
* the augmentation transform and the number of copies ``N = max(1, K)``;
* :meth:`DrQEncoding._encode`: the N augmented copies of a batch (one augmentation call for
  all copies), the online embeddings of the observations (with gradient: the encoder is trained
  by the critic loss only), and, without gradient, the embeddings of the next observations by
  the online encoder (SAC's next action) and by the target encoder (the bootstrapped value).
  Each is one batched encoder pass over all ``N * B`` images.
"""
from __future__ import annotations

import torch
from tensordict import TensorDictBase, TensorDictParams
from tensordict.nn import TensorDictModule
from tensordict.utils import NestedKey
from torchrl.envs.transforms import Transform

from dcs_torchrl.modules.augment import with_next_keys

__all__ = ["DrQEncoding", "augmented_copies"]


def _as_tuple(key: NestedKey) -> tuple[str, ...]:
    return (key,) if isinstance(key, str) else tuple(key)


def augmented_copies(
    tensordict: TensorDictBase, augmentation: Transform | None, num_copies: int
) -> TensorDictBase:
    """``max(1, num_copies)`` augmented copies of a batch, stacked as a new leading dimension.

    ``num_copies=0`` returns the batch unchanged with a leading dimension of 1 (no
    augmentation). Otherwise the batch is expanded (a view, no copy) to
    ``[num_copies, *batch]`` and the augmentation runs once on it, drawing independent random
    parameters for every copy of every sample (and for the observation and next observation).

    Args:
        tensordict (TensorDictBase): the batch, e.g. a replay-buffer sample.
        augmentation (Transform or None): applied to its ``in_keys``; ignored for 0 copies.
        num_copies (int): K = M.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from dcs_torchrl.modules import RandomShift
        >>> data = TensorDict({"pixels": torch.zeros(8, 9, 84, 84, dtype=torch.uint8)}, [8])
        >>> augmented_copies(data, RandomShift(4), 2)["pixels"].shape
        torch.Size([2, 8, 9, 84, 84])
    """
    if num_copies < 0:
        raise ValueError(f"the number of augmented copies must be >= 0, got {num_copies}.")
    if num_copies == 0:
        return tensordict.unsqueeze(0)
    if augmentation is None:
        raise ValueError(f"{num_copies} augmented copies need an augmentation transform, got None.")
    # expand() makes views (stride 0 along the copies): the augmentation reads each sample once
    # per copy and writes fresh tensors; the input batch is left untouched.
    copies = tensordict.expand(num_copies, *tensordict.batch_size).clone(False)
    return augmentation(copies)


class DrQEncoding:
    """Mixin for a :class:`~torchrl.objectives.LossModule` with a shared encoder and DrQ copies.

    Call :meth:`_init_encoding` in ``__init__`` after ``LossModule.__init__``; then
    :meth:`_encode` in ``forward``. The class using it must annotate ``encoder_network``,
    ``encoder_network_params`` and ``target_encoder_network_params``.
    """

    encoder_network: TensorDictModule
    encoder_network_params: TensorDictParams
    target_encoder_network_params: TensorDictParams

    def _init_encoding(
        self,
        encoder: TensorDictModule,
        augmentation: Transform | None,
        num_augmentations: int,
        heads_in_keys: list[NestedKey],
    ) -> None:
        if not isinstance(encoder, TensorDictModule) or len(encoder.out_keys) != 1:
            raise TypeError("encoder must be a TensorDictModule with exactly one out_key (the embedding).")
        if int(num_augmentations) != num_augmentations or num_augmentations < 0:
            raise ValueError(f"num_augmentations (K = M) must be an integer >= 0, got {num_augmentations!r}.")
        num_augmentations = int(num_augmentations)
        if num_augmentations > 0 and augmentation is None:
            raise ValueError(
                f"num_augmentations={num_augmentations} needs an augmentation transform, e.g. "
                f"RandomShift(4, in_keys={with_next_keys(encoder.in_keys)})."
            )
        if num_augmentations == 0 and augmentation is not None:
            raise ValueError("num_augmentations=0 means no augmentation: pass augmentation=None.")
        if augmentation is not None:
            aug_keys = {_as_tuple(k) for k in augmentation.in_keys}
            missing = [k for k in with_next_keys(encoder.in_keys) if _as_tuple(k) not in aug_keys]
            if missing or list(augmentation.in_keys) != list(augmentation.out_keys):
                raise ValueError(
                    f"the augmentation must transform the encoder's inputs and their ('next', ...) "
                    f"counterparts in place; missing {missing}. Build it with "
                    f"in_keys={with_next_keys(encoder.in_keys)} and no out_keys."
                )
        self.embedding_key = encoder.out_keys[0]
        for key in heads_in_keys:
            if _as_tuple(key) in {_as_tuple(k) for k in encoder.in_keys}:
                raise ValueError(
                    f"the actor/critic heads read {key!r}, an encoder input: they must read the "
                    f"encoder's output {self.embedding_key!r}."
                )
        if _as_tuple(self.embedding_key) not in {_as_tuple(k) for k in heads_in_keys}:
            raise ValueError(
                f"the actor/critic heads must read the encoder's output {self.embedding_key!r}; "
                f"they read {heads_in_keys}."
            )
        self.convert_to_functional(encoder, "encoder_network", create_target_params=True)
        self.augmentation = augmentation
        self.num_augmentations = num_augmentations

    def _loss_in_keys(self) -> list[NestedKey]:
        """The keys the loss reads (action, next reward and done flags, encoder inputs and their next)."""
        keys = [
            self.tensor_keys.action,
            ("next", self.tensor_keys.reward),
            ("next", self.tensor_keys.done),
            ("next", self.tensor_keys.terminated),
            *self.encoder_network.in_keys,
            *[("next", key) for key in self.encoder_network.in_keys],
        ]
        return list(dict.fromkeys(keys))

    @property
    def num_copies(self) -> int:
        """N = max(1, K): how many (possibly augmented) copies of each sample the loss uses."""
        return max(1, self.num_augmentations)

    def _encode(
        self, tensordict: TensorDictBase, *, online_next: bool
    ) -> tuple[TensorDictBase, torch.Tensor, torch.Tensor | None, torch.Tensor]:
        """Augments the batch into N copies and embeds them.

        Returns ``(copies, embedding, next_embedding, next_target_embedding)``: ``copies`` is the
        ``[N, *B]`` tensordict of augmented copies; ``embedding`` the online embedding of the
        observations, with gradient (``[N, *B, F]``); ``next_embedding`` the online embedding of
        the next observations (``None`` unless ``online_next``) and ``next_target_embedding``
        the target encoder's, both without gradient.
        """
        copies = augmented_copies(tensordict, self.augmentation, self.num_augmentations)
        in_keys = self.encoder_network.in_keys
        obs = copies.select(*in_keys)
        next_obs = copies.get("next").select(*in_keys)
        with self.encoder_network_params.to_module(self.encoder_network, preserve_module_state=False):
            embedding = self.encoder_network(obs).get(self.embedding_key)
            next_embedding = None
            if online_next:
                with torch.no_grad():
                    next_embedding = self.encoder_network(next_obs.copy()).get(self.embedding_key)
        with torch.no_grad(), self.target_encoder_network_params.to_module(
            self.encoder_network, preserve_module_state=False
        ):
            next_target_embedding = self.encoder_network(next_obs).get(self.embedding_key)
        return copies, embedding, next_embedding, next_target_embedding
