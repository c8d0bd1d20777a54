"""The official DAVIS 2017 lists and split names (Stone et al. 2021, Sec. 3.3; docs/paper.md)."""
import pytest

from dcs_torchrl.videos import DAVIS17_TRAIN, DAVIS17_VAL, canonical_split
from dcs_torchrl.videos.lists import split_folder_names


def test_official_lists_sizes_and_order():
    assert len(DAVIS17_TRAIN) == 60 and len(set(DAVIS17_TRAIN)) == 60
    assert len(DAVIS17_VAL) == 30 and len(set(DAVIS17_VAL)) == 30
    assert not set(DAVIS17_TRAIN) & set(DAVIS17_VAL)
    assert DAVIS17_TRAIN[:10] == (
        "bear", "bmx-bumps", "boat", "boxing-fisheye", "breakdance-flare", "bus", "car-turn", "cat-girl",
        "classic-car", "color-run",
    )
    assert DAVIS17_TRAIN[-3:] == ("upside-down", "varanus-cage", "walking")
    assert DAVIS17_VAL[:3] == ("bike-packing", "blackswan", "bmx-trees")
    assert DAVIS17_VAL[-1] == "soapbox"
    assert list(DAVIS17_TRAIN) == sorted(DAVIS17_TRAIN)  # the official files are alphabetical
    assert list(DAVIS17_VAL) == sorted(DAVIS17_VAL)


@pytest.mark.parametrize(
    "name, canonical",
    [("train", "train"), ("training", "train"), ("val", "val"), ("validation", "val"), ("test", "val"),
     (" Val ", "val")],
)
def test_split_aliases(name, canonical):
    assert canonical_split(name) == canonical


@pytest.mark.parametrize("bad", ["dev", "", None, 1])
def test_unknown_split_lists_the_valid_names(bad):
    with pytest.raises(ValueError, match=r"unknown split .*'test'.*'train'.*'val'"):
        canonical_split(bad)


def test_split_folder_names():
    assert split_folder_names("test") == ("val", "validation", "test")
    assert split_folder_names("train") == ("train", "training")
