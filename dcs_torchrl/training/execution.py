"""How a run's update executes on its device: the settings that change its speed, and TF32.

The recipes' config names them (``training/conf/base.yaml``); :class:`ExecutionOptions` is their
resolved form, read once by the loop and the agents:

==============================  ===============================================================
setting                         what it does
==============================  ===============================================================
``optim.fused``                 ``auto`` | ``true`` | ``false``: fused Adam kernels (one kernel
                                per optimiser step, no host read of the step count). ``auto``:
                                on CUDA only; the CPU keeps torch's default Adam.
``execution.compile``           ``torch.compile`` the whole update (the losses, the backward
                                pass, the optimiser steps and the target update).
``execution.cudagraph``         replay the whole update as CUDA graphs, one per schedule
                                (:class:`GraphedUpdate`); ``device=cuda`` only.
``execution.cudnn_benchmark``   ``auto`` | ``true`` | ``false``: cuDNN times its convolution
                                algorithms once per shape and keeps the fastest (``auto``: on
                                CUDA).
``precision.tf32``              TF32 tensor cores for float32 matmuls and convolutions on CUDA.
                                Off by default, set explicitly either way (PyTorch's own default
                                runs cuDNN convolutions in TF32); it changes the math, so it is
                                part of a run's identity.
``replay_buffer.device``        ``auto`` | ``cpu`` | ``cuda``: where the replay's frames live
                                (:func:`replay_device`).
``execution.render_device``     ``auto`` | an EGL device index: the GPU the envs render on
                                (``auto``: the policy's CUDA GPU where NVIDIA's EGL driver
                                maps it; :func:`dcs_torchrl.training.envs.render_device`).
==============================  ===============================================================

Everything but ``precision.tf32`` runs the same math (summed in other orders at most): a run
resumes under other values, and ``results.json`` records the values that ran
(:meth:`ExecutionOptions.recorded`). On the CPU the defaults are the update as it always ran:
eager, torch's default Adam, host replay.

:class:`DevicePolicy` is the acting side: a policy on the device acting in envs on the host,
with one transfer each way per step.
"""
from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass

import torch
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

__all__ = [
    "AUTO", "DevicePolicy", "ExecutionOptions", "GraphedUpdate", "UpdateRunner", "apply_math_settings",
    "check_execution", "cuda_graph_capture", "on_device", "replay_device",
]

AUTO = "auto"
#: Where ``replay_buffer.device=auto`` puts the frames on CUDA: there if they take at most this
#: share of the device's free memory (the rest is for the update, and for other runs on the card).
REPLAY_SHARE_OF_FREE_MEMORY = 0.5
_FLAG_VALUES = (AUTO, True, False)


def _select(cfg, key: str, default):
    """``cfg``'s value at ``key`` (a ``DictConfig`` or a dict), or ``default`` where a config (e.g. a
    run recorded before the setting existed) lacks it."""
    return OmegaConf.select(cfg if OmegaConf.is_config(cfg) else OmegaConf.create(dict(cfg)), key, default=default)


def _flag(cfg, key: str, default, auto: bool) -> bool:
    value = _select(cfg, key, default)
    if value not in _FLAG_VALUES or isinstance(value, (int, float)) and not isinstance(value, bool):
        raise ValueError(f"{key} must be auto, true or false, got {value!r}.")
    return auto if value == AUTO else bool(value)


@dataclass(frozen=True)
class ExecutionOptions:
    """The resolved execution settings of a run (see the module docstring).

    Attributes:
        device: where the networks and the update live.
        fused: fused Adam.
        compile: ``torch.compile`` the whole update.
        cudagraph: replay the update as CUDA graphs.
        cudnn_benchmark: cuDNN's algorithm search.
        tf32: TF32 matmuls and convolutions (CUDA).

    Examples:
        >>> ExecutionOptions.from_config({"device": "cpu"})
        ExecutionOptions(device=device(type='cpu'), fused=False, compile=False, cudagraph=False, cudnn_benchmark=False, tf32=False)
    """

    device: torch.device = torch.device("cpu")
    fused: bool = False
    compile: bool = False
    cudagraph: bool = False
    cudnn_benchmark: bool = False
    tf32: bool = False

    @classmethod
    def from_config(cls, cfg) -> "ExecutionOptions":
        """The options of a recipe config (a ``DictConfig`` or a dict), ``auto`` resolved for its
        ``device``; settings the config lacks take their defaults (older runs' configs)."""
        device = torch.device(_select(cfg, "device", "cpu"))
        on_cuda = device.type == "cuda"
        return cls(
            device=device,
            fused=_flag(cfg, "optim.fused", AUTO, auto=on_cuda),
            compile=_flag(cfg, "execution.compile", False, auto=False),
            cudagraph=_flag(cfg, "execution.cudagraph", False, auto=False),
            cudnn_benchmark=_flag(cfg, "execution.cudnn_benchmark", AUTO, auto=on_cuda),
            tf32=_flag(cfg, "precision.tf32", False, auto=False),
        )

    @property
    def capturable(self) -> bool:
        """Whether the optimisers must be CUDA-graph safe (step counts on the device)."""
        return self.device.type == "cuda" and (self.cudagraph or self.compile)

    def adam_kwargs(self) -> dict:
        """Keyword arguments for ``torch.optim.Adam``: none for torch's default (the CPU's)."""
        kwargs = {}
        if self.fused:
            kwargs["fused"] = True
        if self.capturable:
            kwargs["capturable"] = True
        return kwargs

    def recorded(self, config: Mapping, replay: torch.device | None = None, render: int | None = None) -> dict:
        """``config`` (a run's resolved config, a dict) with the values that ran in place of ``auto``
        (``render``: the envs' EGL device, ``None`` recorded as ``"process"``: this process's)."""
        config = {key: dict(value) if isinstance(value, Mapping) else value for key, value in config.items()}
        config["optim"] = {**config.get("optim", {}), "fused": self.fused}
        config["execution"] = {**config.get("execution", {}), "compile": self.compile, "cudagraph": self.cudagraph,
                               "cudnn_benchmark": self.cudnn_benchmark,
                               "render_device": "process" if render is None else render}
        config["precision"] = {**config.get("precision", {}), "tf32": self.tf32}
        if replay is not None:
            config["replay_buffer"] = {**config.get("replay_buffer", {}), "device": str(replay)}
        return config


def check_execution(cfg) -> None:
    """Refuses execution settings that cannot run, naming the fix (before a run writes anything)."""
    options = ExecutionOptions.from_config(cfg)  # raises for values other than auto / true / false
    on_cuda = options.device.type == "cuda"
    if options.cudagraph and not on_cuda:
        raise ValueError(
            f"execution.cudagraph=true captures the update as CUDA graphs, but device={cfg.device}: "
            "set device=cuda, or execution.cudagraph=false."
        )
    if options.tf32 and not on_cuda:
        raise ValueError(
            f"precision.tf32=true selects TF32 tensor cores, a CUDA setting, but device={cfg.device}: "
            "set device=cuda, or precision.tf32=false."
        )
    replay = str(_select(cfg, "replay_buffer.device", AUTO))
    if replay != AUTO:
        try:
            kind = torch.device(replay).type
        except RuntimeError:
            kind = None
        if kind not in ("cpu", "cuda"):
            raise ValueError(f"replay_buffer.device must be auto, cpu or cuda, got {replay!r}.")
        if kind == "cuda" and not on_cuda:
            raise ValueError(
                f"replay_buffer.device={replay} with device={cfg.device} would send every sample back to the CPU: "
                "set replay_buffer.device=cpu (or auto), or device=cuda."
            )


def replay_device(cfg, nbytes: int, *, free_bytes: Callable[[torch.device], int] | None = None) -> torch.device:
    """Where the replay's frames live: ``replay_buffer.device``, ``auto`` resolved.

    ``auto`` is the host when the run's ``device`` is the CPU; on CUDA it is the training device
    if the buffer's ``nbytes`` (:meth:`FrameStackReplayBuffer.storage_bytes`, all of it: device
    memory is allocated up front) take at most :data:`REPLAY_SHARE_OF_FREE_MEMORY` of the
    device's free memory, else the host. ``cuda`` means the training device.

    Examples:
        >>> replay_device({"device": "cpu", "replay_buffer": {"device": "auto"}}, 10**9)
        device(type='cpu')
    """
    device = torch.device(_select(cfg, "device", "cpu"))
    choice = str(_select(cfg, "replay_buffer.device", AUTO))
    if choice == AUTO:
        if device.type != "cuda":
            return torch.device("cpu")
        free = (free_bytes or _free_cuda_bytes)(device)
        return device if nbytes <= REPLAY_SHARE_OF_FREE_MEMORY * free else torch.device("cpu")
    return device if torch.device(choice).type == "cuda" else torch.device("cpu")


def _free_cuda_bytes(device: torch.device) -> int:
    return torch.cuda.mem_get_info(device)[0]


def apply_math_settings(options: ExecutionOptions) -> None:
    """Sets the process's CUDA math flags to ``options``: TF32 on or off for matmuls and cuDNN
    convolutions (explicitly, either way), and ``cudnn.benchmark``. Nothing on the CPU."""
    if options.device.type != "cuda":
        return
    precision = "tf32" if options.tf32 else "ieee"
    if hasattr(torch.backends.cudnn, "conv"):  # torch >= 2.9: per-op fp32 precision
        torch.backends.cuda.matmul.fp32_precision = precision
        torch.backends.cudnn.conv.fp32_precision = precision
    else:
        torch.backends.cuda.matmul.allow_tf32 = options.tf32
        torch.backends.cudnn.allow_tf32 = options.tf32
    torch.backends.cudnn.benchmark = options.cudnn_benchmark


# ------------------------------------------------------------------------------------ the update
UpdateStep = Callable[..., Mapping[str, torch.Tensor]]  # step(batch, *schedule) -> detached 0-d metrics


def cuda_graph_capture(fn: Callable[[], torch.Tensor]) -> Callable[[], torch.Tensor]:
    """Captures ``fn`` (no arguments, returning a tensor) as a CUDA graph, without running it;
    returns ``replay``, which runs the graph and returns the same output tensor each time."""
    graph = torch.cuda.CUDAGraph()
    with torch.cuda.graph(graph):
        out = fn()

    def replay() -> torch.Tensor:
        graph.replay()
        return out

    return replay


class GraphedUpdate:
    """An update replayed as graphs: one per schedule, captured after ``warmup`` eager runs of it.

    An update of the recipes is a fixed sequence of kernels for each *schedule*, the flags that
    say which parts run at an update (SAC: the actor and temperature every second update, the
    targets every second; QT-Opt: the targets every second), so the first update of each
    schedule after its warm-up captures that schedule's graph and every later one replays it:
    the batch is copied into the graph's input buffers (on the device: no host transfer), the
    graph runs, and its metrics are copied out of its output buffer, all without a host read.
    Warm-up and capture run on a side stream, as CUDA graphs require; every update, warm-up or
    replayed, is a real update, in order, so the sequence of updates is the eager one.

    Args:
        step (callable): ``step(batch, *schedule) -> {name: detached 0-d tensor}``, the whole
            update (losses, backward, optimiser steps, target update). Its optimisers must be
            ``capturable`` (:meth:`ExecutionOptions.adam_kwargs`).

    Keyword Args:
        warmup (int): eager runs of each schedule before its capture (cuDNN's and cuBLAS's lazy
            set-up, the optimisers' state, ``torch.compile``'s compilation). Defaults to ``3``.
        capture (callable): ``capture(fn) -> replay`` (:func:`cuda_graph_capture`); a test passes
            one that reruns ``fn`` into fixed output buffers to exercise this class on the CPU.
        stream (torch.cuda.Stream, optional): the side stream (``None``: a new one on CUDA, none
            on the CPU).
    """

    def __init__(self, step: UpdateStep, *, warmup: int = 3, capture: Callable | None = None, stream=None):
        if warmup < 1:
            raise ValueError(f"warmup must be >= 1 (capturing needs an eager run first), got {warmup}.")
        self.step = step
        self.warmup = warmup
        self.capture = capture or cuda_graph_capture
        self.stream = stream
        self.warmed: dict[Hashable, int] = {}
        self.replays: dict[Hashable, Callable[[], torch.Tensor]] = {}
        self.names: list[str] | None = None
        self.inputs: TensorDictBase | None = None  # the graphs' input buffers

    def _side_stream(self, device: torch.device):
        if device.type != "cuda":
            return contextlib.nullcontext()
        if self.stream is None:
            self.stream = torch.cuda.Stream(device)
        self.stream.wait_stream(torch.cuda.current_stream(device))
        return torch.cuda.stream(self.stream)

    def _join(self, device: torch.device) -> None:
        if device.type == "cuda":
            torch.cuda.current_stream(device).wait_stream(self.stream)

    def _run(self, schedule: tuple) -> torch.Tensor:
        """One update on the input buffers, its metrics stacked in one tensor (the graph's output)."""
        metrics = self.step(self.inputs.copy(), *schedule)  # a shallow copy: the loss may add entries
        names = list(metrics)
        if self.names is None:
            self.names = names
        elif names != self.names:
            raise RuntimeError(f"the update's metrics changed from {self.names} to {names}: a graph needs fixed outputs.")
        return torch.stack([metrics[name].reshape(()).float() for name in names])

    def __call__(self, batch: TensorDictBase, schedule: tuple = ()) -> dict[str, torch.Tensor]:
        if self.inputs is None:
            self.inputs = batch.clone()
        else:
            self.inputs.update_(batch)  # in place: the graphs read these buffers
        device = self.inputs.device or torch.device("cpu")
        replay = self.replays.get(schedule)
        if replay is not None:
            out = replay()
        elif self.warmed.get(schedule, 0) < self.warmup:
            with self._side_stream(device), warnings.catch_warnings():
                warnings.filterwarnings("ignore", message=".*capturable=True.*")  # eager warm-up steps
                out = self._run(schedule)
            self._join(device)
            self.warmed[schedule] = self.warmed.get(schedule, 0) + 1
        else:
            if device.type == "cuda":
                torch.cuda.synchronize(device)  # once per schedule: the warm-up's work is done
            replay = self.replays[schedule] = self.capture(lambda: self._run(schedule))
            out = replay()  # the capture ran nothing: this is the update
        out = out.clone()  # the graph overwrites its output at the next replay
        return dict(zip(self.names, out.unbind()))


class UpdateRunner:
    """Runs an agent's update step as its :class:`ExecutionOptions` say: eager, compiled, and/or
    replayed as CUDA graphs.

    Args:
        step (callable): ``step(batch, *schedule) -> {name: detached 0-d tensor}``.
        options (ExecutionOptions): ``compile``, ``cudagraph``.

    Keyword Args:
        capture (callable, optional): passed to :class:`GraphedUpdate` (tests).
    """

    def __init__(self, step: UpdateStep, options: ExecutionOptions, *, capture: Callable | None = None):
        self.options = options
        if options.compile:
            step = torch.compile(step)
        self.step = step
        self.graphed = GraphedUpdate(step, capture=capture) if options.cudagraph or capture is not None else None

    def __call__(self, batch: TensorDictBase, schedule: tuple = ()) -> dict[str, torch.Tensor]:
        if self.graphed is not None:
            return self.graphed(batch, schedule)
        return dict(self.step(batch, *schedule))


# ------------------------------------------------------------------------------------ acting
class DevicePolicy(TensorDictModuleBase):
    """A policy on a device acting in envs on the host: one transfer each way per step.

    The policy's inputs (its ``in_keys`` only, not the whole env step) go to the device from
    pinned host memory without waiting; its action comes back in one copy, the step's one wait
    (the env needs it, and it waits for the update before it, which the action depends on).

    Args:
        policy (TensorDictModuleBase): the acting policy, on ``device``; writes ``"action"``.
        device (torch.device): where it runs.

    Examples:
        >>> from tensordict import TensorDict
        >>> from tensordict.nn import TensorDictModule
        >>> inner = TensorDictModule(lambda x: 2 * x, in_keys=["pixels"], out_keys=["action"])
        >>> DevicePolicy(inner, "cpu")(TensorDict({"pixels": torch.ones(2)}))["action"]
        tensor([2., 2.])
    """

    def __init__(self, policy: TensorDictModuleBase, device: str | torch.device, *, action_key="action"):
        super().__init__()
        self.policy = policy
        self.device = torch.device(device)
        self.action_key = action_key
        self.in_keys = list(policy.in_keys)
        self.out_keys = [action_key]
        self.pin = self.device.type == "cuda"

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        inputs = tensordict.select(*self.in_keys)
        if self.pin:
            inputs = inputs.pin_memory()
        out = self.policy(inputs.to(self.device, non_blocking=self.pin))
        tensordict.set(self.action_key, out.get(self.action_key).to(tensordict.device or "cpu"))
        return tensordict


def on_device(policy: TensorDictModuleBase, device: str | torch.device) -> TensorDictModuleBase:
    """``policy`` for envs on the host: itself on the CPU, a :class:`DevicePolicy` elsewhere."""
    return policy if torch.device(device).type == "cpu" else DevicePolicy(policy, device)
