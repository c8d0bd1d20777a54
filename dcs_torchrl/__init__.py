"""dcs-torchrl: the Distracting Control Suite (Stone et al., 2021) as TorchRL transforms.

>>> import dcs_torchrl as dcs
>>> env = dcs.make_env("cheetah", "run", benchmark="medium", dynamic=True, seed=0)
>>> env.rollout(4)["next", "pixels"].shape
torch.Size([4, 84, 84, 3])
"""
import os

# The one import-time default of the package: headless rendering with EGL. It must be set
# before dm_control is imported; an explicit MUJOCO_GL (osmesa, glfw) is respected.
os.environ.setdefault("MUJOCO_GL", "egl")

from dcs_torchrl._compat import judged_warnings  # noqa: E402

judged_warnings.install()  # only the dependency warnings judged harmless (see the module)

from dcs_torchrl.distractions import (  # noqa: E402
    BackgroundDistraction,
    CameraDistraction,
    ColorDistraction,
    DistractionTransform,
)
from dcs_torchrl.envs import EnvOptions, EnvSettings, make_env, make_grouped_env, resolve_settings  # noqa: E402
from dcs_torchrl.presets import BENCHMARKS, TASKS  # noqa: E402
from dcs_torchrl.render.gl import RenderPixels  # noqa: E402
from dcs_torchrl.vector.parallel import ParallelSuiteEnv  # noqa: E402

__all__ = [
    "BENCHMARKS",
    "BackgroundDistraction",
    "EnvOptions",
    "EnvSettings",
    "make_env",
    "make_grouped_env",
    "ParallelSuiteEnv",
    "resolve_settings",
    "TASKS",
    "CameraDistraction",
    "ColorDistraction",
    "DistractionTransform",
    "RenderPixels",
]
