"""The gallery: same seed, same picture (its random actions follow the seed too)."""
import numpy as np

from dcs_torchrl.gallery import cell, main


def test_cell_reproducible_from_seed():
    first = cell("cartpole", "swingup", 3, 32, seed=4, steps=6)
    again = cell("cartpole", "swingup", 3, 32, seed=4, steps=6)
    other = cell("cartpole", "swingup", 3, 32, seed=5, steps=6)
    np.testing.assert_array_equal(first, again)
    assert np.abs(first.astype(int) - other.astype(int)).mean() > 1.0


def test_cell_actions_follow_the_seed():
    """Without distractions only the actions differ between seeds' physics: the pole moves."""
    still = cell("cartpole", "swingup", 0, 32, seed=1, steps=0)
    moved = cell("cartpole", "swingup", 0, 32, seed=1, steps=8)
    assert not np.array_equal(still, moved)


def test_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "g.png"
    out.write_bytes(b"keep")
    try:
        main(["--out", str(out)])
    except SystemExit as exit_:
        assert exit_.code == 2
    assert out.read_bytes() == b"keep"
    assert "--force" in capsys.readouterr().err


def test_blend_views_the_paper_and_the_2021_code():
    from dcs_torchrl.gallery import blend_figure, blend_view

    clean = blend_view(0.0, 32, seed=0)
    paper = blend_view(0.2, 32, seed=0)
    assert np.abs(paper.astype(int) - clean.astype(int)).mean() > 1.0
    accumulated = blend_view(0.2, 32, seed=0, reference_blend=True, episodes=5)
    np.testing.assert_array_equal(accumulated, blend_view(0.2, 32, seed=0, reference_blend=True, episodes=5))
    assert np.abs(accumulated.astype(int) - paper.astype(int)).mean() > 1.0  # the sky has become video
    assert blend_figure([0.0, 1.0], size=32, seeds=(0,), episodes=2).shape == (18 + 2 * 32, 150 + 2 * 32, 3)


def test_the_gallery_has_a_row_each_for_light_and_texture():
    """Under the tasks (none here), a row per distraction beyond the paper: named, one frame per column,
    β = 0 the undistracted task, each β alone (the row's distraction shows, nothing else changes)."""
    from dcs_torchrl.envs import make_env
    from dcs_torchrl.gallery import BEYOND_PAPER_TASK, SCALES, _name, gallery, row_names

    size = 16
    image = gallery(size, seed=0, steps=0, tasks=())
    assert image.shape == (18 + 2 * size, 96 + len(SCALES) * size, 3)
    assert row_names(()) == [("walker walk", "light only"), ("walker walk", "texture only")]
    assert row_names()[:6] == [("ball_in_cup", "catch"), ("cartpole", "swingup"), ("cheetah", "run"),
                               ("finger", "spin"), ("reacher", "easy"), ("walker", "walk")]
    clean = cell(*BEYOND_PAPER_TASK, 0, size, seed=0)
    for row, (words, setting) in enumerate(zip(row_names(()), ("light_scale", "texture_scale"))):
        strip = image[18 + row * size:18 + (row + 1) * size]
        np.testing.assert_array_equal(strip[:, :96], _name(words, size, 96))
        frames = [strip[:, 96 + c * size:96 + (c + 1) * size] for c in range(len(SCALES))]
        np.testing.assert_array_equal(frames[0], clean)
        env = make_env(*BEYOND_PAPER_TASK, **{setting: 1.0}, height=size, width=size, seed=0)
        np.testing.assert_array_equal(frames[-1], env.reset()["pixels"].numpy())  # the setting alone, at β = 1
        env.close()
        assert np.abs(frames[-1].astype(int) - clean.astype(int)).mean() > 1.0, setting
