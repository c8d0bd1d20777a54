"""The process-wide frame cache: decoded once, LRU-bounded in bytes, thread-safe."""
import threading

import numpy as np
import pytest
from torchrl.envs import Compose, DMControlEnv, TransformedEnv

from dcs_torchrl import BackgroundDistraction, RenderPixels
from dcs_torchrl.videos import ArraySource, cache_info, set_cache_limit
from dcs_torchrl.videos.cache import ENV_VAR, FrameCache, parse_size

SIZE = 32
VIDEO_BYTES = 5 * SIZE * SIZE * 3


@pytest.fixture
def source(rng):
    return ArraySource([rng.integers(0, 256, (5, 24, 24, 3), dtype=np.uint8) for _ in range(4)])


def test_each_video_is_decoded_once(source):
    first = source.frames(0, SIZE)
    again = source.frames(0, SIZE)
    assert again is first
    info = cache_info()
    assert (info.entries, info.bytes, info.hits, info.misses, info.decodes) == (1, VIDEO_BYTES, 1, 1, 1)
    source.frames(0, SIZE // 2)  # another size is another entry
    assert cache_info().decodes == 2 and cache_info().entries == 2


def test_lru_eviction_keeps_the_cache_within_its_bound(source):
    set_cache_limit(2 * VIDEO_BYTES)
    source.frames(0, SIZE)
    source.frames(1, SIZE)
    source.frames(0, SIZE)  # 0 is now the most recently used
    source.frames(2, SIZE)  # evicts 1, the least recently used
    info = cache_info()
    assert (info.entries, info.bytes, info.decodes) == (2, 2 * VIDEO_BYTES, 3)
    source.frames(0, SIZE)
    assert cache_info().decodes == 3  # 0 was kept
    source.frames(1, SIZE)
    assert cache_info().decodes == 4  # 1 had to be decoded again
    for index in range(4):
        source.frames(index, SIZE)
        assert cache_info().bytes <= 2 * VIDEO_BYTES


def test_lowering_the_bound_evicts_and_returns_the_old_bound(source):
    for index in range(4):
        source.frames(index, SIZE)
    old = set_cache_limit(VIDEO_BYTES)
    assert old == 3 * 2**30
    assert cache_info()[:2] == (1, VIDEO_BYTES)
    assert set_cache_limit("1.5G") == VIDEO_BYTES
    assert cache_info().limit == 3 * 2**29


def test_a_video_larger_than_the_bound_is_served_but_not_kept(source):
    set_cache_limit(VIDEO_BYTES - 1)
    expected = r"video 'video-00' at 32x32 takes 0.0 MiB, more than the whole frame cache bound .*set_cache_limit"
    with pytest.warns(UserWarning, match=expected):
        frames = source.frames(0, SIZE)
    assert frames.shape == (5, SIZE, SIZE, 3) and not frames.flags.writeable
    assert cache_info()[:2] == (0, 0)


def test_bound_from_the_environment(monkeypatch):
    monkeypatch.setenv(ENV_VAR, "64M")
    assert FrameCache().limit == 64 * 2**20
    monkeypatch.setenv(ENV_VAR, "lots")
    with pytest.raises(ValueError, match=f"{ENV_VAR}='lots' is not a size: use a number of bytes"):
        FrameCache().limit
    monkeypatch.delenv(ENV_VAR)
    assert FrameCache().limit == 3 * 2**30


def test_parse_size():
    assert parse_size(1000) == 1000
    assert parse_size("2KiB") == 2048 and parse_size("3g") == 3 * 2**30 and parse_size(" 5 MB ") == 5 * 2**20
    with pytest.raises(ValueError, match=">= 0 bytes"):
        parse_size(-1)
    with pytest.raises(ValueError, match="not a size"):
        set_cache_limit("a lot")


def test_concurrent_requests_decode_once(source):
    barrier = threading.Barrier(8)
    results = []

    def fetch():
        barrier.wait()
        results.append(source.frames(3, SIZE))

    threads = [threading.Thread(target=fetch) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(results) == 8 and all(r is results[0] for r in results)
    assert cache_info().decodes == 1 and cache_info().entries == 1


def test_a_failed_decode_is_not_cached_and_fails_again(tmp_path):
    from dcs_torchrl.videos import FolderSource

    (tmp_path / "clip").mkdir()
    (tmp_path / "clip" / "00000.jpg").write_bytes(b"not a jpeg")
    source = FolderSource(tmp_path)
    for _ in range(2):
        with pytest.raises(ValueError, match="could not decode frame"):
            source.frames(0, SIZE)
    assert cache_info()[:2] == (0, 0)


def test_env_resets_never_decode_again(source):
    env = TransformedEnv(
        DMControlEnv("cartpole", "swingup", from_pixels=False),
        Compose(BackgroundDistraction(source.first(2), dynamic=True, texture_size=SIZE, seed=0), RenderPixels(32, 32)),
    )
    for _ in range(4):
        env.reset()
    decoded = cache_info().decodes
    assert 1 <= decoded <= 2
    for _ in range(8):
        env.reset()
    assert cache_info().decodes == decoded
