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
