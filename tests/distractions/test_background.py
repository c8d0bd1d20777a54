"""BackgroundDistraction on real dm_control physics and EGL rendering (SPEC §1.3)."""
import mujoco
import numpy as np
import pytest
import torch
from scipy import stats
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import BackgroundDistraction, RenderPixels
from dcs_torchrl.distractions.background import bounce
from dcs_torchrl.render import render_context
from dcs_test_utils import numbered_video, physics_of, solid_video, tinted_video

RED = (255, 0, 0)


def background_env(videos, dynamic=False, frame_skip=1, domain="cartpole", task="swingup", seed=0, **kwargs):
    kwargs.setdefault("ground_alpha", None)
    return TransformedEnv(
        DMControlEnv(domain, task, from_pixels=False, frame_skip=frame_skip),
        Compose(BackgroundDistraction(videos, dynamic, seed=seed, expose=True, **kwargs), RenderPixels()),
    )


def sky(pixels):
    """The top rows of a cartpole frame: sky only."""
    return pixels[:6].float().reshape(-1, 3).mean(0)


def test_solid_video_fills_the_sky():
    pixels = background_env([solid_video(RED)]).reset()["pixels"]
    assert sky(pixels).tolist() == pytest.approx([255, 0, 0], abs=1.0)


def test_blend_mixes_video_and_original_sky():
    original = sky(background_env([solid_video(RED)], blend=0.0).reset()["pixels"])
    plain = sky(TransformedEnv(DMControlEnv("cartpole", "swingup", from_pixels=False), RenderPixels()).reset()["pixels"])
    assert torch.equal(original, plain)  # β_bg = 0 leaves the sky exactly as it was
    for blend in (0.25, 0.5, 0.75):
        mixed = sky(background_env([solid_video(RED)], blend=blend).reset()["pixels"])
        expected = blend * torch.tensor(RED, dtype=torch.float32) + (1 - blend) * plain
        assert mixed.tolist() == pytest.approx(expected.tolist(), abs=3.0)


@pytest.mark.parametrize("domain,task,alpha", [("reacher", "easy", 0.0), ("cartpole", "swingup", 0.3), ("cheetah", "run", 1.0)])
def test_ground_alpha(domain, task, alpha):
    env = background_env([solid_video(RED)], domain=domain, task=task, ground_alpha=alpha)
    env.reset()
    model = physics_of(env).model
    grid = mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_MATERIAL, "grid")
    assert model.mat_rgba[grid, 3] == pytest.approx(alpha)


def test_transparent_floor_shows_the_background():
    # reacher is seen from above: with alpha 0 the floor disappears and the video fills the view
    opaque = background_env([solid_video(RED)], domain="reacher", task="easy", ground_alpha=1.0).reset()["pixels"]
    clear = background_env([solid_video(RED)], domain="reacher", task="easy", ground_alpha=0.0).reset()["pixels"]
    red = lambda p: ((p[..., 0] > 200) & (p[..., 1] < 60)).float().mean()  # noqa: E731
    assert red(opaque) < 0.05 and red(clear) > 0.5


def test_the_pixels_show_the_current_frame():
    env = background_env([numbered_video(12)], dynamic=True)
    td = env.rollout(30, break_when_any_done=False)
    frames = td["next", "distractions", "background"][:, 1]
    brightness = td["next", "pixels"][:, :6].float().mean((1, 2, 3))
    assert brightness.tolist() == pytest.approx((10 * frames).tolist(), abs=1.5)


def test_static_frame_is_constant_within_an_episode():
    env = background_env([numbered_video(12), numbered_video(20)], dynamic=False)
    td = env.rollout(20, break_when_any_done=False)
    state = td["next", "distractions", "background"]
    assert torch.equal(state, state[:1].expand_as(state))
    assert torch.equal(td["distractions", "background"][0], state[0])


def test_dynamic_video_steps_one_frame_per_control_step_and_bounces():
    env = background_env([numbered_video(7)], dynamic=True)
    td = env.rollout(60, break_when_any_done=False)
    frames = torch.cat([td["distractions", "background"][:1, 1], td["next", "distractions", "background"][:, 1]])
    steps = frames.diff()
    assert set(steps.abs().tolist()) == {1}  # always moving, never a cut or a stall
    assert frames.min() == 0 and frames.max() == 6  # it reaches both ends ...
    turns = (steps[1:] != steps[:-1]).nonzero().flatten() + 1
    assert set(frames[turns].tolist()) <= {0, 6}  # ... and turns only there


def test_bounce():
    assert bounce(5, 1, 7, 1) == (6, 1)
    assert bounce(6, 1, 7, 1) == (5, -1)
    assert bounce(0, -1, 7, 3) == (3, 1)
    assert bounce(2, 1, 7, 10) == (0, -1)
    assert bounce(0, 1, 1, 5) == (0, 1)


def test_frame_skip_plays_frame_skip_frames_per_agent_step():
    coarse = background_env([numbered_video(9)], dynamic=True, frame_skip=4)
    fine = background_env([numbered_video(9)], dynamic=True, frame_skip=1)
    a = coarse.rollout(6, break_when_any_done=False)["next", "distractions", "background"]
    b = fine.rollout(24, break_when_any_done=False)["next", "distractions", "background"]
    assert torch.equal(a, b[3::4])


def test_episode_start_is_uniform_over_the_first_b_videos_frames_and_directions():
    """num_videos = 4 of 8 distinct clips: every episode shows one of the first four, and the
    rendered sky is the clip and frame that ("distractions", "background") reports."""
    env = background_env([tinted_video(i) for i in range(8)], dynamic=True, num_videos=4)
    starts, directions = [], []
    for _ in range(400):
        td = env.reset()
        video, frame = td["distractions", "background"].tolist()
        red, green, _ = sky(td["pixels"]).tolist()
        assert (red, green) == pytest.approx((10 * frame, 20 + 25 * video), abs=1.5)
        starts.append((video, frame))
        directions.append(env.transform[0]._direction)
    starts = np.array(starts)
    assert set(starts[:, 0].tolist()) == {0, 1, 2, 3}  # the first b = 4 videos of the list, all of them
    assert stats.chisquare(np.bincount(starts[:, 0], minlength=4)).pvalue > 0.001
    assert stats.chisquare(np.bincount(starts[:, 1], minlength=10)).pvalue > 0.001
    assert stats.binomtest(sum(d == 1 for d in directions), len(directions)).pvalue > 0.001


def test_uploaded_mipmaps_match_mujocos_own_upload():
    env = background_env([np.random.default_rng(0).integers(0, 255, (3, 300, 300, 3), dtype=np.uint8)], dynamic=True)
    env.rollout(3, break_when_any_done=False)  # later frames go through the fast sub-image upload
    physics = physics_of(env)
    fast = env.transform[1]._render().float()
    context = render_context(physics, "default", 84, 84)
    with physics.contexts.gl.make_current() as ctx:  # the same texture through mjr_uploadTexture
        ctx.call(mujoco.mjr_uploadTexture, physics.model.ptr, physics.contexts.mujoco.ptr, env.transform[0]._sky)
    full = env.transform[1]._render().float()
    assert (fast - full).abs().mean() < 0.5
    assert context.uploaded[env.transform[0]._sky] == (256, 256)


def test_no_videos_leaves_the_sky_alone():
    env = background_env([solid_video(RED)], num_videos=0)
    plain = TransformedEnv(DMControlEnv("cartpole", "swingup", from_pixels=False), RenderPixels())
    env.set_seed(0)
    plain.set_seed(0)
    assert torch.equal(env.reset()["pixels"], plain.reset()["pixels"])
    assert env.reset()["distractions", "background"].tolist() == [-1, -1]


def test_bad_background_arguments():
    with pytest.raises(ValueError, match="num_videos"):
        BackgroundDistraction([solid_video(RED)], num_videos=3)
    with pytest.raises(ValueError, match=r"blend must be in \[0, 1\]"):
        BackgroundDistraction([solid_video(RED)], blend=1.2)
    with pytest.raises(ValueError, match=r"ground_alpha must be in \[0, 1\]"):
        BackgroundDistraction([solid_video(RED)], ground_alpha=2)
    with pytest.raises(ValueError, match="texture_size=1000 does not fit"):
        background_env([solid_video(RED)], texture_size=1000).reset()
    with pytest.raises(TypeError, match="videos must be None"):
        BackgroundDistraction(42)
