"""Generation on the Warp batch (``generate(..., backend="warp", num_envs=N)``): the GL set's episodes
where the renderer does not enter, masks from the same render, resume and refusal as on GL."""
import pytest
import torch
from test_datasets import SET, agent, killed_at  # noqa: F401 (agent: a fixture)

import dcs_torchrl as dcs
from dcs_torchrl.datasets import generate, load_data
from dcs_torchrl.datasets.__main__ import main
from dcs_torchrl.datasets.metadata import episode_seed
from dcs_torchrl.render.warp import MASK_LABELS

pytest.importorskip("mujoco_warp")

WARP_EPISODES = 5  # two full waves of 2 envs and one of 1


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    root = tmp_path_factory.mktemp("sets")
    gl = generate(root / "gl", episodes=WARP_EPISODES, seed=0, **SET)
    main(["generate", "--policy", "random", "--domain", "cartpole", "--task", "swingup", "--benchmark", "medium",
          "--dynamic", "--image-size", "32", "--max-steps", str(SET["max_steps"]), "--episodes", str(WARP_EPISODES),
          "--out", str(root / "warp"), "--backend", "warp", "--num-envs", "2", "--masks", "--no-progress"])
    return root / "gl", root / "warp", gl


def test_the_warp_set_holds_the_gl_sets_episodes_where_the_renderer_does_not_enter(sets, capsys):
    gl_path, warp_path, gl = sets
    from dcs_torchrl.datasets.layout import read_json

    warp = read_json(warp_path / "metadata.json")
    assert warp["pixels"] == gl["pixels"] | {"backend": "warp", "masks": True}
    main(["info", str(warp_path)])  # the renderer and the masks: part of the set's identity
    assert "(medium, dynamic; 32x32, Warp renderer, with masks)" in capsys.readouterr().out
    assert warp["keys"]["transitions"] == gl["keys"]["transitions"]
    ours, theirs = load_data(warp_path)["transitions"], load_data(gl_path)["transitions"]
    assert ours.shape == theirs.shape == (WARP_EPISODES * SET["max_steps"],)
    for key in theirs.keys(True, True):  # states, actions, rewards, flags, distraction states, ids: every episode
        assert torch.equal(ours[key], theirs[key]), key
    assert [(e["seed"], e["return"], e["steps"]) for e in warp["episode_table"]] == \
        [(e["seed"], e["return"], e["steps"]) for e in gl["episode_table"]]
    assert [e["seed"] for e in warp["episode_table"]] == [episode_seed(0, k) for k in range(WARP_EPISODES)]


def test_the_masks_are_stored_from_the_render_of_the_stored_frames(sets):
    _, warp_path, _ = sets
    data = load_data(warp_path)
    frames, transitions = data["frames"], data["transitions"]
    assert frames["masks"].dtype == torch.uint8 and frames["masks"].shape == frames["pixels"].shape[:-1]
    assert set(frames["masks"].unique().tolist()) <= set(MASK_LABELS.values())
    env = dcs.make_env("cartpole", "swingup", benchmark="medium", dynamic=True, height=32, width=32, backend="warp",
                       num_envs=1, masks=True)
    try:
        for k in (0, WARP_EPISODES - 1):  # an episode of the first env of a wave, and one of a wave's second env
            rows = transitions[transitions["episode"] == k]
            env.set_seed(episode_seed(0, k))
            td = env.reset()
            first = int(rows["first_frame"][0])
            assert torch.equal(td["masks"][0], frames["masks"][first]) and torch.equal(td["pixels"][0],
                                                                                         frames["pixels"][first])
            for i in range(rows.shape[0]):
                td["action"] = rows["action"][i:i + 1]
                td = env.step(td)["next"]
                assert torch.equal(td["masks"][0], frames["masks"][first + i + 1])
                assert torch.equal(td["pixels"][0], frames["pixels"][first + i + 1])
    finally:
        env.close()


def test_a_killed_warp_run_resumes_with_any_num_envs_to_the_uncut_set(sets, tmp_path, monkeypatch):
    _, warp_path, _ = sets
    out = tmp_path / "killed"
    options = dict(episodes=WARP_EPISODES, seed=0, backend="warp", masks=True, **SET)
    started = killed_at(monkeypatch, 2)
    with pytest.raises(KeyboardInterrupt):
        generate(out, num_envs=2, **options)
    monkeypatch.undo()
    assert started == [0] and sorted(p.name for p in (out / "episodes").iterdir()) == ["000000", "000001"]
    generate(out, num_envs=3, **options)  # the number of envs is not part of the set: the same episodes
    assert (load_data(out) == load_data(warp_path)).all()
    with pytest.raises(FileExistsError, match="pixels.backend: 'warp' in the set, 'gl' asked"):
        generate(out, episodes=WARP_EPISODES + 1, seed=0, **SET)
    with pytest.raises(FileExistsError, match="pixels.masks: True in the set, False asked"):
        generate(out, episodes=WARP_EPISODES + 1, seed=0, backend="warp", **SET)


def test_what_one_warp_batch_cannot_render_is_refused_with_the_fix(tmp_path, agent):
    with pytest.raises(ValueError, match="--backend warp renders one image size, and the agents act on 84-pixel "
                                         "frames: ask --image-size 84, or use --backend gl"):
        generate(tmp_path / "a", domain="cartpole", task="swingup", episodes=1, image_size=64, backend="warp",
                 policies=[agent])
    with pytest.raises(ValueError, match="--reference-blend .* use --backend gl"):
        generate(tmp_path / "b", episodes=1, backend="warp", reference_blend=True, **SET)
    assert not any(tmp_path.iterdir())
