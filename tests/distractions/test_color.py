"""ColorDistraction on real dm_control models (Stone et al. 2021, Sec. 3.2)."""
import numpy as np
import pytest
import torch
from scipy import stats
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import ColorDistraction, RenderPixels
from dcs_test_utils import physics_of


def color_env(scale, dynamic=False, frame_skip=1, domain="cheetah", task="run", render=False):
    transforms = [ColorDistraction(scale, dynamic, seed=0, expose=True)]
    if render:
        transforms.append(RenderPixels())
    return TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=frame_skip), Compose(*transforms))


def original_rgb(domain="cheetah", task="run"):
    return physics_of(DMControlEnv(domain, task, from_pixels=False)).model.mat_rgba[:, :3].copy()


@pytest.mark.parametrize("scale", [0.1, 0.5])
def test_static_colors_cover_the_clipped_range(scale):
    x0 = original_rgb()
    low, high = np.clip(x0 - scale, 0, 1), np.clip(x0 + scale, 0, 1)
    env = color_env(scale)
    samples = np.stack([env.reset()["distractions", "color"].double().numpy() for _ in range(300)])
    assert np.all(samples >= low - 1e-6) and np.all(samples <= high + 1e-6)
    # uniform on [low, high] for every material and channel (KS test on the normalised values)
    spread = (high - low) > 1e-6
    u = (samples[:, spread] - low[spread]) / (high - low)[spread]
    assert stats.kstest(u.ravel(), "uniform").pvalue > 0.001
    assert u.min() < 0.02 and u.max() > 0.98  # the range is covered to its ends
    # and what is exposed is what is in the model
    assert np.allclose(physics_of(env).model.mat_rgba[:, :3], samples[-1], atol=1e-6)


def test_clipping_at_zero_and_one():
    x0 = original_rgb()
    assert (x0 < 0.2).any() and (x0 > 0.8).any()  # the cheetah model has dark and bright channels
    env = color_env(0.9, dynamic=True)
    td = env.rollout(200, break_when_any_done=False)
    colors = td["next", "distractions", "color"].double().numpy()
    assert colors.min() >= 0.0 and colors.max() <= 1.0
    assert np.all(np.abs(colors - x0) <= 0.9 + 1e-6)


def test_static_colors_are_constant_within_an_episode():
    env = color_env(0.4)
    td = env.rollout(25, break_when_any_done=False)
    colors = td["next", "distractions", "color"]
    assert torch.equal(colors, colors[:1].expand_as(colors))


def test_dynamic_colors_walk_with_the_spec_std_per_control_step():
    scale = 0.5
    x0 = original_rgb()
    env = color_env(scale, dynamic=True)
    td = env.rollout(400, break_when_any_done=False)
    colors = td["next", "distractions", "color"].double().numpy()
    steps = np.diff(colors, axis=0)
    low, high = np.clip(x0 - scale, 0, 1), np.clip(x0 + scale, 0, 1)
    interior = (colors[:-1] > low + 0.05) & (colors[:-1] < high - 0.05) & (colors[1:] > low) & (colors[1:] < high)
    assert np.std(steps[interior]) == pytest.approx(0.03 * scale, rel=0.05)  # N(0, 0.03 β) (the paper's Sec. 3.2)
    assert np.all(np.abs(colors - x0) <= scale + 1e-6)


def test_frame_skip_advances_the_walk_per_control_step():
    coarse = color_env(0.3, dynamic=True, frame_skip=2)
    fine = color_env(0.3, dynamic=True, frame_skip=1)
    a = coarse.rollout(10, break_when_any_done=False)["next", "distractions", "color"]
    b = fine.rollout(20, break_when_any_done=False)["next", "distractions", "color"]
    torch.testing.assert_close(a, b[1::2])


def test_alpha_and_physics_are_untouched():
    env = color_env(0.8, dynamic=True)
    reference = DMControlEnv("cheetah", "run", from_pixels=False)
    env.set_seed(5)
    reference.set_seed(5)
    td, ref_td = env.reset(), reference.reset()
    alpha = physics_of(reference).model.mat_rgba[:, 3].copy()
    for _ in range(10):
        action = env.action_spec.rand()
        td = env.step(td.set("action", action))["next"]
        ref_td = reference.step(ref_td.set("action", action))["next"]
        assert torch.equal(td["reward"], ref_td["reward"])
        torch.testing.assert_close(td["position"], ref_td["position"], rtol=0, atol=0)
    assert np.array_equal(physics_of(env).model.mat_rgba[:, 3], alpha)


def test_colours_show_in_the_pixels():
    plain = color_env(0.0, render=True).reset()["pixels"].float()
    colored = color_env(0.5, render=True).reset()["pixels"].float()
    assert (plain - colored).abs().mean() > 2


def test_bad_scale():
    with pytest.raises(ValueError, match=r"ColorDistraction scale must be in \[0, 1\]"):
        ColorDistraction(-0.1)
