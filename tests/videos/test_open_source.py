"""open_source picks the embedded, DAVIS or folder source for a path."""
import pytest

from dcs_torchrl.videos import DAVIS17_TRAIN, DavisSource, EmbeddedSource, FolderSource, open_source
from videos.files import write_frames


def test_none_is_the_embedded_set():
    assert isinstance(open_source(), EmbeddedSource) and open_source().split == "train"
    assert open_source(None, "test").split == "val"


@pytest.mark.parametrize("where", [".", "JPEGImages", "JPEGImages/480p"])
def test_davis_layouts(davis_root, where):
    with pytest.warns(UserWarning, match="only the first 3"):
        source = open_source(davis_root / where)
    assert isinstance(source, DavisSource) and source.names == DAVIS17_TRAIN[:3]


def test_a_folder_of_davis_videos_is_davis(tmp_path):
    write_frames(tmp_path / "bear", 2)
    write_frames(tmp_path / "bike-packing", 2)  # a val video: both splits in one folder, like 480p
    with pytest.warns(UserWarning, match="only the first 1"):
        assert isinstance(open_source(str(tmp_path)), DavisSource)
    with pytest.warns(UserWarning, match="only the first 1"):
        assert open_source(tmp_path, "val").names == ("bike-packing",)


def test_other_folders_are_folder_sources(tmp_path):
    write_frames(tmp_path / "bear", 2)
    write_frames(tmp_path / "my-clip", 2)  # not a DAVIS name
    assert isinstance(open_source(tmp_path), FolderSource)
    split = tmp_path / "split"
    write_frames(split / "train" / "a", 2)  # "train" is also a DAVIS video name
    write_frames(split / "val" / "b", 2)
    assert isinstance(open_source(split), FolderSource) and open_source(split, "val").names == ("b",)


def test_bad_arguments(tmp_path):
    missing = r"background video path '.*missing' does not exist: pass a DAVIS 2017 folder"
    with pytest.raises(FileNotFoundError, match=missing):
        open_source(tmp_path / "missing")
    splits = r"unknown split 'dev': use one of \['test', 'train', 'training', 'val', 'validation'\]"
    with pytest.raises(ValueError, match=splits):
        open_source(None, "dev")
    with pytest.raises(TypeError, match="path must be a folder path or None"):
        open_source(3)
