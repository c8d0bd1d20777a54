"""FolderSource on real frame folders and video files."""
import numpy as np
import pytest

from dcs_torchrl.videos import FolderSource
from videos.files import COLORS, write_frames, write_video


def test_frame_folders_and_video_files_in_name_order(tmp_path):
    write_frames(tmp_path / "walk", 4, COLORS[0], ext=".png")
    write_video(tmp_path / "beach.mp4", 7, COLORS[1])
    write_video(tmp_path / "city.avi", 5, COLORS[2])
    write_frames(tmp_path / "clip10", 2, COLORS[3])
    write_frames(tmp_path / "clip9", 3, COLORS[3])
    source = FolderSource(tmp_path)
    assert source.names == ("beach", "city", "clip9", "clip10", "walk")  # numbers compared by value
    lengths = [len(source.frames(i, 24)) for i in range(len(source))]
    assert lengths == [7, 5, 3, 2, 4]
    for index, color in [(0, COLORS[1]), (1, COLORS[2]), (4, COLORS[0])]:
        frames = source.frames(index, 24)
        assert frames.shape[1:] == (24, 24, 3) and not frames.flags.writeable
        assert np.argmax(frames[-1].reshape(-1, 3).mean(0)) == np.argmax(color)  # RGB order kept


def test_frames_sorted_with_numbers_by_value(tmp_path):
    names = [f"frame{i}.jpg" for i in (1, 2, 10)]  # plain sorting would put frame10 second
    write_frames(tmp_path / "video", 3, names=names)
    brightness = FolderSource(tmp_path).frames(0, 8).reshape(3, -1).mean(1)
    assert (np.diff(brightness) > 0).all()


def test_hidden_files_are_ignored(tmp_path):
    write_frames(tmp_path / "video", 2)
    (tmp_path / ".DS_Store").write_bytes(b"junk")
    (tmp_path / ".cache").mkdir()
    (tmp_path / "video" / ".hidden.txt").write_text("x")
    assert FolderSource(tmp_path).names == ("video",)


def test_split_sub_folders(tmp_path):
    write_frames(tmp_path / "train" / "a", 2)
    write_frames(tmp_path / "train" / "b", 2)
    write_frames(tmp_path / "validation" / "c", 2)
    assert FolderSource(tmp_path).names == ("a", "b")
    assert FolderSource(tmp_path, "training").names == ("a", "b")
    for alias in ("val", "validation", "test"):
        assert FolderSource(tmp_path, alias).names == ("c",)


def test_without_train_folder_the_rest_is_the_train_split(tmp_path):
    write_frames(tmp_path / "a", 2)
    write_frames(tmp_path / "val" / "held-out", 2)
    assert FolderSource(tmp_path).names == ("a",)
    assert FolderSource(tmp_path, "val").names == ("held-out",)


def test_val_without_held_out_videos(tmp_path):
    write_frames(tmp_path / "a", 2)
    fix = r"no held-out videos \(no val/, validation/, test/ sub-folder\).*point at a folder of held-out videos"
    with pytest.raises(ValueError, match=fix + ", or move them into .*val"):
        FolderSource(tmp_path, "val")


def test_missing_folder_file_and_empty_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="video folder '.*nowhere' does not exist"):
        FolderSource(tmp_path / "nowhere")
    video = write_video(tmp_path / "one.mp4", 3)
    with pytest.raises(NotADirectoryError, match="is a file: pass the folder that holds the videos"):
        FolderSource(video)
    (tmp_path / "empty").mkdir()
    expected = r"no videos in .*empty: expected sub-folders of frames \(jpg/jpeg/png\) or video files"
    with pytest.raises(FileNotFoundError, match=expected):
        FolderSource(tmp_path / "empty")
    (tmp_path / "empty" / "frames").mkdir()
    with pytest.raises(FileNotFoundError, match="video folder .*frames has no frames"):
        FolderSource(tmp_path / "empty")


def test_junk_files_are_named(tmp_path):
    write_frames(tmp_path / "a", 2)
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match=r"unsupported file .*notes\.txt in the video folder.*Move or delete"):
        FolderSource(tmp_path)
    (tmp_path / "notes.txt").unlink()
    (tmp_path / "a" / "labels.json").write_text("{}")
    with pytest.raises(ValueError, match=r"unsupported entry .*labels\.json in the frame folder"):
        FolderSource(tmp_path)


def test_frames_directly_in_the_folder(tmp_path):
    write_frames(tmp_path, 3)
    with pytest.raises(ValueError, match="holds image files .* directly: it looks like the frames of one video"):
        FolderSource(tmp_path)


def test_two_videos_with_one_name(tmp_path):
    write_frames(tmp_path / "a", 2)
    write_video(tmp_path / "a.avi", 2)
    with pytest.raises(ValueError, match="several videos named 'a'"):
        FolderSource(tmp_path)


def test_unreadable_video_file(tmp_path):
    write_video(tmp_path / "good.avi", 3)
    (tmp_path / "broken.mp4").write_bytes(b"\x00" * 64)
    source = FolderSource(tmp_path)  # found lazily, when decoded
    assert len(source.frames(1, 8)) == 3
    with pytest.raises(ValueError, match=r"could not read any frame from video file .*broken\.mp4.*Re-encode it"):
        source.frames(0, 8)


def test_corrupt_frame_in_a_folder(tmp_path):
    paths = write_frames(tmp_path / "a", 3)
    paths[1].write_bytes(b"garbage")
    with pytest.raises(ValueError, match=r"could not decode frame .*a/00001\.jpg"):
        FolderSource(tmp_path).frames(0, 8)
