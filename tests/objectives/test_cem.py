"""Cross-entropy method and the CEM policy head."""
import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from dcs_torchrl.modules import make_critic
from dcs_torchrl.objectives import CEMActor, cem_maximize


def _concave(optimum):
    return lambda a: -((a - optimum.unsqueeze(-2)) ** 2).sum(-1)


@pytest.mark.parametrize("dim", [1, 6])
def test_finds_the_maximum_of_a_concave_function(dim):
    torch.manual_seed(0)
    optimum = 1.6 * torch.rand(32, dim) - 0.8
    low, high = -torch.ones(dim), torch.ones(dim)
    # more samples per elite in 6-d: with 6 elites of 64 CEM's variance can collapse on one axis
    settings = {"iterations": 8, "num_samples": 64, "num_elites": 6} if dim == 1 else {"iterations": 10, "num_samples": 256, "num_elites": 25}
    best, value = cem_maximize(_concave(optimum), [32], low, high, **settings)
    assert best.shape == (32, dim) and value.shape == (32,)
    assert (best - optimum).abs().max() < 0.05
    torch.testing.assert_close(value, _concave(optimum)(best.unsqueeze(-2)).squeeze(-1))
    # QT-Opt's own settings (2 iterations, 64 samples, 6 elites): near the optimum, never worse than a random guess
    coarse, coarse_value = cem_maximize(_concave(optimum), [32], low, high)
    assert (coarse - optimum).abs().max() < (0.35 if dim == 1 else 1.0)
    assert (coarse_value > _concave(optimum)(torch.zeros(32, 1, dim)).squeeze(-1) - 0.5).all()


def test_one_batched_objective_call_per_iteration():
    shapes = []

    def objective(actions):
        shapes.append(tuple(actions.shape))
        return -(actions**2).sum(-1, keepdim=True)  # [..., samples, 1] is accepted too

    cem_maximize(objective, [4, 3], -torch.ones(2), torch.ones(2), iterations=3, num_samples=16, num_elites=4)
    assert shapes == [(4, 3, 16, 2)] * 3


def test_respects_the_bounds():
    torch.manual_seed(1)
    optimum = torch.tensor([[3.0, -3.0]])  # outside the box: the best is its corner
    best, _ = cem_maximize(_concave(optimum), [1], -torch.ones(2), torch.ones(2), iterations=5)
    assert best.abs().max() <= 1.0
    torch.testing.assert_close(best, torch.tensor([[1.0, -1.0]]), atol=0.05, rtol=0)


def test_errors():
    with pytest.raises(ValueError, match="num_elites <= num_samples"):
        cem_maximize(lambda a: a.sum(-1), [2], -torch.ones(1), torch.ones(1), num_samples=4, num_elites=8)
    with pytest.raises(ValueError, match=r"must return \[\*batch, num_samples\]"):
        cem_maximize(lambda a: a.sum(), [2], -torch.ones(1), torch.ones(1))


def test_cem_actor_exploration_modes():
    torch.manual_seed(2)
    spec = Bounded(-1.0, 1.0, shape=(2,), dtype=torch.float64)
    critic = make_critic(spec, 5, hidden_dim=16)
    data = TensorDict({"embedding": torch.randn(256, 5)}, [256])
    greedy = CEMActor(critic, action_spec=spec, iterations=4, noise_std=0.0)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        action = greedy(data.clone())["action"]
        q_greedy = critic(data.clone().set("action", action))["state_action_value"]
        q_zero = critic(data.clone().set("action", torch.zeros(256, 2)))["state_action_value"]
    assert action.dtype == torch.float32 and action.abs().max() <= 1.0
    assert (q_greedy >= q_zero - 1e-3).float().mean() > 0.95  # CEM beats a fixed action almost always
    uniform = CEMActor(critic, action_spec=spec, epsilon=1.0)
    with set_exploration_type(ExplorationType.RANDOM):
        random_actions = uniform(data.clone())["action"]
    assert 0.5 < random_actions.std().item() < 0.65  # U(-1, 1) has std 0.577
    with set_exploration_type(ExplorationType.DETERMINISTIC):  # no exploration when evaluating
        torch.manual_seed(3)
        explorer_eval = uniform(data.clone())["action"]
        torch.manual_seed(3)
        torch.testing.assert_close(explorer_eval, CEMActor(critic, action_spec=spec, noise_std=0.0)(data.clone())["action"])
    with pytest.raises(ValueError, match="0 <= epsilon <= 1"):
        CEMActor(critic, action_spec=spec, epsilon=2.0)
