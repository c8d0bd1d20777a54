"""The suite's parallel env: n TorchRL envs, the first here and one per spawned process for the rest, stepped side by side.

TorchRL's ``ParallelEnv`` scales poorly with the suite's envs, whose step is one render: its main
process spin-polls shared-memory flags while the workers step (one core busy doing nothing, taken
from the workers on a small machine) and does TensorDict bookkeeping per batched step while the
workers wait (what it costs: docs/performance.md, "Parallel envs"). :class:`ParallelSuiteEnv` keeps what makes ``ParallelEnv`` fast (observations written
into shared memory, not pickled) and waits the way a pipe waits: each worker steps its own env
exactly as a single env is stepped and writes its ``"next"`` entries into one shared
TensorDict; a byte on a pipe says "step", another says "done", and the main process steps its own
env (``first_here``) in between; a process that waits polls its pipes for ``spin_s`` (3 ms) and
then sleeps in ``select``.

Each worker's env is the env its factory builds, stepped and reset only when this env is, so an
episode through :class:`ParallelSuiteEnv` is the episode of one env with that worker's seed
(``tests/test_parallel.py``). Seeding follows TorchRL's batched envs: worker ``i`` gets the seed
that worker ``i - 1``'s ``set_seed`` returns. This process's torch threads are left as they are
(``ParallelEnv`` lowers them while its workers live); each worker runs one torch thread.

With two or more envs the first is built and stepped in this process (``first_here``), by the
same loop a worker runs and with one torch thread as a worker's, while the other workers step
theirs: the process that ends a batched step is then already awake when its own env's step is done.
What each of these choices gains is measured in docs/performance.md ("Parallel envs") and its
notebook, not here (``benchmarks/parallel_speed.py``).
"""
from __future__ import annotations

import multiprocessing as mp
import time
import traceback
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection, wait

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Composite
from torchrl.envs import EnvBase

from dcs_torchrl.render.egl_devices import EGL_DEVICE_VARIABLE as _EGL_DEVICE
from dcs_torchrl.render.egl_devices import RENDER_THREADS_VARIABLE, process_render_device, render_device_indices, spawn_environment
from dcs_torchrl.vector._batching import chain_seeds, close_once, marked
from dcs_torchrl.vector._threads import torch_threads
from dcs_torchrl.vector.process_pool import WorkerDiedError, worker_died

__all__ = ["ParallelSuiteEnv"]

_STEP, _RESET, _SEED, _CLOSE = b"s", b"r", b"e", b"c"
_OK, _FAILED = b"k", b"f"
_POLL_S = 1.0  # how often a wait checks that the workers are alive
_BUFFERS = torch.device("cpu")  # where the workers' shared buffers live (shared memory)
_SPECS = ("full_observation_spec", "full_action_spec", "full_reward_spec", "full_done_spec", "full_state_spec")
#: Default seconds a process polls its pipes before it sleeps (``spin_s``): a sleeping process
#: wakes late on a virtual machine's idle core, twice a step (docs/performance.md, "Parallel envs").
SPIN_S = 0.003


class ParallelSuiteEnv(EnvBase):
    """``num_workers`` envs from ``create_env_fn``, batch size ``[num_workers]`` (or the sum of
    ``envs_per_worker``, where each worker's env is a batch): the first in this process
    (``first_here``), the others each in its own spawned process.

    A drop-in for ``torchrl.envs.ParallelEnv(num_workers, create_env_fn)`` for envs whose step is
    a render (the suite's): the same specs, seeding, partial resets (``"_reset"``: the other envs
    continue their episodes) and partial steps (``"_step"``, which ``rollout`` writes), usable with TorchRL's
    collectors, ``rollout`` and the suite's evaluation; faster than TorchRL's ``ParallelEnv`` with the
    suite's envs on small machines (docs/performance.md, "Parallel envs"; ``benchmarks/parallel_speed.py``).

    A worker that fails raises its traceback; one that dies (the OOM killer, ``kill -9``) raises
    :class:`~dcs_torchrl.WorkerDiedError` naming it, its envs, its signal or exit code and the fix.
    Either closes the env (the other workers end); a ``close()`` after it returns.

    Args:
        num_workers (int): the number of envs, each in its own process.
        create_env_fn (callable): builds one env (a TorchRL ``EnvBase`` with batch size ``[]``).
            It is pickled to the workers: a module-level function or a ``functools.partial``
            (e.g. ``functools.partial(dcs_torchrl.make_env, "cheetah", "run", benchmark="medium")``),
            not a lambda; envs that render with EGL must be built in the worker (``spawn``).

    Keyword Args:
        render_threads (int, optional): Mesa llvmpipe raster threads per worker (``LP_NUM_THREADS``;
            0: each worker renders in its own thread); ``None`` (default) keeps the environment's
            setting or Mesa's default. Set in each worker's environment from its start (Mesa reads it
            once, at a process's first import of dm_control). No effect on a GPU's EGL driver, nor on
            the first env with ``first_here`` (it renders with this process's setting).
        render_devices (list, optional): the GPU each worker renders on, worker ``i`` on
            ``render_devices[i % len(render_devices)]``, so that the workers of one run spread over
            the GPUs of a node: an EGL device index (``MUJOCO_EGL_DEVICE_ID``'s, not a CUDA
            ordinal) or a CUDA device (``"cuda:1"``, a ``torch.device``), which is mapped to its
            EGL device (:func:`dcs_torchrl.render.egl_devices.egl_device_of_cuda`, NVIDIA's EGL driver).
            ``None`` (default): the device this process's environment names (dm_control's
            default, the first). A device the machine does not have raises ``ValueError`` here,
            naming the machine's EGL devices.
        spin_s (float): seconds each waiting process polls its pipes (busy-waits) before it sleeps
            in ``select``: a worker after its step, this process for the workers' answers. A
            woken process starts late on a virtual machine; a polling one at once, for a core's time
            while it polls. Default :data:`SPIN_S` (3 ms; what it gains: docs/performance.md,
            "Parallel envs"); ``0`` sleeps at once.
        first_here (bool, optional): build and step the first env in this process, while the other
            ``num_workers - 1`` step theirs in their own processes; ``False``: every env in a worker.
            The episodes are the same either way. ``None`` (default): ``True`` for two or more envs
            whose first renders on this process's EGL device (``render_devices`` ``None`` or its
            first entry this process's device), else ``False``. ``True`` with another device first
            raises ``ValueError`` (dm_control picks a process's EGL device once, at import).
        mp_start_method (str): ``"spawn"`` (default; EGL contexts do not survive ``fork``).
        device (optional): the env's device, where its specs say and its outputs are (e.g.
            ``"cuda"`` for a policy on a GPU); the workers' envs and their shared buffers stay on
            the CPU, actions are copied there. Default ``"cpu"``.
        envs_per_worker (sequence of int, optional): each worker's env is itself a batch, worker
            ``i``'s of batch size ``[envs_per_worker[i]]`` (a Warp batch, ``make_env(...,
            num_envs=k, backend="warp")``, which ``make_env(..., processes=P)`` builds here): the envs
            lie worker after worker, batch size ``[sum(envs_per_worker)]``; a ``"_step"`` or
            ``"_reset"`` mask acts on the envs it marks within each worker. ``None`` (default): one
            env per worker, batch size ``[num_workers]``.

    Examples:
        >>> import functools
        >>> import dcs_torchrl as dcs
        >>> env = dcs.ParallelSuiteEnv(2, functools.partial(dcs.make_env, "cartpole", "swingup", benchmark="medium"))
        >>> _ = env.set_seed(0)
        >>> env.rollout(3)["next", "pixels"].shape
        torch.Size([2, 3, 84, 84, 3])
        >>> env.close()
    """

    #: The suite's transforms refuse to sit over this env (``dcs_torchrl._scene.PHYSICS_ELSEWHERE``):
    #: its physics live in its workers.
    physics_in_workers = True

    def __init__(self, num_workers: int, create_env_fn: Callable[[], EnvBase] | Sequence[Callable[[], EnvBase]], *,
                 render_threads: int | None = None, render_devices: Sequence[int] | None = None, spin_s: float = SPIN_S,
                 first_here: bool | None = None, mp_start_method: str = "spawn", device=None,
                 envs_per_worker: Sequence[int] | None = None):
        if not isinstance(num_workers, int) or isinstance(num_workers, bool) or num_workers < 1:
            raise ValueError(f"num_workers must be an int >= 1, got {num_workers!r}.")
        factories = _factories(create_env_fn, num_workers)
        rows, size = _rows(envs_per_worker, num_workers)
        if render_threads is not None and (not isinstance(render_threads, int) or render_threads < 0):
            raise ValueError(f"render_threads must be an int >= 0 (0: render in the worker's own thread) or None, "
                             f"got {render_threads!r}.")
        if isinstance(spin_s, bool) or not isinstance(spin_s, (int, float)) or not 0 <= spin_s < _POLL_S:
            raise ValueError(f"spin_s must be seconds in [0, {_POLL_S}) (0: sleep at once), got {spin_s!r}.")
        devices = render_device_indices(render_devices)
        here_renders = devices is None or devices[0] == process_render_device()
        if first_here is None:
            first_here = num_workers >= 2 and here_renders
        elif not isinstance(first_here, bool):
            raise TypeError(f"first_here must be True, False or None (default: True for two or more envs), got {first_here!r}.")
        if first_here and not here_renders:
            raise ValueError(
                f"first_here=True renders the first env in this process, on its EGL device {process_render_device()}, "
                f"not render_devices[0] = {devices[0]}: pass first_here=False, or set {_EGL_DEVICE} before importing "
                "dm_control."
            )
        super().__init__(batch_size=[size], device=_BUFFERS if device is None else device)
        self.num_workers = num_workers
        self._rows = rows  # worker i's envs: its row (an int) or its rows (a slice) of the batch
        self._render_devices = devices
        self._spin_s = float(spin_s)
        self._pipes: list[Connection | None] = []  # None: the env stepped here (first_here)
        self._procs: list[mp.Process | None] = []
        self._here: _Stepper | None = None
        self._started = False  # every worker's env built and attached to the buffers
        self._failure: str | None = None  # why a failed or dead worker closed the env ("worker 1 died")
        self._close_owed = False  # a user's close() after that: nothing left to close, no error
        self.is_closed = True
        ctx = mp.get_context(mp_start_method)
        try:
            if first_here:
                self._here = _Stepper(_build(factories[0], rows[0]))
                self._pipes.append(None)
                self._procs.append(None)
            for index in range(len(self._pipes), num_workers):
                here, there = ctx.Pipe()
                args = (factories[index], there, index, rows[index], self._spin_s)
                proc = ctx.Process(target=_work, args=args, daemon=True, name=f"ParallelSuiteEnv-{index}")
                with spawn_environment({_EGL_DEVICE: None if devices is None else devices[index % len(devices)],
                                        RENDER_THREADS_VARIABLE: render_threads}):  # read at its first import
                    proc.start()
                there.close()
                self._pipes.append(here)
                self._procs.append(proc)
            self.is_closed = False
            self._wait(range(num_workers))  # every env built (or the first error raised)
            self._set_specs(self._here.specs() if first_here else self._talk(0, self._pipes[0].recv))
            self._buffers = _shared_buffers(self)
            if self.device != _BUFFERS:
                for name in _SPECS:
                    setattr(self, name, getattr(self, name).to(self.device))
            for index in range(int(first_here), num_workers):
                self._talk(index, self._pipes[index].send, self._buffers)
            if first_here:
                self._here.attach(self._buffers, rows[0])
            self._wait(range(num_workers))
            self._started = True
        except BaseException:
            self.close(raise_if_closed=False)
            raise

    @property
    def first_here(self) -> bool:
        """Whether the first env is stepped in this process (see ``first_here`` above)."""
        return self._here is not None

    # ------------------------------------------------------------------ set-up
    def _set_specs(self, specs: dict) -> None:
        n, batched = self.batch_size[0], isinstance(self._rows[0], slice)
        for name in _SPECS:
            spec = specs[name][0] if batched else specs[name]  # one env's, from worker 0's batch
            setattr(self, name, spec.expand(n, *spec.shape).to(_BUFFERS))

    def _mark(self, tensordict: TensorDictBase | None, key: str) -> tuple[torch.Tensor, list[int]]:
        """Which envs ``key`` (``"_step"``, ``"_reset"``) of ``tensordict`` marks (all without one), bool
        ``[batch]``, and the workers holding any of them; a batch worker reads its own part of the mask
        from the shared buffers."""
        mask = torch.zeros(self.batch_size, dtype=torch.bool)
        mask[marked(tensordict, key, self.batch_size[0])] = True
        if key in self._buffers.keys():
            self._buffers[key].copy_(mask)
        return mask, [i for i, rows in enumerate(self._rows) if mask[rows].any()]

    # ------------------------------------------------------------- TorchRL hooks
    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Steps the workers that ``"_step"`` marks (all without it: TorchRL's ``rollout`` writes it
        for the envs still running); an env not stepped keeps its last observation and done flags,
        with reward 0, as the batched env's."""
        self._buffers["action"].update_(tensordict.select(*self.action_keys))
        stepped, workers = self._mark(tensordict, "_step")
        self._command(_STEP, workers)
        out = _copy(self._buffers["next"])
        if not stepped.all():
            skipped = ~stepped
            for key in self.reward_keys:
                out.get(key)[skipped] = 0
        return out.to(self.device)  # no copy on the buffers' device

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        if kwargs:
            raise TypeError(f"ParallelSuiteEnv.reset takes no keyword arguments, got {sorted(kwargs)}.")
        _, workers = self._mark(tensordict, "_reset")
        self._command(_RESET, workers)
        out = _copy(self._buffers["next"].select(*self.observation_keys, *self.done_keys))
        return out.to(self.device)  # no copy on the buffers' device

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        """Seeds worker 0 with ``seed`` and each next worker with what the previous one's
        ``set_seed`` returns (TorchRL's batched envs); returns the last worker's return."""
        def worker(index: int, pipe):
            def set_seed(seed):
                if pipe is None:
                    return self._here.env.set_seed(seed, static_seed=static_seed)
                self._talk(index, pipe.send_bytes, _SEED)
                self._talk(index, pipe.send, (seed, static_seed))
                self._wait([index])
                return self._talk(index, pipe.recv)
            return set_seed

        return chain_seeds([worker(index, pipe) for index, pipe in enumerate(self._pipes)], seed)

    def _set_seed(self, seed: int | None) -> None:  # set_seed is overridden: never called
        raise NotImplementedError

    def close(self, *, raise_if_closed: bool = True) -> None:
        """Ends the workers (each told to close, and terminated if it has not within 10 s). After a
        worker failed or died, which closed the env, the first ``close()`` returns at once."""
        if self._close_owed:
            self._close_owed = False
            return
        if not close_once(self, raise_if_closed):
            return
        pipes, procs = [p for p in self._pipes if p is not None], [p for p in self._procs if p is not None]
        for pipe in pipes:
            try:
                pipe.send_bytes(_CLOSE)
            except (BrokenPipeError, OSError):
                pass
        if self._here is not None:
            self._here.env.close()
        for proc in procs:
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=5)
        for pipe in pipes:
            pipe.close()

    def __del__(self):
        if getattr(self, "is_closed", True) is False:
            self.close(raise_if_closed=False)

    # ------------------------------------------------------------ messaging
    def _talk(self, index: int, call: Callable, *args):
        """``call(*args)``, a send to or receive from worker ``index``'s pipe; a dead worker's error
        where the pipe is broken."""
        try:
            return call(*args)
        except (EOFError, OSError) as error:  # BrokenPipeError, ConnectionResetError
            raise self._died(index) from error

    def _command(self, command: bytes, workers) -> None:
        workers = list(workers)
        if self.is_closed:
            why = "" if self._failure is None else f" ({self._failure})"
            raise RuntimeError(f"ParallelSuiteEnv is closed{why}: build a new one.")
        index = None
        try:
            for index in workers:
                if self._pipes[index] is not None:
                    self._pipes[index].send_bytes(command)
        except OSError as error:  # a dead worker's pipe (BrokenPipeError, ConnectionResetError)
            raise self._died(index) from error
        if self._here is not None and 0 in workers:  # the first env, while the workers step theirs
            # one thread, as in a worker: torch's idle intra-op threads spin on the workers' cores
            with torch_threads(1):
                try:
                    self._here.run(command)
                except BaseException as error:
                    try:
                        self._wait(workers)  # their answers, so that the next command finds none pending
                    except RuntimeError as also:  # a worker failed too (and closed this env): the first env's error first
                        error.add_note(f"Meanwhile: {also}")
                    raise error
        self._wait(workers)

    def _wait(self, workers) -> None:
        """Polls for ``spin_s``, then sleeps, until every worker in ``workers`` has answered; raises
        with a failed worker's traceback."""
        pending = {self._pipes[i]: i for i in workers if self._pipes[i] is not None}
        polled = time.perf_counter() + self._spin_s
        while pending:
            polling = time.perf_counter() < polled
            ready = wait(list(pending), timeout=0 if polling else _POLL_S)
            if not ready and not polling:
                self._check_alive(pending.values())
            for pipe in ready:
                self._answer(pending.pop(pipe))

    def _answer(self, index: int) -> None:
        try:
            status = self._pipes[index].recv_bytes()
            message = self._pipes[index].recv() if status == _FAILED else None
        except (EOFError, OSError) as error:  # a dead worker's pipe
            raise self._died(index) from error
        if status == _FAILED:
            self._fail(f"worker {index} failed")
            raise RuntimeError(f"ParallelSuiteEnv worker {index} failed:\n{message}")

    def _check_alive(self, workers) -> None:
        """Raises for the first of ``workers`` that is dead (a wait's timeout: a dead worker's pipe
        tells at once, except where another process holds its end)."""
        for index in workers:
            if not self._procs[index].is_alive():
                raise self._died(index)

    def _died(self, index: int) -> WorkerDiedError:
        """The error for worker ``index``, found dead (its pipe broken, or not alive at a wait's timeout),
        naming its envs, how it ended and the fix; closes the env (its other workers end)."""
        proc = self._procs[index]
        proc.join(timeout=5)  # a pipe breaks as its process ends: the exit code comes a moment later
        rows = self._rows[index]
        envs = f"env {rows}" if isinstance(rows, int) else (
            f"env {rows.start}" if rows.stop - rows.start == 1 else f"envs {rows.start}-{rows.stop - 1}")
        hint = ""
        if not self._started:
            device = "" if self._render_devices is None else (
                f"; or it could not render on its EGL device, {_EGL_DEVICE}="
                f"{self._render_devices[index % len(self._render_devices)]} (render_devices)")
            hint = (" It died before its env was built: an env that cannot be built in a spawned process (a lambda, "
                    f"a local function) fails this way{device}.")
        fewer = "run fewer envs at once (a smaller num_envs; with backend='warp', fewer processes)"
        error = worker_died(f"ParallelSuiteEnv worker {index} ({envs} of {self.batch_size[0]})", proc.exitcode, fewer,
                            hint)
        self._fail(f"worker {index} died")
        return error

    def _fail(self, failure: str) -> None:
        """Closes the env after a worker failed or died: the other workers end, the next command raises
        naming ``failure``, and the user's next ``close()`` returns at once."""
        self.close(raise_if_closed=False)
        self._failure, self._close_owed = failure, True


def _copy(td: TensorDictBase) -> TensorDictBase:
    """A copy of ``td`` made by numpy, in this thread: torch's copy of a frame batch is split over
    its intra-op threads, which then spin waiting for more work, taking the workers' cores."""
    return td.apply(lambda t: torch.from_numpy(t.numpy().copy()))


def _factories(create_env_fn, num_workers: int) -> list[Callable[[], EnvBase]]:
    """Worker ``i``'s env factory: ``create_env_fn`` for all, or its ``i``-th."""
    if callable(create_env_fn):
        return [create_env_fn] * num_workers
    factories = list(create_env_fn) if isinstance(create_env_fn, Sequence) else []
    if len(factories) != num_workers or not all(callable(f) for f in factories):
        raise TypeError(f"create_env_fn must be callable (a function or functools.partial) or a sequence of "
                        f"num_workers={num_workers} callables, got {create_env_fn!r}.")
    return factories


def _rows(envs_per_worker: Sequence[int] | None, num_workers: int) -> tuple[list, int]:
    """Each worker's rows of the batch (its index, or a slice where each worker's env is a batch) and the
    batch size."""
    if envs_per_worker is None:
        return list(range(num_workers)), num_workers
    sizes = list(envs_per_worker)
    if len(sizes) != num_workers or any(isinstance(k, bool) or not isinstance(k, int) or k < 1 for k in sizes):
        raise ValueError(f"envs_per_worker must hold num_workers={num_workers} positive ints (each worker's batch "
                         f"size), got {envs_per_worker!r}.")
    bounds = [sum(sizes[:i]) for i in range(num_workers + 1)]
    return [slice(a, b) for a, b in zip(bounds, bounds[1:])], bounds[-1]


def _build(create_env_fn: Callable[[], EnvBase], rows) -> EnvBase:
    """The env of a worker with ``rows`` of the batch, checked to be of the batch size they span."""
    env = create_env_fn()
    expected = torch.Size([]) if isinstance(rows, int) else torch.Size([rows.stop - rows.start])
    if env.batch_size != expected:
        size = env.batch_size
        env.close()
        raise ValueError(f"the worker's env has batch size {list(size)}, not {list(expected)}: with "
                         "envs_per_worker, worker i's env must be a batch of envs_per_worker[i] envs; without "
                         "it, one env of batch size [].")
    return env


def _shared_buffers(env: ParallelSuiteEnv) -> TensorDict:
    """``"action"``: what the workers read; ``"next"``: what they write (observations, reward, done); where
    each worker's env is a batch, ``"_step"`` and ``"_reset"``: which of its envs a command acts on."""
    step_spec = Composite(shape=env.batch_size)
    for spec in (env.full_observation_spec, env.full_reward_spec, env.full_done_spec):
        step_spec.update(spec)
    buffers = {"action": env.full_action_spec.zero(), "next": step_spec.zero()}
    if isinstance(env._rows[0], slice):
        buffers.update({key: torch.ones(env.batch_size, dtype=torch.bool) for key in ("_step", "_reset")})
    return TensorDict(buffers, batch_size=env.batch_size, device=_BUFFERS).share_memory_()


def _work(create_env_fn: Callable[[], EnvBase], pipe: Connection, index: int, rows, spin_s: float) -> None:
    """A worker: builds its env, then steps, resets and seeds it on command until told to close."""
    torch.set_num_threads(1)
    try:
        stepper = _Stepper(_build(create_env_fn, rows))
        pipe.send_bytes(_OK)
        if index == 0:
            pipe.send(stepper.specs())
        stepper.attach(pipe.recv(), rows)
        pipe.send_bytes(_OK)
    except BaseException:
        _report(pipe)
        return
    while True:
        try:
            polled = time.perf_counter() + spin_s
            while time.perf_counter() < polled and not pipe.poll():
                pass
            command = pipe.recv_bytes()
        except (EOFError, OSError):  # the main process is gone
            break
        if command == _CLOSE:
            break
        try:
            if command == _SEED:
                seed, static_seed = pipe.recv()
                new_seed = stepper.env.set_seed(seed, static_seed=static_seed)
                pipe.send_bytes(_OK)
                pipe.send(new_seed)
            else:
                stepper.run(command)
                pipe.send_bytes(_OK)
        except BaseException:
            _report(pipe)
    stepper.env.close()


class _Stepper:
    """One env stepped and reset on command, reading its action from and writing its results to
    its row of the shared buffers: what a worker runs, and this process for ``first_here``."""

    def __init__(self, env: EnvBase):
        self.env, self.td = env, None

    def specs(self) -> dict:
        return {name: getattr(self.env, name) for name in _SPECS}

    def attach(self, buffers: TensorDictBase, rows) -> None:
        """Its row (an int) or rows (a slice, where its env is a batch) of the shared buffers."""
        self.action, self.out = buffers["action"][rows], buffers["next"][rows]
        self.masks = {key: buffers[key][rows] for key in ("_step", "_reset")} if isinstance(rows, slice) else {}
        self.action_keys = list(self.env.action_keys)
        self.out_keys = list(self.out.keys(True, True))
        kept = set(self.env.observation_keys) | set(self.env.done_keys)
        self.reset_keys = [k for k in self.out_keys if k in kept]

    def _mask(self, key: str) -> torch.Tensor | None:
        """Which envs of a batch a command acts on (``None``: all of them, or an env that is no batch)."""
        mask = self.masks.get(key)
        return None if mask is None or mask.all() else mask.clone()

    def run(self, command: bytes) -> None:
        if command == _STEP:
            if self.td is None:
                raise RuntimeError("step before reset: call env.reset() first.")
            for key in self.action_keys:
                self.td.set(key, self.action.get(key).clone())
            mask = self._mask("_step")
            if mask is not None:
                self.td.set("_step", mask)
            self.td = self.env.step(self.td).get("next")
            self.out.update_(self.td.select(*self.out_keys))
        elif command == _RESET:
            mask = self._mask("_reset")
            reset = None if mask is None else TensorDict({"_reset": mask.unsqueeze(-1)}, self.env.batch_size,
                                                         device=self.env.device)
            self.td = self.env.reset(reset)
            self.out.update_(self.td.select(*self.reset_keys))
        else:
            raise ValueError(f"unknown command {command!r}")


def _report(pipe: Connection) -> None:
    try:
        pipe.send_bytes(_FAILED)
        pipe.send(traceback.format_exc())
    except (BrokenPipeError, OSError):
        pass
