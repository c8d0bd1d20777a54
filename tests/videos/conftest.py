"""Fixtures of the video tests: a fresh frame cache per test, a DAVIS 2017-like tree of JPEGs."""
from pathlib import Path

import pytest

from dcs_torchrl.videos import DAVIS17_TRAIN, clear_cache, set_cache_limit
from videos.files import COLORS, write_frames


@pytest.fixture(autouse=True)
def fresh_cache():
    """Every test starts with an empty frame cache and the default bound, and leaves it so."""
    clear_cache()
    old = set_cache_limit(None)
    yield
    set_cache_limit(old)
    clear_cache()


@pytest.fixture
def davis_root(tmp_path) -> Path:
    """A DAVIS 2017-like tree holding the first 3 training videos (5, 6 and 7 frames)."""
    root = tmp_path / "DAVIS"
    for i, name in enumerate(DAVIS17_TRAIN[:3]):
        write_frames(root / "JPEGImages" / "480p" / name, 5 + i, COLORS[i])
    (root / "ImageSets" / "2017").mkdir(parents=True)
    return root
