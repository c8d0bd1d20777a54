"""A worker process that dies (the OOM killer, ``kill -9``) raises WorkerDiedError at the next call that talks to it,
naming the worker, its envs, its signal and the fix; ``close()`` after it returns and the other workers end. The same
for the evaluation pools' processes."""
import functools
import os
import signal
import time

import pytest
import torch
from torchrl.envs import DMControlEnv, Transform, TransformedEnv

import dcs_torchrl as dcs
from dcs_torchrl import ParallelSuiteEnv, WorkerDiedError, make_env
from dcs_torchrl.evaluation.protocol import evaluate_in_processes
from dcs_torchrl.vector import process_pool

SMALL = dict(action_repeat=100, height=32, width=32)
FACTORY = functools.partial(make_env, "cartpole", "swingup", **SMALL)
#: What every death by a signal says to do: the machine out of memory is what kills a worker most often.
MEMORY = r"OOM killer.*`dmesg.*free memory or "
ENV_FIX = MEMORY + r"run fewer envs at once \(a smaller num_envs; with backend='warp', fewer processes"
KILLED = r"killed by SIGKILL \(9\)"


def _kill(env, index: int) -> None:
    """Kills worker ``index`` between two calls, as the OOM killer would (dead before the next call)."""
    os.kill(env._procs[index].pid, signal.SIGKILL)
    env._procs[index].join()


def _closes_at_once_and_ends_every_worker(env) -> None:
    env.close()  # the env closed itself at the error: this close returns, with no second error
    assert env.is_closed and not any(proc.is_alive() for proc in env._procs if proc is not None)
    with pytest.raises(RuntimeError, match=r"closed \(worker 1 died\): build a new one"):
        env.reset()


# a reset sends its command as a step does: under -m slow (each worker's spawn costs seconds)
@pytest.mark.parametrize("call", ["step", pytest.param("reset", marks=pytest.mark.slow), "set_seed"])
def test_a_killed_gl_worker_names_itself_at_the_next_call(call):
    env = make_env("cartpole", "swingup", num_envs=2, seed=0, **SMALL)
    td = env.reset()
    _kill(env, 1)
    calls = {"step": lambda: env.rand_step(td), "reset": env.reset, "set_seed": lambda: env.set_seed(1)}
    message = rf"(?s)^ParallelSuiteEnv worker 1 \(env 1 of 2\) died: {KILLED}\. .*{ENV_FIX}"
    with pytest.raises(WorkerDiedError, match=message) as error:
        calls[call]()
    assert isinstance(error.value.__cause__, (EOFError, OSError))  # what the broken pipe raised, chained
    _closes_at_once_and_ends_every_worker(env)


def test_a_killed_warp_process_names_its_envs():
    pytest.importorskip("mujoco_warp")
    env = make_env("cartpole", "swingup", num_envs=4, backend="warp", processes=2, seed=0, **SMALL)
    td = env.reset()
    _kill(env, 1)
    message = rf"(?s)^ParallelSuiteEnv worker 1 \(envs 2-3 of 4\) died: {KILLED}\. .*{ENV_FIX}"
    with pytest.raises(WorkerDiedError, match=message):
        env.rand_step(td)
    _closes_at_once_and_ends_every_worker(env)


class _DiesAtStep(Transform):
    """Kills its process (SIGKILL) in its env's step, after a child process took a copy of its pipes
    (``hold_s`` seconds): no end of file then tells this process of the death, its wait must see it."""

    def __init__(self, hold_s: float = 0.0):
        super().__init__()
        self.hold_s = hold_s

    def _step(self, tensordict, next_tensordict):
        if self.hold_s and os.fork() == 0:
            time.sleep(self.hold_s)
            os._exit(0)
        os.kill(os.getpid(), signal.SIGKILL)


def _dying_env(hold_s: float = 0.0):
    return TransformedEnv(FACTORY(), _DiesAtStep(hold_s))


@pytest.mark.parametrize("hold_s, first_here", [(0.0, False), (30.0, True)],
                         ids=["its-pipe-closes-every-env-in-workers", "a-child-holds-its-pipe-first-here"])
def test_a_worker_killed_while_this_process_waits_for_its_step_names_itself(hold_s, first_here):
    """Worker 1 dies in the middle of a step: its pipe's end of file wakes the wait, or, where another
    process holds the pipe open, the wait's poll of the workers finds it dead (no error to chain). With
    every env in a worker, worker 0 ends with the env."""
    env = ParallelSuiteEnv(2, [FACTORY, functools.partial(_dying_env, hold_s)], first_here=first_here)
    td = env.reset()
    message = rf"(?s)^ParallelSuiteEnv worker 1 \(env 1 of 2\) died: {KILLED}\. .*{ENV_FIX}"
    with pytest.raises(WorkerDiedError, match=message) as error:
        env.rand_step(td)
    assert (error.value.__cause__ is None) == bool(hold_s)
    _closes_at_once_and_ends_every_worker(env)


#: Kills the process that calls it: a worker's env factory, a pool process's initializer.
SIGKILL_HERE = functools.partial(signal.raise_signal, signal.SIGKILL)


def test_a_worker_dead_before_its_env_is_built_names_the_usual_causes():
    with pytest.raises(WorkerDiedError, match=rf"(?s)^ParallelSuiteEnv worker 0 \(env 0 of 1\) died: {KILLED}\. "
                                              r".*It died before its env was built: an env that cannot be built in a "
                                              r"spawned process"):
        ParallelSuiteEnv(1, SIGKILL_HERE)


def _state_env(parent: int):
    """A cartpole from states, killed (SIGKILL) when built in another process than ``parent``."""
    if os.getpid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)
    return DMControlEnv("cartpole", "swingup", frame_skip=100)


def _still(td):
    return td.set("action", torch.zeros(1))


def test_a_killed_evaluation_process_names_itself():
    with pytest.raises(WorkerDiedError, match=rf"(?s)^evaluation process 0 \(pid \d+\) died: {KILLED}\. "
                                              rf".*{MEMORY}evaluate with fewer workers"):
        evaluate_in_processes(functools.partial(_state_env, os.getpid()), _still, 2, 2, seed=0)


class _KilledAtStart(process_pool.SpawnedPool):
    """The robustness command's pool, each of whose processes is killed as it starts."""

    def __init__(self, processes, **kwargs):
        super().__init__(processes, **{**kwargs, "initializer": SIGKILL_HERE, "initargs": ()})


def test_a_killed_robustness_process_names_itself(monkeypatch):
    from dcs_torchrl.evaluation.scheduling import evaluate_settings

    monkeypatch.setattr(process_pool, "SpawnedPool", _KilledAtStart)
    with pytest.raises(WorkerDiedError, match=rf"(?s)^evaluation process [01] \(pid \d+\) died: {KILLED}\. "
                                              rf".*{MEMORY}evaluate fewer settings at once \(processes; the "
                                              r"robustness command's --workers\)"):
        list(evaluate_settings("sac_rad_cartpole_swingup", {"a": {}, "b": {}}, 1, processes=2))


def test_the_package_exports_it():
    assert dcs.WorkerDiedError is process_pool.WorkerDiedError and issubclass(WorkerDiedError, RuntimeError)
