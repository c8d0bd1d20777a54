"""The recipes' training machinery: pixel envs, frame-stack replay, checkpoints, metrics, loop.

>>> from dcs_torchrl.training import FrameStackReplayBuffer, train

The names are imported when first used (:func:`dcs_torchrl.lazy_exports`): a module of this package
that needs no torch (``rundir``, read by the experiments' launcher) loads none.
"""
from dcs_torchrl import lazy_exports

_PUBLIC = {
    "LossAgent": "dcs_torchrl.training.agent", "pixel_networks": "dcs_torchrl.training.agent",
    "CheckpointError": "dcs_torchrl.training.checkpoint", "load_latest": "dcs_torchrl.training.checkpoint",
    "UntrustedCheckpointError": "dcs_torchrl.training.checkpoint",
    "save_checkpoint": "dcs_torchrl.training.checkpoint",
    "batched_pixel_env": "dcs_torchrl.training.envs", "pixel_env": "dcs_torchrl.training.envs",
    "train": "dcs_torchrl.training.loop",
    "MetricsLogger": "dcs_torchrl.training.metrics", "read_metrics": "dcs_torchrl.training.metrics",
    "FrameStackReplayBuffer": "dcs_torchrl.training.replay",
    "RunDirectory": "dcs_torchrl.training.rundir", "RunMismatchError": "dcs_torchrl.training.rundir",
}
__getattr__, __dir__ = lazy_exports(__name__, _PUBLIC)
__all__ = sorted(_PUBLIC)
