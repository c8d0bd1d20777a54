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

A process of either kind that dies (the OOM killer, ``kill -9``) raises :class:`WorkerDiedError` in the
process that talks to it, at its next call: which process, how it ended (:func:`exit_status`) and
what to do (:func:`worker_died`).
"""
from __future__ import annotations

import multiprocessing as mp
import os
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor

from dcs_torchrl.render.egl_devices import spawn_environment

__all__ = ["SpawnedPool", "WorkerDiedError", "exit_status", "exit_with", "worker_died"]


class WorkerDiedError(RuntimeError):
    """A worker process died under the suite (a :class:`~dcs_torchrl.ParallelSuiteEnv`'s, an
    evaluation pool's): killed (the kernel's OOM killer, ``kill -9``) or gone without sending its
    error. The message names the process, how it ended and the fix; the error it was found by
    (a broken pipe, ``BrokenProcessPool``) is its ``__cause__``."""


def exit_status(exitcode: int | None) -> str:
    """How a process ended, from its ``exitcode``: ``"killed by SIGKILL (9)"``, ``"exited with code 1"``."""
    if exitcode is None:
        return "its pipe closed while it still ran"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = "signal"
        return f"killed by {name} ({-exitcode})"
    return f"exited with code {exitcode}"


def worker_died(process: str, exitcode: int | None, fewer: str, hint: str = "") -> WorkerDiedError:
    """The error for ``process`` (e.g. ``"ParallelSuiteEnv worker 1 (env 1 of 2)"``) found dead with
    ``exitcode``: killed by a signal most often means the machine ran out of memory, whose fix is
    ``fewer`` (e.g. ``"run fewer envs at once"``); an exit code, an error printed above. ``hint``: a
    sentence more (e.g. what kills a process that is starting)."""
    if exitcode is not None and exitcode < 0:
        cause = ("Killed from outside: most often by the kernel's OOM killer, the machine out of memory "
                 f"(`dmesg | grep -i -e oom -e killed` names the process): free memory or {fewer}.")
    else:
        cause = f"Look for its error above (printed before it exited); if the machine ran out of memory, {fewer}."
    return WorkerDiedError(f"{process} died: {exit_status(exitcode)}. {cause}{hint}")


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
        self._started: dict = {}  # pid -> process, in the order they started: the pool forgets them when one dies

    def died(self, what: str, fewer: str) -> WorkerDiedError:
        """The error for a job lost with a process of the pool that died (``future.result()`` raised
        ``BrokenProcessPool``): which process (``what`` names the pool's processes, e.g.
        ``"evaluation process"``; numbered in the order they started), how it ended and ``fewer``,
        the fix for memory (:func:`worker_died`). Call it before the pool is shut down (leaving its
        ``with`` block), which forgets its processes."""
        processes = list(self._started.values())
        for process in processes:  # the pool ends the others (SIGTERM): their exit codes are then known
            process.join(timeout=5)
        ended = [(i, p) for i, p in enumerate(processes) if p.exitcode is not None]
        dead = [(i, p) for i, p in ended if p.exitcode != -signal.SIGTERM] or ended
        if not dead:
            return WorkerDiedError(f"a {what} died: if the machine ran out of memory, {fewer}.")
        index, process = dead[0]
        return worker_died(f"{what} {index} (pid {process.pid})", process.exitcode, fewer)

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
            future = super().submit(fn, *args, **kwargs)
        self._started.update(self._processes or {})
        return future


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
