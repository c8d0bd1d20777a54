"""ParallelSuiteEnv: each worker's episodes are those of one env with its seed; specs, resets, errors."""
import functools
import os
import signal
import subprocess
import sys
import time

import pytest
import torch
from torchrl.collectors import Collector
from torchrl.envs.utils import check_env_specs

import dcs_torchrl as dcs
from dcs_torchrl import ParallelSuiteEnv, make_env
from dcs_torchrl.render.egl_devices import egl_devices, process_render_device
from dcs_torchrl.vector import parallel

EPISODE = 10  # agent steps per episode at action repeat 100 (cartpole's 1000-step time limit)
SETTINGS = dict(benchmark="medium", dynamic=True, action_repeat=100, height=32, width=32, expose_distractions=True)
FACTORY = functools.partial(make_env, "cartpole", "swingup", **SETTINGS)


# Both layouts of the envs for the tests of partial resets, partial steps and specs: with first_here both a
# worker's env and this process's are reset or skipped alone; every env in workers under -m slow (the layout
# itself: test_each_worker_runs_the_episodes_of_one_env_with_its_seed).
WORKER_LAYOUTS = [pytest.param(False, marks=pytest.mark.slow), True]


@pytest.fixture(scope="module")
def env2():
    """``ParallelSuiteEnv(2, FACTORY)`` as a user builds it (the first env here, one worker), shared by
    the tests that seed and reset it before use: each spawn of a worker costs seconds."""
    env = ParallelSuiteEnv(2, FACTORY)
    yield env
    env.close(raise_if_closed=False)


@functools.cache
def _seeds(seed: int, n: int) -> list[int]:
    """Each worker's seed under TorchRL's chain: the next is what the previous one's set_seed returns."""
    seeds = [seed]
    for _ in range(n - 1):
        seeds.append(FACTORY().set_seed(seeds[-1]))
    return seeds


def _actions(steps: int, n: int) -> torch.Tensor:
    return torch.rand(steps, n, 1, generator=torch.Generator().manual_seed(0)) * 2 - 1


def _one_env_run(seed: int, actions: torch.Tensor) -> list:
    """(pixels, reward, done, distraction state) after each action, one env, reset at each episode's end."""
    env = FACTORY()
    env.set_seed(seed)
    td, out = env.reset(), []
    for action in actions:
        td = env.step(td.set("action", action))["next"]
        out.append(td.select("pixels", "reward", "done", "distractions").clone())
        if td["done"].item():
            td = env.reset()
    env.close()
    return out


# Both layouts and both ways of waiting (polling, then sleeping; sleeping at once) by default: every env
# in workers sleeping at once, and the default env (the first here, polling first); the other two under -m slow.
@pytest.mark.parametrize("first_here, spin_s", [(False, 0), (True, parallel.SPIN_S),
                                                pytest.param(False, parallel.SPIN_S, marks=pytest.mark.slow),
                                                pytest.param(True, 0, marks=pytest.mark.slow)],
                         ids=["all-in-workers-no-polling", "first-here", "all-in-workers", "first-here-no-polling"])
def test_each_worker_runs_the_episodes_of_one_env_with_its_seed(first_here, spin_s, request):
    n, steps = 2, 2 * EPISODE + 3  # across an episode end and a reset
    shared = first_here and spin_s == parallel.SPIN_S
    env = request.getfixturevalue("env2") if shared else ParallelSuiteEnv(n, FACTORY, first_here=first_here, spin_s=spin_s)
    assert [pipe is None for pipe in env._pipes] == [first_here, False]
    assert env._spin_s == spin_s
    env.set_seed(7)
    actions = _actions(steps, n)
    td, batched = env.reset(), []
    for action in actions:
        td.set("action", action)
        out, td = env.step_and_maybe_reset(td)
        batched.append(out["next"].select("pixels", "reward", "done", "distractions"))
    if not shared:
        env.close()
    for worker, seed in enumerate(_seeds(7, n)):
        alone = _one_env_run(seed, actions[:, worker])
        for k, (got, want) in enumerate(zip(batched, alone)):
            assert (got[worker] == want).all(), f"worker {worker}, step {k}"
    assert not torch.equal(batched[0]["pixels"][0], batched[0]["pixels"][1])  # workers differ


def _layout(first_here: bool, request) -> ParallelSuiteEnv:
    """The shared default env (the first env here), or a new one with every env in workers."""
    return request.getfixturevalue("env2") if first_here else ParallelSuiteEnv(2, FACTORY, first_here=False)


@pytest.mark.parametrize("first_here", WORKER_LAYOUTS, ids=["all-in-workers", "first-here"])
def test_specs_and_partial_reset(first_here, request):
    env = _layout(first_here, request)
    check_env_specs(env, seed=0)
    assert env.batch_size == (2,) and env.observation_spec["pixels"].shape == (2, 32, 32, 3)
    env.set_seed(0)
    td = env.reset()
    first = td["pixels"].clone()
    for reset in (0, 1):  # the first env (here with first_here) alone, then the second alone
        td = env.step(td.set("action", _actions(1, 2)[0]))["next"]
        stepped = td["pixels"].clone()
        td["_reset"] = torch.tensor([[reset == 0], [reset == 1]])
        td = env.reset(td)
        assert not torch.equal(td["pixels"][reset], stepped[reset]), reset
        assert torch.equal(td["pixels"][1 - reset], stepped[1 - reset]), reset
        assert not torch.equal(td["pixels"][reset], first[reset])  # a new episode: a new scene
    if not first_here:
        _collect(env)


def _collect(env: ParallelSuiteEnv) -> None:
    """A TorchRL collector collects from ``env`` (and closes it when done)."""
    collector = Collector(env, None, frames_per_batch=4, total_frames=8)
    batches = [b for b in collector]
    assert [tuple(b.batch_size) for b in batches] == [(2, 2), (2, 2)]
    collector.shutdown()
    env.close(raise_if_closed=False)


def _alone(seed: int, actions: torch.Tensor, reset_after: int | None = None) -> list:
    """(pixels, reward, done, distraction state) after each action of one env seeded ``seed``,
    reset once after ``reset_after`` actions (None: one episode throughout)."""
    env = FACTORY()
    env.set_seed(seed)
    td, out = env.reset(), []
    for k, action in enumerate(actions):
        if k == reset_after:
            td = env.reset()
        td = env.step(td.set("action", action))["next"]
        out.append(td.select("pixels", "reward", "done", "distractions").clone())
    env.close()
    return out


@pytest.mark.parametrize("first_here", WORKER_LAYOUTS, ids=["all-in-workers", "first-here"])
def test_an_env_not_reset_continues_its_episode(first_here, request):
    """A partial reset restarts the marked env only: the other's next steps are those of one env
    stepped without a reset (TorchRL's reset keeps the old entries of the envs not reset, so the
    returned frames alone cannot tell)."""
    actions = _actions(6, 2)
    env = _layout(first_here, request)
    for reset in (0, 1):
        env.set_seed(7)
        td = env.reset()
        for action in actions[:3]:
            td = env.step(td.set("action", action))["next"]
        td["_reset"] = torch.tensor([[reset == 0], [reset == 1]])
        td = env.reset(td)
        later = []
        for action in actions[3:]:
            td = env.step(td.set("action", action))["next"]
            later.append(td.select("pixels", "reward", "done", "distractions").clone())
        for worker, seed in enumerate(_seeds(7, 2)):
            alone = _alone(seed, actions[:, worker], reset_after=3 if worker == reset else None)[3:]
            for k, (got, want) in enumerate(zip(later, alone)):
                assert (got[worker] == want).all(), f"reset {reset}: worker {worker}, step {k} after the reset"
    if not first_here:
        env.close()


@pytest.mark.parametrize("first_here", WORKER_LAYOUTS, ids=["all-in-workers", "first-here"])
def test_an_env_not_stepped_waits_and_then_continues(first_here, request):
    """``"_step"`` (written by ``rollout(break_when_all_done=True)``) steps the marked envs only: the
    other keeps its frame and done flags, with reward 0, and later continues from where it was."""
    actions = _actions(3, 2)
    env = _layout(first_here, request)
    env.set_seed(7)
    td = env.reset()
    td = env.step(td.set("action", actions[0]))["next"]
    before = td["pixels"].clone()
    td.set("action", actions[1]).set("_step", torch.tensor([False, True]))
    skipped = env.step(td)["next"]
    assert torch.equal(skipped["pixels"][0], before[0]) and skipped["reward"][0].item() == 0
    assert not torch.equal(skipped["pixels"][1], before[1])
    skipped.pop("_step", None)
    out = env.step(skipped.set("action", actions[2]))["next"]
    if not first_here:
        env.close()
    seeds = _seeds(7, 2)
    first = _alone(seeds[0], actions[[0, 2], 0])  # env 0 skipped the second action
    second = _alone(seeds[1], actions[:, 1])
    assert (out[0].select(*first[-1].keys(True, True)) == first[-1]).all()
    assert (out[1].select(*second[-1].keys(True, True)) == second[-1]).all()


@pytest.mark.parametrize("device", ["cpu"] + (["cuda"] if torch.cuda.is_available() else []))
def test_the_envs_device_holds_its_specs_and_outputs(device, request):
    """``device`` is where the env's specs and outputs are (the workers stay on the CPU); actions
    on that device reach the workers. The CPU is the default's (the shared env's)."""
    env = request.getfixturevalue("env2") if device == "cpu" else ParallelSuiteEnv(2, FACTORY, device=device)
    assert env.device == torch.device(device)
    assert env.observation_spec["pixels"].device == env.action_spec.device == torch.device(device)
    env.set_seed(7)
    td = env.reset()
    assert td["pixels"].device == torch.device(device)
    out = env.step(td.set("action", _actions(1, 2)[0].to(device)))["next"]
    assert out["pixels"].device == out["reward"].device == torch.device(device)
    if device != "cpu":
        env.close()
    alone = _alone(_seeds(7, 2)[1], _actions(1, 2)[:, 1])
    assert torch.equal(out["pixels"][1].cpu(), alone[0]["pixels"])


def test_first_here_by_default_for_two_envs_on_this_processes_device(env2):
    one = ParallelSuiteEnv(1, FACTORY)
    assert (one.first_here, env2.first_here) == (False, True)
    assert one._procs[0] is not None and env2._procs[0] is None
    one.close()
    with pytest.raises(TypeError, match="first_here must be True, False or None"):
        ParallelSuiteEnv(2, FACTORY, first_here="yes")


def test_first_here_fails_in_this_process_and_refuses_another_render_device(monkeypatch):
    """With first_here, the first env's errors are raised here as they are, the workers' as before;
    its env can only render on this process's EGL device."""
    env = ParallelSuiteEnv(2, FACTORY, first_here=True)
    with pytest.raises(RuntimeError, match="^step before reset: call env.reset") as raised:
        env.step(env.full_action_spec.zero())
    assert "Meanwhile: ParallelSuiteEnv worker 1 failed" in raised.value.__notes__[0]  # the other env's too
    env.close(raise_if_closed=False)
    with pytest.raises(RuntimeError, match="(?s)worker 1 failed.*this env cannot be built"):
        ParallelSuiteEnv(2, _broken_env_in_a_worker, first_here=True)
    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "5")  # as if this process rendered on a sixth GPU
    with pytest.raises(ValueError, match="first_here=True renders the first env in this process, on its EGL device 5, "
                                         "not render_devices\\[0\\] = 0: pass first_here=False"):
        ParallelSuiteEnv(2, FACTORY, first_here=True, render_devices=[0])


def _broken_env():
    raise ValueError("this env cannot be built")


def _broken_env_in_a_worker():
    import multiprocessing
    if multiprocessing.current_process().name != "MainProcess":
        raise ValueError("this env cannot be built")
    return FACTORY()


def test_bad_input_and_failing_workers_name_the_fix():
    with pytest.raises(ValueError, match="num_workers must be an int >= 1"):
        ParallelSuiteEnv(0, FACTORY)
    with pytest.raises(TypeError, match="create_env_fn must be callable"):
        ParallelSuiteEnv(2, "cartpole")
    with pytest.raises(RuntimeError, match="(?s)worker 0 failed.*this env cannot be built"):
        ParallelSuiteEnv(1, _broken_env)
    with pytest.raises(ValueError, match="render_devices must be a non-empty list of EGL device indices"):
        ParallelSuiteEnv(1, FACTORY, render_devices=[-1])
    with pytest.raises(ValueError, match="render_threads must be an int >= 0"):
        ParallelSuiteEnv(1, FACTORY, render_threads=-1)
    for spin_s in (-0.001, 1.0, "3ms", True):
        with pytest.raises(ValueError, match=r"spin_s must be seconds in \[0, 1.0\) \(0: sleep at once\)"):
            ParallelSuiteEnv(1, FACTORY, spin_s=spin_s)
    env = ParallelSuiteEnv(1, FACTORY)
    with pytest.raises(RuntimeError, match="(?s)worker 0 failed.*step before reset"):
        env.step(env.full_action_spec.zero().set("action", torch.zeros(1, 1)))
    assert env.is_closed  # a failed worker closes the env: as closed by close()
    with pytest.raises(RuntimeError, match=r"closed \(worker 0 failed\): build a new one"):
        env.reset()
    env.close()  # the user's close after it (a `finally:`) returns, hiding no error
    with pytest.raises(RuntimeError, match="closed already"):
        env.close()


def test_workers_end_when_the_process_that_made_them_is_killed(tmp_path):
    script = (
        "import functools, os, sys, dcs_torchrl as dcs\n"
        "env = dcs.ParallelSuiteEnv(1, functools.partial(dcs.make_env, 'cartpole', 'swingup'))\n"
        "print(' '.join(str(p.pid) for p in env._procs), flush=True)\n"
        "sys.stdin.read()\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    pids = [int(p) for p in proc.stdout.readline().split()]
    assert len(pids) == 1  # one worker (each spawn costs seconds): what ends it ends every worker
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.time() + 30
    while time.time() < deadline and any(_alive(pid) for pid in pids):
        time.sleep(0.2)
    assert not any(_alive(pid) for pid in pids)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_worker_i_is_started_for_render_devices_i_mod_len_with_the_render_threads(monkeypatch):
    """On a node shaped like four GPUs, render_devices=[2, 3] starts workers 0, 1, 2 for EGL devices
    2, 3, 2. This machine has one EGL device: each worker's device is recorded and it is started on
    device 0, with this process pretending to render on 1, so that a worker which did not get its
    variable fails (dm_control refuses a device the machine lacks).

    Mesa reads LP_NUM_THREADS once, when a process first imports dm_control, which unpickling a
    worker's function does: render_threads must be in each worker's environment from its start,
    and this process's environment is as it was."""
    from contextlib import contextmanager

    from dcs_torchrl.render.egl_devices import EGL_DEVICE_VARIABLE

    started, spawn_environment = [], parallel.spawn_environment

    @contextmanager
    def on_device_zero(variables):
        started.append(variables[EGL_DEVICE_VARIABLE])
        with spawn_environment({**variables, EGL_DEVICE_VARIABLE: 0}):
            yield

    monkeypatch.setattr(parallel, "render_device_indices", lambda devices: list(devices))
    monkeypatch.setattr(parallel, "spawn_environment", on_device_zero)
    monkeypatch.setenv(EGL_DEVICE_VARIABLE, "1")
    before = dict(os.environ)
    env = ParallelSuiteEnv(3, FACTORY, render_devices=[2, 3], first_here=False, render_threads=0)
    try:
        for proc in env._procs:
            with open(f"/proc/{proc.pid}/environ", "rb") as f:
                start = dict(item.split(b"=", 1) for item in f.read().split(b"\0") if b"=" in item)
            assert start[b"LP_NUM_THREADS"] == b"0"
        env.set_seed(0)
        assert env.reset()["pixels"].shape == (3, 32, 32, 3)
    finally:
        env.close()
    assert dict(os.environ) == before  # set only while the workers were started
    assert started == [2, 3, 2]


def test_the_package_exports_it():
    assert dcs.ParallelSuiteEnv is ParallelSuiteEnv


def test_each_worker_renders_on_its_chosen_egl_device(env2):
    """Worker i renders on render_devices[i % len]: device 0 (the machine's first EGL device) works and
    renders the same frames; an index the machine lacks, or a CUDA device no EGL device is (Mesa has
    none), is refused before any worker starts, naming the machine's EGL devices. Its first env is
    here when this process renders on device 0 (first_here's default), and this process's torch
    threads are left alone: by the start, while its first env steps here with one thread, and by the close."""
    before, threads = os.environ.get("MUJOCO_EGL_DEVICE_ID"), torch.get_num_threads()
    env = ParallelSuiteEnv(2, FACTORY, render_devices=[0])
    assert os.environ.get("MUJOCO_EGL_DEVICE_ID") == before  # only the workers' environment
    assert env.first_here == (process_render_device() == 0)
    assert torch.get_num_threads() == threads
    env.set_seed(3)
    frames = env.reset()["pixels"]
    env.rollout(2)
    assert torch.get_num_threads() == threads
    env.close()
    assert torch.get_num_threads() == threads
    env2.set_seed(3)
    assert torch.equal(frames, env2.reset()["pixels"])
    with pytest.raises(ValueError, match=r"EGL device 10000 does not exist: this machine's EGL devices are 0 \("):
        ParallelSuiteEnv(2, FACTORY, render_devices=[0, 10_000])
    if not any(d.cuda is not None for d in egl_devices()):
        with pytest.raises(ValueError, match="no EGL device of this machine is CUDA device 0 .* NVIDIA's EGL driver"):
            ParallelSuiteEnv(1, FACTORY, render_devices=["cuda:0"])


def test_a_collector_collects_from_it(env2):
    """Last in this file: the collector closes the shared env when done."""
    _collect(env2)
