"""Where the loop's wall time goes: seconds per phase, reported per agent step.

>>> timer = PhaseTimer()
>>> with timer("update"):
...     pass
>>> sorted(timer.report(steps=1))
['time/update_ms']
"""
from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["PhaseTimer"]


class PhaseTimer:
    """Sums the wall time of named phases (``collect``, ``update``, ...) between two reports."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)

    @contextmanager
    def __call__(self, phase: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[phase] += time.perf_counter() - start

    def report(self, steps: int) -> dict[str, float]:
        """``{"time/<phase>_ms": milliseconds per agent step}`` since the last report, then resets."""
        rows = {f"time/{phase}_ms": 1000.0 * seconds / max(steps, 1) for phase, seconds in self.seconds.items()}
        self.seconds.clear()
        return rows
