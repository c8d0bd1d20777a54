"""Small real batches for the loss tests: pixels (uint8, 9 x 84 x 84) and cartpole-sized states."""
import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded

ACTION_SPEC = Bounded(-1.0, 1.0, shape=(2,), dtype=torch.float64)  # DM Control specs are float64


def make_batch(batch_size: int, *, pixels: bool, seed: int = 0, obs_dim: int = 5) -> TensorDict:
    gen = torch.Generator().manual_seed(seed)
    if pixels:
        obs = torch.randint(0, 256, (2, batch_size, 9, 84, 84), generator=gen, dtype=torch.int64).to(torch.uint8)
        key = "pixels"
    else:
        obs = torch.randn(2, batch_size, obs_dim, generator=gen)
        key = "observation"
    return TensorDict(
        {
            key: obs[0],
            "action": 2 * torch.rand(batch_size, 2, generator=gen) - 1,
            ("next", key): obs[1],
            ("next", "reward"): torch.rand(batch_size, 1, generator=gen),
            ("next", "done"): torch.zeros(batch_size, 1, dtype=torch.bool),
            ("next", "terminated"): torch.zeros(batch_size, 1, dtype=torch.bool),
        },
        [batch_size],
    )


@pytest.fixture
def action_spec():
    return ACTION_SPEC


@pytest.fixture(name="make_batch")
def make_batch_fixture():
    return make_batch
