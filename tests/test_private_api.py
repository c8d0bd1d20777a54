"""Every private TorchRL / dm_control symbol the package uses still exists (dcs_torchrl/_private_api.py).

An upgrade that removes one fails here, with the symbol and the module that needs it named,
instead of deep inside a rollout or an update.
"""
import ast
import importlib
from pathlib import Path

import pytest
import torch
from dm_control.mujoco import Physics
from torchrl.data import Bounded
from torchrl.envs import DMControlEnv, EnvBase, Transform, TransformedEnv
from torchrl.objectives import LossModule, SACLoss

import dcs_torchrl as dcs
from dcs_torchrl import _private_api
from dcs_torchrl.modules import make_critic, make_encoder, make_sac_actor
from dcs_torchrl.objectives import DrQSACLoss


def _resolve(path: str):
    module, _, name = path.rpartition(".")
    try:
        return importlib.import_module(path)
    except ModuleNotFoundError:
        return getattr(importlib.import_module(module), name)


@pytest.fixture(scope="module")
def live_objects():
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
        "dcs_torchrl/_private_api.py for why; port that use to the new API or pin the dependency below this version."
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


# The TorchRL / dm_control classes the package subclasses or reaches into.
OWNERS = (LossModule, SACLoss, Transform, EnvBase, TransformedEnv, DMControlEnv, Physics)
# Protected hooks TorchRL documents for subclasses to call (its Transform docs' own examples).
DOCUMENTED_HOOKS = {"_call"}


def test_every_private_symbol_the_package_reads_is_listed():
    """A private TorchRL / dm_control attribute read outside _private_api.py (and not one the package
    defines itself, e.g. an override) must be in PRIVATE_SYMBOLS, so that the test above checks it."""
    package = Path(dcs.__file__).parent
    defined, read = set(), {}
    for path in sorted(package.rglob("*.py")):
        if path.name == "_private_api.py":
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
    assert unlisted == {}, "route these through dcs_torchrl/_private_api.py (and list them in PRIVATE_SYMBOLS)"
