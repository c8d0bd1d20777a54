"""Datasets (dcs_torchrl.datasets): generated from real physics and renders, resumed, refused, loaded.

One small set is made once per module (cartpole swingup, medium dynamic, the random policy,
32-pixel frames, episodes cut at 6 steps) and read by most tests; the others make their own.
tests/test_datasets_export.py: V-D4RL's layouts and Minari; tests/test_datasets_warp.py: the Warp batch.
"""
import json
import os
import re
import shlex
import shutil
from pathlib import Path

import pytest
import torch
from tensordict import MemoryMappedTensor, TensorDict
from torchrl.data.replay_buffers.samplers import SamplerWithoutReplacement, SliceSampler

import dcs_torchrl as dcs
from dcs_torchrl.datasets import Mixing, generate, load, load_data, load_vd4rl
from dcs_torchrl.datasets import generation, layout
from dcs_torchrl.datasets.__main__ import main
from dcs_torchrl.datasets.metadata import episode_seed, episode_seeds

SET = dict(domain="cartpole", task="swingup", benchmark="medium", dynamic=True, image_size=32, max_steps=6)
EPISODES = 3


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("sets") / "small"
    generate(out, episodes=EPISODES, seed=0, **SET)
    return out


@pytest.fixture(scope="module")
def agent():
    """The shipped cartpole agent as a behaviour policy, loaded once (it holds no episode state)."""
    from dcs_torchrl.datasets.policies import load_behaviour

    return load_behaviour("sac_rad_cartpole_swingup")


def _copy(small_set, tmp_path) -> Path:
    out = tmp_path / "copy"
    shutil.copytree(small_set, out)
    return out


def test_a_set_holds_every_frame_once_and_replays_bit_for_bit_in_a_fresh_env(small_set):
    data = load_data(small_set)
    transitions, frames = data["transitions"], data["frames"]
    assert transitions.shape == (EPISODES * SET["max_steps"],) and frames.shape == (EPISODES * (SET["max_steps"] + 1),)
    assert frames["pixels"].dtype == torch.uint8 and frames["pixels"].shape[1:] == (32, 32, 3)
    expected = {"action", "done", "terminated", "truncated", ("state", "position"), ("state", "velocity"),
                ("distractions", "camera"), ("distractions", "color"), ("distractions", "background"),
                ("next", "reward"), ("next", "done"), ("next", "terminated"), ("next", "truncated"),
                ("next", "state", "position"), ("next", "distractions", "camera"), "episode", "step", "frame",
                "first_frame", "policy"}
    assert expected <= set(transitions.keys(include_nested=True, leaves_only=True))
    env = dcs.make_env("cartpole", "swingup", benchmark="medium", dynamic=True, height=32, width=32,
                       expose_distractions=True, pixels_only=False)
    try:
        for k in range(EPISODES):
            rows = transitions[transitions["episode"] == k]
            env.set_seed(episode_seed(0, k))
            td = env.reset()
            assert torch.equal(td["pixels"], frames["pixels"][rows["first_frame"][0]])
            for i in range(rows.shape[0]):
                td["action"] = rows["action"][i]
                td = env.step(td)
                assert torch.equal(td["next", "pixels"], frames["pixels"][rows["frame"][i] + 1])
                assert torch.equal(td["next", "position"], rows["next", "state", "position"][i])
                assert torch.equal(td["next", "distractions", "camera"], rows["next", "distractions", "camera"][i])
                assert torch.equal(td["next", "reward"], rows["next", "reward"][i])
                td = td["next"]
            assert bool(rows["next", "truncated"][-1]) and bool(rows["next", "done"][-1])  # cut at max_steps
            assert not rows["next", "done"][:-1].any()
    finally:
        env.close()


def test_the_metadata_records_every_setting_the_videos_the_policy_and_the_seeds(small_set):
    from dcs_torchrl.videos import EMBEDDED_VERSION

    record = json.loads((small_set / "metadata.json").read_text())
    settings = dcs.resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True).as_dict()
    assert record["env"] == settings | {"embedded_videos": EMBEDDED_VERSION}
    assert record["pixels"] == {"image_size": 32, "render_profile": "default", "masks": False, "backend": "gl"}
    assert record["policies"] == [{"name": "random", "kind": "random"}] and record["seed"] == 0
    assert record["max_steps"] == SET["max_steps"] and record["suite_version"]
    assert [e["seed"] for e in record["episode_table"]] == [episode_seed(0, k) for k in range(EPISODES)]
    assert record["episodes"] == EPISODES and record["transitions"] == EPISODES * SET["max_steps"]
    assert record["keys"]["frames"]["pixels"] == "uint8 [32, 32, 3]"
    assert record["versions"]["torchrl"] and record["versions"]["mujoco"]
    returns = [e["return"] for e in record["episode_table"]]
    assert record["returns"]["mean"] == pytest.approx(sum(returns) / len(returns))


def killed_at(monkeypatch, episode: int):
    """Makes generation die (as a kill: nothing after the last whole episode kept) when it starts
    the wave of ``episode``; returns the list of the waves' first episodes run before."""
    run_wave, started = generation._run_wave, []

    def killed(env, plan, first, count, *args):
        if first <= episode < first + count:
            raise KeyboardInterrupt
        started.append(first)
        return run_wave(env, plan, first, count, *args)

    monkeypatch.setattr(generation, "_run_wave", killed)
    return started


def test_the_episode_seeds_are_torchrls_chain_so_one_env_and_a_batch_give_episode_k_one_seed():
    env = dcs.make_env("cartpole", "swingup", height=16, width=16)
    try:
        assert episode_seed(5, 0) == 5 and env.set_seed(5) == episode_seed(5, 1)  # what set_seed returns: the next
        assert env.set_seed(episode_seed(5, 3)) == episode_seed(5, 4)
    finally:
        env.close()
    assert episode_seeds(5, 2, 3) == [episode_seed(5, k) for k in (2, 3, 4)]


def test_a_killed_run_resumes_where_it_stopped_and_makes_the_same_set(small_set, tmp_path, monkeypatch):
    out, run_wave = tmp_path / "killed", generation._run_wave
    killed_at(monkeypatch, 2)
    with pytest.raises(KeyboardInterrupt):
        generate(out, episodes=EPISODES, seed=0, **SET)
    monkeypatch.undo()
    assert not (out / "data").exists()
    assert sorted(p.name for p in (out / "episodes").iterdir()) == ["000000", "000001"]
    (out / "episodes" / ".000002.tmp-1").mkdir()  # a half-written episode (killed while writing it)
    resumed = []
    monkeypatch.setattr(generation, "_run_wave", lambda env, plan, first, *a: resumed.append(first)
                        or run_wave(env, plan, first, *a))
    generate(out, episodes=EPISODES, seed=0, **SET)
    assert resumed == [2]  # the written episodes are skipped
    assert not (out / "episodes").exists()  # merged into data/
    assert (load_data(out) == load_data(small_set)).all()


def test_asking_for_more_episodes_extends_the_set_with_the_episodes_an_uncut_run_makes(small_set, tmp_path):
    out = tmp_path / "grown"
    generate(out, episodes=1, seed=0, **SET)
    assert load_data(out)["transitions"].shape == (SET["max_steps"],)
    record = generate(out, episodes=EPISODES, seed=0, **SET)
    assert record["episodes"] == EPISODES
    assert (load_data(out) == load_data(small_set)).all()
    assert generate(out, episodes=1, seed=0, **SET)["episodes"] == EPISODES  # holding more: left as it is


def test_a_set_made_with_other_settings_is_refused_naming_each_difference(small_set, tmp_path):
    out = _copy(small_set, tmp_path)
    before = (out / "metadata.json").read_bytes()
    other = SET | {"benchmark": "easy"}
    with pytest.raises(FileExistsError, match="env.benchmark: 'medium' in the set, 'easy' asked") as error:
        generate(out, episodes=EPISODES + 1, seed=0, **other)
    assert "env.camera_scale" in str(error.value) and "Choose another --out" in str(error.value)
    with pytest.raises(FileExistsError, match="seed: 0 in the set, 1 asked"):
        generate(out, episodes=EPISODES, seed=1, **SET)
    with pytest.raises(FileExistsError, match="mixing.epsilon"):
        generate(out, episodes=EPISODES, seed=0, mixing=Mixing(epsilon=0.5), **SET)
    # every setting that changes the data: extending with another is refused, naming it
    for other, named in ((SET | {"max_steps": 5}, "max_steps: 6 in the set, 5 asked"),
                         (SET | {"max_steps": None}, "max_steps: 6 in the set, None asked"),
                         (SET | {"image_size": 24}, "pixels.image_size: 32 in the set, 24 asked"),
                         (SET | {"render_profile": "fast"}, "pixels.render_profile: 'default' in the set, 'fast' asked"),
                         (SET | {"backend": "warp"}, "pixels.backend: 'gl' in the set, 'warp' asked"),
                         (SET | {"masks": True, "backend": "warp"}, "pixels.masks: False in the set, True asked"),
                         (SET | {"policies": ["random", "random"]}, "policies.1.name: None in the set, 'random' asked"),
                         (SET | {"action_repeat": 4}, "env.action_repeat: 8 in the set, 4 asked")):
        with pytest.raises(FileExistsError, match=re.escape(named)):
            generate(out, episodes=EPISODES + 1, seed=0, **other)
    assert (out / "metadata.json").read_bytes() == before and sorted(p.name for p in out.iterdir()) == ["data", "metadata.json"]
    stranger = tmp_path / "stranger"
    stranger.mkdir()
    (stranger / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="is not a dataset"):
        generate(stranger, episodes=1, **SET)


def test_frame_stacks_are_the_recipes_and_never_cross_an_episode_boundary(small_set):
    data = load_data(small_set)
    frames, steps = data["frames", "pixels"], SET["max_steps"]
    buffer = load(small_set, batch_size=EPISODES * steps, frame_stack=3, sampler=SamplerWithoutReplacement())
    batch = buffer.sample()
    assert batch["pixels"].shape == (EPISODES * steps, 9, 32, 32) and batch["pixels"].dtype == torch.uint8
    for i in range(batch.shape[0]):
        k, t = int(batch["episode"][i]), int(batch["step"][i])
        first = k * (steps + 1)  # each episode's frames follow the previous one's
        for stack, newest in ((batch["pixels"][i], t), (batch["next", "pixels"][i], t + 1)):
            ids = [max(first + newest - j, first) for j in (2, 1, 0)]  # the reset frame repeated, as CatFrames
            assert torch.equal(stack, torch.cat([frames[j].permute(2, 0, 1) for j in ids]))
    first_steps = batch[batch["step"] == 0]
    assert (first_steps["pixels"][:, :3] == first_steps["pixels"][:, 6:]).all()


def test_the_buffer_is_a_torchrl_replay_buffer_over_memory_mapped_files(small_set):
    from torchrl.data import TensorDictReplayBuffer

    buffer = load(small_set, batch_size=4)
    assert isinstance(buffer, TensorDictReplayBuffer) and len(buffer) == EPISODES * SET["max_steps"]
    stored = buffer.storage[0:2]
    assert isinstance(load_data(small_set)["transitions", "action"], MemoryMappedTensor) and stored.shape == (2,)
    with pytest.raises(RuntimeError):
        buffer.extend(stored)  # a dataset is read-only
    slices = load(small_set, batch_size=6, sampler=SliceSampler(slice_len=3, traj_key="episode")).sample()
    assert (slices["episode"].reshape(2, 3) == slices["episode"].reshape(2, 3)[:, :1]).all()


# The layout TorchRL's VD4RLExperienceReplay documents (its docstring's sample and its _process_data):
# the entries a V-D4RL sample has, their per-row shape (C, H, W for pixels) and dtype.
VD4RL_LAYOUT = {
    "pixels": ((3, 32, 32), torch.float32), ("next", "pixels"): ((3, 32, 32), torch.float32),
    "action": ((1,), torch.float32), ("next", "reward"): ((1,), torch.float32), "is_init": ((), torch.bool),
    "discount": ((), torch.float32),
    "index": ((), torch.int64), "done": ((1,), torch.bool), "terminated": ((1,), torch.bool),
    "truncated": ((1,), torch.bool), ("next", "done"): ((1,), torch.bool), ("next", "terminated"): ((1,), torch.bool),
    ("next", "truncated"): ((1,), torch.bool), ("state", "position"): ((3,), torch.float32),
    ("next", "state", "velocity"): ((2,), torch.float32),
}


def test_the_vd4rl_layout_matches_what_torchrl_vd4rl_experience_replay_gives(small_set):
    batch = load_vd4rl(small_set, batch_size=8).sample()
    for key, (shape, dtype) in VD4RL_LAYOUT.items():
        assert tuple(batch[key].shape) == (8, *shape) and batch[key].dtype == dtype, key
    frames = load_data(small_set)["frames", "pixels"]
    expected = frames[batch["frame"]].permute(0, 3, 1, 2).float() / 255
    assert torch.equal(batch["pixels"], expected) and torch.equal(batch["is_init"], batch["step"] == 0)
    assert not batch["done"].any()  # V-D4RL's root done: an observation is never a terminal one
    assert torch.equal(batch["discount"], 1.0 - batch["next", "terminated"].squeeze(-1).float())
    stacked = load(small_set, batch_size=8, frame_stack=3, layout="vd4rl").sample()
    assert stacked["pixels"].shape == (8, 9, 32, 32) and stacked["pixels"].max() <= 1.0


def test_an_agent_acts_on_the_stacks_the_loader_rebuilds_mixed_policies_alternate_and_noise_stays_in_bounds(tmp_path,
                                                                                                          agent):
    from tensordict import TensorDict
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from dcs_torchrl.evaluation.protocol import torch_threads
    from dcs_torchrl.pretrained import checkpoint_sha256

    out = tmp_path / "mixed"
    record = generate(out, domain="cartpole", task="swingup", episodes=2, max_steps=4, policies=[agent, "random"])
    theirs = record["policies"][0]
    assert theirs["checkpoint_sha256"] == checkpoint_sha256("sac_rad_cartpole_swingup") and theirs["frame_stack"] == 3
    assert record["pixels"]["image_size"] == 84 and [e["policy"] for e in record["episode_table"]] == [0, 1]
    batch = load(out, batch_size=8, sampler=SamplerWithoutReplacement()).sample()
    acted = batch[batch["policy"] == 0]
    assert acted.shape == (4,)
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad(), torch_threads(1):  # as it acted
        for i in range(acted.shape[0]):
            action = agent.agent.policy(TensorDict({"pixels": acted["pixels"][i]}, []))["action"]
            assert torch.allclose(action.double(), acted["action"][i], atol=1e-6)

    low, high = -torch.ones(1, dtype=torch.float64), torch.ones(1, dtype=torch.float64)
    stack = agent.start_episode(torch.full((84, 84, 3), 128, dtype=torch.uint8))
    clean = agent.act(stack, low, high, Mixing(), torch.Generator().manual_seed(0))
    assert torch.equal(clean, agent.act(stack, low, high, Mixing(), torch.Generator().manual_seed(1)))  # deterministic
    noisy = torch.stack([agent.act(stack, low, high, Mixing(action_noise=5.0), torch.Generator().manual_seed(i))
                         for i in range(20)])
    assert noisy.abs().max() <= 1.0 and (noisy.abs() == 1.0).any() and not (noisy == clean).all()
    uniform = agent.act(stack, low, high, Mixing(epsilon=1.0), torch.Generator().manual_seed(3))
    generator = torch.Generator().manual_seed(3)
    torch.rand((), generator=generator)  # the epsilon draw, then the uniform action
    assert torch.equal(uniform, -1 + 2 * torch.rand((1,), generator=generator, dtype=torch.float64))


def test_bad_requests_fail_naming_the_fix(tmp_path):
    with pytest.raises(ValueError, match="--domain ball_in_cup --task catch"):
        generate(tmp_path / "a", domain="cartpole", task="swingup", episodes=1, policies=["sac_rad_ball_in_cup_catch"])
    with pytest.raises(ValueError, match="--masks needs --backend warp"):
        generate(tmp_path / "b", episodes=1, masks=True, **SET)
    with pytest.raises(ValueError, match="--num-envs 4: a positive integer, with --backend warp"):
        generate(tmp_path / "b", episodes=1, num_envs=4, **SET)
    with pytest.raises(ValueError, match="--episodes must be an integer >= 1"):
        generate(tmp_path / "c", episodes=0, **SET)
    with pytest.raises(FileNotFoundError, match="neither a directory nor a shipped agent"):
        generate(tmp_path / "d", domain="cartpole", task="swingup", episodes=1, policies=["no_such_agent"])
    with pytest.raises(ValueError, match="unknown benchmark"):
        generate(tmp_path / "e", domain="cartpole", task="swingup", episodes=1, benchmark="impossible")
    with pytest.raises(ValueError, match="--epsilon must be a probability"):
        Mixing(epsilon=2.0)
    with pytest.raises(FileNotFoundError, match="python -m dcs_torchrl.datasets generate"):
        load(tmp_path / "nothing", batch_size=4)
    assert not any(tmp_path.iterdir())  # nothing was written
    with pytest.raises(SystemExit, match="error: unknown benchmark 'impossible'"):  # the message, no traceback
        main(["generate", "--domain", "cartpole", "--task", "swingup", "--episodes", "1", "--benchmark", "impossible",
              "--out", str(tmp_path / "f")])
    assert not any(tmp_path.iterdir())


def test_behaviour_cloning_learns_the_sets_actions_and_is_scored_by_the_suites_evaluation(small_set):
    from dcs_torchrl.datasets.bc import score, train_bc
    from dcs_torchrl.evaluation.protocol import torch_threads

    with torch_threads(1):
        policy, losses = train_bc(small_set, updates=40, batch_size=18, frame_stack=3, log_every=20, lr=1e-3, shift=0)
    assert len(losses) == 2 and losses[-1] < losses[0]  # it fits the set's actions
    pixels = {"frame_stack": 3, "image_size": 32, "render_profile": "default"}
    result = score(policy, "cartpole", "swingup", {"benchmark": "medium", "action_repeat": 100}, pixels, 1, seed=0)
    assert result["episodes"] == 1 and 0.0 <= result["mean"] <= 1000.0  # 10 steps of 100 physics steps, reward <= 1


def test_info_says_what_a_set_holds(small_set, capsys):
    main(["info", str(small_set)])
    line = capsys.readouterr().out
    assert f"{EPISODES} episodes, {EPISODES * SET['max_steps']} transitions" in line
    assert "(medium, dynamic; 32x32, GL renderer, no masks)" in line  # the Warp set's: tests/test_datasets_warp.py
    main(["info", str(small_set), "--json"])
    record = json.loads(capsys.readouterr().out)
    assert record["env"]["benchmark"] == "medium" and "episode_table" not in record


def test_vd4rl_image_size_resizes_without_torchvision_as_torchrls_resize_does(small_set):
    from dcs_torchrl.datasets.loading import ResizePixels

    batch = load_vd4rl(small_set, batch_size=4, image_size=16, sampler=SamplerWithoutReplacement()).sample()
    assert batch["pixels"].shape == (4, 3, 16, 16) and batch["next", "pixels"].shape == (4, 3, 16, 16)
    full = load_data(small_set)["frames", "pixels"][batch["frame"]].permute(0, 3, 1, 2).float() / 255
    # TorchRL's Resize: torchvision's bilinear antialiased resize, which is interpolate's on tensors
    expected = torch.nn.functional.interpolate(full, size=(16, 16), mode="bilinear", antialias=True)
    assert torch.equal(batch["pixels"], expected)
    frame = torch.rand(2, 3, 8, 8)
    assert torch.equal(ResizePixels(8, in_keys=["pixels"])._apply_transform(frame), frame)  # its own size: unchanged
    with pytest.raises(ValueError, match="image_size must be a positive integer"):
        ResizePixels(0, in_keys=["pixels"])


def test_an_agent_acts_on_its_own_84_pixel_frames_while_the_set_stores_what_a_64_pixel_env_shows(tmp_path, agent):
    from tensordict import TensorDict
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from dcs_torchrl.evaluation.protocol import torch_threads
    settings = dict(domain="cartpole", task="swingup", benchmark="medium", dynamic=True)
    out = tmp_path / "small64"
    record = generate(out, episodes=2, seed=3, max_steps=3, image_size=64, policies=[agent], **settings)
    assert record["pixels"]["image_size"] == 64 and record["policies"][0]["frame_stack"] == 3
    data = load_data(out)
    transitions, frames = data["transitions"], data["frames", "pixels"]
    assert frames.shape[1:] == (64, 64, 3)
    envs = {size: dcs.make_env(**settings, height=size, width=size) for size in (64, 84)}
    try:
        with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad(), torch_threads(1):
            for k in range(2):
                rows = transitions[transitions["episode"] == k]
                tds = {size: (env.set_seed(episode_seed(3, k)), env.reset())[1] for size, env in envs.items()}
                assert torch.equal(tds[64]["pixels"], frames[rows["first_frame"][0]])
                seen = [tds[84]["pixels"].permute(2, 0, 1)] * 3
                for i in range(rows.shape[0]):
                    action = agent.agent.policy(TensorDict({"pixels": torch.cat(seen[-3:])}, []))["action"]
                    assert torch.equal(action.double(), rows["action"][i])  # acted on the 84-pixel frames
                    for size, env in envs.items():
                        tds[size]["action"] = rows["action"][i]
                        tds[size] = env.step(tds[size])["next"]
                    assert torch.equal(tds[64]["pixels"], frames[rows["frame"][i] + 1])  # stored: the 64-pixel env's
                    seen.append(tds[84]["pixels"].permute(2, 0, 1))
    finally:
        for env in envs.values():
            env.close()


def test_resuming_a_mixed_policy_set_gives_each_episode_the_policy_of_its_number(tmp_path, monkeypatch, agent):
    policies = [agent, "random"]
    settings = dict(domain="cartpole", task="swingup", episodes=3, max_steps=2, image_size=32, policies=policies)
    uncut = generate(tmp_path / "uncut", **settings)
    out = tmp_path / "cut"
    killed_at(monkeypatch, 1)
    with pytest.raises(KeyboardInterrupt):
        generate(out, **settings)
    monkeypatch.undo()
    resumed = generate(out, **settings)
    assert [e["policy"] for e in resumed["episode_table"]] == [0, 1, 0] == [e["policy"] for e in uncut["episode_table"]]
    transitions = load_data(out)["transitions"]
    assert torch.equal(transitions["policy"], transitions["episode"] % 2)
    assert (load_data(out) == load_data(tmp_path / "uncut")).all()


def test_a_finished_read_only_set_with_nothing_to_do_succeeds_without_writing(small_set, tmp_path, monkeypatch):
    out = _copy(small_set, tmp_path)
    before = {p: (p.stat().st_mtime_ns, p.stat().st_size) for p in out.rglob("*")}
    real_access = os.access
    monkeypatch.setattr(generation.os, "access", lambda path, mode: False if Path(path).is_relative_to(out)
                        else real_access(path, mode))  # as a read-only folder (also where the tests run as root)
    monkeypatch.setattr(layout, "write_json", lambda *a: pytest.fail("wrote metadata.json"))
    assert generate(out, episodes=EPISODES, seed=0, **SET)["episodes"] == EPISODES
    assert generate(out, episodes=1, seed=0, **SET)["episodes"] == EPISODES
    monkeypatch.setattr(generation, "_run_wave", lambda *a: pytest.fail("simulated before refusing"))
    with pytest.raises(PermissionError, match=rf"read-only and holds {EPISODES} whole episodes, 5 asked: copy it to a "
                                              "writable folder"):
        generate(out, episodes=5, seed=0, **SET)
    assert before == {p: (p.stat().st_mtime_ns, p.stat().st_size) for p in out.rglob("*")}


def test_a_file_for_a_folder_or_a_folder_without_a_set_is_refused_with_the_fix(small_set, tmp_path):
    path = tmp_path / "a_file"
    path.write_text("mine")
    command = ["--domain", "cartpole", "--task", "swingup", "--episodes", "1", "--out", str(path)]
    with pytest.raises(SystemExit, match=r"--out .*a_file is a file, not a folder: give a new folder's path \(or a "
                                         r"set's folder\)\.$"):
        main(["generate", *command])
    with pytest.raises(SystemExit, match="--out .*a_file is a file, not a folder: give a new folder's path\\.$"):
        main(["export", str(small_set), "--format", "vd4rl-npz", "--out", str(path)])
    for run in (["info", str(path)], ["export", str(path), "--format", "vd4rl-npz", "--out", str(tmp_path / "out")]):
        with pytest.raises(SystemExit, match="the set .*a_file is a file, not a folder: give a set's folder\\.$"):
            main(run)
    metadata = re.escape(str(tmp_path / "metadata.json"))
    with pytest.raises(SystemExit, match=f"holds no dataset \\({metadata} is missing\\): make one with: python -m "
                                         "dcs_torchrl.datasets generate \\.\\.\\. --out "):
        main(["info", str(tmp_path)])
    assert path.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_info_load_and_export_of_an_unfinished_set_name_the_command_that_resumes_it(small_set, tmp_path, monkeypatch,
                                                                                    capsys):
    out = tmp_path / "unfinished"
    killed_at(monkeypatch, 2)
    with pytest.raises(KeyboardInterrupt):
        generate(out, episodes=EPISODES, seed=0, **SET)
    monkeypatch.undo()
    main(["info", str(out)])
    line = capsys.readouterr().out.strip()
    assert f"unfinished: 2 whole episodes of the {EPISODES} asked" in line and "resume it with: python -m" in line
    resume = line.split("resume it with: ")[1]
    command = shlex.split(resume)
    assert command[:3] == ["python", "-m", "dcs_torchrl.datasets"]
    missing = f"{out} is an unfinished dataset ({out / 'data' / 'episodes.json'} is missing: a generate run was stopped"
    for run in (lambda: load(out, batch_size=2), lambda: main(["export", str(out), "--format", "vd4rl-npz", "--out",
                                                                  str(tmp_path / "export")])):
        with pytest.raises((FileNotFoundError, SystemExit), match=re.escape(missing)) as refused:
            run()
        assert str(refused.value).endswith(f"resume it with: {resume}")  # the command info prints
    assert not (tmp_path / "export").exists()
    main(command[3:] + ["--no-progress"])  # the printed command finishes the set: the uncut run's
    assert (load_data(out) == load_data(small_set)).all()
    main(["info", str(out)])
    assert ": unfinished:" not in capsys.readouterr().out


def test_a_second_writer_of_a_set_is_refused_and_leaves_nothing(small_set, tmp_path):
    out = _copy(small_set, tmp_path)
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    with layout.writing(out):  # another run holds the set (flock: per open file, so this process counts as another)
        with pytest.raises(layout.SetBusyError, match="being written by another generate run .* wait for that run to "
                                                      "end, then run this command again"):
            generate(out, episodes=EPISODES + 1, seed=0, **SET)
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before  # no temporary folder left


class _CreatesFile:
    """Unpickled, it creates ``path``: the stand-in for a dataset folder that would run code."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return open, (self.path, "w")


def test_a_set_holding_a_pickle_is_refused_and_runs_nothing(small_set, tmp_path):
    """A set folder handed over with a pickled object among its memory-mapped data: load refuses it naming
    why, and nothing of it runs."""
    from tensordict import NonTensorData

    out, marker = _copy(small_set, tmp_path), tmp_path / "ran"
    data = out / layout.DATA
    td = load_data(out).to_tensordict()
    td["note"] = NonTensorData(_CreatesFile(marker))
    table = (data / layout._TABLE).read_text()
    shutil.rmtree(data)
    td.memmap(data)
    (data / layout._TABLE).write_text(table)
    assert list(data.rglob("*.pickle")), "the planted object was not pickled"
    with pytest.raises(ValueError, match="holds pickled Python objects"):
        load(out, batch_size=4)
    assert not marker.exists()
