"""Every private API of TorchRL, dm_control and MuJoCo Warp the package uses, in one place.

Each entry names the symbol, where the package relies on it, and why no public API does the
job (TorchRL 0.14, dm_control 1.0, mujoco_warp 3.17). ``tests/test_private_api.py`` checks
that every symbol is still there, so that an upgrade that removes one fails with a message
naming it and its user, not deep inside a rollout or an update. Public APIs are used
everywhere else.

=============================================  ==============================================
symbol                                         used by, and why
=============================================  ==============================================
``EnvBase._set_seed`` (instance attribute)     :mod:`dcs_torchrl.distractions.base`: TorchRL
                                               has no seed hook for transforms
                                               (``TransformedEnv.set_seed`` seeds the base
                                               env only), so ``env.set_seed(s)`` reaches the
                                               distractions through the base env's hook.
``Transform._container``                       :mod:`dcs_torchrl._scene`: the *live*
                                               container chain (``Transform.parent`` is built
                                               from clones, and ``container`` resolves
                                               lazily).
``DMControlEnv._env``                          :mod:`dcs_torchrl._scene`: the wrapped
                                               dm_control env, for its ``physics`` (no public
                                               accessor); :mod:`dcs_torchrl.gym_env`: its
                                               ``control_timestep()``, for ``render_fps``;
                                               :mod:`dcs_torchrl.vector.batched`: the dm_control env
                                               each env of a batch steps.
``Physics._contexts``,                         :mod:`dcs_torchrl.render.gl`: a render context
``Physics._free_rendering_contexts``           made by someone else with other settings is
                                               freed before the suite's own is made.
``torchrl.envs.transforms.utils.               :mod:`dcs_torchrl.modules.augment`: an
_set_missing_tolerance``                       augmentation applied at reset tolerates the
                                               missing ``pixels`` key, as TorchRL's own
                                               transforms do.
``torchrl.objectives.utils._vmap_func``        :mod:`dcs_torchrl.objectives.qtopt`: the Q
                                               heads evaluated at once, as ``SACLoss`` does.
``SACLoss._compute_target_v2``,                :mod:`dcs_torchrl.objectives.sac`: DrQ's target
``SACLoss._vmap_qnetworkN0``, ``._alpha``      (averaged over K augmented next observations)
                                               replaces SACLoss's target computation, its one
                                               extension point for the target.
``SACLoss._alpha_loss``                        :mod:`dcs_torchrl.objectives.sac`: the
                                               temperature loss of the first copy, as
                                               ``SACLoss.forward`` computes it.
``LossModule._reduce_loss``,                   :mod:`dcs_torchrl.objectives.sac` and
``._maybe_get_priority_weight``                :mod:`~dcs_torchrl.objectives.qtopt`: the
                                               loss's reduction and prioritised-replay weights,
                                               as TorchRL's own losses apply them.
``LossModule._default_value_estimator``        both losses: the value estimator built in
                                               ``__init__``, so ``state_dict()`` has its keys
                                               before the first forward.
``LossModule.                                  :mod:`dcs_torchrl.objectives.qtopt`:
_prepare_value_estimator_kwargs``              ``make_value_estimator``'s defaults (gamma
                                               ...), as TorchRL's losses resolve them.
``dm_control.suite.common.ASSETS``             :func:`dcs_torchrl.vector.batched.compact_skies`: the
(``./common/skybox.xml``'s text,               skybox's ``width``/``height`` rewritten while
``./common/materials.xml``'s)                  the envs of a batch whose sky is never rendered
                                               compile (dm_control takes no texture size);
                                               :func:`dcs_torchrl.distractions.texture.surface_slot`:
                                               one more 2D texture for the bodies (dm_control
                                               takes no extra assets for its suite models).
``mujoco_warp.RenderContext``'s ``textures``,  :meth:`dcs_torchrl.render.warp.WarpRenderer.add_textures`:
``textures_registry``                          the texture distraction's blends beside the model's
                                               textures, which the trace samples by id (MuJoCo Warp
                                               makes textures only from the model).
``mujoco_warp.RenderContext``'s ``rgb_data``,  :mod:`dcs_torchrl.render.warp`: one kernel reads
``rgb_adr``, ``seg_data``, ``seg_adr``,        the trace's packed colours, segmentation and
``ray``, ``cam_res``                           camera-frame rays where a camera's pixels start
                                               (:func:`render_offsets`) and finishes each pixel
                                               (sky, see-through floor, labels) in one pass;
                                               ``get_rgb`` / ``get_segmentation`` copy each
                                               buffer out apart, and nothing public gives rays.
dm_control ``Environment._step_count``,        :mod:`dcs_torchrl.vector.batch_physics`: steps the
``._step_limit``, ``._reset_next_step``,       physics of a batch's envs without their
``._n_sub_steps``                              ``step`` (MuJoCo's C over threads), so keeps
                                               their episode clocks as ``step`` keeps them; no
                                               public accessor has them.
``torchrl._utils.seed_generator``              :mod:`dcs_torchrl.datasets.metadata`: the seed
                                               ``EnvBase.set_seed`` returns, for episode k's
                                               seed without building k envs.
``RenderContext._megakernel``                  :mod:`dcs_torchrl.render.warp`: MuJoCo Warp
                                               builds a context's kernel at its first render
                                               and keeps it there; a renderer renders once when
                                               made, so that renderers made in one thread and
                                               rendering in several never build it at once.
``MjModel._address``, ``MjData._address``;    :mod:`dcs_torchrl.vector._mjstep`: the batch's
the ``mujoco`` wheel's shared library          physics stepped by one compiled call over all
(``libmujoco``) and its C functions            the worlds (no Python per world) on each world's
``mj_step``, ``mj_step1``, ``mj_step2``        own ``MjData``; the bindings give no address of
                                               a struct nor of a C function
                                               (:func:`mujoco_c_api` checks them all).
Warp's ``Device.runtime``, ``.context_guard``  :mod:`dcs_torchrl.render.warp`: MuJoCo Warp
and ``Runtime.default_device``                 launches on the process's one default device,
                                               which ``wp.ScopedDevice`` sets and puts back per
                                               block; render threads overlapping would put it
                                               back under each other, so one counted scope
                                               (``DEFAULT_DEVICE``) sets it as ScopedDevice does.
=============================================  ==============================================
"""
from __future__ import annotations

import ctypes
import functools
import glob
import os
import weakref
from typing import NamedTuple

import numpy as np
from torchrl.envs.transforms.utils import _set_missing_tolerance as set_missing_tolerance
from torchrl._utils import seed_generator
from torchrl.objectives.utils import _vmap_func as vmap_func

__all__ = [
    "PRIVATE_SYMBOLS", "base_set_seed", "build_default_value_estimator", "container_of", "control_timestep", "dm_physics",
    "episode_clock", "set_episode_clock", "sub_steps",
    "free_foreign_render_contexts", "MUJOCO_C_API", "MujocoCApi", "mujoco_c_api",
    "priority_weight", "reduce_loss", "RenderOffsets", "render_offsets", "replace_set_seed",
    "sac_alpha_loss", "seed_generator",
    "set_missing_tolerance", "struct_addresses", "value_estimator_kwargs", "vmap_func",
]

#: ``(owner, attribute, user)`` of every private symbol above (the test checks each one).
PRIVATE_SYMBOLS = (
    ("torchrl.envs.EnvBase", "_set_seed", "dcs_torchrl.distractions.base"),
    ("torchrl.envs.Transform", "_container", "dcs_torchrl._scene"),
    ("torchrl.envs.DMControlEnv", "_env", "dcs_torchrl._scene, dcs_torchrl.gym_env, dcs_torchrl.vector.batched"),
    ("dm_control.mujoco.Physics", "_contexts", "dcs_torchrl.render.gl"),
    ("dm_control.mujoco.Physics", "_free_rendering_contexts", "dcs_torchrl.render.gl"),
    ("dm_control.suite.common", "ASSETS", "dcs_torchrl.vector.batched, dcs_torchrl.distractions.texture"),
    ("torchrl.envs.transforms.utils", "_set_missing_tolerance", "dcs_torchrl.modules.augment"),
    ("torchrl.objectives.utils", "_vmap_func", "dcs_torchrl.objectives.qtopt"),
    ("torchrl.objectives.SACLoss", "_compute_target_v2", "dcs_torchrl.objectives.sac"),
    ("torchrl.objectives.SACLoss", "_vmap_qnetworkN0", "dcs_torchrl.objectives.sac"),
    ("torchrl.objectives.SACLoss", "_alpha", "dcs_torchrl.objectives.sac"),
    ("torchrl.objectives.SACLoss", "_alpha_loss", "dcs_torchrl.objectives.sac"),
    ("torchrl.objectives.LossModule", "_reduce_loss", "dcs_torchrl.objectives.sac, dcs_torchrl.objectives.qtopt"),
    ("torchrl.objectives.LossModule", "_maybe_get_priority_weight", "dcs_torchrl.objectives.sac, dcs_torchrl.objectives.qtopt"),
    ("torchrl.objectives.LossModule", "_default_value_estimator", "dcs_torchrl.objectives.sac, dcs_torchrl.objectives.qtopt"),
    ("torchrl.objectives.LossModule", "_prepare_value_estimator_kwargs", "dcs_torchrl.objectives.qtopt"),
    ("torchrl._utils", "seed_generator", "dcs_torchrl.datasets.metadata"),
) + tuple(("dm_control.rl.control.Environment", field, "dcs_torchrl.vector.batch_physics")
          for field in ("_step_count", "_step_limit", "_reset_next_step", "_n_sub_steps")) + tuple(("mujoco_warp.RenderContext", field, "dcs_torchrl.render.warp")
          for field in ("rgb_data", "rgb_adr", "seg_data", "seg_adr", "ray", "cam_res", "_megakernel", "textures",
                        "textures_registry")) + (
    ("warp.Device", "runtime", "dcs_torchrl.render.warp"), ("warp.Device", "context_guard", "dcs_torchrl.render.warp"),
    ("warp._src.context.Runtime", "default_device", "dcs_torchrl.render.warp"),
    ("mujoco.MjModel", "_address", "dcs_torchrl.vector._mjstep"),
    ("mujoco.MjData", "_address", "dcs_torchrl.vector._mjstep"))


def episode_clock(dm_env) -> tuple[int, float, bool]:
    """A dm_control ``Environment``'s control steps this episode, its time limit in control steps and
    whether its episode is over (its next ``step`` resets it)."""
    return dm_env._step_count, dm_env._step_limit, dm_env._reset_next_step


def set_episode_clock(dm_env, count: int, over: bool) -> None:
    """Sets what ``Environment.step`` sets after stepping: the count and whether the episode ended."""
    dm_env._step_count = count
    dm_env._reset_next_step = over


def sub_steps(dm_env) -> int:
    """A dm_control ``Environment``'s physics steps per control step."""
    return int(dm_env._n_sub_steps)


def base_set_seed(base_env):
    """The seed hook ``base_env.set_seed`` calls (possibly one installed by :func:`replace_set_seed`)."""
    return base_env.__dict__.get("_set_seed", base_env._set_seed)


def replace_set_seed(base_env, hook) -> None:
    """Makes ``base_env.set_seed(s)`` call ``hook(s)`` instead of the env's own ``_set_seed``."""
    base_env.__dict__["_set_seed"] = hook


def container_of(transform):
    """The env or ``Compose`` ``transform`` is attached to (``None`` if none), without cloning."""
    ref = transform.__dict__.get("_container")
    return ref() if isinstance(ref, weakref.ref) else ref


def dm_physics(base_env):
    """The dm_control ``Physics`` of a TorchRL ``DMControlEnv`` / ``DMControlWrapper``."""
    return base_env._env.physics


def control_timestep(base_env) -> float:
    """Seconds of simulated time per control step of a TorchRL ``DMControlEnv`` (before its frame skip)."""
    return float(base_env._env.control_timestep())


def free_foreign_render_contexts(physics) -> None:
    """Frees ``physics``'s render contexts if it has any (made elsewhere, with other settings)."""
    if getattr(physics, "_contexts", None):
        physics._free_rendering_contexts()


def reduce_loss(loss_module, loss, *, weights=None):
    """``loss`` reduced by ``loss_module.reduction``, weighted by ``weights`` (priority weights) if given."""
    return loss_module._reduce_loss(loss, weights=weights)


def priority_weight(loss_module, tensordict):
    """The importance weights of a prioritised-replay sample in ``tensordict`` (``None`` if there are none)."""
    return loss_module._maybe_get_priority_weight(tensordict)


def build_default_value_estimator(loss_module) -> None:
    """Builds ``loss_module``'s default value estimator now (TorchRL builds it at first use)."""
    loss_module._default_value_estimator()


def value_estimator_kwargs(loss_module, value_type, **hyperparams):
    """``make_value_estimator``'s preamble: ``(value_type, hyperparams)`` with TorchRL's defaults,
    or ``(None, None)`` when TorchRL handled the call itself (an estimator instance or class)."""
    return loss_module._prepare_value_estimator_kwargs(value_type, **hyperparams)


def sac_alpha_loss(sac_loss, log_prob):
    """``SACLoss``'s temperature loss for ``log_prob`` (unreduced)."""
    return sac_loss._alpha_loss(log_prob)


class RenderOffsets(NamedTuple):
    """Where one active camera's pixels start in a MuJoCo Warp render context's buffers."""

    rgb: int  #: in each world's row of ``rgb_data`` (packed colours)
    seg: int  #: in each world's row of ``seg_data`` (``(geom, object type)`` per pixel)
    ray: int  #: in ``ray`` (camera-frame directions, shared by the worlds)


def render_offsets(context, index: int) -> RenderOffsets:
    """:class:`RenderOffsets` of the ``index``-th active camera of a ``mujoco_warp.RenderContext``
    made with colours and segmentation on (its ``rgb_adr`` and ``seg_adr``; the rays of the active
    cameras follow one another, ``cam_res`` pixels each)."""
    resolutions = context.cam_res.numpy()
    rgb, seg = int(context.rgb_adr.numpy()[index]), int(context.seg_adr.numpy()[index])
    if rgb < 0 or seg < 0:
        raise ValueError(f"camera {index} of this render context renders no colours or no segmentation: "
                         "make it with render_rgb=True and render_seg=True.")
    return RenderOffsets(rgb, seg, int(sum(int(w) * int(h) for w, h in resolutions[:index])))


#: The MuJoCo whose C API :func:`mujoco_c_api` was written and checked against (the ``[warp]`` extra's).
MUJOCO_C_API = "3.17"
#: The C functions of MuJoCo's library the batch's compiled physics calls, ``(name, argument count)``
#: (``void mj_step(const mjModel*, mjData*)`` and its two halves).
_STEP_FUNCTIONS = (("mj_step", 2), ("mj_step1", 2), ("mj_step2", 2))


class MujocoCApi(NamedTuple):
    """MuJoCo's C library as the ``mujoco`` package's bindings load it."""

    path: str  #: the shared library in the ``mujoco`` wheel's folder
    library: ctypes.CDLL  #: it, opened by ctypes (the bindings' own copy: the same version)
    functions: dict  #: the address of each of ``mj_step``, ``mj_step1``, ``mj_step2``


def _c_api_error(problem: str) -> RuntimeError:
    import mujoco

    return RuntimeError(f"{problem} (mujoco {mujoco.__version__}): dcs_torchrl.vector's batch physics calls MuJoCo's "
                        f"C library directly and was checked against mujoco {MUJOCO_C_API} (the [warp] extra's "
                        f"mujoco>=3.17,<4); install mujoco=={MUJOCO_C_API}.0 (pip install 'mujoco=={MUJOCO_C_API}.0'), "
                        "or port dcs_torchrl/_compat/private_api.py's mujoco_c_api to this version.")


@functools.cache
def mujoco_c_api() -> MujocoCApi:
    """MuJoCo's C library from the ``mujoco`` wheel's folder (``libmujoco.so.*``, ``libmujoco.*.dylib`` or
    ``mujoco.dll``), checked to be the library the bindings call (its ``mj_version``) and to export the step
    functions; raises ``RuntimeError`` naming the version to pin if not."""
    import mujoco

    folder = os.path.dirname(mujoco.__file__)
    found = sorted(path for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll")
                   for path in glob.glob(os.path.join(folder, pattern)))
    if len(found) != 1:
        raise _c_api_error(f"expected one MuJoCo shared library in {folder}, found {found}")
    library = ctypes.CDLL(found[0])
    try:
        version, functions = library.mj_version, {name: library[name] for name, _ in _STEP_FUNCTIONS}
    except AttributeError as error:
        raise _c_api_error(f"{found[0]} lacks a function: {error}") from None
    version.restype, version.argtypes = ctypes.c_int, []
    if version() != mujoco.mj_version():
        raise _c_api_error(f"{found[0]} is MuJoCo {version()}, the bindings {mujoco.mj_version()}")
    for name, count in _STEP_FUNCTIONS:
        functions[name].restype, functions[name].argtypes = None, [ctypes.c_void_p] * count
    library.mj_getState.restype = None  # void mj_getState(const mjModel*, const mjData*, mjtNum*, int)
    library.mj_getState.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
    return MujocoCApi(found[0], library, {name: ctypes.cast(f, ctypes.c_void_p).value for name, f in functions.items()})


def struct_addresses(model, data) -> tuple[int, int]:
    """The C addresses of an ``MjModel`` and an ``MjData`` of it (their ``_address``), checked: MuJoCo's
    C ``mj_getState`` called on them through :func:`mujoco_c_api` gives the bindings' ``mj_getState``."""
    import mujoco

    try:
        addresses = int(model._address), int(data._address)
    except AttributeError as error:
        raise _c_api_error(f"the bindings' structs have no C address: {error}") from None
    library, spec = mujoco_c_api().library, int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    expected = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, expected, spec)
    state = np.full_like(expected, np.nan)
    library.mj_getState(*addresses, state.ctypes.data, spec)
    if not np.array_equal(state, expected, equal_nan=True):
        raise _c_api_error("MuJoCo's C mj_getState on MjModel._address / MjData._address differs from the bindings'")
    return addresses
