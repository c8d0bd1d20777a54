"""What every distraction shares: finding its physics, seeding, stepping per control step.

A distraction is a TorchRL :class:`~torchrl.envs.Transform` that edits the dm_control
scene of the env it is attached to: once at episode start (``_reset``, after the base
env's reset) and once per agent step (``_step``, after the base env's ``frame_skip``
physics steps and before :class:`~dcs_torchrl.RenderPixels` renders). A dynamic
distraction advances its random walk by ``frame_skip`` control steps per agent step, as
in the authors' code where action repeat wraps the distracting env.

Seeding: each distraction owns a ``numpy`` generator. ``seed=s`` (or ``env.set_seed(s)``
on any env built over the same base env) derives it from ``SeedSequence(s,
spawn_key=(tag,))`` with a tag per distraction type (1 to 5), so their streams are
independent and the whole pixel sequence is a function of ``s``.
"""
from __future__ import annotations

import weakref
from typing import ClassVar

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Composite, Unbounded
from torchrl.envs import Transform

from dcs_torchrl._compat.private_api import base_set_seed, replace_set_seed
from dcs_torchrl._scene import Scene, locate


def check_scale(name: str, value: float) -> float:
    """Returns ``value`` as a float if it lies in [0, 1], else raises a ValueError naming ``name``."""
    value = float(value)
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"{name} must be in [0, 1] (Stone et al. 2021, Sec. 3), got {value}.")
    return value


def per_world(value, n: int) -> np.ndarray:
    """``value`` (one int for all, or one a world) as int64 ``[n]``: a ``Worlds`` class's frame skips."""
    return np.broadcast_to(np.asarray(value, np.int64), (n,)).copy()


def generator(seed: int | None, tag: int) -> np.random.Generator:
    """The generator of distraction type ``tag`` for ``seed`` (fresh entropy if ``None``)."""
    if seed is not None:
        if int(seed) < 0:
            raise ValueError(f"seed must be a non-negative integer, got {seed}.")
        return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(tag,)))
    return np.random.default_rng(np.random.SeedSequence(spawn_key=(tag,)))


class _SeedFanout:
    """Replaces ``base_env._set_seed`` so that ``env.set_seed`` reseeds the distractions too.

    TorchRL's ``TransformedEnv.set_seed`` only seeds the base env (transforms have no seed
    hook), and wrapping a ``TransformedEnv`` in another one rebuilds it around the same
    base env, so the base env is the one object every composition shares.
    """

    def __init__(self, base_set_seed):
        self.base_set_seed = base_set_seed
        self.listeners: weakref.WeakSet = weakref.WeakSet()

    def __call__(self, seed):
        self.base_set_seed(seed)
        if seed is not None:
            for listener in list(self.listeners):
                listener.reseed(seed)


def _listen_to_seeds(base_env, transform) -> None:
    fanout = base_set_seed(base_env)
    if not isinstance(fanout, _SeedFanout):
        fanout = _SeedFanout(fanout)
        replace_set_seed(base_env, fanout)
    fanout.listeners.add(transform)


class DistractionTransform(Transform):
    """Base class of the suite's distractions (not used directly).

    A distraction's state lives in arrays over worlds (its ``Worlds`` class: ``CameraWorlds``,
    ``ColorWorlds``, ``BackgroundWorlds``), row :attr:`row` of them: on one env a one-world instance of its
    own, in a batch the batch's (:meth:`share`), which then steps and places every world at once. So one
    env and a batch run the same code. Subclasses set ``state_name`` / ``seed_tag`` and implement
    ``_new_worlds(scene)``, ``_start(physics)`` where its start needs more than ``Worlds.start(row, self)``,
    ``_edit_scene(physics)`` (its row into the one env's scene) and ``_state_like(scene)``; the ``Worlds`` class implements
    ``advance(rows)`` and ``states(rows)``.

    Keyword Args:
        seed (int, optional): seed of this distraction's generator; ``None`` draws fresh
            entropy. ``env.set_seed(s)`` reseeds it.
        expose (bool): write the distraction's state to ``("distractions", state_name)``
            at every reset and step (and declare it in the observation spec), so that
            collectors and replay buffers carry it as ground-truth nuisance data.
    """

    state_name: ClassVar[str]
    seed_tag: ClassVar[int]

    def __init__(self, *, seed: int | None = None, expose: bool = False):
        self.expose = bool(expose)
        super().__init__(in_keys=[], out_keys=[("distractions", self.state_name)] if expose else [])
        self.__dict__["_scene"] = None
        self._hold(None, 0, owner=False)
        self.reseed(seed)

    def _hold(self, worlds, row: int, owner: bool) -> None:
        """Keeps this distraction's state in row ``row`` of ``worlds`` (``None``: none yet); ``owner``: the
        arrays are this transform's own (one env), which its step advances and places."""
        self.__dict__.update(_worlds=worlds, row=row, _rows=np.array([row], np.int64), _owner=owner)

    # ----------------------------------------------------------------- wiring
    def reseed(self, seed: int | None) -> None:
        """Restarts this distraction's random stream from ``seed``; takes effect at the next reset."""
        self._rng = generator(seed, self.seed_tag)
        worlds = self._worlds
        if worlds is not None and hasattr(worlds, "noise"):
            worlds.noise.use(self.row, self._rng)

    def share(self, worlds, row: int) -> None:
        """Keeps this distraction's state in row ``row`` of ``worlds`` (a batch's arrays, of this
        distraction's ``Worlds`` class), whose owner then advances and places every world at once: this
        transform's own step and scene edit then leave the scene to it; its episode starts still draw
        the row from its own generator."""
        self._hold(worlds, row, owner=False)
        if hasattr(worlds, "noise"):
            worlds.noise.use(row, self._rng)

    def clone(self):
        """TorchRL's shallow copy (for a ``parent`` view or a new env), without this distraction's state: a
        clone that shared its arrays would redirect their noise to its own generator when reseeded."""
        copy = super().clone()
        copy._hold(None, 0, owner=False)
        return copy

    @property
    def worlds(self):
        """The arrays this distraction's state lives in (row :attr:`row`); ``None`` before its first reset."""
        return self._worlds

    def _own_worlds(self, scene: Scene) -> None:
        if self._worlds is None:
            self.share(self._new_worlds(scene), 0)
            self._owner = True

    def set_container(self, container) -> None:
        super().set_container(container)
        self.__dict__["_scene"] = None
        self._bind(strict=False)  # catch misuse at construction when the env is complete

    def reset_parent(self) -> None:
        super().reset_parent()
        self.__dict__["_scene"] = None

    def _bind(self, strict: bool = True) -> Scene | None:
        scene = self.__dict__.get("_scene")
        if scene is not None:
            return scene
        scene = locate(self, strict=strict)
        if scene is None:
            return None
        from dcs_torchrl.render.gl import RenderPixels  # render imports nothing from here

        if any(isinstance(t, RenderPixels) for t in scene.before()):
            raise RuntimeError(
                f"{type(self).__name__} is placed after RenderPixels: the frame is already "
                "rendered when it edits the scene, so the edit would show one step late. "
                "Move it before RenderPixels in the Compose."
            )
        _listen_to_seeds(scene.base_env, self)
        self._on_bind(scene)
        self.__dict__["_scene"] = scene
        return scene

    def _on_bind(self, scene: Scene) -> None:
        """Checks against the model once the env is known (override)."""

    # ---------------------------------------------------------- TorchRL hooks
    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        scene = self._bind()
        self._own_worlds(scene)
        self._start(scene.physics)
        if self._owner:
            self._edit_scene(scene.physics)
        return self._write_state(tensordict_reset)

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        if self._owner:  # an agent step: frame_skip control steps of the walk, the scene edited
            self._worlds.advance(self._rows)
            self._edit_scene(self._bind().physics)
        return self._write_state(next_tensordict)

    def state(self) -> np.ndarray:
        """The distraction's current state, as ``expose`` writes it."""
        if self.worlds is None:
            raise RuntimeError(f"{type(self).__name__} has no state before its env's first reset: call env.reset().")
        return self._worlds.states(self._rows)[0]

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        raise RuntimeError(
            f"{type(self).__name__} edits a live MuJoCo scene; it cannot transform stored "
            "data (e.g. replay-buffer samples). Use it as an env transform."
        )

    def _write_state(self, tensordict: TensorDictBase) -> TensorDictBase:
        if self.expose:
            tensordict.set(self.out_keys[0], torch.as_tensor(self.state()))
        return tensordict

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        if self.expose:
            scene = self._bind()
            state = np.asarray(self._state_like(scene))
            observation_spec[self.out_keys[0]] = Unbounded(
                shape=state.shape,
                dtype=torch.as_tensor(state).dtype,
                device=observation_spec.device,
            )
        return observation_spec

    # ------------------------------------------------------ subclass contract
    def _new_worlds(self, scene: Scene):
        """A one-world instance of this distraction's ``Worlds`` class for ``scene``'s env."""
        raise NotImplementedError

    def _start(self, physics) -> None:
        """The episode start of this distraction's row: its ``Worlds`` class's ``start(row, self)`` (override
        where the start needs more, e.g. the physics)."""
        self._worlds.start(self.row, self)

    def _edit_scene(self, physics) -> None:
        raise NotImplementedError

    def _state_like(self, scene: Scene) -> np.ndarray:
        """An array with the shape and dtype of :meth:`state`, available before any reset."""
        raise NotImplementedError
