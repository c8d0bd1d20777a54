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
