"""The recipes on CUDA: the update, its graphs, the device replay and the acting path against the
CPU's. Every test but the first needs CUDA and is skipped without it.

CPU and CUDA draw other random numbers from the same seed, so the CPU/CUDA comparisons run under
:class:`HostRandom`, which makes every draw of the update on the host from one seeded generator
(the first test checks that no draw escapes it, on the CPU).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import torch
from omegaconf import OmegaConf
from tensordict import TensorDict
from test_execution import OBS, SPEC, batch, config, make_agent
from test_replay import C, H, S, episodes
from torch.overrides import TorchFunctionMode
from torchrl.envs.utils import ExplorationType, set_exploration_type

from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import FrameStackReplayBuffer
from dcs_torchrl.training.execution import DevicePolicy, ExecutionOptions, apply_math_settings

needs_cuda = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA (a GPU and a CUDA build of torch)")
ROOT = Path(__file__).resolve().parents[2]


class HostRandom(TorchFunctionMode):
    """Every random draw made on the host from one seeded generator, then moved to its device:
    the same numbers on any device (not under CUDA-graph capture: it copies from the host)."""

    def __init__(self, seed: int):
        super().__init__()
        self.generator = torch.Generator().manual_seed(seed)

    def _host(self, func, args, kwargs):
        device = kwargs.pop("device", None)
        kwargs.pop("generator", None)
        out = func(*args, **kwargs, generator=self.generator, device="cpu")
        return out if device is None else out.to(device)

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = dict(kwargs or {})
        if func in (torch.randint, torch.randn, torch.rand):
            return self._host(func, args, kwargs)
        if func in (torch.Tensor.normal_, torch.Tensor.uniform_):
            tensor = args[0]
            fill = torch.randn if func is torch.Tensor.normal_ else torch.rand
            with torch.no_grad():
                tensor.copy_(fill(tensor.shape, generator=self.generator, dtype=tensor.dtype))
            return tensor
        if func in (torch.randn_like, torch.rand_like):
            like = args[0]
            fill = torch.randn if func is torch.randn_like else torch.rand
            return fill(like.shape, generator=self.generator, dtype=like.dtype).to(like.device)
        return func(*args, **kwargs)


def _updates(agent, seed: int, count: int = 4) -> list[dict]:
    out = []
    with HostRandom(seed):
        for index in range(count):
            out.append({k: v.cpu() for k, v in agent.update(batch(8, seed=index), index).items()})
    return out


@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_host_random_makes_every_draw_of_an_update(algo):
    """Two agents under HostRandom with one seed and different global seeds update alike: no
    random draw of the update escaped to the global generators (on the CPU)."""
    first, second = make_agent(algo), make_agent(algo)
    torch.manual_seed(1)
    a = _updates(first, seed=7, count=2)
    torch.manual_seed(2)
    b = _updates(second, seed=7, count=2)
    assert a == b


@pytest.fixture(autouse=True)
def deterministic_cudnn():
    """cuDNN's convolution backward sums in a run-dependent order: on an H200, two eager CUDA twins
    of the SAC agent, same seed and batches, left 4 of the 9216 weights of an encoder convolution
    1e-4 apart after 10 updates (Adam turns tiny gradient differences into step-sized ones), and a
    graph-captured twin no further than that. With ``cudnn.deterministic`` both comparisons agreed
    to the tolerance below on every parameter of both methods, so these tests compare under it."""
    before = torch.backends.cudnn.deterministic
    torch.backends.cudnn.deterministic = True
    yield
    torch.backends.cudnn.deterministic = before


def _cuda_twin(algo: str, cpu_agent, *overrides: str):
    agent = agent_class(algo)(config(algo, "device=cuda", *overrides), OBS, SPEC)
    agent.load_state_dict(cpu_agent.state_dict())
    apply_math_settings(agent.options)  # float32 (no TF32), as the CPU
    torch.backends.cudnn.benchmark = False
    return agent


@needs_cuda
@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_a_cuda_update_equals_the_cpu_update(algo):
    cpu = make_agent(algo)
    cuda = _cuda_twin(algo, cpu)
    for got, expected in zip(_updates(cuda, seed=0), _updates(cpu, seed=0)):
        for name in expected:
            torch.testing.assert_close(got[name], expected[name], rtol=1e-3, atol=1e-4, msg=name)
    for (name, p), q in zip(cpu.loss.named_parameters(), cuda.loss.parameters()):
        torch.testing.assert_close(q.cpu(), p, rtol=1e-3, atol=1e-4, msg=name)


@needs_cuda
@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_a_graph_captured_update_equals_the_eager_one(algo):
    """Same seed, same batches: the eager CUDA agent and the one replaying CUDA graphs (after 3
    warm-up updates of each schedule) make the same updates (graph-safe RNG: a replay draws the
    numbers the eager kernels would)."""
    cpu = make_agent(algo)
    eager, graphed = _cuda_twin(algo, cpu), _cuda_twin(algo, cpu, "execution.cudagraph=true")
    assert graphed.options.cudagraph and all(g["capturable"] for o in graphed.optimisers.values() for g in o.param_groups)
    for index in range(10):
        data = batch(8, seed=index).to("cuda")
        torch.cuda.manual_seed(index)
        expected = eager.update(data.clone(), index)
        torch.cuda.manual_seed(index)
        got = graphed.update(data.clone(), index)
        for name in expected:
            torch.testing.assert_close(got[name], expected[name].float(), rtol=1e-4, atol=1e-5, msg=f"{name} at {index}")
    assert len(graphed.runner.graphed.replays) == 2
    for (name, p), q in zip(eager.loss.named_parameters(), graphed.loss.parameters()):
        torch.testing.assert_close(q, p, rtol=1e-4, atol=1e-5, msg=name)


@needs_cuda
@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_replayed_updates_never_wait_for_the_device(algo):
    agent = _cuda_twin(algo, make_agent(algo), "execution.cudagraph=true")
    buffer = FrameStackReplayBuffer(50, S, (C, H, H), (1,), batch_size=8, device="cuda")
    data = batch(8).to("cuda")
    for index in range(8):
        agent.update(data, index)  # warm-up and capture
    torch.cuda.synchronize()
    torch.cuda.set_sync_debug_mode("error")  # any implicit sync (a host read, a blocking copy) raises
    try:
        for index in range(8, 12):
            agent.update(data, index)
        buffer.extend(torch.stack(episodes(0, [20])))
        buffer.sample()
    finally:
        torch.cuda.set_sync_debug_mode("default")


@needs_cuda
def test_the_device_replay_on_cuda_samples_what_the_host_replay_does():
    host, device = (FrameStackReplayBuffer(20, S, (C, H, H), (1,), batch_size=8, min_episode_steps=1,
                                           generator=torch.Generator().manual_seed(0), device=d) for d in (None, "cuda"))
    data = torch.stack(episodes(0, [2] * 30))
    for start in range(0, 60, 7):
        host.extend(data[start:start + 7])
        device.extend(data[start:start + 7])
    for _ in range(3):
        a, b = host.sample(64), device.sample(64)
        assert b.device.type == "cuda"
        for key in a.keys(True, True):
            assert torch.equal(a[key], b[key].cpu()), key


@needs_cuda
@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_the_device_policy_acts_as_the_cpu_policy(algo):
    cpu = make_agent(algo)
    cuda = _cuda_twin(algo, cpu)
    step = TensorDict({"pixels": torch.randint(0, 256, (1, *OBS), dtype=torch.uint8)}, [1], device="cpu")
    with set_exploration_type(ExplorationType.DETERMINISTIC), HostRandom(0):
        expected = cpu.policy(step.clone())["action"]
    with set_exploration_type(ExplorationType.DETERMINISTIC), HostRandom(0):
        got = DevicePolicy(cuda.policy, "cuda")(step.clone())["action"]
    assert got.device.type == "cpu"
    torch.testing.assert_close(got, expected, rtol=1e-3, atol=1e-4)


@needs_cuda
def test_a_short_cuda_run_records_what_ran(tmp_path):
    """The recipe on CUDA with graphs and the device replay: it trains, evaluates, and its
    results.json records the values that ran for each ``auto``."""
    from dcs_torchrl.training import train

    cfg = config("sac", "device=cuda", "execution.cudagraph=true", "algo.batch_size=8", "replay_buffer.size=500",
                 "collector.seed_steps=10", "total_frames=240", "logger.interval=80", "eval.interval=1000000",
                 "eval.episodes=1", "eval.video=false", "checkpoint.interval=1000000", "progress=false",
                 "env.action_repeat=8")
    results = train(cfg, agent_class("sac"), tmp_path / "run")
    recorded = results["config"]
    assert recorded["replay_buffer"]["device"].startswith("cuda") and recorded["optim"]["fused"] is True
    assert recorded["execution"]["cudagraph"] is True and recorded["precision"]["tf32"] is False
    assert json.loads((tmp_path / "run/results.json").read_text())["config"] == recorded


@needs_cuda
def test_the_gpu_benchmark_runs_as_one_command():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import gpu_speed

    rows = gpu_speed.main(["--device", "cuda", "--batch-sizes", "8", "--updates", "2", "--warmup", "6",
                           "--loop-steps", "0", "--hidden", "64", "--matmul-size", "1024", "--variants", "eager", "cudagraph"])
    expected = {(m, v) for m in ("SAC+DrQ", "QT-Opt+DrQ") for v in ("eager", "cudagraph")}
    assert {(r["method"], r["variant"]) for r in rows} == expected
    assert all(r["update_s"] > 0 and r["flops"] > 0 and r["replay"].startswith("cuda") for r in rows)


def test_cuda_settings_without_cuda_name_the_fix():
    if torch.cuda.is_available():
        pytest.skip("this machine has CUDA")
    options = ExecutionOptions.from_config(config("sac", "device=cuda", "execution.cudagraph=true"))
    assert options.cudagraph and options.capturable  # resolved from the config alone
    from dcs_torchrl.training.loop import _check_config

    with pytest.raises(ValueError, match="CUDA is not available: use device=cpu"):
        _check_config(config("sac", "device=cuda"))


@needs_cuda
def test_each_visible_gpu_has_the_egl_device_the_recipes_render_on():
    """With NVIDIA's EGL driver every visible CUDA device is one EGL device (``EGL_NV_device_cuda``),
    ``execution.render_device=auto`` picks the policy's, and an env told to render there gives
    the frames an env rendering on this process's device gives (the same GPU model, the same driver)."""
    from dcs_torchrl.envs import resolve_settings
    from dcs_torchrl.render.egl_devices import egl_device_of_cuda, egl_devices
    from dcs_torchrl.training.envs import batched_pixel_env, render_device

    devices = egl_devices()
    indices = [egl_device_of_cuda(k, devices) for k in range(torch.cuda.device_count())]
    assert len(set(indices)) == len(indices)
    assert render_device(OmegaConf.merge(config("sac"), {"device": "cuda:0"})) == indices[0]
    settings = resolve_settings("cartpole", "swingup", benchmark="medium")
    frames = []
    for device in (None, indices[-1]):
        env = batched_pixel_env(settings, num_workers=1, seed=1, frame_stack=3, image_size=64, render_device=device)
        frames.append(env.reset()["pixels"])
        env.close()
    assert frames[0].shape == frames[1].shape
    if torch.cuda.device_count() == 1:
        assert torch.equal(*frames)
