"""The recipes' training machinery: pixel envs, frame-stack replay, checkpoints, metrics, loop.

>>> from dcs_torchrl.training import FrameStackReplayBuffer, train
"""
from dcs_torchrl.training.agent import LossAgent, pixel_networks
from dcs_torchrl.training.checkpoint import CheckpointError, load_latest, save_checkpoint
from dcs_torchrl.training.envs import batched_pixel_env, pixel_env
from dcs_torchrl.training.loop import train
from dcs_torchrl.training.metrics import MetricsLogger, read_metrics
from dcs_torchrl.training.replay import FrameStackReplayBuffer
from dcs_torchrl.training.rundir import RunDirectory, RunMismatchError

__all__ = [
    "CheckpointError", "FrameStackReplayBuffer", "LossAgent", "MetricsLogger",
    "RunDirectory", "RunMismatchError", "batched_pixel_env", "load_latest", "pixel_env",
    "pixel_networks", "read_metrics", "save_checkpoint", "train",
]
