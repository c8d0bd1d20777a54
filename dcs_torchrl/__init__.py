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

import importlib  # noqa: E402
import importlib.util  # noqa: E402
import sys  # noqa: E402

#: The public names and the module each lives in, imported when first used: ``import dcs_torchrl``
#: itself loads neither torch nor TorchRL, so that what needs neither (the methods' registry, the
#: experiments' launcher deciding a run is finished, the report) starts at once.
_PUBLIC = {
    "BENCHMARKS": "dcs_torchrl.presets",
    "TASKS": "dcs_torchrl.presets",
    "BackgroundDistraction": "dcs_torchrl.distractions",
    "CameraDistraction": "dcs_torchrl.distractions",
    "ColorDistraction": "dcs_torchrl.distractions",
    "DistractionTransform": "dcs_torchrl.distractions",
    "LightingDistraction": "dcs_torchrl.distractions",
    "TextureDistraction": "dcs_torchrl.distractions",
    "EnvOptions": "dcs_torchrl.envs",
    "EnvSettings": "dcs_torchrl.envs",
    "make_env": "dcs_torchrl.envs",
    "make_grouped_env": "dcs_torchrl.envs",
    "resolve_settings": "dcs_torchrl.envs",
    "ParallelSuiteEnv": "dcs_torchrl.vector.parallel",
    "RenderPixels": "dcs_torchrl.render.gl",
    "WorkerDiedError": "dcs_torchrl.vector.process_pool",
}


def lazy_exports(package: str, public: dict[str, str]):
    """A package's ``__getattr__`` and ``__dir__`` (PEP 562): each of ``public``'s names imported from
    its module on first use, and the package's submodules on first access."""

    def __getattr__(name: str):
        if name in public:
            value = getattr(importlib.import_module(public[name]), name)
        elif importlib.util.find_spec(f"{package}.{name}") is not None:
            value = importlib.import_module(f"{package}.{name}")
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__


__getattr__, __dir__ = lazy_exports(__name__, _PUBLIC)
__all__ = list(_PUBLIC)
