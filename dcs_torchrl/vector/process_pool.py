"""Whole jobs in spawned processes: the suite's one pool for work done elsewhere than in an env's step.

An env's workers (:class:`~dcs_torchrl.ParallelSuiteEnv`) step in lock-step with the process that
owns the env. Two jobs are bigger than a step and run whole in other processes, each through
:class:`SpawnedPool`: an evaluation's episodes spread over processes that each hold a copy of the
policy (:func:`dcs_torchrl.evaluation.protocol.evaluate_in_processes`), and whole robustness points, one
pool per render device (:func:`dcs_torchrl.evaluation.scheduling.evaluate_settings`). A pool's processes are
spawned (EGL contexts do not survive ``fork``) with the environment variables they must read at
their first import of dm_control (the EGL device, Mesa's render threads), run a set number of
torch threads, and end when the process that started them is gone (:func:`exit_with`): killed, no
one would read their results.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor

from dcs_torchrl.render.egl_devices import spawn_environment

__all__ = ["SpawnedPool", "exit_with"]


class SpawnedPool(ProcessPoolExecutor):
    """A ``ProcessPoolExecutor`` of ``processes`` spawned processes that start with
    ``environment`` set, run ``threads`` torch threads, watch this process and then run
    ``initializer(*initargs)``.

    Args:
        processes (int): the most processes at once.

    Keyword Args:
        environment (dict, optional): variables each process starts with (``None``: as in this process's);
            this process's environment is left as it was (:func:`dcs_torchrl.render.egl_devices.spawn_environment`).
        threads (int): torch threads of each process. Default 1.
        initializer, initargs: run once in each process after the above (e.g. to load a policy).

    Examples:
        >>> with SpawnedPool(1, environment={"DCS_EXAMPLE": "1"}) as pool:
        ...     pool.submit(os.getenv, "DCS_EXAMPLE").result()
        '1'
    """

    def __init__(self, processes: int, *, environment: dict | None = None, threads: int = 1,
                 initializer: Callable | None = None, initargs: tuple = ()):
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be an int >= 1, got {threads!r}.")
        super().__init__(processes, mp_context=mp.get_context("spawn"), initializer=_start,
                         initargs=(os.getpid(), threads, initializer, initargs))
        self._environment = dict(environment or {})

    def terminate(self) -> None:
        """Ends every process of the pool now, jobs running or not (a job's error, an interrupt:
        nothing would read what they finish)."""
        for process in list((self._processes or {}).values()):
            process.terminate()
        self.shutdown(wait=True, cancel_futures=True)

    def __exit__(self, kind, value, traceback):
        if kind is not None:  # leaving on an error: the processes' jobs are not waited for
            self.terminate()
        return super().__exit__(kind, value, traceback)

    def submit(self, fn: Callable, /, *args, **kwargs) -> Future:
        # the pool spawns a process when a job finds none free: in this call, with the environment set
        with spawn_environment(self._environment):
            return super().submit(fn, *args, **kwargs)


def _start(parent: int, threads: int, initializer: Callable | None, initargs: tuple) -> None:
    import torch

    threading.Thread(target=exit_with, args=(parent,), daemon=True).start()
    torch.set_num_threads(threads)
    if initializer is not None:
        initializer(*initargs)


def exit_with(parent: int) -> None:
    """Ends this process when the process that started it (pid ``parent``) is gone: killed, no one
    would read its results. Run it in a daemon thread."""
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)
