"""Every preset of the suite as a Gymnasium env, for training loops that do not use TorchRL.

Importing this module registers ``dcs/<domain>-<task>-<benchmark>[-dynamic]-v0`` for every
dm_control suite task (``dm_control.suite.ALL_TASKS``) and every benchmark of
:data:`dcs_torchrl.BENCHMARKS`, so that ``gymnasium.make`` builds any preset; keyword
arguments of ``gymnasium.make`` are :func:`~dcs_torchrl.make_env` settings. Gymnasium 1.x
loads no plugin entry points, so the ids exist once this module is imported; the id
``"dcs_torchrl.gym_env:dcs/cartpole-swingup-medium-v0"`` imports it on the way (what a
string config or a spawned worker needs).

The env is an adapter over :func:`~dcs_torchrl.make_env`, not a second implementation: it
steps that TorchRL env and hands its tensors over as NumPy arrays, so that for the same seed
and actions its frames are ``make_env``'s, frame for frame. ``docs/gymnasium.md`` has a
complete loop, frame stacking and vector envs.

Examples:
    >>> import gymnasium
    >>> import dcs_torchrl.gym_env  # registers the dcs/ ids
    >>> env = gymnasium.make("dcs/cheetah-run-medium-dynamic-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, obs.dtype
    ((84, 84, 3), dtype('uint8'))
    >>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    >>> env.close()
"""
from __future__ import annotations

import dataclasses
import numbers

import numpy as np
import torch
from dm_control import suite
from tensordict import TensorDict
from torchrl.data import Bounded

try:
    import gymnasium
    from gymnasium import spaces
except ModuleNotFoundError as error:  # only Gymnasium itself missing gets the install hint
    if error.name != "gymnasium" and not (error.name or "").startswith("gymnasium."):
        raise
    raise ModuleNotFoundError(
        'dcs_torchrl.gym_env needs Gymnasium, an optional extra of the package: pip install "dcs-torchrl[gym]" '
        '(in a clone: pip install -e ".[gym]").',
        name="gymnasium",
    ) from error

from dcs_torchrl import presets
from dcs_torchrl._compat.private_api import control_timestep
from dcs_torchrl.envs import EnvOptions, make_env

__all__ = ["DICT_LAYOUTS", "DistractingControlEnv", "DistractingControlVectorEnv", "NAMESPACE", "OBS_TYPES", "env_id",
           "register_envs"]

#: The Gymnasium namespace of the suite's ids.
NAMESPACE = "dcs"
#: What an observation can be: the frame alone, or a ``Dict`` of the frame, the physics state and
#: (with ``expose_distractions=True``) the distraction state.
OBS_TYPES = ("pixels", "dict")
#: How a ``Dict`` observation holds the distraction state: ``"nested"`` (a ``"distractions"`` Dict
#: of ``"camera"``, ``"color"``, ``"background"``, ...) or ``"flat"`` (``"distractions/camera"``, ... beside
#: ``"pixels"`` and ``"state"``: one level of Boxes, what Stable-Baselines3's ``MultiInputPolicy`` takes).
DICT_LAYOUTS = ("nested", "flat")
_VERSION = 0
# make_env's keywords (the fields of EnvOptions), each a setting of the Gymnasium env; pixels_only follows from obs_type.
_MAKE_ENV_SETTINGS = tuple(f.name for f in dataclasses.fields(EnvOptions) if f.name != "pixels_only")


def env_id(domain: str, task: str, benchmark: str = "none", dynamic: bool = False) -> str:
    """The Gymnasium id of a preset: ``dcs/<domain>-<task>-<benchmark>[-dynamic]-v0``.

    Examples:
        >>> env_id("ball_in_cup", "catch", "medium", dynamic=True)
        'dcs/ball_in_cup-catch-medium-dynamic-v0'
    """
    return f"{NAMESPACE}/{domain}-{task}-{benchmark}{'-dynamic' if dynamic else ''}-v{_VERSION}"


def register_envs() -> list[str]:
    """Registers every task (``dm_control.suite.ALL_TASKS``) with every benchmark, static and
    dynamic, in Gymnasium's registry; returns the ids. Idempotent (ids already there are kept).

    Called when this module is imported. ``dog fetch`` is registered but, as with
    :func:`~dcs_torchrl.make_env`, needs ``camera_id=2`` (its cameras 0 and 1 track a target).

    Examples:
        >>> "dcs/walker-walk-hard-dynamic-v0" in register_envs()
        True
    """
    ids = []
    for domain, task in suite.ALL_TASKS:
        for benchmark in presets.BENCHMARKS:
            for dynamic in (False, True):
                name = env_id(domain, task, benchmark, dynamic)
                if name not in gymnasium.registry:
                    gymnasium.register(
                        id=name,
                        entry_point=f"{__name__}:DistractingControlEnv",
                        vector_entry_point=f"{__name__}:DistractingControlVectorEnv",
                        kwargs={"domain": domain, "task": task, "benchmark": benchmark, "dynamic": dynamic,
                                "registered_id": name},
                    )
                ids.append(name)
    return ids


def _box(spec, dtype=None) -> spaces.Box:
    """The Gymnasium ``Box`` of a TorchRL spec: a ``Bounded`` one's bounds, else the widest (infinite for floats);
    of ``dtype`` if given (else the spec's)."""
    dtype = torch.empty((), dtype=spec.dtype).numpy().dtype if dtype is None else np.dtype(dtype)
    if isinstance(spec, Bounded):
        low, high = spec.space.low.cpu().numpy().astype(dtype), spec.space.high.cpu().numpy().astype(dtype)
    elif np.issubdtype(dtype, np.floating):
        low, high = -np.inf, np.inf
    else:
        low, high = np.iinfo(dtype).min, np.iinfo(dtype).max
    return spaces.Box(low=low, high=high, shape=tuple(spec.shape), dtype=dtype)


class DistractingControlEnv(gymnasium.Env):
    """A Distracting Control Suite env with Gymnasium's API, over :func:`~dcs_torchrl.make_env`.

    Each :meth:`step` is one step of the TorchRL env ``make_env`` builds (``action_repeat``
    physics steps, the distractions, one render); the arrays it returns are that env's
    tensors, so the frames are ``make_env``'s for the same seed and actions.

    Args:
        domain, task (str): a dm_control suite task, e.g. ``"cheetah", "run"``.

    Keyword Args:
        obs_type (str): ``"pixels"`` (default): the observation is the frame, a
            ``Box(0, 255, (height, width, 3), uint8)``. ``"dict"``: a ``Dict`` with ``"pixels"``
            (the frame), ``"state"`` (the task's physics observations, concatenated in
            dm_control's order, float64) and, with ``expose_distractions=True``,
            ``"distractions"`` (``"camera"``, ``"color"``, ``"background"``, and ``"lighting"`` /
            ``"texture"`` where their scale is not 0: what ``make_env(..., expose_distractions=True)`` reports).
        dict_layout (str): with ``obs_type="dict"``, how the distraction state is laid out:
            ``"nested"`` (default), a ``"distractions"`` Dict; ``"flat"``, the keys
            ``"distractions/camera"``, ``"distractions/color"``, ``"distractions/background"`` beside
            ``"pixels"`` and ``"state"`` (a Dict of Boxes only, which Stable-Baselines3 takes).
        render_mode (str, optional): ``None`` or ``"rgb_array"``: :meth:`render` returns the
            last frame, the observation's pixels (rendered once per step, not twice).
            ``gymnasium.make`` turns ``"rgb_array_list"`` and ``"human"`` into wrappers.
        registered_id (str, optional): set by the registry: the id ``gymnasium.make`` was given,
            whose task, benchmark and static/dynamic keywords must not contradict it.
        **settings: any keyword of :func:`~dcs_torchrl.make_env` (a field of
            :class:`~dcs_torchrl.EnvOptions`) but ``pixels_only`` (which
            ``obs_type`` decides): ``benchmark``, ``dynamic``, ``seed``, ``camera_scale``,
            ``height``, ``render_profile``, ... ``seed`` seeds as ``make_env(seed=...)``
            does; ``reset(seed=s)`` does the same later.

    Seeding: ``reset(seed=s)`` seeds the physics and every distraction as ``make_env(seed=s)``
    does (``env.set_seed(s)``), then resets: its frames are those of ``make_env(seed=s)``
    followed by ``reset()``. ``reset()`` without a seed continues the streams, as the TorchRL
    env does across its resets.

    The action space is ``Box(low, high, shape, float32)`` with the task's bounds (what
    Stable-Baselines3 expects); an action of any float dtype is passed on to the TorchRL env in
    its own dtype (dm_control's float64), so a float64 action is not rounded on the way.

    After :meth:`close`, :meth:`step` and :meth:`reset` raise ``gymnasium.error.ClosedEnvironmentError``.

    Episodes end as dm_control's do: at the task's time limit (1000 control steps on the
    paper's six tasks, so ``ceil(1000 / action_repeat)`` agent steps) with ``truncated=True``
    and ``terminated=False``; ``terminated=True`` only where the task itself ends the episode
    (discount 0, as TorchRL's ``DMControlEnv`` reports it). Step after either and the env
    asks for a :meth:`reset`.

    Attributes:
        torchrl_env: the ``make_env`` env it steps.

    Examples:
        >>> from dcs_torchrl.gym_env import DistractingControlEnv
        >>> env = DistractingControlEnv("cartpole", "swingup", benchmark="medium", obs_type="dict",
        ...                             render_mode="rgb_array")
        >>> obs, info = env.reset(seed=0)
        >>> obs["pixels"].shape, obs["state"].shape, env.action_space
        ((84, 84, 3), (5,), Box(-1.0, 1.0, (1,), float32))
        >>> bool((env.render() == obs["pixels"]).all())
        True
        >>> env.close()
    """

    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, domain: str, task: str, *, obs_type: str = "pixels", render_mode: str | None = None,
                 dict_layout: str = "nested", registered_id: str | None = None, **settings):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"unknown render_mode {render_mode!r}; choose one of {[None, *self.metadata['render_modes']]} "
                "(gymnasium.make(..., render_mode='rgb_array_list' or 'human') wraps 'rgb_array')."
            )
        if settings.get("backend", "gl") != "gl" or settings.get("num_envs") is not None:
            raise ValueError(
                "DistractingControlEnv is one env (backend='gl'): for a batch of envs rendered by MuJoCo Warp use "
                "gymnasium.make_vec(id, num_envs=N, vectorization_mode='vector_entry_point') "
                "(DistractingControlVectorEnv)."
            )
        seed = _checked_settings(domain, task, obs_type, dict_layout, registered_id, settings)
        self.render_mode = render_mode
        self.torchrl_env = make_env(domain, task, seed=seed, pixels_only=obs_type == "pixels", **settings)
        _set_spaces(self, self.torchrl_env, obs_type, dict_layout)
        base = self.torchrl_env.base_env
        # instance metadata: the frame rate of this task and action repeat (RecordVideo reads it)
        self.metadata = {**self.metadata, "render_fps": 1.0 / (control_timestep(base) * base.wrapper_frame_skip)}
        self._frame: np.ndarray | None = None
        self._needs_reset = True
        self._closed = False

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts an episode; ``seed`` reseeds the physics and every distraction first.

        Args:
            seed (int, optional): as ``make_env(seed=seed)``; ``None`` continues the streams.
            options (dict, optional): none are defined; ``None`` or ``{}``.

        Returns:
            ``(observation, info)``; ``info`` is an empty dict.
        """
        self._check_open("reset")
        if options:
            raise ValueError(f"reset takes no options, got {sorted(options)}; pass options=None (or {{}}).")
        if seed is not None:
            seed = _checked_seed(seed)
        super().reset(seed=seed)
        if seed is not None:
            self.torchrl_env.set_seed(seed)
        td = self.torchrl_env.reset()
        self._needs_reset = False
        return self._observation(td), {}

    def step(self, action):
        """One agent step: ``action_repeat`` physics steps, the distractions, one render.

        Returns:
            ``(observation, reward, terminated, truncated, info)``, ``reward`` the sum over the
            action repeat, as in ``make_env``'s env.
        """
        self._check_open("step")
        if self._needs_reset:
            raise gymnasium.error.ResetNeeded(
                "call reset() before step(): the env starts an episode at reset, and starts none after an "
                "episode ended (terminated or truncated)."
            )
        action = np.asarray(action)
        if action.shape != self._action_shape:
            raise ValueError(
                f"action must have shape {self._action_shape} (the action space {self.action_space}), got {action.shape}."
            )
        td = TensorDict({"action": torch.as_tensor(action, dtype=self._action_dtype)}, batch_size=())
        next_td = self.torchrl_env.step(td)["next"]
        terminated = bool(next_td["terminated"])
        truncated = bool(next_td["truncated"])
        self._needs_reset = terminated or truncated
        return self._observation(next_td), float(next_td["reward"]), terminated, truncated, {}

    def render(self):
        """The last frame (``render_mode="rgb_array"``), a copy of the observation's pixels: no second
        render. ``None`` without a render mode."""
        if self.render_mode is None:
            return None
        if self._frame is None:
            raise gymnasium.error.ResetNeeded("call reset() before render(): the first frame is rendered at reset.")
        return self._frame.copy()

    def close(self):
        """Closes the TorchRL env (and so its render context); calling it twice is harmless."""
        if not self._closed:
            self._closed = True
            self.torchrl_env.close()

    # -------------------------------------------------------------- helpers
    def _check_open(self, call: str) -> None:
        if self._closed:
            raise gymnasium.error.ClosedEnvironmentError(
                f"{call}() after close(): this env's TorchRL env and render context are closed; make a new env "
                "(gymnasium.make(...) or DistractingControlEnv(...))."
            )

    def _observation(self, td):
        self._frame = td["pixels"].cpu().numpy()
        return _observation(self, td, self._frame)


class DistractingControlVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` Distracting Control Suite envs as one Gymnasium vector env, over
    ``make_env(..., num_envs=num_envs, backend=backend)``: by default ``backend="warp"``, their physics
    stepped in this process, their frames rendered in one MuJoCo Warp batch (``pip install
    "dcs-torchrl[warp]"``; docs/batched.md); ``backend="gl"``, one process each
    (:class:`~dcs_torchrl.ParallelSuiteEnv`), the same episodes.

    ``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` builds it for any
    registered id (keywords as for ``gymnasium.make``). Sub-env ``i`` is env ``i`` of the batched env:
    for ``reset(seed=s)`` its episodes are those of ``ParallelSuiteEnv(N, ...)`` seeded ``s``, worker ``i``
    (TorchRL's chain of seeds). Autoreset is Gymnasium's default, ``NEXT_STEP``: the step after a
    sub-env's episode ended resets it (its action unused, reward 0, the new episode's first frame).
    ``reset(options={"reset_mask": mask})`` resets the marked sub-envs only; the others continue.

    Args:
        domain, task (str): a dm_control suite task.
        num_envs (int): the sub-envs.

    Keyword Args:
        obs_type, dict_layout, **settings: as :class:`DistractingControlEnv` (``device`` is where Warp
            renders; the arrays returned are NumPy's, on the host).

    Examples:
        >>> import gymnasium, dcs_torchrl.gym_env
        >>> envs = gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=3,
        ...                           vectorization_mode="vector_entry_point", height=32, width=32)
        >>> obs, info = envs.reset(seed=0)
        >>> obs.shape, envs.action_space.shape
        ((3, 32, 32, 3), (3, 1))
        >>> obs, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
        >>> envs.close()
    """

    metadata = {"autoreset_mode": gymnasium.vector.AutoresetMode.NEXT_STEP}

    def __init__(self, domain: str, task: str, num_envs: int = 1, *, obs_type: str = "pixels",
                 dict_layout: str = "nested", registered_id: str | None = None, **settings):
        if settings.pop("render_mode", None) is not None:
            raise ValueError("DistractingControlVectorEnv has no render mode: the frames are its observations.")
        settings.setdefault("backend", "warp")
        seed = _checked_settings(domain, task, obs_type, dict_layout, registered_id, settings)
        self.torchrl_env = make_env(domain, task, seed=seed, pixels_only=obs_type == "pixels", num_envs=num_envs,
                                    **settings)
        self.num_envs = int(num_envs)
        _set_spaces(self, self.torchrl_env, obs_type, dict_layout)  # one sub-env's, then batched
        self.single_observation_space, self.single_action_space = self.observation_space, self.action_space
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self._ended = np.zeros(self.num_envs, bool)
        self._needs_reset = True

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts every sub-env's episode (or those of ``options["reset_mask"]``); ``seed`` (an int)
        reseeds them first as :meth:`dcs_torchrl.vector.batched.BatchedSuiteEnv.set_seed` does."""
        self._check_open("reset")
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if options:
            raise ValueError(f"reset takes only the option reset_mask, got {sorted(options)}.")
        if seed is not None and not isinstance(seed, numbers.Integral):
            raise ValueError(f"seed must be one integer (sub-env i gets the i-th seed of its chain), got {seed!r}.")
        if seed is not None:
            seed = _checked_seed(seed)
            super().reset(seed=seed)
            self.torchrl_env.set_seed(seed)
        if mask is None:
            td = self.torchrl_env.reset()
            self._ended[:] = False
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != bool:
                raise ValueError(f"reset_mask must be a bool array of shape ({self.num_envs},), got {mask!r}.")
            if self._needs_reset:
                raise gymnasium.error.ResetNeeded("call reset() without reset_mask first: no sub-env has started.")
            # TorchRL's partial reset returns the given entries of the sub-envs not reset: the last ones
            td = self.torchrl_env.reset(self._last.clone().set("_reset", torch.from_numpy(mask).reshape(-1, 1)))
            self._ended[mask] = False
        self._needs_reset = False
        self._last = td.exclude("_reset")
        return _observation(self, td, td["pixels"].cpu().numpy()), {}

    def step(self, actions):
        """One agent step of every sub-env; a sub-env whose episode ended at the last step is reset instead."""
        self._check_open("step")
        if self._needs_reset:
            raise gymnasium.error.ResetNeeded("call reset() before step().")
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape} (the action space), got {actions.shape}.")
        ended = self._ended.copy()
        env = self.torchrl_env
        if ended.any():  # NEXT_STEP autoreset: these start a new episode now
            out = env.reset(TensorDict({"_reset": torch.from_numpy(ended).reshape(-1, 1)}, batch_size=[self.num_envs]))
        if not ended.all():
            td = TensorDict({"action": torch.as_tensor(actions, dtype=self._action_dtype)}, batch_size=[self.num_envs])
            if ended.any():
                td.set("_step", torch.from_numpy(~ended))
            out = env.step(td)["next"]
        else:  # every sub-env restarted: no step
            out = out.set("reward", torch.zeros((self.num_envs, 1)))
        terminated = out["terminated"].reshape(self.num_envs).cpu().numpy().copy()
        truncated = out["truncated"].reshape(self.num_envs).cpu().numpy().copy()
        rewards = out["reward"].reshape(self.num_envs).cpu().numpy().astype(np.float64)
        terminated[ended] = truncated[ended] = False
        rewards[ended] = 0.0
        self._ended = terminated | truncated
        self._last = out.select(*self._last.keys(True, True))
        return _observation(self, out, out["pixels"].cpu().numpy()), rewards, terminated, truncated, {}

    def close_extras(self, **kwargs):
        self.torchrl_env.close(raise_if_closed=False)

    def _check_open(self, call: str) -> None:
        if self.closed:
            raise gymnasium.error.ClosedEnvironmentError(f"{call}() after close(): make a new vector env.")


def _checked_settings(domain: str, task: str, obs_type: str, dict_layout: str, registered_id: str | None,
                      settings: dict) -> int | None:
    """Refuses what the Gymnasium envs cannot take (naming the fix); pops and returns the seed."""
    if registered_id is not None:
        _check_id(registered_id, domain, task, settings.get("benchmark", "none"), settings.get("dynamic", False))
    if obs_type not in OBS_TYPES:
        raise ValueError(f"unknown obs_type {obs_type!r}; choose one of {list(OBS_TYPES)}.")
    if dict_layout not in DICT_LAYOUTS:
        raise ValueError(f"unknown dict_layout {dict_layout!r}; choose one of {list(DICT_LAYOUTS)}.")
    if dict_layout != "nested" and obs_type != "dict":
        raise ValueError(f"dict_layout={dict_layout!r} lays out a Dict observation: pass obs_type='dict' too.")
    if "pixels_only" in settings:
        raise ValueError(
            "pixels_only is not a setting of the Gymnasium env: obs_type decides it; pass "
            "obs_type='pixels' (the frame) or obs_type='dict' (the frame and the physics state)."
        )
    unknown = sorted(set(settings) - set(_MAKE_ENV_SETTINGS))
    if unknown:
        raise ValueError(
            f"unknown env setting(s) {unknown}: choose among {list(_MAKE_ENV_SETTINGS)} (make_env's) "
            "or obs_type, render_mode, dict_layout."
        )
    if settings.get("expose_distractions") and obs_type != "dict":
        raise ValueError(
            "expose_distractions=True adds the distraction state to a Dict observation: pass obs_type='dict' too."
        )
    seed = settings.pop("seed", None)
    return None if seed is None else _checked_seed(seed)


def _set_spaces(owner, env, obs_type: str, dict_layout: str) -> None:
    """One env's action and observation spaces (of a batched TorchRL env: one sub-env's) on
    ``owner``, with what :func:`_observation` needs to convert its observations."""
    action_spec = env.action_spec[0] if env.batch_size else env.action_spec
    observation_spec = env.observation_spec[0] if env.batch_size else env.observation_spec
    owner.obs_type, owner.dict_layout = obs_type, dict_layout
    owner._action_dtype = action_spec.dtype
    owner._action_shape = tuple(action_spec.shape)
    owner.action_space = _box(action_spec, np.float32)
    pixels = spaces.Box(0, 255, tuple(observation_spec["pixels"].shape), np.uint8)
    owner._state_keys, owner._distraction_keys = [], []
    if obs_type == "pixels":
        owner.observation_space = pixels
        return
    # the task's physics observations, in dm_control's order (before the distractions and the frame)
    owner._state_keys = [k for k in observation_spec.keys(True, True)
                         if k not in ("pixels", "masks") and not (isinstance(k, tuple) and k[0] == "distractions")]
    size = sum(int(np.prod(observation_spec[k].shape)) for k in owner._state_keys)
    observation = {"pixels": pixels, "state": spaces.Box(-np.inf, np.inf, (size,), np.float64)}
    if "distractions" in observation_spec.keys():
        distractions = observation_spec["distractions"]
        owner._distraction_keys = list(distractions.keys())
        boxes = {k: _box(distractions[k]) for k in owner._distraction_keys}
        if dict_layout == "flat":
            observation |= {f"distractions/{k}": box for k, box in boxes.items()}
        else:
            observation["distractions"] = spaces.Dict(boxes)
    owner.observation_space = spaces.Dict(observation)


def _observation(owner, td, frame: np.ndarray):
    """The Gymnasium observation of ``td`` (one env's, or a batch's: each array then leads with the batch)."""
    if owner.obs_type == "pixels":
        return frame
    lead = tuple(td.batch_size)
    state = np.concatenate([td[k].cpu().numpy().reshape(*lead, -1) for k in owner._state_keys], axis=-1)
    obs = {"pixels": frame, "state": state.astype(np.float64, copy=False)}
    if owner._distraction_keys:
        distractions = {k: td["distractions", k].cpu().numpy() for k in owner._distraction_keys}
        if owner.dict_layout == "flat":
            obs |= {f"distractions/{k}": value for k, value in distractions.items()}
        else:
            obs["distractions"] = distractions
    return obs


def _check_id(registered_id: str, domain: str, task: str, benchmark: str, dynamic: bool) -> None:
    """Refuses ``gymnasium.make(id, ...)`` keywords that name another preset than the id does, or none."""
    if benchmark not in presets.BENCHMARKS:
        raise ValueError(
            f"gymnasium.make({registered_id!r}) was given benchmark={benchmark!r}, which is no benchmark of the "
            f"suite; choose one of {list(presets.BENCHMARKS)}, in the id (dcs/<domain>-<task>-<benchmark>"
            "[-dynamic]-v0) or as the keyword; single settings override it (camera_scale=..., num_videos=..., ...)."
        )
    if (domain, task) not in suite.ALL_TASKS:
        raise ValueError(
            f"gymnasium.make({registered_id!r}) was given domain={domain!r}, task={task!r}, which is no dm_control "
            "suite task (dm_control.suite.ALL_TASKS): name the task in the id, dcs/<domain>-<task>-<benchmark>"
            "[-dynamic]-v0, not as keywords."
        )
    asked = env_id(domain, task, benchmark, bool(dynamic))
    if asked != registered_id:
        raise ValueError(
            f"gymnasium.make({registered_id!r}) was given keywords for another preset ({asked!r}): make that id "
            "instead, or override single settings of this one (camera_scale=..., num_videos=..., ...)."
        )


def _checked_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or not 0 <= int(seed) < 2**32:
        raise ValueError(f"seed must be a non-negative integer below 2**32 (or None), got {seed!r}.")
    return int(seed)


register_envs()
