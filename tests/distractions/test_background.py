"""BackgroundDistraction on real dm_control physics and EGL rendering (Stone et al. 2021, Sec. 3.3)."""
import mujoco
import numpy as np
import pytest
import torch
from scipy import stats
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import BackgroundDistraction, RenderPixels
from dcs_torchrl.distractions.background import bounce
from dcs_torchrl.render.gl import render_context
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
        directions.append(int(env.transform[0]._worlds.direction[0]))
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


# ------------------------------------------------------------- reference_blend (the 2021 code's)
def _sky_faces(physics, transform):
    """The six faces of the sky texture as the model holds them now."""
    model, s = physics.model, transform.texture_size
    adr = int(model.tex_adr[transform._sky])
    return model.tex_data[adr: adr + 6 * s * s * 3].reshape(6, s, s, 3).copy()


def _blended(shown, frame, blend):
    """The 2021 code's blend: float32, truncated to uint8."""
    return (np.float32(1 - blend) * shown.astype(np.float32) + np.float32(blend) * frame.astype(np.float32)).astype(np.uint8)


def _random_videos(count=3):
    rng = np.random.default_rng(0)
    return [rng.integers(0, 256, (5, 32, 32, 3), dtype=np.uint8) for _ in range(count)]


@pytest.mark.parametrize("dynamic", [False, True])
def test_reference_blend_accumulates_over_episodes_as_the_2021_code(dynamic):
    videos, blend = _random_videos(), 0.3
    env = background_env(videos, dynamic=dynamic, blend=blend, texture_size=32, reference_blend=True)
    transform, physics = env.transform[0], physics_of(env)
    td = env.reset()
    shown = np.stack(transform._sky_faces)  # the original sky, resized: what the first episode blends onto
    for episode in range(4):
        td = env.reset() if episode else td
        for step in range(3):
            video, frame = td["distractions", "background"].tolist()
            np.testing.assert_array_equal(_sky_faces(physics, transform), _blended(shown, videos[video][frame], blend),
                                          err_msg=f"episode {episode} step {step}")
            td = env.step(td.set("action", env.action_spec.zero()))["next"]
        shown = _sky_faces(physics, transform)  # the next episode blends onto the last frame shown


def test_reference_blend_is_the_paper_blend_at_beta_1_and_keeps_seeding_and_state():
    videos = [tinted_video(i) for i in range(3)]

    def run(reference_blend, blend, seed=0):
        env = background_env(videos, dynamic=True, blend=blend, reference_blend=reference_blend)
        env.set_seed(seed)
        zero = lambda td: td.set("action", env.action_spec.zero())  # noqa: E731
        tds = [env.rollout(4, zero, break_when_any_done=False) for _ in range(3)]  # three episodes
        return (torch.stack([td["next", "pixels"] for td in tds]),
                torch.stack([td["next", "distractions", "background"] for td in tds]))

    pixels_paper, state_paper = run(False, 1.0)
    pixels_ref, _ = run(True, 1.0)
    assert torch.equal(pixels_paper, pixels_ref)  # β_bg = 1: nothing to accumulate
    pixels_a, state_a = run(True, 0.2)
    pixels_b, _ = run(True, 0.2)
    assert torch.equal(pixels_a, pixels_b)  # same seed, same pixels
    assert torch.equal(state_a, state_paper)  # the same draws (exposed state): only the sky differs
    assert not torch.equal(pixels_a, run(False, 0.2)[0])


def test_reference_blend_history_restarts_with_the_seed_and_belongs_to_each_env():
    from torchrl.envs import SerialEnv

    videos, blend = _random_videos(), 0.2
    env = background_env(videos, blend=blend, texture_size=32, reference_blend=True)
    env.set_seed(0)
    first = env.reset()["pixels"]
    for _ in range(3):
        env.reset()
    env.set_seed(0)
    assert torch.equal(env.reset()["pixels"], first)  # seeding starts again from the original sky

    make = lambda: background_env(videos, blend=blend, texture_size=32, reference_blend=True)  # noqa: E731
    batched = SerialEnv(2, make)
    batched.set_seed(0)
    td = batched.reset()
    subs = [(e.transform[0], physics_of(e)) for e in batched._envs]
    shown = [np.stack(t._sky_faces) for t, _ in subs]
    for episode in range(3):  # each sub-env accumulates over its own episodes only
        td = batched.reset() if episode else td
        for i, (transform, physics) in enumerate(subs):
            video, frame = td["distractions", "background"][i].tolist()
            expected = _blended(shown[i], videos[video][frame], blend)
            np.testing.assert_array_equal(_sky_faces(physics, transform), expected, err_msg=f"{episode}, env {i}")
            shown[i] = expected
