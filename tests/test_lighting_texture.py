"""The lighting and texture distractions across renderers and in the batch (docs/lighting_textures.md).

Here: a batch's plain worlds beside lit and textured ones are today's batch bit for bit, for every preset;
a lit and textured batch equals its worlds' one-env states (tests/test_distraction_arrays.py) and its own
batch alone; GL and Warp show the same scene within the tolerance docs/lighting_textures.md states; and a
dataset records both states.
"""
import json

import numpy as np
import pytest
import torch

import dcs_torchrl as dcs

pytest.importorskip("mujoco_warp")

NEW = {"light_scale": 0.6, "texture_scale": 0.7}
OPTIONS = dict(height=24, width=24, pixels_only=False, expose_distractions=True)


def _run(env, actions: torch.Tensor) -> list:
    td = env.reset()
    out = [td.clone()]
    for action in actions:
        td = env.step(td.set("action", action))["next"]
        out.append(td.clone())
    return out


@pytest.mark.parametrize("benchmark", ["none", "easy", "medium", "blind", "hard"])
def test_beside_lit_and_textured_worlds_the_plain_ones_are_todays_batch_bit_for_bit(benchmark):
    """A grouped batch: 2 worlds of the preset, 2 with lighting and textures over it (dynamic). The first two
    give the pixels, rewards and states of make_env(num_envs=2, backend="warp") of the preset, bit for bit
    (their lighting and texture at rest); the other two, those of their own batch alone."""
    plain = {"benchmark": benchmark, "dynamic": True, "action_repeat": 100}  # 10 agent steps an episode
    lit = {**plain, **NEW}
    grouped = dcs.make_grouped_env("cartpole", "swingup", [(plain, 2), (lit, 2)], seed=7, **OPTIONS)
    actions = torch.rand(12, 4, 1, generator=torch.Generator().manual_seed(0)) * 2 - 1  # across an episode's end
    together = _run(grouped, actions)
    grouped.close()
    for start, settings in ((0, plain), (2, lit)):
        alone_env = dcs.make_env("cartpole", "swingup", num_envs=2, backend="warp", seed=7, **settings, **OPTIONS)
        alone = _run(alone_env, actions[:, start:start + 2])
        alone_env.close()
        for t, (mine, theirs) in enumerate(zip(together, alone)):
            for key in theirs.keys(True, True):
                assert torch.equal(mine[key][start:start + 2], theirs[key]), f"{benchmark} {start}: step {t}, {key}"
        if start == 0:  # the plain worlds carry the states at rest
            for out in together:
                assert out["distractions", "lighting"][:2].tolist() == [[0.0, 0.0, 1.0, 6500.0, 0.0]] * 2
                assert out["distractions", "texture"][:2].eq(-1).all()
    moved = torch.stack([out["distractions", "lighting"][2:] for out in together])
    assert moved.diff(dim=0).abs().sum(-1).gt(0).all(), "the lit worlds' lighting stood still"


def test_a_batch_holds_each_blend_of_a_set_once_among_its_renderers_textures():
    """Worlds at one β share their blends: each renderer holds the model's textures and one floor and one body
    blend per texture of the set and β (not one per world)."""
    from dcs_torchrl.textures import texture_set

    k = len(texture_set(None, "train"))
    env = dcs.make_grouped_env("cartpole", "swingup", [({"texture_scale": 0.5}, 3), ({"texture_scale": 1.0}, 3)],
                               height=16, width=16, seed=0)
    ntex = env._worlds[0].physics.model.ntex
    assert [len(r._textures) for r in env.renderers] == [ntex + 2 * 2 * k] * len(env.renderers)
    env.close()


def _frames(backend: str, domain: str, task: str, settings: dict, seeds, size: int = 64) -> np.ndarray:
    frames = []
    for seed in seeds:
        batch = dict(num_envs=1, backend="warp") if backend == "warp" else {}
        env = dcs.make_env(domain, task, height=size, width=size, seed=seed, expose_distractions=True, **batch,
                           **settings)
        td = env.reset()
        td = env.step(td.set("action", env.action_spec.zero()))["next"]
        frames.append((td["pixels"].reshape(-1, size, size, 3)[0].numpy(),
                       {k: v.reshape(-1, *v.shape[-1:])[0] for k, v in td["distractions"].items()}))
        env.close()
    return frames


# Mean absolute difference of Warp's frames to GL's, grey levels of 255 (docs/lighting_textures.md, "Both
# renderers"): the lighting as close as the clean scene; textures farther, as Warp samples a texture once a
# pixel without mipmaps, so that fine patterns alias where GL averages them.
TOLERANCE = {"light": 6.0, "texture": 20.0}


@pytest.mark.parametrize("axis, settings", [("light", {"light_scale": 1.0}), ("texture", {"texture_scale": 1.0})])
@pytest.mark.parametrize("domain, task", [("cartpole", "swingup"), ("cheetah", "run")])
def test_gl_and_warp_show_the_same_lighting_and_textures_within_the_stated_tolerance(axis, settings, domain, task):
    seeds = range(3)
    gl, warp = _frames("gl", domain, task, settings, seeds), _frames("warp", domain, task, settings, seeds)
    plain = _frames("gl", domain, task, {}, seeds)
    for (g, gs), (w, ws), (p, _) in zip(gl, warp, plain):
        key = "lighting" if axis == "light" else "texture"
        assert torch.equal(gs[key], ws[key])  # the same draw
        difference = np.abs(g.astype(int) - w.astype(int)).mean()
        assert difference < TOLERANCE[axis], difference
        assert np.abs(g.astype(int) - p.astype(int)).mean() > difference / 2  # the distraction shows on both


@pytest.mark.parametrize("domain, task", [("cartpole", "swingup"), ("cheetah", "run")])
def test_warp_shows_each_surface_its_own_blend_as_gl_does(domain, task):
    """At β_tex = 0.5 the floor's blend (over the grid) and the bodies' (over white) differ: the agent's and
    the floor's pixels (Warp's masks) of each renderer agree within the texture tolerance, each surface
    apart (a body shown the floor's blend is ~55 grey levels off)."""
    for seed in range(2):
        settings = dict(height=64, width=64, seed=seed, texture_scale=0.5)
        gl = dcs.make_env(domain, task, **settings)
        expected = gl.reset()["pixels"].numpy().astype(int)
        gl.close()
        warp = dcs.make_env(domain, task, num_envs=1, backend="warp", masks=True, **settings)
        td = warp.reset()
        warp.close()
        pixels, masks = td["pixels"][0].numpy().astype(int), td["masks"][0].numpy()
        for label in (1, 2):  # the floor, the agent
            assert (masks == label).sum() > 20
            assert np.abs(pixels - expected)[masks == label].mean() < TOLERANCE["texture"], (seed, label)


def test_a_dataset_records_the_lighting_and_texture_states_a_fresh_env_replays(tmp_path):
    from dcs_torchrl.datasets import generate, load_data
    from dcs_torchrl.datasets.metadata import episode_seed

    generate(tmp_path / "set", episodes=2, seed=0, domain="cartpole", task="swingup", dynamic=True, image_size=16,
             max_steps=3, **NEW)
    data = load_data(tmp_path / "set")
    transitions, frames = data["transitions"], data["frames"]
    env = dcs.make_env("cartpole", "swingup", dynamic=True, height=16, width=16, expose_distractions=True,
                       pixels_only=False, **NEW)
    for k in range(2):  # every episode: the recorded states are those the env steps to, and its frames
        rows = transitions[transitions["episode"] == k]
        env.set_seed(episode_seed(0, k))
        td = env.reset()
        assert torch.equal(td["pixels"], frames["pixels"][rows["first_frame"][0]])
        for i in range(rows.shape[0]):
            for key in ("lighting", "texture"):
                assert torch.equal(td["distractions", key], rows["distractions", key][i]), (k, i, key)
            td = env.step(td.set("action", rows["action"][i]))["next"]
            assert torch.equal(td["pixels"], frames["pixels"][rows["frame"][i] + 1])
            for key in ("lighting", "texture"):
                assert torch.equal(td["distractions", key], rows["next", "distractions", key][i]), (k, i, key)
    env.close()
    assert json.loads((tmp_path / "set" / "metadata.json").read_text())["env"]["light_scale"] == NEW["light_scale"]
