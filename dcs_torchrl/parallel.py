"""The suite's parallel env: n TorchRL envs, one per spawned process, stepped side by side.

TorchRL's ``ParallelEnv`` scales poorly with the suite's envs, whose step is one render of a
few milliseconds: its main process spin-polls shared-memory flags while the workers step (one
core busy doing nothing, taken from the workers on a small machine) and does a few milliseconds
of TensorDict bookkeeping per batched step, while the workers wait (docs/performance.md, "Parallel
envs"). :class:`ParallelSuiteEnv` keeps what makes ``ParallelEnv`` fast (observations written
into shared memory, not pickled) and waits the way a pipe waits: each worker steps its own env
exactly as a single env is stepped and writes its ``"next"`` entries into one shared
TensorDict; a byte on a pipe says "step", another says "done", and the main process sleeps in
``select`` in between.

Each worker's env is the env its factory builds, stepped and reset only when this env is, so an
episode through :class:`ParallelSuiteEnv` is the episode of one env with that worker's seed
(``tests/test_parallel.py``). Seeding follows TorchRL's batched envs: worker ``i`` gets the seed
that worker ``i - 1``'s ``set_seed`` returns. This process's torch threads are left as they are
(``ParallelEnv`` lowers them while its workers live); each worker runs one torch thread.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import traceback
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection, wait

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Composite
from torchrl.envs import EnvBase

from dcs_torchrl.egl_devices import EGL_DEVICE_VARIABLE as _EGL_DEVICE
from dcs_torchrl.egl_devices import egl_device_environment, render_device_indices

__all__ = ["ParallelSuiteEnv"]

_STEP, _RESET, _SEED, _CLOSE = b"s", b"r", b"e", b"c"
_OK, _FAILED = b"k", b"f"
_POLL_S = 1.0  # how often a wait checks that the workers are alive


class ParallelSuiteEnv(EnvBase):
    """``num_workers`` envs from ``create_env_fn``, each in its own spawned process; batch size ``[num_workers]``.

    A drop-in for ``torchrl.envs.ParallelEnv(num_workers, create_env_fn)`` for envs whose step is
    a render (the suite's): the same specs, seeding and partial resets, usable with TorchRL's
    collectors, ``rollout`` and the suite's evaluation, at close to n times one env's speed on n
    idle cores (``benchmarks/parallel_speed.py``).

    Args:
        num_workers (int): the number of envs, each in its own process.
        create_env_fn (callable): builds one env (a TorchRL ``EnvBase`` with batch size ``[]``).
            It is pickled to the workers: a module-level function or a ``functools.partial``
            (e.g. ``functools.partial(dcs_torchrl.make_env, "cheetah", "run", benchmark="medium")``),
            not a lambda; envs that render with EGL must be built in the worker (``spawn``).

    Keyword Args:
        render_threads (int, optional): Mesa llvmpipe raster threads per worker (``LP_NUM_THREADS``;
            0: each worker renders in its own thread); ``None`` (default) keeps the environment's
            setting or Mesa's default. No effect on a GPU's EGL driver.
        render_devices (list, optional): the GPU each worker renders on, worker ``i`` on
            ``render_devices[i % len(render_devices)]``, so that the workers of one run spread over
            the GPUs of a node: an EGL device index (``MUJOCO_EGL_DEVICE_ID``'s, not a CUDA
            ordinal) or a CUDA device (``"cuda:1"``, a ``torch.device``), which is mapped to its
            EGL device (:func:`dcs_torchrl.egl_devices.egl_device_of_cuda`, NVIDIA's EGL driver).
            ``None`` (default): the device this process's environment names (dm_control's
            default, the first). A device the machine does not have raises ``ValueError`` here,
            naming the machine's EGL devices.
        mp_start_method (str): ``"spawn"`` (default; EGL contexts do not survive ``fork``).

    Examples:
        >>> import functools
        >>> import dcs_torchrl as dcs
        >>> env = dcs.ParallelSuiteEnv(2, functools.partial(dcs.make_env, "cartpole", "swingup", benchmark="medium"))
        >>> _ = env.set_seed(0)
        >>> env.rollout(3)["next", "pixels"].shape
        torch.Size([2, 3, 84, 84, 3])
        >>> env.close()
    """

    def __init__(self, num_workers: int, create_env_fn: Callable[[], EnvBase], *, render_threads: int | None = None,
                 render_devices: Sequence[int] | None = None, mp_start_method: str = "spawn"):
        if not isinstance(num_workers, int) or isinstance(num_workers, bool) or num_workers < 1:
            raise ValueError(f"num_workers must be an int >= 1, got {num_workers!r}.")
        if render_threads is not None and (not isinstance(render_threads, int) or render_threads < 0):
            raise ValueError(f"render_threads must be an int >= 0 (0: render in the worker's own thread) or None, "
                             f"got {render_threads!r}.")
        devices = render_device_indices(render_devices)
        if not callable(create_env_fn):
            raise TypeError(f"create_env_fn must be callable (a function or functools.partial), got {create_env_fn!r}.")
        super().__init__(batch_size=[num_workers], device="cpu")
        self.num_workers = num_workers
        self._render_devices = devices
        self._pipes: list[Connection] = []
        self._procs: list[mp.Process] = []
        self.is_closed = True
        ctx = mp.get_context(mp_start_method)
        try:
            for index in range(num_workers):
                here, there = ctx.Pipe()
                proc = ctx.Process(target=_work, args=(create_env_fn, there, index, render_threads), daemon=True,
                                   name=f"ParallelSuiteEnv-{index}")
                with egl_device_environment(None if devices is None else devices[index % len(devices)]):
                    proc.start()
                there.close()
                self._pipes.append(here)
                self._procs.append(proc)
            self.is_closed = False
            self._wait(range(num_workers))  # every env built (or the first error raised)
            self._set_specs(self._pipes[0].recv())
            self._buffers = _shared_buffers(self)
            for pipe in self._pipes:
                pipe.send(self._buffers)
            self._wait(range(num_workers))
        except BaseException:
            self.close(raise_if_closed=False)
            raise

    # ------------------------------------------------------------------ set-up
    def _set_specs(self, specs: dict) -> None:
        n = self.num_workers
        for name in ("full_observation_spec", "full_action_spec", "full_reward_spec", "full_done_spec", "full_state_spec"):
            setattr(self, name, specs[name].expand(n, *specs[name].shape))

    # ------------------------------------------------------------- TorchRL hooks
    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        self._buffers["action"].update_(tensordict.select(*self.action_keys))
        self._command(_STEP, range(self.num_workers))
        return _copy(self._buffers["next"])

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        if kwargs:
            raise TypeError(f"ParallelSuiteEnv.reset takes no keyword arguments, got {sorted(kwargs)}.")
        workers = range(self.num_workers)
        if tensordict is not None and "_reset" in tensordict.keys():
            workers = tensordict.get("_reset").reshape(self.num_workers, -1).any(-1).nonzero().flatten().tolist()
        self._command(_RESET, workers)
        return _copy(self._buffers["next"].select(*self.observation_keys, *self.done_keys))

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        """Seeds worker 0 with ``seed`` and each next worker with what the previous one's
        ``set_seed`` returns (TorchRL's batched envs); returns the last worker's return."""
        for index, pipe in enumerate(self._pipes):
            pipe.send_bytes(_SEED)
            pipe.send((seed, static_seed))
            seed = self._receive(index)
        return seed

    def _set_seed(self, seed: int | None) -> None:  # set_seed is overridden: never called
        raise NotImplementedError

    def close(self, *, raise_if_closed: bool = True) -> None:
        if self.is_closed:
            if raise_if_closed:
                raise RuntimeError("ParallelSuiteEnv is closed already.")
            return
        self.is_closed = True
        for pipe in self._pipes:
            try:
                pipe.send_bytes(_CLOSE)
            except (BrokenPipeError, OSError):
                pass
        for proc in self._procs:
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=5)
        for pipe in self._pipes:
            pipe.close()

    def __del__(self):
        if getattr(self, "is_closed", True) is False:
            self.close(raise_if_closed=False)

    # ------------------------------------------------------------ messaging
    def _command(self, command: bytes, workers) -> None:
        workers = list(workers)
        if self.is_closed:
            raise RuntimeError("ParallelSuiteEnv is closed: build a new one.")
        for index in workers:
            self._pipes[index].send_bytes(command)
        self._wait(workers)

    def _wait(self, workers) -> None:
        """Sleeps until every worker in ``workers`` has answered; raises with a failed worker's traceback."""
        pending = {self._pipes[i]: i for i in workers}
        while pending:
            ready = wait(list(pending), timeout=_POLL_S)
            if not ready:
                self._check_alive(pending.values())
            for pipe in ready:
                self._answer(pending.pop(pipe))

    def _receive(self, index: int):
        """The object worker ``index`` sends after its status byte."""
        self._wait([index])
        return self._pipes[index].recv()

    def _answer(self, index: int) -> None:
        try:
            status = self._pipes[index].recv_bytes()
        except EOFError:
            self._check_alive([index])
            raise
        if status == _FAILED:
            message = self._pipes[index].recv()
            self.close(raise_if_closed=False)
            raise RuntimeError(f"ParallelSuiteEnv worker {index} failed:\n{message}")

    def _check_alive(self, workers) -> None:
        for index in workers:
            proc = self._procs[index]
            if not proc.is_alive():
                self.close(raise_if_closed=False)
                device = "" if self._render_devices is None else (
                    f"; or it could not render on its EGL device, {_EGL_DEVICE}="
                    f"{self._render_devices[index % len(self._render_devices)]} (render_devices)")
                raise RuntimeError(
                    f"ParallelSuiteEnv worker {index} died (exit code {proc.exitcode}): "
                    "look for its error above; an env that cannot be built in a spawned process "
                    f"(a lambda, a local function) fails this way{device}."
                )


def _copy(td: TensorDictBase) -> TensorDictBase:
    """A copy of ``td`` made by numpy, in this thread: torch's copy of a frame batch is split over
    its intra-op threads, which then spin waiting for more work, taking the workers' cores."""
    return td.apply(lambda t: torch.from_numpy(t.numpy().copy()))


def _shared_buffers(env: ParallelSuiteEnv) -> TensorDict:
    """``"action"``: what the workers read; ``"next"``: what they write (observations, reward, done)."""
    step_spec = Composite(shape=env.batch_size)
    for spec in (env.full_observation_spec, env.full_reward_spec, env.full_done_spec):
        step_spec.update(spec)
    return TensorDict(
        {"action": env.full_action_spec.zero(), "next": step_spec.zero()}, batch_size=env.batch_size, device=env.device
    ).share_memory_()


def _work(create_env_fn: Callable[[], EnvBase], pipe: Connection, index: int, render_threads: int | None) -> None:
    """A worker: builds its env, then steps, resets and seeds it on command until told to close."""
    torch.set_num_threads(1)
    os.environ.setdefault("MUJOCO_GL", "egl")
    if render_threads is not None:  # read by Mesa's llvmpipe at the first GL context, which comes later
        os.environ["LP_NUM_THREADS"] = str(render_threads)
    try:
        env = create_env_fn()
        pipe.send_bytes(_OK)
        if index == 0:
            pipe.send({name: getattr(env, name) for name in (
                "full_observation_spec", "full_action_spec", "full_reward_spec", "full_done_spec", "full_state_spec")})
        buffers = pipe.recv()
        action, out = buffers["action"][index], buffers["next"][index]
        action_keys = list(env.action_keys)
        out_keys = list(out.keys(True, True))
        reset_keys = [k for k in out_keys if k in set(env.observation_keys) | set(env.done_keys)]
        pipe.send_bytes(_OK)
    except BaseException:
        _report(pipe)
        return
    td = None
    while True:
        try:
            command = pipe.recv_bytes()
        except (EOFError, OSError):  # the main process is gone
            break
        try:
            if command == _STEP:
                if td is None:
                    raise RuntimeError("step before reset: call env.reset() first.")
                for key in action_keys:
                    td.set(key, action.get(key).clone())
                td = env.step(td).get("next")
                out.update_(td.select(*out_keys))
                pipe.send_bytes(_OK)
            elif command == _RESET:
                td = env.reset()
                out.update_(td.select(*reset_keys))
                pipe.send_bytes(_OK)
            elif command == _SEED:
                seed, static_seed = pipe.recv()
                new_seed = env.set_seed(seed, static_seed=static_seed)
                pipe.send_bytes(_OK)
                pipe.send(new_seed)
            elif command == _CLOSE:
                break
        except BaseException:
            _report(pipe)
    env.close()


def _report(pipe: Connection) -> None:
    try:
        pipe.send_bytes(_FAILED)
        pipe.send(traceback.format_exc())
    except (BrokenPipeError, OSError):
        pass
