"""The paper's networks (DrQ's encoder, tanh-Gaussian actor, Q heads) and their TensorDict wrappers."""
import platform
import shutil
import subprocess
import sys

import pytest
import torch
import torch.nn.functional as F
from tensordict import TensorDict
from tensordict.nn import TensorDictSequential
from torch import nn
from torchrl.data import Bounded, Unbounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from dcs_torchrl.modules import (
    FlatEncoder,
    PixelEncoder,
    QHead,
    TanhGaussianHead,
    make_critic,
    make_encoder,
    make_sac_actor,
    mlp,
)

SPEC = Bounded(-1.0, 1.0, shape=(6,), dtype=torch.float64)  # DM Control specs are float64


def _reference_encoder(enc: PixelEncoder, pixels: torch.Tensor) -> torch.Tensor:
    """DrQ's encoder computed the plain way: /255, conv + ReLU x4, flatten, linear, LayerNorm, tanh."""
    x = pixels.float() / 255.0
    for conv in enc.convs:
        x = F.relu(conv(x))
    return torch.tanh(enc.norm(enc.linear(x.flatten(1))))


def test_pixel_encoder_architecture():
    enc = PixelEncoder(9)
    assert [(c.in_channels, c.out_channels, c.kernel_size, c.stride) for c in enc.convs] == [
        (9, 32, (3, 3), (2, 2)),
        (32, 32, (3, 3), (1, 1)),
        (32, 32, (3, 3), (1, 1)),
        (32, 32, (3, 3), (1, 1)),
    ]
    assert enc.conv_output_shape == (32, 35, 35)  # DrQ: 84 -> 41 -> 39 -> 37 -> 35
    assert (enc.linear.in_features, enc.linear.out_features) == (32 * 35 * 35, 50)
    assert isinstance(enc.norm, nn.LayerNorm) and enc.norm.normalized_shape == (50,)
    # DrQ's weight_init: orthogonal linear weights, zero biases
    w = enc.linear.weight
    torch.testing.assert_close(w @ w.T, torch.eye(50), atol=1e-4, rtol=0)
    assert not enc.linear.bias.any()
    # ... and orthogonal convolutions with the ReLU gain (rows: output channels, flattened)
    for conv in enc.convs:
        rows = conv.weight.flatten(1)
        torch.testing.assert_close(rows @ rows.T, 2.0 * torch.eye(32), atol=1e-4, rtol=0)
        assert not conv.bias.any()


@pytest.mark.parametrize("channels_last", [False, True])
def test_pixel_encoder_matches_reference_math(channels_last):
    torch.manual_seed(0)
    enc = PixelEncoder(9, channels_last=channels_last)
    pixels = torch.randint(0, 256, (3, 9, 84, 84), dtype=torch.uint8)
    out = enc(pixels)
    assert out.shape == (3, 50)
    # tanh of a layer-normalised embedding: atanh(out) has mean 0 and standard deviation 1 over the
    # 50 features (checked apart from the reference, which shares the encoder's own LayerNorm)
    features = out.double().atanh()
    torch.testing.assert_close(features.mean(-1), torch.zeros(3, dtype=torch.float64), atol=1e-3, rtol=0)
    torch.testing.assert_close(features.std(-1, unbiased=False), torch.ones(3, dtype=torch.float64), atol=1e-2, rtol=0)
    torch.testing.assert_close(out, _reference_encoder(enc, pixels), atol=1e-5, rtol=1e-4)
    torch.testing.assert_close(enc(pixels.float()), out)  # uint8 and float inputs agree


def test_pixel_encoder_leading_dims_and_errors():
    enc = PixelEncoder(6, image_size=32)
    assert enc(torch.zeros(2, 3, 6, 32, 32)).shape == (2, 3, 50)
    assert enc(torch.zeros(6, 32, 32)).shape == (50,)
    with pytest.raises(ValueError, match=r"expects \[\.\.\., 6, H, W\]"):
        enc(torch.zeros(2, 9, 32, 32))
    with pytest.raises(ValueError, match="too small"):
        PixelEncoder(3, image_size=9)


def test_flat_encoder():
    assert FlatEncoder(5)(torch.ones(2, 5, dtype=torch.float64)).dtype == torch.float32
    torch.testing.assert_close(FlatEncoder(5)(torch.arange(5.0)), torch.arange(5.0))
    mlp_enc = FlatEncoder(5, hidden_dims=(32, 32), feature_dim=8)
    assert mlp_enc(torch.zeros(4, 5)).shape == (4, 8) and mlp_enc.feature_dim == 8
    with pytest.raises(ValueError, match="identity FlatEncoder keeps in_features"):
        FlatEncoder(5, feature_dim=8)


def test_mlp_depth_and_init():
    net = mlp(10, 64, 3, 2)
    linears = [m for m in net if isinstance(m, nn.Linear)]
    assert [(l.in_features, l.out_features) for l in linears] == [(10, 64), (64, 64), (64, 3)]
    assert all(not l.bias.any() for l in linears)
    for layer in linears:  # orthogonal: W W^T = I on the smaller side
        w = layer.weight if layer.out_features <= layer.in_features else layer.weight.T
        torch.testing.assert_close(w @ w.T, torch.eye(w.shape[0]), atol=1e-4, rtol=0)


def test_tanh_gaussian_head_log_std_bounds():
    torch.manual_seed(1)
    head = TanhGaussianHead(50, 6, hidden_dim=64)
    loc, scale = head(100 * torch.randn(256, 50))
    assert loc.shape == scale.shape == (256, 6)
    assert scale.min() >= torch.tensor(-10.0).exp() * 0.999 and scale.max() <= torch.tensor(2.0).exp() * 1.001
    with pytest.raises(ValueError, match="increasing"):
        TanhGaussianHead(50, 6, log_std_bounds=(2.0, -10.0))


def test_sac_actor_deterministic_is_tanh_of_mean_and_samples_in_bounds():
    torch.manual_seed(2)
    actor = make_sac_actor(SPEC, 50, hidden_dim=64)
    data = TensorDict({"embedding": torch.randn(32, 50)}, [32])
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        out = actor(data.clone())
    torch.testing.assert_close(out["action"], torch.tanh(out["loc"]))
    with set_exploration_type(ExplorationType.RANDOM):
        sampled = actor(data.clone())["action"]
    assert sampled.abs().max() < 1.0 and not torch.equal(sampled, out["action"])
    with pytest.raises(TypeError, match="Bounded action spec"):
        make_sac_actor(Unbounded(shape=(6,)), 50)


def test_q_head_broadcasts_embedding_over_candidate_actions():
    torch.manual_seed(3)
    q = QHead(50, 6, hidden_dim=64)
    emb, actions = torch.randn(4, 50), torch.rand(4, 7, 6)
    batched = q(emb, actions)
    assert batched.shape == (4, 7, 1)
    torch.testing.assert_close(batched[:, 3], q(emb, actions[:, 3]))


def test_make_encoder_and_critic_keys():
    enc = make_encoder((9, 84, 84))
    assert (enc.in_keys, enc.out_keys, enc.feature_dim) == (["pixels"], ["embedding"], 50)
    flat = make_encoder((5,), hidden_dims=(16,), feature_dim=8)
    assert (flat.in_keys, flat.feature_dim) == (["observation"], 8)
    critic = make_critic(SPEC, 50, hidden_dim=64)
    assert critic.in_keys == ["embedding", "action"] and critic.out_keys == ["state_action_value"]
    with pytest.raises(ValueError, match="square images"):
        make_encoder((9, 84, 64))
    with pytest.raises(ValueError, match=r"\[C, H, W\] \(pixels\) or \[D\]"):
        make_encoder((2, 3))


def test_policy_pipeline_and_state_dict_round_trip():
    torch.manual_seed(4)
    enc, actor = make_encoder((9, 84, 84)), make_sac_actor(SPEC, 50, hidden_dim=64)
    policy = TensorDictSequential(enc, actor)
    data = TensorDict({"pixels": torch.randint(0, 256, (2, 9, 84, 84), dtype=torch.uint8)}, [2])
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        action = policy(data.clone())["action"]
    torch.manual_seed(5)
    other = TensorDictSequential(make_encoder((9, 84, 84)), make_sac_actor(SPEC, 50, hidden_dim=64))
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        assert not torch.equal(other(data.clone())["action"], action)
        other.load_state_dict(policy.state_dict())
        torch.testing.assert_close(other(data.clone())["action"], action, rtol=0, atol=0)


@pytest.mark.skipif(shutil.which("c++") is None and shutil.which("g++") is None, reason="inductor needs a C++ compiler")
def test_compiled_and_channels_last_encoder_match_eager():
    torch.manual_seed(6)
    eager = PixelEncoder(9, channels_last=False)
    fast = PixelEncoder(9, channels_last=True, compile=True)
    fast.load_state_dict(eager.state_dict())
    pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
    out = fast(pixels)
    torch.testing.assert_close(out, eager(pixels), atol=1e-5, rtol=1e-4)
    out.sum().backward()
    assert all(c.weight.grad is not None for c in fast.convs)


def test_retain_freed_memory_in_a_fresh_process():
    code = "from dcs_torchrl.modules.allocator import retain_freed_memory; print(retain_freed_memory())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    expected = "True" if platform.system() == "Linux" and platform.libc_ver()[0] == "glibc" else "False"
    assert out[-1] == expected
