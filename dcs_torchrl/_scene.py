"""Finding the one dm_control ``Physics`` a scene transform acts on, and refusing misuse.

Every transform of the suite edits (or renders) the MuJoCo scene of the env it is
attached to. TorchRL's :attr:`Transform.parent` is built from *clones* of the preceding
transforms, so this module walks the live container chain instead: it returns the
root env, the base env and the live, flattened list of transforms in the order they
run. Misplaced transforms are caught here, with an error that says how to fix them.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from torchrl.envs import Compose, DMControlWrapper, EnvBase, ParallelEnv, SerialEnv, Transform, TransformedEnv

from dcs_torchrl._compat.private_api import container_of, dm_physics

#: The class attribute, set to True, by which an env that is not a TorchRL ``SerialEnv`` or ``ParallelEnv``
#: says that its dm_control physics live out of a transform's reach (in its workers):
#: :class:`~dcs_torchrl.ParallelSuiteEnv` sets it, so that this module, which every distraction
#: uses, imports nothing about processes.
PHYSICS_ELSEWHERE = "physics_in_workers"

_FACTORY_HINT = (
    "build the suite inside each worker instead, e.g. "
    "ParallelSuiteEnv(n, functools.partial(dcs_torchrl.make_env, 'cheetah', 'run', ...))"
)


@dataclass
class Scene:
    """Where a scene transform lives: its base env, its physics and its neighbours."""

    base_env: DMControlWrapper
    transforms: list[Transform]  # live, flattened, in execution order
    index: int  # position of the transform itself in ``transforms``

    @property
    def physics(self):
        return dm_physics(self.base_env)

    @property
    def frame_skip(self) -> int:
        return int(getattr(self.base_env, "wrapper_frame_skip", 1))

    def before(self) -> list[Transform]:
        return self.transforms[: self.index]

    @property
    def domain(self) -> str | None:
        return getattr(self.base_env, "env_name", None)


def _flatten(transform) -> list[Transform]:
    if isinstance(transform, Compose):
        return [t for child in transform.transforms for t in _flatten(child)]
    return [transform]


def _root(transform: Transform) -> tuple[EnvBase | None, Transform]:
    """The env at the top of ``transform``'s container chain, and the transform right under it.

    The chain is walked from the transform up (not from ``env.transform`` down) because
    TransformedEnv attaches its transform before storing it.
    """
    node = transform
    while True:
        container = container_of(node)
        if container is None or isinstance(container, EnvBase):
            return container, node
        node = container


def locate(transform: Transform, *, strict: bool) -> Scene | None:
    """Returns the :class:`Scene` of ``transform``, or ``None`` if it is not in an env yet.

    Raises a ``RuntimeError`` naming the fix when the transform sits over something it
    cannot act on: a batched env (physics in other processes or sub-envs), a
    non-dm_control env, or a dm_control env that renders its own pixels.
    """
    name = type(transform).__name__
    root, top = _root(transform)
    if root is None:
        if strict:
            raise RuntimeError(
                f"{name} is not attached to an environment: use it inside "
                "TransformedEnv(DMControlEnv(domain, task, from_pixels=False), Compose(...))."
            )
        return None
    if not isinstance(root, TransformedEnv):
        raise RuntimeError(f"{name} must be a transform of a TransformedEnv, got {type(root).__name__}.")
    chain = _flatten(top)
    base = root.base_env
    while isinstance(base, TransformedEnv):  # nested with auto_unwrap=False
        chain = _flatten(base.transform) + chain
        base = base.base_env
    if isinstance(base, (SerialEnv, ParallelEnv)) or getattr(type(base), PHYSICS_ELSEWHERE, False) is True:
        raise RuntimeError(
            f"{name} is placed over a {type(base).__name__}, whose dm_control physics live in "
            f"its workers (other processes or sub-envs), out of this transform's reach: {_FACTORY_HINT}."
        )
    if not isinstance(base, DMControlWrapper):
        raise RuntimeError(
            f"{name} needs a dm_control base env (torchrl DMControlEnv / DMControlWrapper), "
            f"got {type(base).__name__}."
        )
    if getattr(base, "from_pixels", False):
        raise RuntimeError(
            f"{name} is placed over a DMControlEnv with from_pixels=True, which renders inside "
            "its own step, before any transform can edit the scene (and once per frame-skip "
            "sub-step). Use DMControlEnv(domain, task, from_pixels=False, frame_skip=k) and put "
            "dcs_torchrl.RenderPixels() after the distractions."
        )
    index = next((i for i, t in enumerate(chain) if t is transform), None)
    if index is None:
        if strict:
            raise RuntimeError(f"{name} could not find itself in its environment's transforms.")
        return None
    return Scene(base_env=base, transforms=chain, index=index)


class _Originals:
    """The model values the suite edits, as they were before any edit."""

    def __init__(self, physics):
        model = physics.model
        self.mat_rgba = model.mat_rgba.copy()
        self.mat_texid = model.mat_texid.copy()
        self.light_ambient = model.light_ambient.copy()
        self.light_diffuse = model.light_diffuse.copy()
        self.light_specular = model.light_specular.copy()
        headlight = model.vis.headlight
        self.headlight_ambient = np.array(headlight.ambient, np.float64)
        self.headlight_diffuse = np.array(headlight.diffuse, np.float64)
        self.headlight_specular = np.array(headlight.specular, np.float64)
        self.tex_size = {i: (int(model.tex_width[i]), int(model.tex_height[i])) for i in range(model.ntex)}
        self._model = model
        self._textures: dict[int, object] = {}

    def texture(self, tex_id: int):
        """The original bytes of texture ``tex_id`` (copied on first request)."""
        if tex_id not in self._textures:
            w, h = self.tex_size[tex_id]
            adr, n = int(self._model.tex_adr[tex_id]), int(self._model.tex_nchannel[tex_id])
            self._textures[tex_id] = self._model.tex_data[adr : adr + w * h * n].copy()
        return self._textures[tex_id]


_ORIGINALS: "weakref.WeakKeyDictionary[object, _Originals]" = weakref.WeakKeyDictionary()


def originals(physics) -> _Originals:
    """Snapshot of ``physics``'s editable model values, taken when a suite transform first binds.

    Several transforms (and clones TorchRL makes of them) may bind to one physics at
    different times; they all see the values from before the suite changed anything.
    """
    snapshot = _ORIGINALS.get(physics)
    if snapshot is None:
        snapshot = _ORIGINALS[physics] = _Originals(physics)
    return snapshot
