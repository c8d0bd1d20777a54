"""Evaluations of one agent under many settings at once: in processes (a pool per render device)
or, with ``backend="warp"``, in batched envs of several settings each.

The robustness command (:mod:`dcs_torchrl.robustness`) and the experiments' evaluation-only runs
(:mod:`dcs_torchrl.experiments.evaluate`) schedule their points through :func:`evaluate_settings`;
each point's returns are those of :meth:`dcs_torchrl.pretrained.Pretrained.evaluate` alone.
"""
from __future__ import annotations

import os
import time
from collections import Counter
from collections.abc import Hashable, Iterator, Mapping, Sequence

from dcs_torchrl.pretrained import (Pretrained, agent_checkpoint, agent_directory, agent_env_settings, agent_results,
                                    load_pretrained)

__all__ = ["WARP_BATCH_ENVS", "evaluate_settings"]

#: The most envs :func:`evaluate_settings` puts in one batched env with ``backend="warp"``.
WARP_BATCH_ENVS = 128


def evaluate_settings(agent: str | os.PathLike, settings: Mapping[Hashable, dict], episodes: int, *,
                      processes: int = 1, workers: int = 1, device: str = "cpu", final: bool = False,
                      render_devices: Sequence[int | str] | None = None, backend: str = "gl",
                      trust_checkpoint: bool = False) -> Iterator[tuple[Hashable, dict, float]]:
    """:meth:`Pretrained.evaluate` of ``agent`` under each of several make_env ``settings``, in
    ``processes`` processes at once; yields ``(key, EvalResult.to_dict(), seconds)`` as each one
    finishes.

    Each process evaluates whole settings, each in one env, so every episode's return is the one
    an evaluation in this process gives (and the 2021 code's background blend accumulates over all
    of a setting's episodes, as there). Processes get an equal share of the cores for torch and for
    Mesa's llvmpipe render threads (``LP_NUM_THREADS``, in each process's environment from its
    start: Mesa reads it once, at the process's first import of dm_control; a user's setting is
    kept) and end when this process is killed.
    ``processes=1`` evaluates here, one setting after another, unless it must render elsewhere.

    Args:
        agent: a finished run, an exported agent or a shipped agent's name.
        settings: per key, make_env settings over the training env's (``{}``: the training env).
        episodes: episodes per setting.
        processes: settings (with ``backend="warp"``: batches of settings) evaluated at once.
        workers: :meth:`Pretrained.evaluate`'s env workers per setting (1: one env).
        device, final, trust_checkpoint: as :func:`load_pretrained` (a checkpoint it refuses is
            refused here, before any process starts).
        render_devices: the GPU each process renders on, process ``i`` on
            ``render_devices[i % len]``: EGL device indices or CUDA devices (``"cuda:1"``), as
            :class:`~dcs_torchrl.ParallelSuiteEnv`'s, checked before anything starts; ``None``
            (default): this process's device. A process's env workers render on its device.
        backend: ``"gl"``, or ``"warp"``: several settings' episodes all at once, in one batched
            env (:meth:`Pretrained.evaluate_each`: each setting's returns are those of
            :meth:`Pretrained.evaluate` with ``backend="warp"``), in batches of at most
            :data:`WARP_BATCH_ENVS` envs (or one setting's episodes), settings that show videos
            apart from those that show none, about as many envs to each process. ``seconds``
            is then its batch's wall time shared among the batch's settings.
    """
    from dcs_torchrl.render.egl_devices import process_render_device, render_device_indices

    if processes < 1:
        raise ValueError(f"processes must be >= 1, got {processes}.")
    devices = render_device_indices(render_devices)
    if devices is not None and set(devices) == {process_render_device()}:
        devices = None  # all on this process's device: nothing to spawn for
    if backend == "warp":
        batches = _warp_batches(agent_results(agent_directory(agent))["config"], settings, episodes, processes)
    else:
        batches = [[key] for key in settings]
    if devices is None and (processes == 1 or len(batches) < 2):
        loaded = load_pretrained(agent, device, final=final, trust_checkpoint=trust_checkpoint) if settings else None
        for batch in batches:
            results = _timed_evaluation(loaded, [settings[key] for key in batch], episodes, workers, backend)
            yield from ((key, *result) for key, result in zip(batch, results))
        return
    agent_checkpoint(agent, final=final, trust_checkpoint=trust_checkpoint)  # its refusal here, not in a process
    yield from _evaluate_in_processes(agent, settings, batches, episodes, min(processes, len(batches)), workers,
                                      device, final, devices, backend, trust_checkpoint)


def _warp_batches(config: Mapping, settings: Mapping[Hashable, dict], episodes: int,
                  processes: int) -> list[list[Hashable]]:
    """The keys of ``settings`` in batches for one batched env each (:func:`evaluate_settings`),
    largest first: those that one render cannot mix apart (videos or none, texture size, camera),
    each batch at most the envs of all settings shared among the processes, of
    :data:`WARP_BATCH_ENVS` or of one setting."""
    from dcs_torchrl.results import shows_videos

    kinds: dict[tuple, list[Hashable]] = {}
    for key, overrides in settings.items():
        env = agent_env_settings(config, overrides)
        videos = shows_videos(env.as_dict())
        kind = (videos, env.texture_size if videos else None, env.camera_id)
        kinds.setdefault(kind, []).append(key)
    share = -(-len(settings) * episodes // max(1, processes))
    per = max(1, min(WARP_BATCH_ENVS, share) // episodes)
    batches = [keys[i:i + per] for keys in kinds.values() for i in range(0, len(keys), per)]
    return sorted(batches, key=len, reverse=True)


def _evaluate_in_processes(agent, settings: Mapping[Hashable, dict], batches: list[list[Hashable]], episodes: int,
                           processes: int, workers: int, device: str, final: bool, devices: list[int] | None,
                           backend: str = "gl", trust_checkpoint: bool = False):
    """:func:`evaluate_settings` in spawned processes: one pool per render device (its processes
    spawned with ``MUJOCO_EGL_DEVICE_ID`` naming it), each fed a batch of settings whenever one of
    its processes is free."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool
    from contextlib import ExitStack

    from dcs_torchrl.render.egl_devices import EGL_DEVICE_VARIABLE, RENDER_THREADS_VARIABLE, render_threads_share
    from dcs_torchrl.vector.process_pool import SpawnedPool

    threads = max(1, (os.cpu_count() or 1) // processes)
    share = Counter(None if devices is None else devices[i % len(devices)] for i in range(processes))
    todo = iter(batches)
    running = {}
    with ExitStack() as stack:
        def feed(pool):
            batch = next(todo, None)
            if batch is not None:
                overrides = [settings[key] for key in batch]
                running[pool.submit(_evaluate_in_worker, overrides, episodes, workers, backend)] = batch, pool

        for render, count in share.items():
            pool = stack.enter_context(SpawnedPool(
                count, environment={EGL_DEVICE_VARIABLE: render, RENDER_THREADS_VARIABLE: render_threads_share(threads)},
                threads=threads, initializer=_start_worker,
                initargs=(os.fspath(agent), device, final, render, trust_checkpoint)))
            for _ in range(count):
                feed(pool)
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                batch, pool = running.pop(future)
                try:
                    results = future.result()
                except BrokenProcessPool as error:  # a process died: killed (out of memory) or gone without its error
                    raise pool.died("evaluation process", "evaluate fewer settings at once (processes; the robustness "
                                                          "command's --workers)") from error
                feed(pool)
                yield from ((key, *result) for key, result in zip(batch, results))


_WORKER_AGENT = None


def _start_worker(agent: str, device: str, final: bool, render: int | None, trust_checkpoint: bool = False) -> None:
    from dcs_torchrl.render.egl_devices import process_render_device

    if render is not None and process_render_device() != render:  # spawned outside its pool's environment
        raise RuntimeError(f"an evaluation process meant to render on EGL device {render} was started on "
                           f"{process_render_device()}: it must be spawned with MUJOCO_EGL_DEVICE_ID={render}.")
    global _WORKER_AGENT
    _WORKER_AGENT = load_pretrained(agent, device, final=final, trust_checkpoint=trust_checkpoint)


def _timed_evaluation(agent: Pretrained, batch: list[dict], episodes: int, workers: int,
                      backend: str = "gl") -> list[tuple[dict, float]]:
    """Each setting of ``batch`` evaluated (``backend="warp"``: all at once), with its share of the seconds."""
    start = time.time()
    if backend == "warp":
        results = agent.evaluate_each(batch, episodes)
    else:
        results = [agent.evaluate(episodes, workers=workers, backend=backend, **overrides) for overrides in batch]
    seconds = (time.time() - start) / len(batch)
    return [(result.to_dict(), seconds) for result in results]


def _evaluate_in_worker(batch: list[dict], episodes: int, workers: int, backend: str = "gl") -> list[tuple[dict, float]]:
    return _timed_evaluation(_WORKER_AGENT, batch, episodes, workers, backend)
