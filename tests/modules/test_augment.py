"""RandomShift / RandomCrop / ObservationNoise and the K = M knob."""
import pytest
import torch
import torch.nn.functional as F
from tensordict import TensorDict
from torchrl.data import Bounded, Composite
from torchrl.envs import Compose, PermuteTransform
from torchrl.envs.utils import check_env_specs

from dcs_torchrl.modules import (
    ObservationNoise,
    RandomCrop,
    RandomShift,
    augmentation_copies,
    with_next_keys,
)
from dcs_torchrl.methods import METHODS


def _images(*shape, dtype=torch.uint8, seed=0):
    gen = torch.Generator().manual_seed(seed)
    return torch.randint(0, 256, shape, generator=gen, dtype=torch.int64).to(dtype)


def _recover_shift(image: torch.Tensor, shifted: torch.Tensor, pad: int) -> list[tuple[int, int]]:
    """Every (dy, dx) in [-pad, pad]^2 for which replicate-pad + crop of image gives shifted."""
    _, height, width = image.shape
    padded = F.pad(image.float().unsqueeze(0), (pad, pad, pad, pad), mode="replicate")[0]
    matches = []
    for dy in range(-pad, pad + 1):
        for dx in range(-pad, pad + 1):
            window = padded[:, pad + dy : pad + dy + height, pad + dx : pad + dx + width]
            if torch.equal(window, shifted.float()):
                matches.append((dy, dx))
    return matches


@pytest.mark.parametrize("dtype", [torch.uint8, torch.float32])
def test_random_shift_is_replicate_pad_and_crop_with_independent_shifts(dtype):
    torch.manual_seed(0)
    pad = 4
    images = _images(64, 3, 20, 20, dtype=dtype)
    shifted = RandomShift(pad)._apply_transform(images)
    assert shifted.shape == images.shape and shifted.dtype == dtype
    shifts = []
    for image, out in zip(images, shifted):
        matches = _recover_shift(image, out, pad)
        assert len(matches) == 1  # random images: exactly one shift in [-pad, pad]^2 explains the output
        shifts.append(matches[0])
    assert len(set(shifts)) > 20  # independent per sample (81 possible shifts for 64 samples)
    assert {dy for dy, _ in shifts} | {dx for _, dx in shifts} <= set(range(-pad, pad + 1))


def test_random_shift_any_leading_dims_and_expanded_views():
    torch.manual_seed(1)
    images = _images(5, 9, 16, 16)
    copies = images.expand(2, 5, 9, 16, 16)  # a view, as the losses pass it
    out = RandomShift(2)._apply_transform(copies)
    assert out.shape == (2, 5, 9, 16, 16)
    for n in range(2):
        for b in range(5):
            assert len(_recover_shift(images[b], out[n, b], 2)) == 1
    assert not torch.equal(out[0], out[1])  # the two copies of a sample are shifted independently
    single = RandomShift(2)._apply_transform(images[0])  # no batch dimension at all
    assert single.shape == images[0].shape


def test_random_shift_same_shift_for_all_channels_of_a_sample():
    torch.manual_seed(2)
    image = _images(1, 1, 12, 12).expand(1, 9, 12, 12)  # 9 identical channels
    out = RandomShift(3)._apply_transform(image)
    assert all(torch.equal(out[0, 0], out[0, c]) for c in range(9))


def test_random_shift_identity_in_eval_mode_and_for_zero_pad():
    images = _images(4, 3, 10, 10)
    shift = RandomShift(4).eval()
    assert shift._apply_transform(images) is images
    assert RandomShift(0)._apply_transform(images) is images


def test_random_shift_on_a_tensordict_with_next_keys():
    torch.manual_seed(3)
    data = TensorDict({"pixels": _images(4, 9, 12, 12), ("next", "pixels"): _images(4, 9, 12, 12, seed=1)}, [4])
    before = data.clone()
    out = RandomShift(2, in_keys=with_next_keys(["pixels"]))(data)
    for key in ("pixels", ("next", "pixels")):
        for b in range(4):
            assert len(_recover_shift(before[key][b], out[key][b], 2)) == 1


def test_random_shift_errors():
    with pytest.raises(ValueError, match="pad must be non-negative"):
        RandomShift(-1)
    with pytest.raises(ValueError, match=r"channel-first images"):
        RandomShift(2)._apply_transform(torch.zeros(4, 4))


def test_random_crop_offsets_are_independent_and_in_range():
    torch.manual_seed(4)
    images = _images(32, 3, 24, 24)
    crops = RandomCrop(16)._apply_transform(images)
    assert crops.shape == (32, 3, 16, 16)
    offsets = set()
    for image, crop in zip(images, crops):
        found = [
            (top, left)
            for top in range(9)
            for left in range(9)
            if torch.equal(image[:, top : top + 16, left : left + 16], crop)
        ]
        assert len(found) == 1
        offsets.add(found[0])
    assert len(offsets) > 10


def test_random_crop_centre_in_eval_mode_float_and_rectangular():
    images = _images(2, 3, 4, 20, 30, dtype=torch.float32)
    crop = RandomCrop((10, 20)).eval()
    out = crop._apply_transform(images)
    assert torch.equal(out, images[..., 5:15, 5:25])


def test_random_crop_errors():
    with pytest.raises(ValueError, match="positive int"):
        RandomCrop(0)
    with pytest.raises(ValueError, match="cannot crop"):
        RandomCrop(32)._apply_transform(torch.zeros(1, 3, 16, 16))


def test_random_crop_observation_spec():
    spec = Composite(pixels=Bounded(0, 255, shape=(9, 100, 100), dtype=torch.uint8))
    out = RandomCrop(84).transform_observation_spec(spec)
    assert out["pixels"].shape == (9, 84, 84) and out["pixels"].dtype == torch.uint8


def test_augmentations_on_the_suite_pixel_env():
    from dcs_torchrl import make_env

    torch.manual_seed(5)
    env = make_env("cartpole", "swingup", seed=0)
    env.append_transform(
        Compose(
            PermuteTransform((-1, -3, -2), in_keys=["pixels"]),  # HWC -> CHW
            RandomCrop(64, in_keys=["pixels"]),
            RandomShift(4, in_keys=["pixels"]),
        )
    )
    check_env_specs(env, seed=0)
    rollout = env.rollout(3)
    assert rollout["pixels"].shape == (3, 3, 64, 64) and rollout["pixels"].dtype == torch.uint8


def test_observation_noise():
    torch.manual_seed(6)
    obs = torch.zeros(1000, 5)
    noisy = ObservationNoise(0.1)._apply_transform(obs)
    assert 0.09 < noisy.std().item() < 0.11
    assert ObservationNoise(0.1).eval()._apply_transform(obs) is obs
    with pytest.raises(TypeError, match="float observations"):
        ObservationNoise(0.1)._apply_transform(torch.zeros(3, dtype=torch.uint8))
    with pytest.raises(ValueError, match="non-negative"):
        ObservationNoise(-1.0)


def test_augmentation_knob():
    assert [augmentation_copies(a) for a in ("none", "rad", "drq")] == [0, 1, 2]
    assert {m.aug: m.copies for m in METHODS.values()} == {"none": 0, "rad": 1, "drq": 2}
    with pytest.raises(ValueError, match="unknown augmentation 'crop'"):
        augmentation_copies("crop")
    assert with_next_keys(["pixels", ("a", "b")]) == ["pixels", ("a", "b"), ("next", "pixels"), ("next", "a", "b")]
