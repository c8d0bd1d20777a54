"""Exports (dcs_torchrl.datasets.vd4rl, .export): a set read back as V-D4RL's code and Minari read it.

The readers below are written from what V-D4RL's loaders do (github.com/conglu1997/v-d4rl), not
copied: its offline DreamerV2 (``offlinedv2/dreamerv2/common/replay.py``: ``load_episodes`` globs
``*.npz``, takes the length after the filename's last ``-``, ``np.load``s every key; an episode's
length is ``len(action) - 1``) and its DrQ+BC (``drqbc/utils.py``: ``load_offline_dataset_into_buffer``
globs ``*.hdf5`` sorted, reads every key whole, checks that every key has the rows of ``reward``,
and walks the rows as dm_env time steps, a ``step_type`` of 0 starting an episode whose first
observation is repeated to fill the frame stack).
"""
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from test_datasets import EPISODES, SET, agent  # noqa: F401 (a fixture)

from dcs_torchrl.datasets import generate, load_data, load_vd4rl
from dcs_torchrl.datasets.__main__ import main
from dcs_torchrl.datasets.layout import episode_table


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("sets") / "small"
    generate(out, episodes=EPISODES, seed=0, **SET)
    return out


def dreamer_episodes(folder: Path) -> list[dict]:
    """The episodes as V-D4RL's offline DreamerV2 loads them (in file order)."""
    episodes = []
    for filename in sorted(folder.glob("*.npz")):
        length = int(str(filename).split("-")[-1][:-4])
        with filename.open("rb") as f:
            episode = dict(np.load(f))
        assert length == len(episode["action"]) - 1  # DreamerV2's eplen: the steps, the reset's row aside
        episodes.append(episode)
    return episodes


def drqbc_episodes(folder: Path, frame_stack: int = 3) -> list[list[dict]]:
    """The time steps V-D4RL's DrQ+BC loader adds to its buffer, per episode: observation (stacked
    channel-first frames), action, reward, discount, first."""
    import h5py

    episodes = []
    for filename in sorted(folder.glob("*.hdf5")):
        with h5py.File(filename, "r") as f:
            data = {key: f[key][:] for key in f.keys()}
        assert all(len(value) == len(data["reward"]) for value in data.values())
        for i in range(len(data["reward"])):
            first = data["step_type"][i] == 0
            if first:
                stack = [data["observation"][i]] * frame_stack
                episodes.append([])
            else:
                stack = stack[1:] + [data["observation"][i]]
            episodes[-1].append({"observation": np.concatenate(stack), "action": data["action"][i],
                                 "reward": data["reward"][i], "discount": data["discount"][i], "first": first,
                                 "last": data["step_type"][i] == 2})
    return episodes


def _episodes(path):
    data = load_data(path)
    for e in episode_table(Path(path)):
        rows = data["transitions"][e["first_transition"]:e["first_transition"] + e["steps"]]
        yield e, rows, data["frames", "pixels"][e["first_frame"]:e["first_frame"] + e["steps"] + 1]


def test_the_vd4rl_npz_export_is_what_v_d4rls_dreamerv2_loader_reads(small_set, tmp_path):
    main(["export", str(small_set), "--format", "vd4rl-npz", "--out", str(tmp_path / "npz")])
    loaded = dreamer_episodes(tmp_path / "npz")
    assert len(loaded) == EPISODES
    for episode, (e, rows, frames) in zip(loaded, _episodes(small_set)):
        steps = e["steps"]
        assert set(episode) == {"image", "action", "reward", "discount", "is_first", "is_last", "is_terminal"}
        assert episode["image"].dtype == np.uint8 and episode["image"].shape == (steps + 1, 32, 32, 3)  # HWC
        assert (episode["image"] == frames.numpy()).all()
        assert episode["action"].dtype == np.float32 and (episode["action"][0] == 0).all()  # the reset's dummy action
        assert (episode["action"][1:] == rows["action"].numpy().astype(np.float32)).all()
        assert episode["reward"].dtype == np.float32 and episode["reward"][0] == 0
        assert (episode["reward"][1:] == rows["next", "reward"].reshape(-1).numpy().astype(np.float32)).all()
        terminated = rows["next", "terminated"].reshape(-1).numpy()
        assert episode["discount"].dtype == np.float32 and (episode["discount"] == np.r_[1.0, 1.0 - terminated]).all()
        assert episode["is_first"].tolist() == [True] + [False] * steps
        assert episode["is_last"].tolist() == [False] * steps + [True]
        assert episode["is_terminal"].tolist() == [False] + terminated.tolist()


def test_the_vd4rl_hdf5_export_is_what_v_d4rls_drqbc_loader_reads(small_set, tmp_path):
    pytest.importorskip("h5py")  # the datasets extra
    main(["export", str(small_set), "--format", "vd4rl-hdf5", "--out", str(tmp_path / "hdf5")])
    loaded = drqbc_episodes(tmp_path / "hdf5")
    assert len(loaded) == EPISODES
    for steps, (e, rows, frames) in zip(loaded, _episodes(small_set)):
        assert len(steps) == e["steps"] + 1 and steps[0]["first"] and steps[-1]["last"]
        chw = frames.permute(0, 3, 1, 2).numpy()
        for t, step in enumerate(steps):
            assert step["observation"].dtype == np.uint8 and step["observation"].shape == (9, 32, 32)
            newest = [max(t - 2, 0), max(t - 1, 0), t]  # the reset frame repeated, as the set's own stacks
            assert (step["observation"] == np.concatenate([chw[j] for j in newest])).all()
            if t == 0:
                assert step["reward"] == 0 and step["discount"] == 1 and (step["action"] == 0).all()
            else:
                assert step["action"].dtype == np.float32 and (step["action"] == rows["action"][t - 1].numpy().astype(np.float32)).all()
                assert step["reward"] == np.float32(rows["next", "reward"][t - 1].item())
                assert step["discount"] == 1.0 - float(rows["next", "terminated"][t - 1].item())


def test_torchrls_vd4rl_processing_of_the_export_has_the_keys_load_vd4rl_gives(small_set, tmp_path):
    from torchrl.data.datasets.vd4rl import VD4RLExperienceReplay, _from_npz

    main(["export", str(small_set), "--format", "vd4rl-npz", "--out", str(tmp_path / "npz")])
    theirs = VD4RLExperienceReplay._process_data(_from_npz(str(sorted((tmp_path / "npz").glob("*.npz"))[0])))
    for key in ("pixels", ("next", "pixels")):  # their ToTensorImage
        theirs[key] = theirs[key].permute(0, 3, 1, 2).float() / 255
    assert {"discount", "is_init", ("next", "reward"), ("next", "terminated")} <= set(theirs.keys(True, True))
    ours = load_vd4rl(small_set, batch_size=4).sample()
    for key in theirs.keys(True, True):
        assert key in ours.keys(True, True), key
        assert ours[key].dtype == theirs[key].dtype and ours[key].shape[1:] == theirs[key].shape[1:], key


def test_an_export_refuses_a_folder_holding_files_and_writes_nothing(small_set, tmp_path):
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "old.npz").write_bytes(b"")
    with pytest.raises(SystemExit, match="is not empty: give a new or empty folder"):
        main(["export", str(small_set), "--format", "vd4rl-npz", "--out", str(busy)])
    with pytest.raises(SystemExit, match="takes --out DIR"):
        main(["export", str(small_set), "--format", "vd4rl-hdf5"])
    assert [p.name for p in busy.iterdir()] == ["old.npz"]


def _minari():
    if sys.version_info < (3, 11):
        pytest.skip("Minari needs Python >= 3.11")
    import minari

    return minari


def test_the_export_to_minari_reads_back_with_minaris_api_as_the_set(small_set, tmp_path):
    minari = _minari()
    from dcs_torchrl.datasets.export import export_minari

    export_minari(small_set, "dcs/cartpole-test-v0", root=tmp_path)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
        dataset = minari.load_dataset("dcs/cartpole-test-v0")
    assert dataset.total_episodes == EPISODES and dataset.total_steps == EPISODES * SET["max_steps"]
    assert json.loads(dataset.storage.metadata["description"])["env"]["benchmark"] == "medium"
    for episode, (e, rows, frames) in zip(dataset.iterate_episodes(), _episodes(small_set)):
        assert episode.id == e["episode"]
        assert (episode.observations["pixels"] == frames.numpy()).all()
        for key in ("position", "velocity"):
            expected = torch.cat([rows["state", key][:1], rows["next", "state", key]])
            assert (episode.observations[key] == expected.numpy()).all()
        assert (episode.actions == rows["action"].numpy()).all()
        assert (episode.rewards == rows["next", "reward"].reshape(-1).numpy()).all()
        assert (episode.terminations == rows["next", "terminated"].reshape(-1).numpy()).all()
        assert (episode.truncations == rows["next", "truncated"].reshape(-1).numpy()).all()
        for key in ("camera", "color", "background"):
            expected = torch.cat([rows["distractions", key][:1], rows["next", "distractions", key]])
            assert (episode.infos["distractions"][key] == expected.numpy()).all()


def test_a_bad_minari_id_is_refused_before_anything_is_written(small_set, tmp_path):
    _minari()
    root = tmp_path / "minari"
    with pytest.raises(SystemExit, match=r"--dataset-id 'badid': Minari's ids are \(namespace/\)name-v<version>"):
        main(["export", str(small_set), "--dataset-id", "badid", "--root", str(root)])
    assert not root.exists() or not any(root.rglob("*"))
    main(["export", str(small_set), "--dataset-id", "dcs/cartpole-test-v0", "--root", str(root)])
    with pytest.raises(SystemExit, match="Minari holds that dataset already .* give another version"):
        main(["export", str(small_set), "--dataset-id", "dcs/cartpole-test-v0", "--root", str(root)])


def test_a_64_pixel_set_of_a_shipped_agent_exports_to_both_layouts_at_64_pixels(tmp_path, agent):
    pytest.importorskip("h5py")
    out = tmp_path / "agent64"
    generate(out, domain="cartpole", task="swingup", episodes=2, max_steps=2, image_size=64,
             policies=[agent])
    main(["export", str(out), "--format", "vd4rl-npz", "--out", str(tmp_path / "npz")])
    main(["export", str(out), "--format", "vd4rl-hdf5", "--out", str(tmp_path / "hdf5")])
    dreamer, drqbc = dreamer_episodes(tmp_path / "npz"), drqbc_episodes(tmp_path / "hdf5")
    assert len(dreamer) == len(drqbc) == 2
    for episode, steps, (e, rows, frames) in zip(dreamer, drqbc, _episodes(out)):
        assert episode["image"].shape == (3, 64, 64, 3) and (episode["image"] == frames.numpy()).all()
        assert steps[-1]["observation"].shape == (9, 64, 64)
        assert (episode["action"][1:] == rows["action"].numpy().astype(np.float32)).all()
