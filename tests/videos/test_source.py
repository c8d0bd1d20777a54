"""VideoSource through ArraySource: frames, first-b selection, validation."""
import gc
import pickle

import numpy as np
import pytest

from dcs_torchrl.videos import ArraySource, cache_info


def solid(rgb, frames=4, height=40, width=60):
    video = np.empty((frames, height, width, 3), np.uint8)
    video[...] = rgb
    return video


@pytest.fixture
def three():
    return ArraySource([solid((255, 0, 0)), solid((0, 255, 0), 6), solid((0, 0, 255), 3)], names=["r", "g", "b"])


def test_frames_are_square_rgb_uint8_read_only(three):
    frames = three.frames(0, 32)
    assert frames.shape == (4, 32, 32, 3) and frames.dtype == np.uint8
    assert frames.flags.c_contiguous and not frames.flags.writeable
    assert (frames == [255, 0, 0]).all()  # a solid colour stays that colour, channel order kept
    with pytest.raises(ValueError, match="read-only"):
        frames[0, 0, 0, 0] = 1
    assert three.frames(1, 16).shape == (6, 16, 16, 3)


def test_frames_are_squashed_not_cropped(rng):
    video = np.zeros((2, 20, 80, 3), np.uint8)
    video[:, :, :40] = 255  # left half white
    frames = ArraySource([video]).frames(0, 16)
    assert (frames[:, :, :7] == 255).all() and (frames[:, :, 9:] == 0).all()


def test_first_b_videos_in_order(three):
    assert three.names == ("r", "g", "b") and len(three) == 3
    assert three.first(2).names == ("r", "g")
    assert three.first(None) is three and three.first(3) is three
    assert len(three.first(0)) == 0
    assert three.first(2).first(1).names == ("r",)
    # the subset shares the parent's decoded frames
    assert three.first(2).frames(1, 8) is three.frames(1, 8)
    assert repr(three.first(2)) == "ArraySource(3 videos).first(2)"


def test_first_b_errors_say_how_many_and_how_to_get_more(three):
    with pytest.raises(ValueError, match=r"num_videos=4 but .* has only 3 videos: lower num_videos to at most 3"):
        three.first(4)
    with pytest.raises(ValueError, match=r"num_videos must be >= 0"):
        three.first(-1)
    with pytest.raises(TypeError, match="num_videos must be an int or None"):
        three.first(2.0)


def test_bad_index_and_size(three):
    with pytest.raises(IndexError, match=r"video index 3 is out of range .* use 0 \.\. 2"):
        three.frames(3, 8)
    with pytest.raises(TypeError, match="video index must be an int"):
        three.frames("r", 8)
    with pytest.raises(ValueError, match="size must be a positive number of pixels"):
        three.frames(0, 0)


@pytest.mark.parametrize(
    "videos, error, match",
    [
        (solid((1, 2, 3)), TypeError, "wrap a single video in a list"),
        ([solid((1, 2, 3))[0]], ValueError, r"expected \[T, H, W, 3\]"),
        ([np.zeros((2, 8, 8, 4), np.uint8)], ValueError, r"expected \[T, H, W, 3\]"),
        ([np.zeros((0, 8, 8, 3), np.uint8)], ValueError, "T, H, W >= 1"),
        ([np.zeros((2, 8, 8, 3), np.float32)], ValueError, r"dtype float32: expected uint8.*astype\(np.uint8\)"),
        ([[[[[0, 0, 0]]]]], TypeError, "pass numpy uint8 arrays"),
    ],
)
def test_array_source_validates_its_videos(videos, error, match):
    with pytest.raises(error, match=match):
        ArraySource(videos)


def test_array_source_names():
    assert ArraySource([solid(0), solid(1)]).names == ("video-00", "video-01")
    with pytest.raises(ValueError, match="names must be 2 strings"):
        ArraySource([solid(0), solid(1)], names=["a"])
    with pytest.raises(ValueError, match=r"unique, got duplicates \['a'\]"):
        ArraySource([solid(0), solid(1)], names=["a", "a"])


def test_collected_array_source_frees_its_frames():
    source = ArraySource([solid((9, 9, 9))])
    source.frames(0, 32)
    assert cache_info().entries == 1
    del source
    gc.collect()
    assert cache_info() [:2] == (0, 0)


def test_array_source_pickles(three):
    """Sources travel to spawned ParallelEnv workers by pickling."""
    copy = pickle.loads(pickle.dumps(three.first(2)))
    assert copy.names == ("r", "g")
    assert np.array_equal(copy.frames(1, 8), three.frames(1, 8))
