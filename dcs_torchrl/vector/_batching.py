"""What every batch of suite envs does alike (the Warp batch, the process env): TorchRL's seed chain, its
partial masks, the split of n envs into near-equal contiguous shares and closing once, spelled once.

TorchRL's batched envs seed worker ``i`` with what worker ``i - 1``'s ``set_seed`` returns
(:func:`chain_seeds`); a ``"_reset"`` or ``"_step"`` entry marks the envs a reset or a step acts on, all
of them without one (:func:`marked`).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from tensordict import TensorDictBase

__all__ = ["chain_seeds", "close_once", "marked", "shares"]


def chain_seeds(set_seeds: Iterable[Callable[[int | None], int | None]], seed: int | None) -> int | None:
    """Calls each of ``set_seeds`` (an env's ``set_seed``) with what the previous one returned, the
    first with ``seed``; returns the last return (what the batch's ``set_seed`` returns)."""
    for set_seed in set_seeds:
        seed = set_seed(seed)
    return seed


def marked(tensordict: TensorDictBase | None, key: str, n: int) -> np.ndarray:
    """The envs a ``"_reset"`` / ``"_step"`` mask of ``tensordict`` marks (any entry of an env's row), int64;
    every env of the ``n`` without one."""
    mask = None if tensordict is None else tensordict.get(key, None)
    if mask is None:
        return np.arange(n)
    return mask.reshape(n, -1).any(-1).nonzero().flatten().cpu().numpy()


def shares(n: int, parts: int) -> list[range]:
    """``n`` envs in ``min(parts, n)`` contiguous, near-equal ranges (n = 3, parts = 2: 0-1 and 2)."""
    parts = min(parts, n)
    bounds = [round(k * n / parts) for k in range(parts + 1)]
    return [range(a, b) for a, b in zip(bounds, bounds[1:])]


def close_once(env, raise_if_closed: bool) -> bool:
    """Marks ``env`` closed; ``False`` where it was already (a RuntimeError instead with ``raise_if_closed``)."""
    if env.is_closed:
        if raise_if_closed:
            raise RuntimeError(f"{type(env).__name__} is closed already.")
        return False
    env.is_closed = True
    return True
