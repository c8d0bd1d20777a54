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
(``./common/skybox.xml``'s text)               skybox's ``width``/``height`` rewritten while
                                               the envs of a batch whose sky is never rendered
                                               compile (dm_control takes no texture size).
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
Warp's ``Device.runtime``, ``.context_guard``  :mod:`dcs_torchrl.render.warp`: MuJoCo Warp
and ``Runtime.default_device``                 launches on the process's one default device,
                                               which ``wp.ScopedDevice`` sets and puts back per
                                               block; render threads overlapping would put it
                                               back under each other, so one counted scope
                                               (``DEFAULT_DEVICE``) sets it as ScopedDevice does.
=============================================  ==============================================
"""
from __future__ import annotations

import weakref
from typing import NamedTuple

from torchrl.envs.transforms.utils import _set_missing_tolerance as set_missing_tolerance
from torchrl._utils import seed_generator
from torchrl.objectives.utils import _vmap_func as vmap_func

__all__ = [
    "PRIVATE_SYMBOLS", "base_set_seed", "build_default_value_estimator", "container_of", "control_timestep", "dm_physics",
    "episode_clock", "set_episode_clock", "sub_steps",
    "free_foreign_render_contexts", "priority_weight", "reduce_loss", "RenderOffsets", "render_offsets", "replace_set_seed",
    "sac_alpha_loss", "seed_generator",
    "set_missing_tolerance", "value_estimator_kwargs", "vmap_func",
]

#: ``(owner, attribute, user)`` of every private symbol above (the test checks each one).
PRIVATE_SYMBOLS = (
    ("torchrl.envs.EnvBase", "_set_seed", "dcs_torchrl.distractions.base"),
    ("torchrl.envs.Transform", "_container", "dcs_torchrl._scene"),
    ("torchrl.envs.DMControlEnv", "_env", "dcs_torchrl._scene, dcs_torchrl.gym_env, dcs_torchrl.vector.batched"),
    ("dm_control.mujoco.Physics", "_contexts", "dcs_torchrl.render.gl"),
    ("dm_control.mujoco.Physics", "_free_rendering_contexts", "dcs_torchrl.render.gl"),
    ("dm_control.suite.common", "ASSETS", "dcs_torchrl.vector.batched"),
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
          for field in ("rgb_data", "rgb_adr", "seg_data", "seg_adr", "ray", "cam_res", "_megakernel")) + (
    ("warp.Device", "runtime", "dcs_torchrl.render.warp"), ("warp.Device", "context_guard", "dcs_torchrl.render.warp"),
    ("warp._src.context.Runtime", "default_device", "dcs_torchrl.render.warp"))


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
