"""Each world's random walk noise, drawn ahead in blocks from its own generator.

A dynamic distraction moves every control step by noise from its own ``numpy`` generator. Drawn a step
at a time, N worlds cost N Python calls per step; :class:`NoiseBank` draws each world's noise for
several agent steps at once (``standard_normal`` gives the same numbers drawn in one call or in
consecutive ones), so a step of all the worlds takes its noise as one array. A world whose episode ends
before its block is used up is wound back at its next episode start (:meth:`NoiseBank.rewind`): its
generator then stands where one drawn step by step would stand, and every later draw (the next
episode's start) is the same.
"""
from __future__ import annotations

import numpy as np

from dcs_torchrl.distractions.base import per_world

__all__ = ["BLOCK_STEPS", "NoiseBank"]

#: Control steps of noise a world draws at once (rounded down to whole agent steps, at least one).
BLOCK_STEPS = 64


class NoiseBank:
    """Standard normal noise for N worlds, ``width`` numbers per control step.

    Args:
        n (int): the worlds.
        width (int): numbers a control step takes (4 for the camera, 3 per material for the colours).
        frame_skip (int or array of int): control steps a world takes per agent step.
    """

    def __init__(self, n: int, width: int, frame_skip):
        self.width = int(width)
        self.per_step = per_world(frame_skip, n) * self.width  # numbers an agent step takes
        self.block = np.maximum(1, BLOCK_STEPS // (self.per_step // self.width)) * self.per_step  # numbers a block holds
        self.values = np.zeros((n, int(self.block.max())), np.float64)
        self.used = np.zeros(n, np.int64)  # numbers of the current block taken
        self.drawn = np.zeros(n, np.int64)  # numbers of the current block drawn (0 or the block)
        self.rngs: list[np.random.Generator | None] = [None] * n
        self._before: list[dict | None] = [None] * n  # each generator's state before its current block

    def use(self, row: int, rng: np.random.Generator) -> None:
        """World ``row`` draws from ``rng`` from now on (a new seed): what was drawn from another is dropped."""
        if self.rngs[row] is not rng:
            self.rngs[row], self._before[row] = rng, None
            self.used[row] = self.drawn[row] = 0

    def rewind(self, row: int) -> None:
        """Puts world ``row``'s generator where it would stand had it drawn only the numbers taken, and
        empties the world's block (an episode start: the start's draws come next)."""
        before, untaken = self._before[row], self.drawn[row] - self.used[row]
        if before is not None and untaken > 0:
            rng = self.rngs[row]
            rng.bit_generator.state = before
            rng.standard_normal(int(self.used[row]))
        self._before[row] = None
        self.used[row] = self.drawn[row] = 0

    def take(self, rows: np.ndarray) -> np.ndarray:
        """One agent step's noise of worlds ``rows``: where it starts in each world's row of :attr:`values`
        (int64 ``[len(rows)]``); world ``rows[j]``'s control step ``t`` takes ``values[rows[j], start[j] + t *
        width:][:width]``, for its frame skip's steps."""
        empty = rows[self.used[rows] >= self.drawn[rows]]
        for row in empty.tolist():  # a block every BLOCK_STEPS control steps: the only loop over worlds
            rng = self.rngs[row]
            self._before[row] = rng.bit_generator.state
            size = int(self.block[row])
            self.values[row, :size] = rng.standard_normal(size)
            self.used[row], self.drawn[row] = 0, size
        start = self.used[rows]
        self.used[rows] += self.per_step[rows]
        return start
