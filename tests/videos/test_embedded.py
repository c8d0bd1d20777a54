"""EmbeddedSource: 60 + 30 deterministic procedural clips, the default without DAVIS."""
import hashlib

import numpy as np
import pytest

from dcs_torchrl.videos import EmbeddedSource, cache_info
from dcs_torchrl.videos.embedded import GENERATOR_VERSION, LENGTHS, SCENE_CYCLE, clip_seed, generate_clip


def test_split_sizes_and_names():
    train, val = EmbeddedSource(), EmbeddedSource("test")
    assert len(train) == 60 and len(val) == 30 and val.split == "val"
    assert train.names[:2] == ("embedded-train-00", "embedded-train-01") and val.names[-1] == "embedded-val-29"
    assert train.cache_key != val.cache_key
    with pytest.raises(ValueError, match=r"num_videos=61 .* only 60 videos.*point at a folder with more videos"):
        train.first(61)


def test_same_bits_every_time():
    first = EmbeddedSource().frames(2, 48)
    again = generate_clip(clip_seed("train", 2), 48, SCENE_CYCLE[2])
    assert first.dtype == np.uint8 and first.shape[1:] == (48, 48, 3) and not first.flags.writeable
    assert np.array_equal(first, again)
    assert cache_info().decodes == 1


# sha256 of two clips at 32x32: the clips must not change silently, since results computed on them
# would no longer be comparable. If a change is intended, bump GENERATOR_VERSION and update these.
GOLDEN = {("train", 0, "meadow"): "ff4423ccc64dc78b", ("val", 1, "city"): "bd5ccaa4934c7ba8"}


@pytest.mark.parametrize("split, index, scene", list(GOLDEN))
def test_clips_do_not_change_silently(split, index, scene):
    clip = generate_clip(clip_seed(split, index), 32, scene)
    digest = hashlib.sha256(clip.tobytes()).hexdigest()[:16]
    assert digest == GOLDEN[split, index, scene], f"embedded clips changed (GENERATOR_VERSION={GENERATOR_VERSION})"


def test_train_and_val_clips_differ():
    assert clip_seed("train", 0) != clip_seed("validation", 0)
    train, val = EmbeddedSource("train"), EmbeddedSource("val")
    for index in range(3):
        a, b = train.frames(index, 16), val.frames(index, 16)
        assert a.shape != b.shape or not np.array_equal(a, b)


@pytest.mark.parametrize("split", ["train", "val"])
def test_every_clip_has_a_davis_like_length(split):
    source = EmbeddedSource(split)
    lengths = [len(source.frames(i, 8)) for i in range(len(source))]
    assert min(lengths) >= LENGTHS[0] and max(lengths) <= LENGTHS[1]
    assert len(set(lengths)) > 10  # varied


def test_clips_look_like_moving_footage_not_noise():
    source = EmbeddedSource()
    clips = [source.frames(i, 32).astype(np.int16) for i in range(12)]
    firsts = np.stack([clip[0] for clip in clips])
    cross = np.median([np.abs(a - b).mean() for i, a in enumerate(firsts) for b in firsts[:i]])
    for clip in clips:
        steps = np.abs(np.diff(clip, axis=0)).mean(axis=(1, 2, 3))
        assert steps.max() < 0.75 * cross  # no cuts: consecutive frames far closer than two clips
        assert np.abs(clip - clip[0]).mean(axis=(1, 2, 3)).max() > 4  # the camera or something moves
        assert clip[0].std() > 10  # textured, not flat
        assert np.abs(np.diff(clip[0], axis=1)).mean() < 30  # smooth regions (uniform noise: ~85)
    colours = firsts.reshape(12, -1, 3).mean(1)
    assert colours.std(0).min() > 10  # varied palettes


def test_any_size_and_bad_scene():
    for size in (1, 5, 84):
        assert generate_clip(clip_seed("train", 1), size).shape[1:] == (size, size, 3)
    with pytest.raises(ValueError, match="unknown scene 'moon'"):
        generate_clip(0, 8, "moon")
