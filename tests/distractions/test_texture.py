"""TextureDistraction on real dm_control models (beyond the paper; docs/lighting_textures.md)."""
import cv2
import mujoco
import numpy as np
import pytest
import torch
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import RenderPixels, TextureDistraction, make_env
from dcs_torchrl.distractions import texture as tx
from dcs_torchrl.textures import texture_set
from dcs_test_utils import physics_of


def texture_env(scale, domain="cartpole", task="swingup", render=False, seed=0, size=32, **kwargs):
    with tx.surface_slot():
        base = DMControlEnv(domain, task, from_pixels=False, frame_skip=4)
    transforms = [TextureDistraction(scale, seed=seed, expose=True, **kwargs)]
    if render:
        transforms.append(RenderPixels(size, size))
    return TransformedEnv(base, Compose(*transforms))


def test_each_episode_draws_a_floor_and_a_body_texture_kept_for_the_episode():
    env = texture_env(0.7)
    k = len(texture_set(None, "train"))
    draws = []
    for _ in range(40):
        td = env.reset()
        state = td["distractions", "texture"].clone()
        rollout = env.rollout(3, auto_reset=False, tensordict=td)
        assert torch.equal(rollout["next", "distractions", "texture"], state.expand(3, 2))
        draws.append(state.tolist())
    draws = np.array(draws)
    assert draws.min() >= 0 and draws.max() < k
    assert len(set(draws[:, 0])) > k // 3 and len(set(draws[:, 1])) > k // 3  # both draws spread over the set


def test_the_scene_shows_the_drawn_blends_on_the_floor_and_the_bodies():
    scale = 0.6
    env = texture_env(scale, render=True)
    t = env.transform[0]
    model = physics_of(env).model
    floor_tex, body_tex = t.floor_texture, t.body_texture
    original_floor = tx.texture_image(model, floor_tex).astype(np.float64).copy()
    textures = texture_set(None, "train")
    for _ in range(3):
        td = env.reset()
        f, b = td["distractions", "texture"].tolist()
        h, w = original_floor.shape[:2]
        expected_floor = np.rint((1 - scale) * original_floor + scale * textures.image(f, max(h, w)))
        np.testing.assert_array_equal(tx.texture_image(model, floor_tex), expected_floor.astype(np.uint8))
        side = int(model.tex_width[body_tex])
        expected_body = np.rint((1 - scale) * 255.0 + scale * textures.image(b, side).astype(np.float64))
        np.testing.assert_array_equal(tx.texture_image(model, body_tex), expected_body.astype(np.uint8))
        assert np.all(model.mat_texid[t.body_materials, mujoco.mjtTextureRole.mjTEXROLE_RGB] == body_tex)
        assert len(t.body_materials) and len(t.floor_materials)


def test_zero_scale_renders_todays_frames_and_the_slot_changes_nothing():
    plain = TransformedEnv(DMControlEnv("cheetah", "run", from_pixels=False, frame_skip=4), RenderPixels(32, 32))
    slotted = texture_env(0.0, domain="cheetah", task="run", render=True)
    for env in (plain, slotted):
        env.set_seed(1)
    a = plain.rollout(4, lambda td: td.set("action", plain.action_spec.zero()), break_when_any_done=False)
    b = slotted.rollout(4, lambda td: td.set("action", plain.action_spec.zero()), break_when_any_done=False)
    a = a["next", "pixels"]
    assert torch.equal(a, b["next", "pixels"])
    assert b["next", "distractions", "texture"].eq(-1).all()


def test_textures_change_the_frames_more_as_the_scale_grows():
    diffs = []
    reference = None
    for scale in (0.0, 0.3, 1.0):
        env = texture_env(scale, render=True, seed=4, size=48)
        pixels = env.reset()["pixels"].double()
        reference = pixels if reference is None else reference
        diffs.append((pixels - reference).abs().mean().item())
    assert diffs[0] == 0 < diffs[1] < diffs[2]


def test_the_same_seed_reproduces_the_draws_and_the_split_is_honoured(tmp_path):
    a = [texture_env(1.0, seed=9).reset()["distractions", "texture"].tolist() for _ in range(2)]
    assert a[0] == a[1]
    folder = tmp_path / "dtd" / "images"
    rng = np.random.default_rng(0)
    for category in ("banded", "dotted"):
        (folder / category).mkdir(parents=True)
        for i in range(5):
            cv2.imwrite(str(folder / category / f"{category}_{i}.png"), rng.integers(0, 255, (20, 30, 3), np.uint8))
    for split, count in (("train", 8), ("val", 2)):
        env = texture_env(1.0, texture_dir=folder, split=split)
        assert len(env.transform[0].textures) == count
        assert env.reset()["distractions", "texture"].max() < count


def test_make_env_builds_the_slot_and_refuses_bad_input(tmp_path):
    env = make_env("cartpole", "swingup", texture_scale=0.5, expose_distractions=True, height=16, width=16, seed=0)
    assert env.reset()["distractions", "texture"].ge(0).all()
    for bad in (-0.5, 2.0):
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            make_env("cartpole", "swingup", texture_scale=bad)
    with pytest.raises(ValueError, match="texture_split"):
        make_env("cartpole", "swingup", texture_scale=0.5, texture_split="test")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError):
        make_env("cartpole", "swingup", texture_scale=0.5, texture_dir=tmp_path / "empty")
    (tmp_path / "broken").mkdir()
    for i in range(5):
        (tmp_path / "broken" / f"{i}.png").write_bytes(b"not an image")
    with pytest.raises(ValueError, match=r"\.png"):
        make_env("cartpole", "swingup", texture_scale=0.5, texture_dir=tmp_path / "broken").reset()
    # a model built without the bodies' texture: the fix is named
    base = DMControlEnv("cartpole", "swingup", from_pixels=False)
    with pytest.raises(ValueError, match="surface_slot"):
        TransformedEnv(base, Compose(TextureDistraction(0.5), RenderPixels(16, 16))).reset()
