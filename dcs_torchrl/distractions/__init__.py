"""The three distractions of the suite, one TorchRL transform each."""
from dcs_torchrl.distractions.background import BackgroundDistraction
from dcs_torchrl.distractions.base import DistractionTransform
from dcs_torchrl.distractions.camera import CameraDistraction
from dcs_torchrl.distractions.color import ColorDistraction

__all__ = ["BackgroundDistraction", "CameraDistraction", "ColorDistraction", "DistractionTransform"]
