"""DavisSource on a DAVIS 2017-like tree of real JPEG files."""
import cv2
import numpy as np
import pytest

from dcs_torchrl.videos import DAVIS17_TRAIN, DavisSource, cache_info
from dcs_torchrl.videos.decode import read_frames, reduction
from videos.files import COLORS, write_frames

def davis(root, split="train", count=3):
    """A DavisSource over a tree holding only the first ``count`` videos of the split (it warns)."""
    total = 60 if split == "train" else 30
    with pytest.warns(UserWarning, match=rf"holds only the first {count} of the {total} DAVIS 2017 .* videos"):
        return DavisSource(root, split)


def test_official_order_and_first_b(davis_root):
    source = davis(davis_root)
    assert source.names == DAVIS17_TRAIN[:3]
    assert source.first(2).names == ("bear", "bmx-bumps")
    with pytest.raises(ValueError, match=r"num_videos=8 but DavisSource\(.*\) has only 3 videos.*davischallenge\.org"):
        source.first(8)


@pytest.mark.parametrize("where", [".", "JPEGImages", "JPEGImages/480p"])
def test_root_may_be_any_level_of_the_layout(davis_root, where):
    source = davis(davis_root / where)
    assert source.frames_dir == davis_root / "JPEGImages" / "480p"
    assert source.cache_key == davis(davis_root).cache_key  # same files, same cache entries


def test_frames_in_sorted_order_rgb_read_only(davis_root):
    frames = davis(davis_root).frames(1, 32)  # bmx-bumps: 6 frames, green, brighter each frame
    assert frames.shape == (6, 32, 32, 3) and frames.dtype == np.uint8 and not frames.flags.writeable
    means = frames.reshape(6, -1, 3).mean(1)
    assert np.argmax(means[-1]) == 1  # green stays green (RGB, not BGR)
    assert (np.diff(means[:, 1]) > 0).all()  # 00000.jpg first


def test_frame_order_is_by_name_not_creation(tmp_path):
    folder = tmp_path / "JPEGImages" / "480p" / "bear"
    write_frames(folder, 3, names=["00002.jpg", "00000.jpg", "00001.jpg"])  # index i -> brightness i
    frames = davis(tmp_path, count=1).frames(0, 16)
    brightness = frames.reshape(3, -1).mean(1)  # of 00000.jpg, 00001.jpg, 00002.jpg, written as 1, 2, 0
    assert brightness[2] < brightness[0] < brightness[1]


def test_decoded_once_across_sources(davis_root):
    davis(davis_root).frames(0, 32)
    davis(davis_root / "JPEGImages").frames(0, 32)
    assert cache_info().decodes == 1 and cache_info().hits == 1


def test_reduced_jpeg_decode_matches_a_full_decode(tmp_path, rng):
    """854x480 frames are decoded at half size for a 256 texture; the result matches a full decode."""
    smooth = cv2.resize(rng.integers(0, 256, (12, 20, 3), dtype=np.uint8), (854, 480), interpolation=cv2.INTER_CUBIC)
    paths = []
    for i in range(2):
        paths.append(tmp_path / f"{i:05d}.jpg")
        cv2.imwrite(str(paths[-1]), smooth)
    assert reduction(854, 480, 256) == 2 and reduction(854, 480, 84) == 4 and reduction(300, 200, 256) == 1
    reduced = read_frames(paths, 256)[1].astype(float)  # frame 1 takes the reduced path
    full = cv2.resize(cv2.imread(str(paths[1])), (256, 256), interpolation=cv2.INTER_AREA)[..., ::-1]
    assert np.abs(reduced - full).mean() < 2.0


def test_missing_root_says_how_to_get_davis(tmp_path):
    layout = r"does not exist: expected the layout DAVIS/JPEGImages/480p/.*davischallenge\.org/davis2017/code\.html"
    with pytest.raises(FileNotFoundError, match=layout):
        DavisSource(tmp_path / "nowhere")
    (tmp_path / "other").mkdir()
    with pytest.raises(FileNotFoundError, match="does not hold DAVIS 2017 frames.*TrainVal"):
        DavisSource(tmp_path / "other")


def test_gap_in_the_official_list_names_the_missing_video(tmp_path):
    write_frames(tmp_path / "JPEGImages" / "480p" / "bear", 2)
    write_frames(tmp_path / "JPEGImages" / "480p" / "boat", 2)  # bmx-bumps is missing
    missing = r"'bmx-bumps' of the train split is missing \(expected folder .*480p/bmx-bumps\)"
    with pytest.raises(FileNotFoundError, match=missing):
        DavisSource(tmp_path)


def test_video_folder_without_frames(tmp_path):
    (tmp_path / "JPEGImages" / "480p" / "bear").mkdir(parents=True)
    (tmp_path / "JPEGImages" / "480p" / "bear" / ".DS_Store").write_bytes(b"")
    with pytest.raises(FileNotFoundError, match=r"'bear' has no frames in .*bear .*re-extract"):
        DavisSource(tmp_path)


def test_val_split_missing(davis_root):
    with pytest.raises(FileNotFoundError, match="none of the 30 DAVIS 2017 val videos .*bike-packing"):
        DavisSource(davis_root, split="validation")


def test_val_split(tmp_path):
    write_frames(tmp_path / "JPEGImages" / "480p" / "bike-packing", 3, COLORS[2])
    source = davis(tmp_path / "JPEGImages" / "480p", "test", count=1)
    assert source.split == "val" and source.names == ("bike-packing",)
    assert source.frames(0, 16).shape == (3, 16, 16, 3)


@pytest.mark.parametrize("content", [b"", b"\xff\xd8\xff garbage, not a JPEG"])
def test_corrupt_frame_names_the_file_and_the_fix(davis_root, content):
    bad = davis_root / "JPEGImages" / "480p" / "boat" / "00003.jpg"
    bad.write_bytes(content)
    source = davis(davis_root)  # not decoded yet: construction only lists folders
    source.frames(0, 16)
    with pytest.raises(ValueError, match=r"could not decode frame .*boat/00003\.jpg.*Re-extract .*or delete the file"):
        source.frames(2, 16)
