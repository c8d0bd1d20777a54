"""backend="warp": N envs in one process, each the episodes and distraction draws of one GL env with its seed."""
import functools
import json
import os

import numpy as np
import pytest
import torch
from torchrl.collectors import Collector
from torchrl.envs import Compose, DMControlEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs

import dcs_torchrl as dcs
from dcs_torchrl import BackgroundDistraction, make_env
from dcs_torchrl.render.warp import MASK_LABELS
from dcs_torchrl.vector.batch_physics import physics_threads
from dcs_torchrl.vector.batched import BatchedSuiteEnv, _chunks

pytest.importorskip("mujoco_warp")

#: where the Warp envs of these tests live and render (benchmarks/gpu_check.sh batched sets cuda)
DEVICE = os.environ.get("DCS_WARP_DEVICE", "cpu")

EPISODE = 10  # agent steps per episode at action repeat 100 (cartpole's 1000-step time limit)
SETTINGS = dict(benchmark="medium", dynamic=True, action_repeat=100, height=32, width=32, expose_distractions=True,
                pixels_only=False)
STATE_KEYS = ["position", "velocity", "reward", "done", "terminated", "truncated", "distractions"]


def _gl(**extra):
    return functools.partial(make_env, "cartpole", "swingup", **{**SETTINGS, **extra})


def _warp(n: int, **extra):
    return make_env("cartpole", "swingup", num_envs=n, backend="warp", device=DEVICE, **{**SETTINGS, **extra})


def _seeds(seed: int, n: int, factory) -> list[int]:
    """Each env's seed under TorchRL's chain: the next is what the previous one's set_seed returns."""
    seeds = [seed]
    for _ in range(n - 1):
        seeds.append(factory().set_seed(seeds[-1]))
    return seeds


def _actions(steps: int, n: int) -> torch.Tensor:
    return (torch.rand(steps, n, 1, generator=torch.Generator().manual_seed(0)) * 2 - 1).double()


def _gl_run(seed: int, actions: torch.Tensor, factory) -> list:
    """The entries of STATE_KEYS after each action, one GL env, reset at each episode's end."""
    env = factory()
    env.set_seed(seed)
    td, out = env.reset(), [None]
    out[0] = td.select(*[k for k in STATE_KEYS if k in td.keys()]).clone()
    for action in actions:
        td = env.step(td.set("action", action))["next"]
        out.append(td.select(*STATE_KEYS).clone())
        if td["done"].item():
            td = env.reset()
    env.close()
    return out


def _assert_same(batched, alone, where: str) -> None:
    for key in batched.keys(True, True):
        assert torch.equal(batched[key].cpu(), alone[key].to(batched[key].dtype)), f"{where}: {key} differs"


@pytest.mark.parametrize("extra", [{}, {"dynamic": False, "benchmark": "hard"}, {"background_blend": 0.5, "reference_blend": True}],
                         ids=["medium-dynamic", "hard-static", "reference-blend"])
def test_each_env_of_the_batch_runs_the_episodes_of_one_gl_env_with_its_seed(extra):
    n, steps = 3, 2 * EPISODE + 3  # across an episode end and a reset
    env = _warp(n, **extra)
    env.set_seed(7)
    actions = _actions(steps, n)
    td = env.reset()
    batched = [td.select(*[k for k in STATE_KEYS if k in td.keys()]).clone()]
    for action in actions:
        td.set("action", action)
        out, td = env.step_and_maybe_reset(td)
        batched.append(out["next"].select(*STATE_KEYS).clone())
        assert out["next", "pixels"].device == torch.device(DEVICE) and out["next", "pixels"].dtype == torch.uint8
    env.close()
    factory = _gl(**extra)
    for i, seed in enumerate(_seeds(7, n, factory)):
        alone = _gl_run(seed, actions[:, i], factory)
        for t, (b, a) in enumerate(zip(batched, alone)):
            _assert_same(b[i], a, f"env {i}, step {t}")
    assert any(b["done"].any() for b in batched)


#: the six tasks over arrays, each with one of the settings above; action repeat 300 does not divide the
#: 1000 control steps of an episode: its last agent step stops at the time limit (4 agent steps)
OVER_ARRAYS = [("ball_in_cup", "catch", {}), ("cartpole", "swingup", {"dynamic": False, "benchmark": "hard"}),
               ("cheetah", "run", {"background_blend": 0.5, "reference_blend": True}), ("finger", "spin", {}),
               ("reacher", "easy", {"dynamic": False, "benchmark": "hard"}),
               ("walker", "walk", {"background_blend": 0.5, "reference_blend": True})]


@pytest.mark.parametrize("domain, task, extra", OVER_ARRAYS, ids=[f"{d}-{t}" for d, t, _ in OVER_ARRAYS])
def test_each_task_over_arrays_runs_the_episodes_of_one_gl_env_with_its_seed(domain, task, extra):
    """The physics in MuJoCo's C and the task over arrays (BatchPhysics) give each env the states, rewards,
    observations, episode ends and distraction draws of one GL env (dm_control's step) with its seed."""
    settings = {**SETTINGS, "action_repeat": 300, "height": 24, "width": 24, **extra}
    n, steps = 2, 9  # two episodes of 4 agent steps, a reset, one more step
    env = make_env(domain, task, num_envs=n, backend="warp", device=DEVICE, **settings)
    assert env.physics is not None  # the task is stepped over arrays
    spec = env.action_spec
    actions = (torch.rand(steps, *spec.shape, generator=torch.Generator().manual_seed(1)) * 2 - 1).double()
    env.set_seed(5)
    td = env.reset()
    keys = [k for k in td.keys(True, True) if k not in ("pixels",)]
    batched = [td.select(*keys).clone()]
    for action in actions:
        out, td = env.step_and_maybe_reset(td.set("action", action))
        batched.append(out["next"].exclude("pixels").clone())
    env.close()
    assert [b["truncated"].all().item() for b in batched] == [False] * 4 + [True] + [False] * 3 + [True] + [False]
    factory = functools.partial(make_env, domain, task, **settings)
    for i, seed in enumerate(_seeds(5, n, factory)):
        alone = factory()
        alone.set_seed(seed)
        td = alone.reset()
        _assert_same(batched[0][i], td.select(*keys), f"env {i}, reset")
        for t, action in enumerate(actions, start=1):
            td = alone.step(td.set("action", action[i]))["next"]
            _assert_same(batched[t][i], td.exclude("pixels"), f"env {i}, step {t}")
            if td["done"].item():
                td = alone.reset()
        alone.close()
    assert any(b["reward"].any() for b in batched[1:])


def test_an_env_stepped_past_its_episode_end_without_a_reset_does_what_one_gl_env_does():
    """dm_control resets an env stepped after its episode ended (reward 0, the next episode's draw: reacher's
    target size too); the batch's next steps over arrays continue that episode as one GL env does."""
    settings = {**SETTINGS, "action_repeat": 300, "height": 24, "width": 24}
    actions = (torch.rand(7, 2, 2, generator=torch.Generator().manual_seed(2)) * 2 - 1).double()
    env = make_env("reacher", "easy", num_envs=2, backend="warp", device=DEVICE, seed=3, **settings)
    td, batched = env.reset(), []
    for action in actions:  # no reset at the episode's end (step 4)
        td = env.step(td.set("action", action))["next"]
        batched.append(td.exclude("pixels").clone())
    for i, world in enumerate(env._worlds):  # the rewards over arrays read the new episode's target size
        assert np.array_equal(env.physics.model["geom_size"][i], world.physics.model.geom_size)
    env.close()
    factory = functools.partial(make_env, "reacher", "easy", **settings)
    for i, seed in enumerate(_seeds(3, 2, factory)):
        alone = factory()
        alone.set_seed(seed)
        td = alone.reset()
        for t, action in enumerate(actions[:, i]):
            td = alone.step(td.set("action", action))["next"]
            _assert_same(batched[t][i], td.exclude("pixels"), f"env {i}, step {t}")
        alone.close()


def test_a_task_not_over_arrays_keeps_dm_controls_step_and_its_episodes():
    settings = {**SETTINGS, "action_repeat": 300, "height": 24, "width": 24}
    env = make_env("hopper", "stand", num_envs=2, backend="warp", device=DEVICE, seed=2, **settings)
    assert env.physics is None
    actions = _actions(5, 2).expand(5, 2, 4)
    td, batched = env.reset(), []
    for action in actions:
        out, td = env.step_and_maybe_reset(td.set("action", action))
        batched.append(out["next"].exclude("pixels").clone())
    env.close()
    alone = make_env("hopper", "stand", seed=2, **settings)
    td = alone.reset()
    for t, action in enumerate(actions[:, 0]):
        td = alone.step(td.set("action", action))["next"]
        _assert_same(batched[t][0], td.exclude("pixels"), f"step {t}")
        if td["done"].item():
            td = alone.reset()


def test_the_batch_equals_parallel_suite_env_seeded_alike():
    """make_env(num_envs=N): both backends, the same tensordict shapes, the same episodes (GL: N processes)."""
    n, steps = 2, EPISODE + 2
    actions = _actions(steps, n)
    runs = []
    gl = make_env("cartpole", "swingup", num_envs=n, **SETTINGS)
    assert isinstance(gl, dcs.ParallelSuiteEnv) and gl.batch_size == (n,)
    for env in (_warp(n), gl):
        assert env.observation_spec["pixels"].shape == (n, 32, 32, 3)
        env.set_seed(3)
        td, run = env.reset(), []
        for action in actions:
            out, td = env.step_and_maybe_reset(td.set("action", action))
            run.append(out["next"].select(*STATE_KEYS).clone())
        env.close()
        runs.append(run)
    for t, (b, p) in enumerate(zip(*runs)):
        _assert_same(b, p, f"step {t}")


def _continue_alone(seed: int, steps_before: int, actions: torch.Tensor) -> list:
    """One GL env stepped ``steps_before`` actions, then ``actions``, with no reset between."""
    env = _gl()()
    env.set_seed(seed)
    td = env.reset()
    out = []
    for k, action in enumerate(actions):
        td = env.step(td.set("action", action))["next"]
        if k >= steps_before:
            out.append(td.select(*STATE_KEYS).clone())
    env.close()
    return out


def test_only_the_first_model_holds_the_full_sky_unless_videos_are_blended_onto_it():
    """The batch renders from env 0's model: the others are compiled with a sky of texture_size texels
    a face (their frames and draws are still GL's: the test above), except where videos are blended
    onto the sky (0 < background_blend < 1), which each env reads from its own model."""
    def sky_bytes(env):
        return [w.physics.model.tex_data.nbytes for w in env._worlds]

    env = _warp(3)
    full, compact, other = sky_bytes(env)
    env.close()
    assert compact == other and compact < full / 5
    from dm_control.suite import common

    assert b'width="800"' in common.ASSETS["./common/skybox.xml"]  # the suite's asset as it was
    env = _warp(2, background_blend=0.5)
    assert len(set(sky_bytes(env))) == 1
    env.close()


def test_the_batch_writes_no_video_frame_into_a_model_it_does_not_render_from():
    env = _warp(2)
    skies = [w.physics.model.tex_data.copy() for w in env._worlds]
    env.set_seed(0)
    td = env.reset()
    for action in _actions(3, 2):
        td = env.step(td.set("action", action))["next"]
    assert all(np.array_equal(w.physics.model.tex_data, sky) for w, sky in zip(env._worlds, skies))
    assert len(td["pixels"].unique()) > 10  # the frames show the videos all the same
    env.close()


def test_an_env_not_reset_continues_its_episode():
    n = 2
    actions = _actions(6, n)
    env = _warp(n)
    env.set_seed(11)
    td = env.reset()
    for action in actions[:3]:
        td = env.step(td.set("action", action))["next"]
    td.set("_reset", torch.tensor([[True], [False]]))
    td = env.reset(td)
    later = []
    for action in actions[3:]:
        td = env.step(td.set("action", action))["next"]
        later.append(td.select(*STATE_KEYS).clone())
    env.close()
    seeds = _seeds(11, n, _gl())
    alone = _continue_alone(seeds[1], 3, actions[:, 1])
    for t, (b, a) in enumerate(zip(later, alone)):
        _assert_same(b[1], a, f"env 1 (not reset), step {t}")
    first = _gl()()
    first.set_seed(seeds[0])
    first.reset()
    for action in actions[:3, 0]:
        first.rand_step()  # the first episode's steps, whatever they were
    reset = first.reset()
    assert not torch.equal(later[0][0]["position"], reset["position"])  # env 0 moved on from a new start
    first.close()


def test_an_env_not_stepped_keeps_its_state():
    n = 2
    env = _warp(n)
    env.set_seed(5)
    td = env.reset()
    before = td["position"].clone()
    td.set("action", _actions(1, n)[0])
    td.set("_step", torch.tensor([True, False]))
    out = env.step(td)["next"]
    assert torch.equal(out["position"][1], before[1])
    assert not torch.equal(out["position"][0], before[0])
    env.close()


def test_the_frames_a_rollout_returns_are_those_stepped_alone():
    """Frame t of env.rollout(T) equals frame t of the same env stepped by hand: no frame is a view of a
    buffer the next step overwrites."""
    actions = _actions(EPISODE + 2, 2)

    class Replay:  # a policy replaying the actions, one a call
        def __init__(self):
            self.t = 0

        def __call__(self, td):
            self.t += 1
            return td.set("action", actions[self.t - 1])

    env = _warp(2, pixels_only=True, expose_distractions=False)
    env.set_seed(4)
    rolled = env.rollout(len(actions), Replay(), break_when_any_done=False)["next", "pixels"]
    env.set_seed(4)
    td, stepped = env.reset(), []
    for action in actions:
        out, td = env.step_and_maybe_reset(td.set("action", action))
        stepped.append(out["next", "pixels"])
    env.close()
    assert torch.equal(rolled, torch.stack(stepped, dim=1))
    assert not torch.equal(rolled[:, 0], rolled[:, 1])


def test_rollout_with_partial_steps_and_a_collector():
    env = _warp(2, pixels_only=True, expose_distractions=False)
    env.set_seed(0)
    td = env.rollout(EPISODE + 3, break_when_any_done=False, break_when_all_done=True)
    assert td["next", "pixels"].shape == (2, EPISODE, 32, 32, 3)
    assert td["next", "pixels"].dtype == torch.uint8
    collector = Collector(env, None, frames_per_batch=8, total_frames=16)
    batches = list(collector)
    collector.shutdown()
    assert [b["next", "pixels"].shape for b in batches] == [(2, 4, 32, 32, 3)] * 2


@pytest.mark.parametrize("domain, task", sorted(dcs.TASKS))
@pytest.mark.parametrize("benchmark", ["none", "medium"])
def test_check_env_specs_on_every_task(domain, task, benchmark):
    env = make_env(domain, task, benchmark=benchmark, dynamic=benchmark == "medium", num_envs=2, backend="warp",
                   height=24, width=24, expose_distractions=True, masks=True, seed=0)
    check_env_specs(env)
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("domain, task", sorted(dcs.TASKS))
@pytest.mark.parametrize("benchmark", sorted(dcs.BENCHMARKS))
@pytest.mark.parametrize("dynamic", [False, True])
def test_check_env_specs_on_every_task_benchmark_and_dynamic(domain, task, benchmark, dynamic):
    env = make_env(domain, task, benchmark=benchmark, dynamic=dynamic, num_envs=2, backend="warp",
                   height=24, width=24, expose_distractions=True, masks=True, seed=0)
    check_env_specs(env)
    env.close()


def _gl_frame(env_kwargs: dict, seed: int) -> tuple[np.ndarray, dict]:
    env = make_env("cartpole", "swingup", seed=seed, **env_kwargs)
    td = env.reset()
    frame = td["pixels"].numpy()
    env.close()
    return frame, td


def test_a_clean_frame_is_the_gl_frame_within_a_few_grey_levels():
    kwargs = dict(height=64, width=64)
    gl, _ = _gl_frame(kwargs, 0)
    env = make_env("cartpole", "swingup", seed=0, num_envs=1, backend="warp", **kwargs)
    warp = env.reset()["pixels"][0].numpy()
    env.close()
    assert np.abs(warp.astype(int) - gl.astype(int)).mean() < 6


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU (benchmarks/gpu_check.sh batched)")
@pytest.mark.parametrize("preset", ["none", "medium"])  # not "benchmark": pytest-benchmark's fixture
@pytest.mark.parametrize("order", [("cuda", "cpu"), ("cpu", "cuda")], ids=["cuda-first", "cpu-first"])
def test_cuda_frames_are_the_cpu_warp_frames_within_a_grey_level(preset, order):
    """The same seed rendered by Warp on CUDA and on the CPU, without and with videos, over a few steps; both
    orders in one process (a CPU Warp env first has failed on an H200 box: docs/notes/performance_log.md)."""
    frames = {}
    for device in order:
        env = make_env("cheetah", "run", benchmark=preset, dynamic=True, num_envs=4, backend="warp", device=device,
                       height=48, width=48, seed=3)
        td, run = env.reset(), []
        for action in _actions(3, 4).expand(3, 4, 6):
            td = env.step(td.set("action", action.to(device)))["next"]
            run.append(td["pixels"].cpu().int())
        env.close()
        frames[device] = torch.stack(run)
    difference = (frames["cpu"] - frames["cuda"]).abs()
    assert difference.max() <= 1 and difference.float().mean() < 0.05, (difference.max(), difference.float().mean())


def _red_sky_envs(n: int, ground_alpha: float) -> list:
    red = np.zeros((4, 32, 32, 3), np.uint8)
    red[..., 0] = 255
    envs = []
    for i in range(n):
        base = DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8)
        base.set_seed(i)  # the same initial state in every call: frames of two calls are compared pixel by pixel
        envs.append(TransformedEnv(base, Compose(BackgroundDistraction([red], ground_alpha=ground_alpha, seed=i))))
    return envs


def test_the_video_fills_the_sky_and_shows_through_the_floor_at_ground_alpha():
    env = BatchedSuiteEnv(_red_sky_envs(2, 0.0), height=48, width=48, masks=True)
    td = env.reset()
    pixels, labels = td["pixels"].numpy(), td["masks"].numpy()
    sky = labels == MASK_LABELS["background"]
    assert sky.mean() > 0.5 and (labels == MASK_LABELS["agent"]).any()
    assert not (labels == MASK_LABELS["floor"]).any()  # a floor of alpha 0 is not drawn: sky
    rails = sky & (pixels[..., 1] > 0)  # the rails are static world geoms, labelled background
    assert (pixels[sky & ~rails][:, 0] == 255).all() and (pixels[sky & ~rails][:, 1:] == 0).all()
    env.close()
    env = BatchedSuiteEnv(_red_sky_envs(1, 0.3), height=48, width=48, masks=True)
    td = env.reset()
    floor = td["masks"][0].numpy() == MASK_LABELS["floor"]
    opaque = BatchedSuiteEnv(_red_sky_envs(1, 1.0), height=48, width=48).reset()["pixels"][0].numpy()
    pixels = td["pixels"][0].numpy().astype(float)
    # GL draws a transparent geom twice over the sky: 1 - 0.7^2 = 0.51 of the floor, 0.49 of the red sky
    expected = 0.51 * opaque[floor].astype(float) + 0.49 * np.array([255.0, 0, 0])
    assert floor.mean() > 0.1 and np.abs(pixels[floor] - expected).max() <= 1.0
    env.close()


def _colour(video: int, frame: int) -> tuple[int, int, int]:
    return 40 * video + 20, 30 * frame + 10, 200


@pytest.mark.parametrize("sky_table", [True, False], ids=["frame-table", "rows"])
def test_each_world_shows_the_frame_its_own_distraction_draws_every_step(sky_table):
    """Solid-colour clips, a colour per (video, frame): at every step, across an episode's end, each
    world's sky is the colour of the (video, frame) its distraction state says, over chunks of the batch."""
    clips = [np.stack([np.full((8, 8, 3), _colour(v, f), np.uint8) for f in range(5)]) for v in range(3)]
    envs = []
    for i in range(5):
        base = DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=100)
        envs.append(TransformedEnv(base, Compose(BackgroundDistraction(clips, dynamic=True, texture_size=16, seed=i,
                                                                       expose=True))))
    env = BatchedSuiteEnv(envs, height=32, width=32, masks=True, render_chunks=2, sky_table=sky_table)
    assert (env.skies.table is not None) == sky_table
    env.set_seed(3)
    td, seen = env.reset(), set()
    for t in range(EPISODE + 3):
        seen |= _skies_shown(td, f"step {t}")
        td = env.step_and_maybe_reset(td.set("action", _actions(1, 5)[0]))[1]
    env.close()
    assert len(seen) > 5  # worlds apart and frames over time


def _skies_shown(td, where: str) -> set:
    """The (video, frame) each world's distraction state says, checked against its sky: every sky pixel
    (labelled background, less the rails) of that pair's colour (:func:`_colour`)."""
    labels, pixels, seen = td["masks"].cpu().numpy(), td["pixels"].cpu().numpy(), set()
    for world, (video, frame) in enumerate(td["distractions", "background"].tolist()):
        sky = labels[world] == MASK_LABELS["background"]
        rails = sky & (pixels[world, ..., 2] != 200)  # the rails: static world geoms, labelled background
        shown = pixels[world][sky & ~rails]
        assert len(shown) > 100 and (shown == _colour(video, frame)).all(), (where, world, video, frame)
        seen.add((video, frame))
    return seen


@pytest.mark.parametrize("device", ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(
    not torch.cuda.is_available(), reason="needs a CUDA GPU (benchmarks/gpu_check.sh batched)"))])
def test_a_clip_added_to_the_frame_table_in_place_is_shown(device):
    """The frame table grows into a new array or, while it has room, in place: a CUDA renderer, which
    renders from its own copy of the table, copies it again when its version rises, not only when the array
    is new. Solid-colour clips, each reset drawing videos: each world's sky is its (video, frame)'s colour."""
    clips = [np.stack([np.full((8, 8, 3), _colour(v, f), np.uint8) for f in range(2)]) for v in range(6)]
    envs = [TransformedEnv(DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=100), Compose(
        BackgroundDistraction(clips, dynamic=True, texture_size=16, seed=i, expose=True))) for i in range(2)]
    env = BatchedSuiteEnv(envs, height=32, width=32, device=device, masks=True, sky_table=True)
    env.set_seed(0)
    added = {"new array": 0, "in place": 0}
    for reset in range(6):
        rows, version = env.skies.table.rows, env.skies.table.version
        td = env.reset()
        if env.skies.table.version > version:
            added["in place" if env.skies.table.rows is rows else "new array"] += 1
        _skies_shown(td, f"reset {reset}")
    env.close()
    assert min(added.values()) > 0, added  # both kinds of addition were rendered


@pytest.mark.parametrize("extra", [{}, {"background_blend": 0.5}], ids=["frames-alone", "blended"])
def test_the_frame_table_and_each_worlds_rows_give_the_same_pixels(extra):
    from dcs_torchrl.envs import _distracted_env, resolve_settings

    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True, action_repeat=100, **extra)
    frames = []
    for sky_table in (True, False):
        env = BatchedSuiteEnv([_distracted_env(settings, False) for _ in range(5)], height=24, width=24,
                              render_chunks=3, sky_table=sky_table)
        env.set_seed(0)
        td, run = env.reset(), []
        for action in _actions(EPISODE + 2, 5):  # across an episode's end: new clips drawn
            out, td = env.step_and_maybe_reset(td.set("action", action))
            run.append(out["next", "pixels"])
        frames.append(torch.stack(run))
        env.close()
    assert torch.equal(frames[0], frames[1])


@pytest.mark.parametrize("dynamic", [False, True])
def test_a_worlds_own_sky_is_marked_changed_exactly_when_its_distraction_writes_it(dynamic):
    """Each world's own row (a blended sky): its part's sky_version, which a CUDA renderer uploads on,
    rises once at the steps its skies are written (every step of a dynamic background) and at no other."""
    from dcs_torchrl.envs import _distracted_env, resolve_settings

    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=dynamic, background_blend=0.5)
    env = BatchedSuiteEnv([_distracted_env(settings, False) for _ in range(4)], height=16, width=16, render_chunks=2,
                          sky_table=False)
    env.set_seed(0)
    td = env.reset()
    versions = [[scene.sky_version for scene in env._scenes]]
    for action in _actions(3, 4):
        td = env.step(td.set("action", action))["next"]
        versions.append([scene.sky_version for scene in env._scenes])
    env.close()
    assert versions[0] == [1, 1]  # two worlds a part, both written at the reset
    rises = [[b - a for a, b in zip(before, after)] for before, after in zip(versions, versions[1:])]
    assert rises == [[1, 1] if dynamic else [0, 0]] * 3


def test_the_frame_table_holds_each_clip_once_and_keeps_rows_as_it_grows():
    from dcs_torchrl.render.skies import FrameTable

    table = FrameTable(2)
    clips = [np.full((n, 2, 2, 3), v, np.uint8) for n, v in ((3, 10), (1, 20), (4, 30))]
    rows = [table.row(clip, len(clip) - 1) for clip in clips]
    assert rows == [3, 4, 8] and table.used == 9 and table.version == 3  # row 0: the blank sky before any clip
    before = table.rows
    assert table.row(clips[0], 0) == 1 and table.version == 3 and table.rows is before  # seen: not added again
    for clip, last in zip(clips, rows):
        assert (table.rows[last - len(clip) + 1:last + 1, 0] == clip).all()
    big = np.full((len(before), 2, 2, 3), 40, np.uint8)
    start = table.row(big, 0)
    assert table.rows is not before and len(table.rows) >= table.used == start + len(big)
    assert (table.rows[:len(before)][:9] == before[:9]).all() and (before[9:] == 0).all()  # the former array kept


def test_masks_label_the_floor_and_the_agent():
    env = make_env("cheetah", "run", num_envs=1, backend="warp", masks=True, height=48, width=48, seed=0)
    labels = env.reset()["masks"][0].numpy()
    assert set(np.unique(labels)) == set(MASK_LABELS.values())
    rows = np.arange(labels.shape[0])[:, None].repeat(labels.shape[1], 1)
    # the floor (a strip, with sky below it) lies under the cheetah
    assert np.median(rows[labels == MASK_LABELS["floor"]]) > np.median(rows[labels == MASK_LABELS["agent"]])
    assert (labels[:3] == MASK_LABELS["background"]).all()  # the top rows are sky
    env.close()


def test_colours_and_camera_change_the_frames_per_env():
    env = make_env("cartpole", "swingup", benchmark="medium", num_envs=3, backend="warp", height=32, width=32, seed=0)
    pixels = env.reset()["pixels"]
    assert not torch.equal(pixels[0], pixels[1]) and not torch.equal(pixels[1], pixels[2])
    env.close()


def test_each_renderer_builds_its_kernels_in_the_thread_that_makes_it(monkeypatch):
    """MuJoCo Warp specialises a kernel per render context at its first render. The chunks of a batch
    render in threads at once, and two first renders building their kernels together gave a few wrong
    pixels (a fresh env's first frame, seen with the machine loaded): every renderer renders first in
    the thread that builds the env, before any render thread runs."""
    import threading

    import mujoco_warp

    first, real = {}, mujoco_warp.render

    def render(m, d, rc):
        first.setdefault(id(rc), threading.current_thread().name)
        return real(m, d, rc)

    monkeypatch.setattr(mujoco_warp, "render", render)
    env = _warp(4)
    assert len(env._chunks) == 4
    env.set_seed(0)
    td = env.reset()
    env.step(td.set("action", _actions(1, 4)[0]))
    assert len(first) == 4 and set(first.values()) == {threading.current_thread().name}, first
    env.close()


def test_render_chunks_give_the_same_pixels():
    from dcs_torchrl.envs import _distracted_env, resolve_settings

    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True)
    frames = []
    for chunks in (1, 3):
        env = BatchedSuiteEnv([_distracted_env(settings, False) for _ in range(5)], height=24, width=24,
                              render_chunks=chunks)
        assert [len(r) for r in env._chunks] == ([5] if chunks == 1 else [2, 1, 2])
        env.set_seed(0)
        td, run = env.reset(), []
        for action in _actions(3, 5):
            td = env.step(td.set("action", action))["next"]
            run.append(td["pixels"])
        frames.append(torch.stack(run))
        env.close()
    assert torch.equal(frames[0], frames[1])


def test_bad_settings_are_refused_with_the_fix():
    from dcs_torchrl.envs import _distracted_env, resolve_settings

    with pytest.raises(ValueError, match="sky_table must be True, False or None"):
        BatchedSuiteEnv([_distracted_env(resolve_settings("cartpole", "swingup"), False)], sky_table="yes")
    with pytest.raises(ValueError, match="pass num_envs=N"):
        make_env("cartpole", "swingup", backend="warp")
    with pytest.raises(ValueError, match="masks=True needs backend='warp'"):
        make_env("cartpole", "swingup", masks=True)
    with pytest.raises(ValueError, match="unknown backend"):
        make_env("cartpole", "swingup", backend="vulkan")
    with pytest.raises(ValueError, match="num_envs must be a positive integer"):
        make_env("cartpole", "swingup", backend="warp", num_envs=0)
    with pytest.raises(ValueError, match="camera_id=-1"):
        make_env("cartpole", "swingup", backend="warp", num_envs=1, camera_id=-1)
    from dcs_torchrl.render.gl import PROFILES
    from dcs_torchrl.vector.batched import WARP_PROFILES

    assert set(WARP_PROFILES) == set(PROFILES)  # one name of each profile, checked once (render.check_profile)
    with pytest.raises(ValueError, match="unknown render_profile"):
        make_env("cartpole", "swingup", backend="warp", num_envs=1, render_profile="fastest")
    with pytest.raises(ValueError, match="render_chunks"):
        _chunks(4, 0)
    env = _warp(1)
    env.close()
    with pytest.raises(RuntimeError, match="closed"):
        env.reset()


AGENT = "sac_rad_cartpole_swingup"


def test_a_shipped_agent_evaluated_on_warp_runs_its_episodes_at_once_and_still_swings_up():
    from dcs_torchrl.evaluation.protocol import evaluate
    from dcs_torchrl.pretrained import agent_env_settings, load_pretrained
    from dcs_torchrl.training.envs import pixel_env, pixel_options

    agent = load_pretrained(AGENT)
    result = agent.evaluate(3, backend="warp", num_envs=2)
    env = pixel_env(agent_env_settings(agent._cfg, {}), backend="warp", num_envs=2, **pixel_options(agent._cfg.pixels))
    assert env.batch_size == (2,) and env.observation_spec["pixels"].shape == (2, 9, 84, 84)
    again = evaluate(env, agent.policy, 3, seed=agent.eval_seed)
    env.close()
    assert result.returns == again.returns and len(set(result.returns)) == 3
    assert result.mean > 500  # the random policy scores ~30: GL's agent acts on Warp's frames (docs/results.md)
    with pytest.raises(ValueError, match="unknown backend"):
        agent.evaluate(1, backend="vulkan")


def test_the_robustness_command_keeps_warp_points_apart_from_gl_points(tmp_path, monkeypatch):
    from dcs_torchrl.robustness import Point, main, sweep_agent

    calls = []

    def evaluate_settings(agent, settings, episodes, backend="gl", **_):
        for key, overrides in settings.items():
            calls.append(backend)
            yield key, {"mean": 1.0, "stderr": 0.0, "episodes": episodes, "returns": [1.0] * episodes}, 0.0

    monkeypatch.setattr("dcs_torchrl.evaluation.scheduling.evaluate_settings", evaluate_settings)
    points = [Point("color", 0.0, False), Point("color", 0.5, False)]
    sweep_agent(AGENT, points, tmp_path, episodes=1, progress=False, backend="warp")
    sweep_agent(AGENT, points, tmp_path, episodes=1, progress=False)  # GL's points: not the Warp ones
    sweep_agent(AGENT, points, tmp_path, episodes=1, progress=False, backend="warp")  # all stored
    assert calls == ["warp", "warp", "gl", "gl"]
    records = [json.loads(p.read_text()) for p in (tmp_path / "points").iterdir()]
    assert sorted(r["pixels"].get("backend", "gl") for r in records) == ["gl", "gl", "warp", "warp"]
    main([AGENT, "--axes", "color", "--intensities", "0", "--episodes", "1", "--backend", "warp",
          "--out", str(tmp_path), "--no-progress"])
    assert calls == ["warp", "warp", "gl", "gl"]  # the stored Warp point is reused
    with pytest.raises(ValueError, match="unknown backend"):
        sweep_agent(AGENT, points, tmp_path, episodes=1, progress=False, backend="vulkan")


def test_a_recipe_collects_with_the_warp_backend_and_records_it(tmp_path):
    """collector.backend=warp: the recipe's collection steps collector.num_workers envs in one batched
    env of this process; the run trains, evaluates on GL (the reference) and records the backend."""
    from hydra import compose, initialize_config_module

    from dcs_torchrl.methods import agent_class
    from dcs_torchrl.training import train

    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("sac", overrides=[
            "collector.backend=warp", "collector.num_workers=4", "total_frames=1600", "collector.seed_steps=8",
            "env.benchmark=medium", "env.dynamic=true", "env.action_repeat=100", "pixels.image_size=32",
            "network.hidden_dim=16", "replay_buffer.size=64", "algo.batch_size=4", "eval.episodes=1",
            "eval.periodic_episodes=1", "eval.interval=1600", "eval.video=false", "progress=false",
        ])
    results = train(cfg, agent_class("sac"), tmp_path / "run")
    assert results["steps"] == 1600 and results["config"]["collector"]["backend"] == "warp"
    assert results["eval"]["episodes"] == 1
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        bad = compose("sac", overrides=["collector.backend=vulkan"])
    with pytest.raises(ValueError, match="collector.backend='vulkan': choose one of"):
        train(bad, agent_class("sac"), tmp_path / "bad")
    assert not (tmp_path / "bad").exists()


def test_the_gymnasium_vector_env_steps_the_batch_and_autoresets_at_the_next_step():
    """make_vec(id, num_envs, vectorization_mode="vector_entry_point"): the batched env's frames and
    rewards as NumPy arrays; the step after an episode's end starts the next (reward 0, no done flag,
    the frame of the batched env's own reset); a reset_mask resets the marked sub-envs only."""
    import gymnasium

    import dcs_torchrl.gym_env  # noqa: F401  (registers the ids)

    n, options = 2, dict(action_repeat=100, height=32, width=32, device=DEVICE)
    envs = gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=n,
                              vectorization_mode="vector_entry_point", **options)
    env = make_env("cartpole", "swingup", benchmark="medium", dynamic=True, num_envs=n, backend="warp", **options)
    actions = _actions(EPISODE + 2, n).float()
    obs, _ = envs.reset(seed=7)
    env.set_seed(7)
    td = env.reset()
    assert envs.observation_space.shape == (n, 32, 32, 3) and np.array_equal(obs, td["pixels"].cpu().numpy())
    for t in range(EPISODE):
        obs, rewards, terminated, truncated, _ = envs.step(actions[t].numpy())
        td = env.step(td.set("action", actions[t].double()))["next"]
        assert np.array_equal(obs, td["pixels"].cpu().numpy()), t
        assert np.allclose(rewards, td["reward"].reshape(n).cpu().numpy())
    assert truncated.all() and not terminated.any()  # the time limit
    obs, rewards, terminated, truncated, _ = envs.step(actions[EPISODE].numpy())
    td = env.reset()
    assert np.array_equal(obs, td["pixels"].cpu().numpy()) and not rewards.any() and not (terminated | truncated).any()
    obs, *_ = envs.step(actions[EPISODE + 1].numpy())
    before = obs.copy()
    obs, _ = envs.reset(options={"reset_mask": np.array([True, False])})
    assert np.array_equal(obs[1], before[1]) and not np.array_equal(obs[0], before[0])
    for _ in range(EPISODE - 1):  # sub-env 1 (one step into its episode) reaches its time limit before sub-env 0
        obs, rewards, terminated, truncated, _ = envs.step(actions[0].numpy())
    assert truncated.tolist() == [False, True]
    last = obs.copy()
    obs, rewards, terminated, truncated, _ = envs.step(actions[0].numpy())  # 1 restarts while 0 ends its episode
    assert rewards[1] == 0 and rewards[0] > 0 and truncated.tolist() == [True, False] and not terminated.any()
    assert not np.array_equal(obs[0], last[0]) and not np.array_equal(obs[1], last[1])
    envs.close()
    env.close()
    with pytest.raises(gymnasium.error.ClosedEnvironmentError):
        envs.step(actions[0].numpy())
    with pytest.raises(ValueError, match="vectorization_mode='vector_entry_point'"):
        gymnasium.make("dcs/cartpole-swingup-none-v0", backend="warp", num_envs=2)
    # backend="gl": make_env's N GL envs in processes under the same vector env, the same episodes
    envs = gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=n, backend="gl",
                              vectorization_mode="vector_entry_point", **{**options, "device": None})
    warp = gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=n,
                              vectorization_mode="vector_entry_point", **options)
    for vector in (envs, warp):
        vector.reset(seed=3)
    for t in range(EPISODE + 1):
        gl_step, warp_step = envs.step(actions[t].numpy()), warp.step(actions[t].numpy())
        assert gl_step[0].shape == warp_step[0].shape == (n, 32, 32, 3)
        for a, b in zip(gl_step[1:4], warp_step[1:4]):
            assert np.array_equal(a, b), t
    envs.close()
    warp.close()


def test_every_sub_env_of_the_gymnasium_vector_env_starts_its_next_episode_unstepped_at_an_autoreset():
    """The sub-envs' episodes staggered (reset_mask), so that each ends while the others run on: at the step
    after each episode's end that sub-env shows the reset frame of its next episode (reward 0, no flag) and is
    not stepped; every sub-env's frames, rewards and flags are those of one Warp env seeded with its seed of
    the chain, reset where its episode ended."""
    import gymnasium

    import dcs_torchrl.gym_env  # noqa: F401  (registers the ids)

    n, options = 3, dict(action_repeat=100, height=32, width=32, device=DEVICE)
    envs = gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=n,
                              vectorization_mode="vector_entry_point", **options)
    alone = [make_env("cartpole", "swingup", benchmark="medium", dynamic=True, num_envs=1, backend="warp", **options)
             for _ in range(n)]
    chained = 5
    for env in alone:  # sub-env i: the i-th seed of the chain from 5
        chained = env.set_seed(chained)
    obs, _ = envs.reset(seed=5)
    tds = [env.reset() for env in alone]
    actions = _actions(2 * EPISODE + 6, n).float()
    ended, autoresets = np.zeros(n, bool), np.zeros(n, int)
    for t, action in enumerate(actions):
        if t in (1, 2):  # restart 0 and 1, then 0: sub-env i is i steps into its episode, each ends at its own step
            mask = np.array([True, True, False]) if t == 1 else np.array([True, False, False])
            obs, _ = envs.reset(options={"reset_mask": mask})
            tds = [env.reset() if reset else td for env, td, reset in zip(alone, tds, mask)]
        for i in range(n):
            assert np.array_equal(obs[i], tds[i]["pixels"][0].cpu().numpy()), f"before step {t}: sub-env {i}'s frame"
        obs, rewards, terminated, truncated, _ = envs.step(action.numpy())
        for i, env in enumerate(alone):
            if ended[i]:  # NEXT_STEP: the next episode's reset frame, no step
                tds[i], expected = env.reset(), (0.0, False, False)
                autoresets[i] += 1
            else:
                tds[i] = env.step(tds[i].set("action", action[i:i + 1].double().to(env.device)))["next"]
                expected = tuple(tds[i][key].item() for key in ("reward", "terminated", "truncated"))
            assert (rewards[i], terminated[i], truncated[i]) == expected, f"step {t}: sub-env {i}"
        ended = terminated | truncated
    for i in range(n):
        assert np.array_equal(obs[i], tds[i]["pixels"][0].cpu().numpy()), f"the last step: sub-env {i}'s frame"
    assert autoresets.tolist() == [2] * n  # each sub-env's two episode ends, at steps of its own
    envs.close()
    for env in alone:
        env.close()


def _run(env, actions: torch.Tensor) -> list:
    """Every step's output of ``env`` (reset once) under ``actions``, cloned, on the CPU."""
    td = env.reset()
    out = [td.exclude("action").clone().cpu()]
    for action in actions:
        td = env.step(td.set("action", action.to(env.device)))["next"]
        out.append(td.clone().cpu())
    return out


@pytest.mark.parametrize("groups", [
    [({"camera_scale": 0.3, "num_videos": 0}, 2), ({"benchmark": "none"}, 1)],
    [({}, 2), ({"background_blend": 0.5}, 2)],  # one face of video beside six faces blended onto the sky
], ids=["no-videos", "videos-blended-and-not"])
def test_each_group_of_a_grouped_env_runs_the_episodes_and_pixels_of_its_own_batch(groups):
    """make_grouped_env(..., seed=s): every group runs the episodes, distraction draws and pixels of its own
    batch, make_env(..., num_envs=its envs, backend="warp", seed=s); another seed, other episodes in every group."""
    base = {k: v for k, v in SETTINGS.items() if k not in ("height", "width", "pixels_only", "expose_distractions")}
    options = dict(height=32, width=32, device=DEVICE, pixels_only=False, expose_distractions=True)
    n = sum(count for _, count in groups)
    actions = _actions(EPISODE + 2, n)
    together = {}
    for seed in (11, 12):
        grouped = dcs.make_grouped_env("cartpole", "swingup", [({**base, **s}, c) for s, c in groups], **options,
                                       seed=seed)
        assert grouped.batch_size == (n,)
        together[seed] = _run(grouped, actions)
        grouped.close()
    start = 0
    for settings, count in groups:
        alone_env = make_env("cartpole", "swingup", num_envs=count, backend="warp", **{**base, **settings}, **options,
                             seed=11)
        alone = _run(alone_env, actions[:, start:start + count])
        alone_env.close()
        for t, (mine, theirs) in enumerate(zip(together[11], alone)):
            part = mine[start:start + count]
            assert set(part.keys(True, True)) == set(theirs.keys(True, True))
            for key in theirs.keys(True, True):
                assert torch.equal(part[key], theirs[key]), f"group at {start}, step {t}: {key} differs"
        frames = [torch.stack([out["pixels"] for out in alone]),
                  torch.stack([out["pixels"][start:start + count] for out in together[12]])]
        for i in range(count):  # each env of the group: another start, other frames
            assert not torch.equal(together[12][0]["position"][start + i], alone[0]["position"][i]), f"env {start + i}"
            assert not torch.equal(frames[0][:, i], frames[1][:, i]), f"env {start + i}"
        start += count


def test_a_grouped_env_refuses_what_one_render_cannot_mix():
    with pytest.raises(ValueError, match="all show background videos or none"):
        dcs.make_grouped_env("cartpole", "swingup", [({"benchmark": "medium"}, 1), ({"benchmark": "none"}, 1)])
    with pytest.raises(ValueError, match="texture_size"):
        dcs.make_grouped_env("cartpole", "swingup", [({"benchmark": "medium", "texture_size": 128}, 1),
                                                         ({"benchmark": "medium", "texture_size": 64}, 1)])
    with pytest.raises(TypeError, match="scene settings go in each group's settings"):
        dcs.make_grouped_env("cartpole", "swingup", [({}, 1)], camera_scale=0.2)
    with pytest.raises(TypeError, match="scene settings go in each group's settings"):
        dcs.make_grouped_env("cartpole", "swingup", [({}, 1)], num_envs=2)
    with pytest.raises(TypeError, match=r"\(settings dict, num_envs\) pair"):
        dcs.make_grouped_env("cartpole", "swingup", [{"camera_scale": 0.2}])
    with pytest.raises(ValueError, match="positive integer"):
        dcs.make_grouped_env("cartpole", "swingup", [({}, 0)])
    with pytest.raises(ValueError, match="at least one"):
        dcs.make_grouped_env("cartpole", "swingup", [])


def test_evaluate_each_gives_each_setting_the_returns_of_its_own_warp_evaluation():
    from dcs_torchrl.pretrained import load_pretrained

    agent = load_pretrained(AGENT)
    settings = [{"color_scale": 0.3}, {"camera_scale": 0.2, "dynamic": True}]
    together = agent.evaluate_each(settings, 2)
    assert [r.returns for r in together] == [agent.evaluate(2, backend="warp", **s).returns for s in settings]
    assert together[0].returns != together[1].returns
    assert agent.evaluate_each([], 2) == []


def test_warp_batches_keep_videos_apart_and_share_the_envs_among_the_processes():
    from dcs_torchrl.evaluation.scheduling import WARP_BATCH_ENVS, _warp_batches
    from dcs_torchrl.pretrained import agent_directory, agent_results

    config = agent_results(agent_directory(AGENT))["config"]
    settings = {f"color{i}": {"color_scale": 0.1 * i} for i in range(6)}
    settings |= {f"video{i}": {"num_videos": 4, "background_blend": 0.2 * (i + 1)} for i in range(3)}
    batches = _warp_batches(config, settings, 10, processes=2)  # 90 envs: at most 45 a batch
    assert sorted(map(sorted, batches)) == sorted(map(sorted, [
        ["color0", "color1", "color2", "color3"], ["color4", "color5"], ["video0", "video1", "video2"]]))
    assert [len(b) for b in batches] == sorted((len(b) for b in batches), reverse=True)  # largest first
    assert _warp_batches(config, settings, 10, processes=1)[0] == [f"color{i}" for i in range(6)]
    many = {f"c{i}": {"color_scale": 0.01 * i} for i in range(30)}
    assert max(len(b) for b in _warp_batches(config, many, 10, processes=1)) == WARP_BATCH_ENVS // 10
    assert _warp_batches(config, {"one": {}}, 500, processes=4) == [["one"]]  # one setting's episodes: one batch


def test_a_batch_in_processes_runs_the_episodes_and_frames_of_one_batch():
    """processes=2: the envs shared among two Warp batches (2 + 1, the first in this process) run the
    episodes, distraction draws, pixels and masks of one batch seeded alike, across an episode end,
    partial steps (within a process's share; none of a process's envs) and a partial reset."""
    n, steps = 3, EPISODE + 6
    actions = _actions(steps, n)
    # the steps at which only some envs are stepped (at 4, none of the second process's) / reset
    partial_steps, partial_reset = {3: [True, False, True], 4: [True, True, False]}, 6
    runs = []
    for processes in (2, None):
        env = _warp(n, processes=processes, masks=True)
        assert env.batch_size == (n,) and isinstance(env, dcs.ParallelSuiteEnv) == (processes == 2)
        if processes and physics_threads() <= processes:  # a core or less per process: its physics on one thread
            here = env._here.env.physics  # the first process's share, stepped in this one
            assert here.threads == 1
        env.set_seed(9)
        td, run = env.reset(), []
        run.append(td.clone())
        for t, action in enumerate(actions):
            if t == partial_reset:
                td = env.reset(td.set("_reset", torch.tensor([[False], [True], [False]])))
                run.append(td.clone())
            if t in partial_steps:
                td.set("_step", torch.tensor(partial_steps[t]))
            out, td = env.step_and_maybe_reset(td.set("action", action))
            td = td.exclude("_step")
            run.append(out["next"].clone())
        env.close()
        runs.append(run)
    for t, (apart, together) in enumerate(zip(*runs)):
        assert set(apart.keys(True, True)) == set(together.keys(True, True))
        for key in together.keys(True, True):
            assert torch.equal(apart[key], together[key]), f"step {t}: {key} differs"
    assert any(r["done"].any() for r in runs[0])
    for t, mask in partial_steps.items():  # run[t + 1] is step t: an env not stepped has reward 0, its state kept
        for i in np.flatnonzero(~np.array(mask)):
            assert runs[0][t + 1]["reward"][i].item() == 0
            assert torch.equal(runs[0][t + 1]["position"][i], runs[0][t]["position"][i])


def test_processes_are_refused_where_they_cannot_apply():
    with pytest.raises(ValueError, match="leave processes out"):
        make_env("cartpole", "swingup", num_envs=2, processes=2)  # GL
    with pytest.raises(ValueError, match="processes <= num_envs"):
        make_env("cartpole", "swingup", num_envs=2, backend="warp", processes=3)
    for bad in (0, True, 1.5):
        with pytest.raises(ValueError, match="processes must be a positive integer"):
            make_env("cartpole", "swingup", num_envs=2, backend="warp", processes=bad)
    with pytest.raises(ValueError, match="leave processes out"):
        dcs.make_grouped_env("cartpole", "swingup", [({}, 2)], processes=2)
    one = functools.partial(make_env, "cartpole", "swingup", num_envs=2, backend="warp", height=16, width=16)
    with pytest.raises(ValueError, match=r"batch size \[2\], not \[1\]"):
        dcs.ParallelSuiteEnv(2, one, envs_per_worker=[1, 2], first_here=True)
    with pytest.raises(ValueError, match="envs_per_worker must hold num_workers=2"):
        dcs.ParallelSuiteEnv(2, one, envs_per_worker=[2])
    with pytest.raises(TypeError, match="sequence of num_workers=2 callables"):
        dcs.ParallelSuiteEnv(2, [one])


def test_the_gymnasium_vector_env_takes_processes_and_runs_the_same_episodes_and_frames():
    """gymnasium.make_vec(..., processes=2): the batch shared among two processes under the vector env, frames,
    rewards and episode ends those of one batch, through its autoreset and a reset_mask."""
    import gymnasium

    import dcs_torchrl.gym_env  # noqa: F401  (registers the ids)

    n, options = 3, dict(action_repeat=100, height=32, width=32, device=DEVICE)
    vectors = [gymnasium.make_vec("dcs/cartpole-swingup-medium-dynamic-v0", num_envs=n,
                                  vectorization_mode="vector_entry_point", **options, **extra)
               for extra in ({"processes": 2}, {})]
    assert isinstance(vectors[0].unwrapped.torchrl_env, dcs.ParallelSuiteEnv)
    actions = _actions(EPISODE + 3, n).float().numpy()
    outs = [[vector.reset(seed=5)[:1]] for vector in vectors]  # each entry: (obs,) or (obs, rewards, terminated, truncated)
    for t, action in enumerate(actions):
        for vector, out in zip(vectors, outs):
            if t == 3:
                out.append(vector.reset(options={"reset_mask": np.array([False, True, True])})[:1])
            out.append(vector.step(action)[:4])
    for t, (apart, together) in enumerate(zip(*outs)):
        assert all(np.array_equal(a, b) for a, b in zip(apart, together)), t
    assert any(out[3].any() for out in outs[0] if len(out) == 4)  # an episode ended (autoreset at the next step)
    for vector in vectors:
        vector.close()
