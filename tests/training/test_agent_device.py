"""Everything an agent exposes is moved to its device (an inspection test: no GPU needed).

QT-Opt's CEM actor keeps its action bounds as buffers; before the policy moved with the agent,
``device=cuda`` died at the first evaluation (CEM sampled on the CPU and met GPU weights).
The ``meta`` device cannot hold TensorDictParams here, so the test records every
``nn.Module.to`` call made while the agent is built and checks that each module holding a
parameter or buffer of the loss or the policy was moved to the agent's device (itself or an
ancestor).
"""
import pytest
import torch
from hydra import compose, initialize_config_module
from torch import nn
from torchrl.data import Bounded

from dcs_torchrl.methods import agent_class


def _moved_modules(monkeypatch, algo: str):
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose(algo, overrides=["network.hidden_dim=16", "algo.aug=drq"])
    moved = []
    original = nn.Module.to

    def to(self, *args, **kwargs):
        moved.append((self, torch.device(args[0]) if args and isinstance(args[0], (str, torch.device)) else kwargs.get("device")))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(nn.Module, "to", to)
    spec = Bounded(-torch.ones(2), torch.ones(2), shape=(2,))
    agent = agent_class(algo)(cfg, (9, 32, 32), spec)
    monkeypatch.undo()
    return agent, {id(m) for m, device in moved if device == agent.device}


@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_everything_the_agent_exposes_is_moved_to_its_device(monkeypatch, algo):
    agent, moved = _moved_modules(monkeypatch, algo)
    for name, root in (("loss", agent.loss), ("policy", agent.policy)):
        missed = []
        for path, module in root.named_modules():
            own = [*module.parameters(recurse=False), *module.buffers(recurse=False)]
            if not own:
                continue
            ancestors = [root] + [root.get_submodule(".".join(path.split(".")[:i])) for i in range(1, len(path.split(".")) + 1)] if path else [root]
            if not any(id(a) in moved for a in ancestors):
                missed.append(path or "<root>")
        assert not missed, f"{algo} {name}: {missed} never moved to {agent.device}"


def test_cem_bounds_are_buffers_that_follow_the_policy():
    """The CEM actor's bounds move with ``policy.to`` (what the agent now calls)."""
    agent, _ = _moved_modules(pytest.MonkeyPatch(), "qtopt")
    buffers = dict(agent.policy.named_buffers())
    assert any(key.endswith("low") for key in buffers) and any(key.endswith("high") for key in buffers)
    moved = agent.policy.to(torch.float64)
    assert all(b.dtype == torch.float64 for k, b in moved.named_buffers() if k.endswith(("low", "high")))


@pytest.mark.parametrize("override, repeat", [([], 8), (["env.action_repeat=2"], 2)])
def test_qtopt_reward_range_is_the_envs_action_repeat(override, repeat):
    """QT-Opt normalises values by [0, action repeat] per agent step: the repeat the training env
    resolves (cartpole swingup's 8, or env.action_repeat)."""
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("qtopt", overrides=["network.hidden_dim=16", "env.domain=cartpole", "env.task=swingup", *override])
    agent = agent_class("qtopt")(cfg, (9, 32, 32), Bounded(-torch.ones(1), torch.ones(1), shape=(1,)))
    assert agent.loss.reward_range == (0.0, float(repeat))
