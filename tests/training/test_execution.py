"""How the update runs (dcs_torchrl/training/execution.py): options, no host reads, graphs, acting.

Everything here runs on the CPU. The CUDA-graph runner is exercised with a stand-in capture that
reruns the update into fixed output buffers (what a graph's replay does), so its bookkeeping
(input buffers, one graph per schedule after its warm-up, outputs copied out) is checked against
the eager updates; tests/training/test_cuda.py checks the real capture where CUDA is available.
"""
from __future__ import annotations

import collections
import json
import traceback

import pytest
import torch
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torch.utils._python_dispatch import TorchDispatchMode
from torchrl.data import Bounded

from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import RunDirectory, RunMismatchError
from dcs_torchrl.training.execution import (
    DevicePolicy, ExecutionOptions, GraphedUpdate, UpdateRunner, check_execution, on_device, replay_device,
)
from dcs_torchrl.training.metrics import RunningMeans

SPEC = Bounded(-torch.ones(2), torch.ones(2), shape=(2,))
OBS = (9, 32, 32)


def config(algo: str = "sac", *overrides: str):
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        return compose(algo, overrides=["network.hidden_dim=16", "algo.aug=drq", *overrides])


def make_agent(algo: str, *overrides: str, seed: int = 0):
    torch.manual_seed(seed)
    return agent_class(algo)(config(algo, *overrides), OBS, SPEC)


def batch(size: int = 4, seed: int = 0) -> TensorDict:
    gen = torch.Generator().manual_seed(seed)
    pixels = torch.randint(0, 256, (2, size, *OBS), generator=gen, dtype=torch.uint8)
    return TensorDict({
        "pixels": pixels[0], "action": 2 * torch.rand(size, 2, generator=gen) - 1,
        ("next", "pixels"): pixels[1], ("next", "reward"): torch.rand(size, 1, generator=gen),
        ("next", "done"): torch.zeros(size, 1, dtype=torch.bool), ("next", "terminated"): torch.zeros(size, 1, dtype=torch.bool),
    }, [size])


# ------------------------------------------------------------------------------------ options
def test_cpu_defaults_are_the_update_as_it_ran():
    options = ExecutionOptions.from_config(config())
    assert options == ExecutionOptions(device=torch.device("cpu"))
    assert options.adam_kwargs() == {}  # torch's default Adam
    agent = make_agent("sac")
    assert all(group["fused"] is None and not group["capturable"]
               for optimiser in agent.optimisers.values() for group in optimiser.param_groups)


def test_auto_resolves_for_cuda_and_old_configs_take_the_defaults():
    cuda = ExecutionOptions.from_config({"device": "cuda", "optim": {"fused": "auto"}, "execution": {"cudagraph": True}})
    assert cuda.fused and cuda.cudnn_benchmark and cuda.cudagraph and not cuda.tf32
    assert cuda.adam_kwargs() == {"fused": True, "capturable": True}
    old = {"device": "cpu", "optim": {"lr": 1e-3}, "network": {"compile": False}}  # a run recorded before these settings
    assert ExecutionOptions.from_config(old) == ExecutionOptions()
    recorded = ExecutionOptions.from_config(OmegaConf.to_container(config())).recorded(
        OmegaConf.to_container(config()), torch.device("cpu"))
    assert recorded["optim"] == {"lr": 0.001, "fused": False}
    assert recorded["execution"] == {"compile": False, "cudagraph": False, "cudnn_benchmark": False, "render_device": "process"}
    assert recorded["replay_buffer"]["device"] == "cpu" and recorded["precision"] == {"tf32": False}


@pytest.mark.parametrize("overrides, message", [
    (["execution.cudagraph=true"], "execution.cudagraph=true .* set device=cuda, or execution.cudagraph=false"),
    (["precision.tf32=true"], "precision.tf32=true .* set device=cuda, or precision.tf32=false"),
    (["replay_buffer.device=cuda"], "replay_buffer.device=cuda with device=cpu .* replay_buffer.device=cpu"),
    (["replay_buffer.device=disk"], "replay_buffer.device must be auto, cpu or cuda"),
    (["optim.fused=maybe"], "optim.fused must be auto, true or false"),
])
def test_settings_that_cannot_run_are_refused_naming_the_fix(overrides, message):
    with pytest.raises(ValueError, match=message):
        check_execution(config("sac", *overrides))


def test_replay_goes_to_the_gpu_when_it_fits_in_half_its_free_memory():
    cuda = OmegaConf.create({"device": "cuda", "replay_buffer": {"device": "auto"}})
    free = {torch.device("cuda"): 8 * 2**30}.get
    assert replay_device(cuda, 4 * 2**30, free_bytes=free) == torch.device("cuda")
    assert replay_device(cuda, 5 * 2**30, free_bytes=free) == torch.device("cpu")
    assert replay_device(OmegaConf.merge(cuda, {"replay_buffer": {"device": "cpu"}}), 1, free_bytes=free).type == "cpu"
    assert replay_device(config(), 1) == torch.device("cpu")  # device=cpu: the host, as always


def test_how_the_update_runs_is_not_identity_but_tf32_is(tmp_path):
    base = OmegaConf.to_container(config(), resolve=True)
    RunDirectory(tmp_path, base).claim()
    faster = OmegaConf.to_container(config("sac", "optim.fused=true", "execution.compile=true",
                                           "execution.cudnn_benchmark=true", "replay_buffer.device=cpu"), resolve=True)
    RunDirectory(tmp_path, faster).claim()  # resumes
    with pytest.raises(RunMismatchError, match="precision.tf32: False there, True now"):
        RunDirectory(tmp_path, OmegaConf.to_container(config("sac", "precision.tf32=true"), resolve=True)).claim()
    older = tmp_path / "older"  # recorded before precision.tf32 existed: float32 math
    older.mkdir()
    recorded = {k: v for k, v in json.loads((tmp_path / "run_config.json").read_text()).items() if k != "precision"}
    (older / "run_config.json").write_text(json.dumps(recorded))
    RunDirectory(older, base).claim()


# ------------------------------------------------------------------------------------ no host reads
HOST_READS = {"_local_scalar_dense", "nonzero", "masked_select"}  # .item(), bool(), float(), data-dependent shapes


class HostReads(TorchDispatchMode):
    """Records every op that reads a tensor's value on the host (a device sync on CUDA), with
    the file that called it."""

    def __init__(self):
        super().__init__()
        self.callers = collections.Counter()

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        if func._overloadpacket.__name__ in HOST_READS:
            frames = [f for f in traceback.extract_stack()[:-1] if "/torch/" not in f.filename]
            self.callers[f"{frames[-1].filename}:{frames[-1].lineno}"] += 1
        return func(*args, **(kwargs or {}))


# TorchRL's TanhNormal checks its bounds on the host each time it is built, except while compiling
# or capturing a CUDA graph (torchrl/modules/distributions/continuous.py): not ours to change.
TORCHRL_TANH_NORMAL = "torchrl/modules/distributions/continuous.py"


@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_the_update_reads_nothing_on_the_host(algo):
    """With the optimisers CUDA uses (fused Adam: no host read of the step count), an update reads
    no tensor on the host, so on CUDA it never waits for the device; the loop reads its metrics
    once per logging row."""
    agent = make_agent(algo, "optim.fused=true")
    data = batch()
    agent.update(data.clone(), 0)
    agent.update(data.clone(), 1)  # both schedules once: optimiser state exists
    reads, means = HostReads(), RunningMeans()
    with reads:
        for index in range(2, 6):
            means.add(agent.update(data.clone(), index))
    ours = {caller: n for caller, n in reads.callers.items() if TORCHRL_TANH_NORMAL not in caller}
    assert not ours, ours
    assert set(means.means()) == set(agent.update(data.clone(), 6))


def test_running_means_equal_the_mean_of_the_values_read_one_by_one():
    values = torch.randn(1000, generator=torch.Generator().manual_seed(0))  # float32, as the losses
    means = RunningMeans()
    for value in values:
        means.add({"loss/critic": value, "train/alpha": 2 * value})
    floats = [float(v) for v in values]
    assert means.means() == {"loss/critic": sum(floats) / len(floats), "train/alpha": sum(2 * f for f in floats) / 1000}


# ------------------------------------------------------------------------------------ graphs
def rerun_capture(fn):
    """A stand-in for ``cuda_graph_capture`` on the CPU: captures nothing; each replay reruns
    ``fn`` and copies its output into one fixed buffer, as a graph's replay overwrites its output."""
    state = {}

    def replay():
        out = fn()
        if "out" not in state:
            state["out"] = out
        else:
            state["out"].copy_(out)
        return state["out"]

    return replay


@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_the_graph_runner_makes_the_eager_updates(algo):
    """Warm-up runs of each schedule, then one graph per schedule replayed: the same updates, in
    the same order, as eager (same random numbers, same parameters, same metrics), and each
    update's metrics are its own (not the buffer the next replay overwrites)."""
    eager, graphed = make_agent(algo), make_agent(algo)
    graphed.runner = UpdateRunner(graphed.update_step, graphed.options, capture=rerun_capture)
    kept = []
    for index in range(10):  # 3 warm-ups of each schedule, then captures and replays
        data = batch(seed=index)
        torch.manual_seed(100 + index)
        expected = eager.update(data.clone(), index)
        torch.manual_seed(100 + index)
        got = graphed.update(data.clone(), index)
        assert got.keys() == expected.keys()
        for name in got:
            torch.testing.assert_close(got[name], expected[name].float(), msg=f"{name} at update {index}")
        kept.append((got, expected))
    assert set(graphed.runner.graphed.replays) == {graphed.schedule(i) for i in range(2)}
    for got, expected in kept:  # earlier updates' metrics were not overwritten by later replays
        assert all(torch.equal(got[n], expected[n].float()) for n in got)
    for (name, p), q in zip(eager.loss.named_parameters(), graphed.loss.parameters()):
        torch.testing.assert_close(p, q, rtol=0, atol=0, msg=name)


def test_graphs_need_fixed_metrics_and_a_warm_up():
    with pytest.raises(ValueError, match="warmup must be >= 1"):
        GraphedUpdate(lambda b: {}, warmup=0)
    calls = iter([{"a": torch.tensor(1.0)}, {"b": torch.tensor(1.0)}])
    runner = GraphedUpdate(lambda b: next(calls), warmup=2, capture=rerun_capture)
    runner(TensorDict({"x": torch.zeros(1)}, []))
    with pytest.raises(RuntimeError, match="metrics changed"):
        runner(TensorDict({"x": torch.zeros(1)}, []))


def test_a_checkpoint_loads_with_this_runs_optimiser_flags(tmp_path):
    """A checkpoint of torch's default Adam resumes under fused Adam (and back): the optimisers
    keep this run's flags, their step counts where those flags want them."""
    plain, fused = make_agent("sac"), make_agent("sac", "optim.fused=true")
    data = batch()
    for index in range(2):
        plain.update(data.clone(), index)
    fused.load_state_dict(plain.state_dict())
    groups = [g for o in fused.optimisers.values() for g in o.param_groups]
    assert all(g["fused"] for g in groups)
    steps = [s["step"] for o in fused.optimisers.values() for s in o.state.values()]
    assert steps and all(s.dtype == torch.float32 and float(s) in (1.0, 2.0) for s in steps)  # actor: 1, critic: 2
    fused.update(data.clone(), 2)
    plain.load_state_dict(fused.state_dict())
    assert all(g["fused"] is None for o in plain.optimisers.values() for g in o.param_groups)
    plain.update(data.clone(), 3)


def test_compiling_the_update_is_an_option_recorded_and_built_lazily():
    agent = make_agent("qtopt", "execution.compile=true")
    assert agent.options.compile and agent.runner is None  # evaluation-only loads never compile


@pytest.mark.slow  # compiling the whole update takes ~1 min on a 2-core CPU
@pytest.mark.parametrize("algo", ["qtopt", "sac"])
def test_the_compiled_update_equals_the_eager_one(algo):
    torch._dynamo.reset()
    eager, compiled = make_agent(algo), make_agent(algo, "execution.compile=true")
    with torch._inductor.config.patch(fallback_random=True):  # inductor's own RNG draws other numbers
        for index in range(4):
            data = batch(seed=index)
            torch.manual_seed(index)
            expected = eager.update(data.clone(), index)
            torch.manual_seed(index)
            got = compiled.update(data.clone(), index)
            for name in got:
                torch.testing.assert_close(got[name], expected[name], rtol=1e-4, atol=1e-5, msg=f"{name} at update {index}")


# ------------------------------------------------------------------------------------ acting
def test_a_device_policy_sends_only_the_policy_inputs_and_returns_the_action():
    seen = []

    def act(pixels):
        seen.append(pixels)
        return pixels.float().mean((-1, -2, -3)).unsqueeze(-1).expand(*pixels.shape[:-3], 2)

    inner = TensorDictModule(act, in_keys=["pixels"], out_keys=["action"])
    step = TensorDict({"pixels": torch.randint(0, 256, (1, *OBS), dtype=torch.uint8),
                       "done": torch.zeros(1, 1, dtype=torch.bool), "episode_reward": torch.zeros(1, 1)}, [1], device="cpu")
    out = DevicePolicy(inner, "cpu")(step.clone())
    assert torch.equal(out["action"], inner(step.clone())["action"])
    assert out["done"].shape == (1, 1) and len(seen) == 2
    assert on_device(inner, "cpu") is inner


def test_the_agent_acts_the_same_through_a_device_policy():
    agent = make_agent("sac")
    step = TensorDict({"pixels": torch.randint(0, 256, (1, *OBS), dtype=torch.uint8)}, [1])
    torch.manual_seed(0)
    expected = agent.policy(step.clone())["action"]
    torch.manual_seed(0)
    assert torch.equal(DevicePolicy(agent.policy, "cpu")(step.clone())["action"], expected)


def test_the_collector_takes_a_device_policy_as_it_is():
    """On CUDA the loop hands the collector a DevicePolicy with no device settings (envs, policy
    and data on the host as the collector sees them): it collects what the plain policy does."""
    from torchrl.collectors import Collector

    from dcs_torchrl.envs import resolve_settings
    from dcs_torchrl.training.envs import pixel_env

    def make_env():
        return pixel_env(resolve_settings("cartpole", "swingup"), frame_stack=3, image_size=OBS[-1],
                         render_profile="default", seed=0)

    env = make_env()
    agent = agent_class("sac")(config(), OBS, env.action_spec)
    env.close()
    actions = []
    for policy in (agent.policy, DevicePolicy(agent.policy, "cpu")):
        env = make_env()
        torch.manual_seed(0)
        collector = Collector(env, policy, frames_per_batch=3, total_frames=3, auto_register_policy_transforms=False)
        data = next(iter(collector))
        collector.shutdown()
        env.close()
        actions.append(data["action"])
    assert torch.equal(*actions)


def test_the_render_device_is_the_policys_gpu_where_an_egl_device_is_that_gpu():
    """``execution.render_device``: ``auto`` on the CPU leaves rendering to this process's device;
    an EGL index is taken when the machine has it; on CUDA ``auto`` is that GPU's EGL device, or
    this process's where no EGL device is that GPU (Mesa); a bad value is refused naming the fix."""
    from dcs_torchrl.render.egl_devices import egl_device_of_cuda, egl_devices
    from dcs_torchrl.training.envs import render_device

    assert render_device(config("sac")) is None
    assert render_device(config("sac", "execution.render_device=0")) == 0
    cuda = OmegaConf.merge(config("sac"), {"device": "cuda:0"})
    if any(d.cuda == 0 for d in egl_devices()):
        assert render_device(cuda) == egl_device_of_cuda("cuda:0")
    else:
        assert render_device(cuda) is None
    with pytest.raises(ValueError, match=r"EGL device 99 does not exist: this machine's EGL devices are"):
        render_device(config("sac", "execution.render_device=99"))
    with pytest.raises(ValueError, match="execution.render_device must be auto or an EGL device index"):
        render_device(config("sac", "execution.render_device=gpu"))
