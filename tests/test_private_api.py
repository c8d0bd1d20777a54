"""Every private TorchRL / dm_control / MuJoCo Warp symbol the package uses still exists (dcs_torchrl/_compat/private_api.py).

An upgrade that removes one fails here, with the symbol and the module that needs it named,
instead of deep inside a rollout or an update.
"""
import ast
import importlib
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import torch
from dm_control import suite
from dm_control.mujoco import Physics
from mujoco_warp import RenderContext
from torchrl.data import Bounded
from torchrl.envs import DMControlEnv, EnvBase, ParallelEnv, SerialEnv, Transform, TransformedEnv
from torchrl.objectives import LossModule, SACLoss

import dcs_torchrl as dcs
from dcs_torchrl._compat import private_api as _private_api
from dcs_torchrl.modules import make_critic, make_encoder, make_sac_actor
from dcs_torchrl.objectives import DrQSACLoss


def _resolve(path: str):
    module, _, name = path.rpartition(".")
    try:
        return importlib.import_module(path)
    except ModuleNotFoundError:
        return getattr(importlib.import_module(module), name)


#: The two cameras of cartpole at two sizes (width, height): the second one's pixels start after the first's.
CAMERAS = ((8, 6), (12, 10))


@pytest.fixture(scope="module")
def warp_context():
    """A MuJoCo Warp render context of two worlds of cartpole, both cameras, each kernel once:
    ``(context, its kernel before the first render, after it, after a second, Warp's CPU device)``."""
    from dcs_torchrl.render.warp import import_warp

    wp, mjw = import_warp("cpu")
    physics = suite.load("cartpole", "swingup", task_kwargs={"random": 0}).physics
    mjm = physics.model.ptr
    with wp.ScopedDevice("cpu"):
        model = mjw.put_model(mjm)
        data = mjw.put_data(mjm, physics.data.ptr, nworld=2, nconmax=1, njmax=1)
        context = mjw.create_render_context(mjm, nworld=2, cam_res=list(CAMERAS), render_rgb=True, render_depth=False,
                                            render_seg=True, cam_active=[0, 1])
        kernels = [context._megakernel]
        for _ in range(2):
            mjw.refit_bvh(model, data, context)
            mjw.render(model, data, context)
            kernels.append(context._megakernel)
    return context, kernels, wp.get_device("cpu")


@pytest.fixture(scope="module")
def live_objects(warp_context):
    """Instances whose instance-level private attributes are checked."""
    env = dcs.make_env("cartpole", "swingup", seed=0)
    env.rollout(2)  # makes the render context
    spec = Bounded(-1.0, 1.0, (1,))
    encoder = make_encoder((9, 84, 84))
    loss = DrQSACLoss(make_sac_actor(spec, encoder.feature_dim, hidden_dim=8),
                      [make_critic(spec, encoder.feature_dim, hidden_dim=8) for _ in range(2)],
                      encoder=encoder, num_augmentations=0)
    physics = _private_api.dm_physics(env.base_env)
    objects = {
        "torchrl.envs.EnvBase": env.base_env,
        "torchrl.envs.Transform": env.transform[-1],
        "torchrl.envs.DMControlEnv": env.base_env,
        "dm_control.mujoco.Physics": physics,
        "torchrl.objectives.SACLoss": loss,
        "mujoco_warp.RenderContext": warp_context[0],
        "dm_control.rl.control.Environment": env.base_env._env,
        "warp.Device": warp_context[2],
        "warp._src.context.Runtime": warp_context[2].runtime,
    }
    yield objects
    env.close()


@pytest.mark.parametrize("owner, attribute, user", _private_api.PRIVATE_SYMBOLS,
                         ids=[f"{o}.{a}" for o, a, _ in _private_api.PRIVATE_SYMBOLS])
def test_private_symbol_still_exists(owner, attribute, user, live_objects):
    target = _resolve(owner)
    instance = live_objects.get(owner)
    found = hasattr(target, attribute) or (instance is not None and (
        attribute in vars(instance) or hasattr(instance, attribute)))
    assert found, (
        f"{owner}.{attribute} is gone (torch {torch.__version__}): {user} relies on it, see "
        "dcs_torchrl/_compat/private_api.py for why; port that use to the new API or pin the dependency below this version."
    )


def test_the_wrappers_act_on_the_live_objects(live_objects):
    env_base = live_objects["torchrl.envs.EnvBase"]
    transform = live_objects["torchrl.envs.Transform"]
    assert _private_api.container_of(transform) is not None
    assert _private_api.dm_physics(env_base) is live_objects["dm_control.mujoco.Physics"]
    calls = []
    original = _private_api.base_set_seed(env_base)  # the distractions' fan-out, already installed
    _private_api.replace_set_seed(env_base, lambda seed: calls.append(seed) or original(seed))
    env_base.set_seed(3)
    assert calls == [3]
    _private_api.replace_set_seed(env_base, original)


def test_render_offsets_find_each_cameras_pixels(warp_context):
    """dcs_torchrl.render.warp reads the trace's buffers where render_offsets says a camera's pixels
    start: there they are MuJoCo Warp's own unpacked colours and segmentation, and camera-frame rays
    that sweep the image row by row."""
    import warp as wp
    from mujoco_warp import get_rgb, get_segmentation

    context = warp_context[0]
    for index, (width, height) in enumerate(CAMERAS):
        at = _private_api.render_offsets(context, index)
        rgb = wp.zeros((2, height, width), dtype=wp.vec3, device="cpu")
        seg = wp.zeros((2, height, width), dtype=wp.vec2i, device="cpu")
        get_rgb(context, index, rgb)
        get_segmentation(context, index, seg)
        packed = context.rgb_data.numpy()[:, at.rgb: at.rgb + width * height].reshape(2, height, width)
        ours = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=-1) / 255.0
        np.testing.assert_allclose(ours, rgb.numpy(), atol=1e-6, err_msg=f"camera {index}'s colours")
        labels = context.seg_data.numpy()[:, at.seg: at.seg + width * height].reshape(2, height, width, 2)
        np.testing.assert_array_equal(labels, seg.numpy(), err_msg=f"camera {index}'s segmentation")
        assert (labels[..., 0] >= 0).any(), "the test's scene shows no geom"
        rays = context.ray.numpy()[at.ray: at.ray + width * height].reshape(height, width, 3)
        assert (rays[..., 2] < 0).all() and (np.diff(rays[..., 0], axis=1) > 0).all() and \
            (np.diff(rays[..., 1], axis=0) < 0).all(), f"camera {index}'s rays are not where render_offsets says"


def test_render_offsets_refuse_a_context_without_segmentation():
    from dcs_torchrl.render.warp import import_warp

    wp, mjw = import_warp("cpu")
    mjm = suite.load("cartpole", "swingup").physics.model.ptr
    with wp.ScopedDevice("cpu"):
        context = mjw.create_render_context(mjm, nworld=1, cam_res=(4, 4), render_rgb=True, render_seg=False,
                                            render_depth=False, cam_active=[0])
    with pytest.raises(ValueError, match="render_seg=True"):
        _private_api.render_offsets(context, 0)


def test_mujoco_warp_builds_a_contexts_kernel_at_its_first_render_and_keeps_it(warp_context):
    """WarpRenderer renders once when made so that its renderers, rendering in threads, never build
    their kernels at once: that holds while the first render builds the kernel and later ones reuse it."""
    before, first, second = warp_context[1]
    assert before is None and first is not None and second is first


def test_dm_control_skybox_asset_is_rewritten_by_compact_skies():
    """dcs_torchrl.vector.batched.compact_skies rewrites the texture size in dm_control.suite.common.ASSETS:
    a model compiled inside it has a skybox of texture_size texels a face, one compiled after it 800."""
    from dcs_torchrl.vector import batched

    compact_skies = getattr(batched, "compact_skies", None)
    assert compact_skies is not None, ("dcs_torchrl.vector.batched.compact_skies is gone: remove dm_control.suite.common.ASSETS "
                                       "from _private_api.PRIVATE_SYMBOLS and this test")

    def sky_sides():
        model = suite.load("cartpole", "swingup").physics.model
        sky = int(np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)[0])
        return int(model.tex_width[sky]), int(model.tex_height[sky])

    with compact_skies(SimpleNamespace(num_videos=0, background_blend=1.0, texture_size=32)):
        assert sky_sides() == (32, 32 * 6)
    assert sky_sides() == (800, 800 * 6)


def test_serial_and_parallel_env_are_every_torchrl_batched_env():
    """dcs_torchrl._scene refuses a distraction over TorchRL's batched envs by their public classes;
    a new kind of batched env in TorchRL must be added there."""
    from torchrl.envs.batched_envs import BatchedEnvBase

    assert set(BatchedEnvBase.__subclasses__()) <= {SerialEnv, ParallelEnv}


# The TorchRL / dm_control / MuJoCo Warp classes the package subclasses or reaches into.
OWNERS = (LossModule, SACLoss, Transform, EnvBase, TransformedEnv, DMControlEnv, Physics, RenderContext,
          suite.load("cartpole", "swingup"))  # a dm_control Environment: its attributes are set per instance
# Protected hooks TorchRL documents for subclasses to call (its Transform docs' own examples).
DOCUMENTED_HOOKS = {"_call"}


def test_every_private_symbol_the_package_reads_is_listed():
    """A private TorchRL / dm_control attribute read outside _compat/private_api.py (and not one the package
    defines itself, e.g. an override) must be in PRIVATE_SYMBOLS, so that the test above checks it."""
    package = Path(dcs.__file__).parent
    defined, read = set(), {}
    for path in sorted(package.rglob("*.py")):
        if path == package / "_compat" / "private_api.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                defined.add(node.name)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                defined.add(node.attr)
            elif isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
                read.setdefault(node.attr, f"{path.relative_to(package.parent)}:{node.lineno}")
    listed = {attribute for _, attribute, _ in _private_api.PRIVATE_SYMBOLS} | DOCUMENTED_HOOKS
    unlisted = {name: where for name, where in read.items()
                if name not in defined | listed and any(hasattr(owner, name) for owner in OWNERS)}
    assert unlisted == {}, "route these through dcs_torchrl/_compat/private_api.py (and list them in PRIVATE_SYMBOLS)"


def test_mujoco_c_api_is_the_bindings_library_and_struct_addresses_their_structs():
    """dcs_torchrl.vector._mjstep calls MuJoCo's C step functions on MjModel._address / MjData._address: the
    library in the mujoco wheel's folder is the bindings' own (its version), and the addresses are their structs'."""
    import os

    api = _private_api.mujoco_c_api()
    assert os.path.dirname(api.path) == os.path.dirname(mujoco.__file__)
    assert sorted(api.functions) == ["mj_step", "mj_step1", "mj_step2"] and all(api.functions.values())
    physics = suite.load("cartpole", "swingup", task_kwargs={"random": 0}).physics
    model, data = physics.model.ptr, physics.data.ptr
    assert _private_api.struct_addresses(model, data) == (model._address, data._address)


def test_a_wrong_or_missing_struct_address_is_refused_naming_the_mujoco_to_pin(monkeypatch):
    """An upgrade whose ``_address`` is gone or no longer the struct's fails at the batch's construction, with
    the MuJoCo version to pin, not inside a compiled step."""
    first, other = (suite.load("cartpole", "swingup", task_kwargs={"random": i}) for i in range(2))
    for env in (first, other):
        env.reset()
    model, data = first.physics.model.ptr, first.physics.data.ptr
    elsewhere = other.physics.data.ptr._address  # another cartpole's data: readable, another state
    monkeypatch.setattr(mujoco.MjData, "_address", property(lambda self: elsewhere))
    with pytest.raises(RuntimeError, match=r"mj_getState on MjModel._address / MjData._address differs.*"
                                           r"install mujoco==3\.17\.0"):
        _private_api.struct_addresses(model, data)

    def gone(self):
        raise AttributeError("'mujoco._structs.MjData' object has no attribute '_address'")

    monkeypatch.setattr(mujoco.MjData, "_address", property(gone))
    with pytest.raises(RuntimeError, match=r"the bindings' structs have no C address.*pip install 'mujoco==3\.17\.0'"):
        _private_api.struct_addresses(model, data)
