"""The official DAVIS 2017 video lists and the split names accepted everywhere.

The lists are the ``ImageSets/2017/train.txt`` and ``val.txt`` of DAVIS 2017 TrainVal,
in official order: the order the authors' 2021 code draws "the first b videos" from.
The paper's 30 held-out "test" videos are the validation list.
"""
from __future__ import annotations

DAVIS17_TRAIN: tuple[str, ...] = (
    "bear", "bmx-bumps", "boat", "boxing-fisheye", "breakdance-flare", "bus", "car-turn",
    "cat-girl", "classic-car", "color-run", "crossing", "dance-jump", "dancing",
    "disc-jockey", "dog-agility", "dog-gooses", "dogs-scale", "drift-turn", "drone",
    "elephant", "flamingo", "hike", "hockey", "horsejump-low", "kid-football", "kite-walk",
    "koala", "lady-running", "lindy-hop", "longboard", "lucia", "mallard-fly",
    "mallard-water", "miami-surf", "motocross-bumps", "motorbike", "night-race",
    "paragliding", "planes-water", "rallye", "rhino", "rollerblade", "schoolgirls",
    "scooter-board", "scooter-gray", "sheep", "skate-park", "snowboard", "soccerball",
    "stroller", "stunt", "surf", "swing", "tennis", "tractor-sand", "train", "tuk-tuk",
    "upside-down", "varanus-cage", "walking",
)  # fmt: skip

DAVIS17_VAL: tuple[str, ...] = (
    "bike-packing", "blackswan", "bmx-trees", "breakdance", "camel", "car-roundabout",
    "car-shadow", "cows", "dance-twirl", "dog", "dogs-jump", "drift-chicane",
    "drift-straight", "goat", "gold-fish", "horsejump-high", "india", "judo", "kite-surf",
    "lab-coat", "libby", "loading", "mbike-trick", "motocross-jump", "paragliding-launch",
    "parkour", "pigs", "scooter-black", "shooting", "soapbox",
)  # fmt: skip

# Every accepted spelling of a split -> its canonical name.
SPLIT_ALIASES: dict[str, str] = {
    "train": "train",
    "training": "train",
    "val": "val",
    "validation": "val",
    "test": "val",  # the paper calls the 30 held-out videos its test split
}

DAVIS17_SPLITS: dict[str, tuple[str, ...]] = {"train": DAVIS17_TRAIN, "val": DAVIS17_VAL}


def canonical_split(split: str) -> str:
    """The canonical name (``"train"`` or ``"val"``) of a split name or alias.

    Args:
        split (str): ``"train"`` / ``"training"`` or ``"val"`` / ``"validation"`` /
            ``"test"`` (case-insensitive).

    Examples:
        >>> canonical_split("validation")
        'val'
    """
    key = split.strip().lower() if isinstance(split, str) else None
    if key not in SPLIT_ALIASES:
        raise ValueError(
            f"unknown split {split!r}: use one of {sorted(SPLIT_ALIASES)} "
            "('train' = the first b training videos, 'val' = the 30 held-out videos)."
        )
    return SPLIT_ALIASES[key]


def split_folder_names(split: str) -> tuple[str, ...]:
    """The folder names that may hold a split on disk, canonical name first.

    Examples:
        >>> split_folder_names("val")
        ('val', 'validation', 'test')
    """
    canonical = canonical_split(split)
    return tuple(name for name, target in SPLIT_ALIASES.items() if target == canonical)
