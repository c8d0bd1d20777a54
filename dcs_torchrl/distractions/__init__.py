"""The suite's distractions, one TorchRL transform each: the paper's three (camera, colour, background) and
two beyond it (lighting, textures; docs/lighting_textures.md)."""
from dcs_torchrl.distractions.background import BackgroundDistraction
from dcs_torchrl.distractions.base import DistractionTransform
from dcs_torchrl.distractions.camera import CameraDistraction
from dcs_torchrl.distractions.color import ColorDistraction
from dcs_torchrl.distractions.lighting import LightingDistraction
from dcs_torchrl.distractions.texture import TextureDistraction

__all__ = ["BackgroundDistraction", "CameraDistraction", "ColorDistraction", "DistractionTransform",
           "LightingDistraction", "TextureDistraction"]
