"""What every batch of suite envs does alike (the Warp batch, the process env): TorchRL's seed chain and
its partial masks, spelled once.

TorchRL's batched envs seed worker ``i`` with what worker ``i - 1``'s ``set_seed`` returns
(:func:`chain_seeds`); a ``"_reset"`` or ``"_step"`` entry marks the envs a reset or a step acts on, all
of them without one (:func:`marked`).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

from tensordict import TensorDictBase

__all__ = ["chain_seeds", "marked"]


def chain_seeds(set_seeds: Iterable[Callable[[int | None], int | None]], seed: int | None) -> int | None:
    """Calls each of ``set_seeds`` (an env's ``set_seed``) with what the previous one returned, the
    first with ``seed``; returns the last return (what the batch's ``set_seed`` returns)."""
    for set_seed in set_seeds:
        seed = set_seed(seed)
    return seed


def marked(tensordict: TensorDictBase | None, key: str, n: int) -> list[int]:
    """The envs a ``"_reset"`` / ``"_step"`` mask of ``tensordict`` marks (any entry of an env's row);
    every env of the ``n`` without one."""
    mask = None if tensordict is None else tensordict.get(key, None)
    if mask is None:
        return list(range(n))
    return mask.reshape(n, -1).any(-1).nonzero().flatten().tolist()
