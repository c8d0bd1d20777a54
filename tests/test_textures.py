"""The texture sets: the procedural stand-ins (deterministic, every size, train apart from val) and folders of
images (the every-fifth split, centre crop and resize, the cache), with the errors of bad input."""
import hashlib
import pickle
from pathlib import Path

import cv2
import numpy as np
import pytest

from dcs_torchrl.textures import STANDIN_VERSION, TEXTURE_SPLITS, TextureSet, texture_set
from dcs_torchrl.textures.procedural import FAMILIES, STANDINS, family_of, standin
from dcs_torchrl.textures.sets import TEXTURE_CACHE


@pytest.fixture(autouse=True)
def fresh_cache():
    """Every test starts and ends with an empty texture cache."""
    TEXTURE_CACHE.clear()
    yield
    TEXTURE_CACHE.clear()


def _standins() -> list[tuple[str, int]]:
    return [(split, i) for split in TEXTURE_SPLITS for i in range(STANDINS[split])]


# ------------------------------------------------------------------------------------------------ stand-ins


def test_the_standins_are_20_training_and_5_held_out_textures_of_every_family():
    train, val = texture_set(None), texture_set(None, "val")
    assert (len(train), len(val)) == (20, 5) and TEXTURE_SPLITS == ("train", "val")
    assert train.key == ("standin", "train") and val.key == ("standin", "val") and hash(train.key) != hash(val.key)
    assert texture_set(None, "validation").key == val.key
    assert repr(train) == "TextureSet(stand-ins, split='train', 20 images)"
    assert sorted(family_of("train", i) for i in range(20)) == sorted(FAMILIES * 2)
    assert train.names[0] == "standin-train-00-grain" and len(set(train.names + val.names)) == 25


# sha256 of stand-ins at 32x32: they must not change silently, since results computed on them would no longer be
# comparable. If a change is intended, bump STANDIN_VERSION and update these.
GOLDEN = {("train", 0): "20f6d3993b8acdd5", ("train", 7): "bed383184d034c99", ("train", 13): "966d54ae5f7056c9",
          ("val", 2): "c39b903bc2521cfe"}


@pytest.mark.parametrize("split, index", list(GOLDEN))
def test_standins_do_not_change_silently(split, index):
    digest = hashlib.sha256(standin(split, index, 32).tobytes()).hexdigest()[:16]
    assert digest == GOLDEN[split, index], f"stand-in textures changed (STANDIN_VERSION={STANDIN_VERSION})"


def test_every_standin_is_the_same_bits_every_time_it_is_made():
    for split in TEXTURE_SPLITS:
        textures = texture_set(None, split)
        first = textures.images(24)
        TEXTURE_CACHE.clear()
        for index in reversed(range(len(textures))):  # another order: an image depends on (split, index) only
            assert np.array_equal(textures.image(index, 24), first[index]), (split, index)
            assert np.array_equal(standin(split, index, 24), first[index]), (split, index)


@pytest.mark.parametrize("size", [1, 2, 17, 40])
def test_every_standin_has_the_size_asked_for(size):
    for split, index in _standins():
        image = texture_set(None, split).image(index, size)
        assert image.dtype == np.uint8 and image.shape == (size, size, 3), (split, index)
        assert image.flags.c_contiguous and not image.flags.writeable
    stack = texture_set(None, "val").images(size)
    assert stack.dtype == np.uint8 and stack.shape == (5, size, size, 3) and stack.flags.c_contiguous


def _detail(image: np.ndarray) -> float:
    grey = image.astype(float).mean(-1)
    return np.abs(np.diff(grey, axis=0)).mean() + np.abs(np.diff(grey, axis=1)).mean()


def test_a_standin_is_drawn_at_each_size_not_upscaled():
    """Drawn at 64, every texture has far more detail than its 16-pixel version blown up to 64."""
    for split, index in _standins():
        blown_up = cv2.resize(standin(split, index, 16), (64, 64), interpolation=cv2.INTER_CUBIC)
        assert _detail(standin(split, index, 64)) > 1.5 * _detail(blown_up), (split, index)


def test_a_standin_shows_the_same_pattern_at_every_size():
    """Drawn at 128 and at 64, then both shrunk to 32, a texture's luminance is nearly the same image: its
    random fields do not depend on the size."""
    correlations = []
    for split, index in _standins():
        grey = [cv2.resize(standin(split, index, size), (32, 32), interpolation=cv2.INTER_AREA).mean(-1).ravel()
                for size in (128, 64)]
        correlations.append(np.corrcoef(*grey)[0, 1])
        assert correlations[-1] > 0.6, (split, index, correlations[-1])
    assert np.mean(correlations) > 0.9


def test_no_held_out_standin_equals_a_training_one():
    train, val = texture_set(None, "train").images(32), texture_set(None, "val").images(32)
    for v in range(len(val)):
        for t in range(len(train)):
            assert np.abs(val[v].astype(int) - train[t]).mean() > 5, (v, t)
    everything = np.concatenate([train, val]).reshape(25, -1)
    assert len({row.tobytes() for row in everything}) == 25


def test_every_standin_tiles():
    """The last column runs into the first and the last row into the first: the step across that seam is no
    bigger than the biggest step between neighbouring columns (rows) inside the texture."""
    for split, index in _standins():
        image = standin(split, index, 64).astype(int)
        for a in (image, image.transpose(1, 0, 2)):
            inside = max(np.abs(a[:, j] - a[:, j + 1]).mean() for j in range(63))
            assert np.abs(a[:, -1] - a[:, 0]).mean() <= inside + 1, (split, index)


# ------------------------------------------------------------------------------------------------ folders


def _write(path: Path, rgb, size=(12, 12)) -> Path:
    """An image of one flat RGB colour, written with cv2 (BGR on disk)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    image = np.empty((size[1], size[0], 3), np.uint8)
    image[...] = rgb[::-1]
    assert cv2.imwrite(str(path), image)
    return path


def _colour(k: int) -> tuple[int, int, int]:
    return (20 + 9 * k) % 256, (230 - 7 * k) % 256, (60 + 31 * k) % 256


# Nested categories, every extension in any case, numbers in names compared by value (img2 before img10).
FILES = ["banded/img1.jpg", "banded/img2.png", "banded/img10.jpg", "banded/img11.JPEG",
         "bubbly/a.bmp", "bubbly/b.PNG", "bubbly/c.jpeg", "bubbly/deep/d1.png", "bubbly/deep/d2.png",
         "cracked/x.jpg", "cracked/y.jpg", "loose.png", "zigzag/01.png", "zigzag/2.png", "zigzag/3.png"]


@pytest.fixture
def tree(tmp_path) -> Path:
    """A DTD-like folder: FILES, each its own colour, beside files that are not textures."""
    root = tmp_path / "dtd" / "images"
    for k, name in enumerate(FILES):
        _write(root / name, _colour(k))
    _write(root / ".hidden.png", (255, 0, 0))
    _write(root / ".cache" / "old.jpg", (255, 0, 0))
    (root / "banded" / "notes.txt").write_text("not an image")
    (root / "Thumbs.db").write_bytes(b"\0")
    return root


def test_every_image_lands_in_one_split_and_every_fifth_is_held_out(tree):
    train, val = texture_set(tree, "train"), texture_set(tree, "val")
    assert train.names + val.names and set(train.names).isdisjoint(val.names)
    assert sorted(train.names + val.names) == sorted(FILES)  # each file exactly once, nothing else
    assert list(val.names) == [FILES[i] for i in range(len(FILES)) if i % 5 == 4]
    assert list(train.names) == [FILES[i] for i in range(len(FILES)) if i % 5 != 4]
    for textures in (train, val):
        for index, name in enumerate(textures.names):  # every image is its file's, RGB
            pixel = textures.image(index, 4)[1, 1].astype(int)
            tolerance = 6 if name.lower().endswith(("jpg", "jpeg")) else 0
            assert np.abs(pixel - _colour(FILES.index(name))).max() <= tolerance, name


def test_a_folder_sets_key_is_its_resolved_path_and_split(tree, monkeypatch):
    monkeypatch.chdir(tree.parent)
    assert texture_set("images/", "train").key == (str(tree.resolve()), "train") == texture_set(tree).key
    assert texture_set(tree, "val").key == (str(tree.resolve()), "val")
    assert repr(texture_set(tree, "val")) == f"TextureSet({str(tree.resolve())!r}, split='val', 3 images)"


@pytest.mark.parametrize("shape", ["wide", "tall"])
def test_an_image_is_centre_cropped_to_a_square_and_resized(tmp_path, shape):
    """Three bands of 20 pixels (red, green, blue) across a 60 x 30 image: the centre square keeps 5, 20 and 5
    of them, and at 6 pixels (INTER_AREA) its first column is red, the next four green, the last blue."""
    bands = np.zeros((30, 60, 3), np.uint8)
    bands[:, :20, 0], bands[:, 20:40, 1], bands[:, 40:, 2] = 255, 255, 255
    if shape == "tall":
        bands = bands.transpose(1, 0, 2)
    assert cv2.imwrite(str(tmp_path / "bands.png"), np.ascontiguousarray(bands[..., ::-1]))
    for i in range(4):
        _write(tmp_path / f"other{i}.png", (0, 0, 0))
    textures = texture_set(tmp_path)
    image = textures.image(textures.names.index("bands.png"), 6)
    if shape == "tall":
        image = image.transpose(1, 0, 2)
    expected = np.zeros((6, 6, 3), np.uint8)
    expected[:, 0, 0], expected[:, 1:5, 1], expected[:, 5, 2] = 255, 255, 255
    assert np.array_equal(image, expected)
    assert textures.image(textures.names.index("bands.png"), 30).shape == (30, 30, 3)


def test_images_are_cached_read_only_and_the_cache_is_bounded(tree, monkeypatch):
    textures = texture_set(tree)
    first = textures.image(0, 16)
    assert textures.image(0, 16) is first and not first.flags.writeable
    assert textures.image(0, 8) is not first and texture_set(tree).image(0, 16) is first  # same key, same image
    monkeypatch.setattr(TEXTURE_CACHE, "limit", 3 * first.nbytes)
    TEXTURE_CACHE.clear()
    for index in range(len(textures)):
        textures.image(index, 16)
        assert len(TEXTURE_CACHE) <= 3
    stack = textures.images(16)
    assert stack.flags.writeable and stack.shape == (len(textures), 16, 16, 3)


def test_a_set_pickles_to_the_same_images(tree):
    """A distraction holding a set may be sent to a worker process."""
    for textures in (texture_set(None, "val"), texture_set(tree, "val")):
        again = pickle.loads(pickle.dumps(textures))
        assert again.key == textures.key and again.names == textures.names
        TEXTURE_CACHE.clear()
        assert np.array_equal(again.images(8), textures.images(8))


# ------------------------------------------------------------------------------------------------ bad input


def test_an_unknown_split_names_the_splits(tree):
    for directory in (None, tree):
        with pytest.raises(ValueError, match=r"unknown texture split 'eval': use one of \('train', 'val'\)"):
            texture_set(directory, "eval")


def test_a_missing_folder_or_a_file_says_to_pass_a_folder(tmp_path):
    with pytest.raises(ValueError, match=r"does not exist: pass a folder of images .*or None for the stand-ins"):
        texture_set(tmp_path / "nowhere")
    image = _write(tmp_path / "one.png", (1, 2, 3))
    with pytest.raises(ValueError, match=r"is a file: pass the folder that holds the images"):
        texture_set(image)
    with pytest.raises(TypeError, match=r"texture_dir must be a folder's path .* got int"):
        texture_set(5)


def test_a_folder_without_images_names_the_extensions(tmp_path):
    (tmp_path / "labels").mkdir()
    (tmp_path / "labels" / "train1.txt").write_text("banded/banded_0002.jpg")
    _write(tmp_path / ".hidden.jpg", (0, 0, 0))
    with pytest.raises(ValueError, match=r"no image files \(jpg/jpeg/png/bmp\) under .*point texture_dir at a folder"):
        texture_set(tmp_path)


def test_a_split_without_images_says_how_many_there_are_and_the_rule(tmp_path):
    for i in range(3):
        _write(tmp_path / "cat" / f"{i}.png", (i, i, i))
    assert len(texture_set(tmp_path, "train")) == 3
    with pytest.raises(ValueError, match=r"holds 3 image\(s\), so its 'val' split is empty: 'val' takes every "
                                         r"fifth image .*Add images, or use split='train'"):
        texture_set(tmp_path, "val")


def test_a_folder_linked_into_itself_names_the_link(tmp_path):
    """A symbolic link to a folder above it is refused, naming it; a link to a folder elsewhere is followed."""
    _write(tmp_path / "elsewhere" / "far.png", (9, 9, 9))
    root = tmp_path / "textures"
    _write(root / "cat" / "0.png", (1, 1, 1))
    (root / "cat" / "more").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    assert texture_set(root).names == ("cat/0.png", "cat/more/far.png")
    (root / "cat" / "loop").symlink_to(root, target_is_directory=True)
    with pytest.raises(ValueError, match=r"cat/loop is a link to a folder above it .*Remove the link, or point "
                                         r"texture_dir below it"):
        texture_set(root)


def test_a_corrupt_image_is_named(tmp_path):
    for i in range(4):
        _write(tmp_path / f"{i}.png", (i, i, i))
    (tmp_path / "4.jpg").write_bytes(b"not a jpeg at all")
    textures = texture_set(tmp_path, "val")  # listing reads no image
    assert textures.names == ("4.jpg",)
    with pytest.raises(ValueError, match=r"could not decode texture image .*4\.jpg.* or delete the file"):
        textures.image(0, 16)


def test_a_bad_size_or_index_says_what_is_allowed(tree):
    for textures in (texture_set(None), texture_set(tree)):
        last = len(textures) - 1
        for size in (0, -3, 2.5, True):
            with pytest.raises(ValueError, match=r"size must be a positive number of pixels"):
                textures.image(0, size)
        with pytest.raises(ValueError, match=r"size must be a positive number of pixels"):
            textures.images(0)
        for index in (last + 1, -1, 1.0, True):
            with pytest.raises(ValueError, match=rf"texture index .* out of range .*: use 0 \.\. {last}"):
                textures.image(index, 8)
        assert isinstance(textures, TextureSet) and textures.image(last, 8).shape == (8, 8, 3)
