"""Warnings of the dependencies that were read, judged harmless, and are kept out of the console.

Each entry says what prints, why it is harmless, and what would make it matter. Everything else
(DeprecationWarnings of TorchRL and dm_control included) reaches the user.

* ``absl: compiler attribute 'settotalmass' is deprecated ...`` — MuJoCo 3 reports it once per
  model compiled from dm_control's ``cheetah.xml`` (``<compiler settotalmass="14"/>``), i.e. for
  every cheetah env built, in every worker. MuJoCo 3 still honours the attribute, so the cheetah
  weighs 14 kg as in the paper. It matters once MuJoCo removes it (4.x, which this package
  excludes: ``mujoco<4``); ``tests/test_judged_warnings.py`` checks the mass.
"""
from __future__ import annotations

import logging

__all__ = ["JUDGED_ABSL_MESSAGES", "install"]

JUDGED_ABSL_MESSAGES = ("compiler attribute 'settotalmass' is deprecated",)


class _DropJudged(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        return not any(judged in message for judged in JUDGED_ABSL_MESSAGES)


_FILTER = _DropJudged()


def install() -> None:
    """Adds the filter to absl's logger (idempotent)."""
    logger = logging.getLogger("absl")
    if _FILTER not in logger.filters:
        logger.addFilter(_FILTER)
