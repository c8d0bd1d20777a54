"""torch's intra-op thread count for a block of code: below the envs and the evaluation protocol.

:mod:`dcs_torchrl.vector.parallel` (the env it steps in this process) and :mod:`dcs_torchrl.evaluation.protocol`
(an evaluation's episodes) both use :func:`torch_threads`; it lives here so that the parallel env
does not import the evaluation protocol. ``dcs_torchrl.evaluation.protocol.torch_threads`` is the same function.
"""
from __future__ import annotations

import contextlib

import torch

__all__ = ["torch_threads"]


@contextlib.contextmanager
def torch_threads(threads: int | None):
    """torch's intra-op threads set to ``threads`` inside (``None``: left alone), this process's
    count restored after (an evaluation's episodes; the env :class:`~dcs_torchrl.ParallelSuiteEnv`
    steps in this process)."""
    own = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(own)
