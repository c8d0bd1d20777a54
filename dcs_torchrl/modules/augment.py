"""Image augmentations of DrQ and RAD as TorchRL transforms, and the K = M knob.

Both image transforms move whole pixels: every output pixel is a copy of an input pixel, picked
by one ``torch.gather`` over the flattened image for the whole batch (no interpolation, no padded
copy, no Python loop over samples), so they work on ``uint8`` and float images alike and on any
number of leading batch dimensions, channel-first (``[..., C, H, W]``).

* :class:`RandomShift` (DrQ, Kostrikov et al. 2020): replicate-pad by ``pad`` and crop back to
  the input size at a random offset, i.e. shift every image by an independent integer
  ``(dy, dx)`` in ``[-pad, pad]`` with the border pixels repeated. Replicate padding followed by
  a crop is the same as reading the input at clamped coordinates, which is what is done here.
* :class:`RandomCrop` (RAD, Laskin et al. 2020): crop a ``size`` window at an independent random
  offset from a larger image.
* :class:`ObservationNoise`: additive Gaussian noise, the stand-in augmentation for flat state
  vectors (so the DrQ code path can be exercised from states).

All three are random in training mode only: in eval mode (``transform.eval()``) RandomShift and
ObservationNoise are the identity and RandomCrop takes the centre crop (RAD's evaluation).

The number of augmented copies K (target) = M (Q-loss) is one knob,
:func:`~dcs_torchrl.methods.augmentation_copies` (defined in :data:`dcs_torchrl.methods.AUGMENTATIONS`):
``"none"`` -> 0 (no augmentation), ``"rad"`` -> 1, ``"drq"`` -> 2 (Stone et al. 2021, section 4:
"DrQ with K = M in {0, 1, 2}").
"""
from __future__ import annotations

from collections.abc import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.data.tensor_specs import Bounded, TensorSpec, Unbounded
from torchrl.envs.transforms import Transform

from dcs_torchrl._compat.private_api import set_missing_tolerance
from dcs_torchrl.methods import augmentation_copies

__all__ = [
    "ObservationNoise",
    "RandomCrop",
    "RandomShift",
    "augmentation_copies",
    "with_next_keys",
]

def with_next_keys(keys: Sequence[NestedKey]) -> list[NestedKey]:
    """``keys`` followed by their ``("next", key)`` counterparts: the keys a loss augments.

    Examples:
        >>> with_next_keys(["pixels"])
        ['pixels', ('next', 'pixels')]
    """
    keys = list(keys)
    return keys + [("next", *((k,) if isinstance(k, str) else k)) for k in keys]


def _gather_windows(
    images: torch.Tensor, top: torch.Tensor, left: torch.Tensor, height: int, width: int
) -> torch.Tensor:
    """Windows ``images[..., top + i, left + j]`` (coordinates clamped to the image), one gather.

    ``images`` is ``[*lead, C, H, W]`` (any strides, e.g. an expanded view), ``top`` and ``left``
    are integer tensors of shape ``lead``. Returns a contiguous ``[*lead, C, height, width]``.
    """
    *lead, channels, in_h, in_w = images.shape
    device = images.device
    rows = (top.unsqueeze(-1) + torch.arange(height, device=device)).clamp_(0, in_h - 1)
    cols = (left.unsqueeze(-1) + torch.arange(width, device=device)).clamp_(0, in_w - 1)
    index = (rows.unsqueeze(-1) * in_w + cols.unsqueeze(-2)).flatten(-2)  # [*lead, height*width]
    index = index.unsqueeze(-2).expand(*lead, channels, height * width)
    return images.flatten(-2).gather(-1, index).unflatten(-1, (height, width))


def _randint(low: int, high: int, shape: Sequence[int], generator, device: torch.device) -> torch.Tensor:
    """``torch.randint`` on the generator's device (a CPU generator for CUDA data), moved to ``device``."""
    gen_device = generator.device if generator is not None else device
    return torch.randint(low, high, tuple(shape), generator=generator, device=gen_device).to(device)


def _check_image(images: torch.Tensor, name: str) -> None:
    if images.ndim < 3:
        raise ValueError(f"{name} expects channel-first images [..., C, H, W], got shape {tuple(images.shape)}.")


class RandomShift(Transform):
    """DrQ's random shift: replicate-pad by ``pad`` and randomly crop back to the input size.

    Every image (each index of the leading dimensions) gets its own integer shift
    ``(dy, dx)``, uniform in ``[-pad, pad]``. Equivalent to DrQ's ``ReplicationPad2d(pad)``
    followed by a random crop of the original size, computed as a single gather.

    Args:
        pad (int): maximum shift in pixels. Defaults to ``4`` (DrQ's ``image_pad``).

    Keyword Args:
        in_keys (sequence of NestedKey): the image entries. Defaults to ``["pixels"]``.
        out_keys (sequence of NestedKey): where to write the shifted images. Defaults to ``in_keys``.
        generator (torch.Generator, optional): source of the shifts; the global RNG if ``None``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> _ = torch.manual_seed(0)
        >>> shift = RandomShift(4, in_keys=["pixels", ("next", "pixels")])
        >>> data = TensorDict({"pixels": torch.randint(0, 256, (8, 9, 84, 84), dtype=torch.uint8),
        ...                    ("next", "pixels"): torch.randint(0, 256, (8, 9, 84, 84), dtype=torch.uint8)}, [8])
        >>> shift(data)["pixels"].shape, shift(data)["pixels"].dtype
        (torch.Size([8, 9, 84, 84]), torch.uint8)
    """

    def __init__(
        self,
        pad: int = 4,
        *,
        in_keys: Sequence[NestedKey] | None = None,
        out_keys: Sequence[NestedKey] | None = None,
        generator: torch.Generator | None = None,
    ):
        if pad < 0:
            raise ValueError(f"pad must be non-negative, got {pad}.")
        in_keys = ["pixels"] if in_keys is None else list(in_keys)
        out_keys = list(in_keys) if out_keys is None else list(out_keys)
        super().__init__(in_keys=in_keys, out_keys=out_keys)
        self.pad = int(pad)
        self.generator = generator

    def sample_shifts(self, lead: Sequence[int], device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
        """Draws ``(dy, dx)``, each an integer tensor of shape ``lead`` in ``[-pad, pad]``."""
        shifts = _randint(-self.pad, self.pad + 1, (2, *lead), self.generator, device)
        return shifts[0], shifts[1]

    def _apply_transform(self, images: torch.Tensor) -> torch.Tensor:
        _check_image(images, type(self).__name__)
        if not self.training or self.pad == 0:
            return images
        *lead, _, height, width = images.shape
        dy, dx = self.sample_shifts(lead, images.device)
        return _gather_windows(images, dy, dx, height, width)

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        with set_missing_tolerance(self, True):
            tensordict_reset = self._call(tensordict_reset)
        return tensordict_reset

    def __repr__(self) -> str:
        return f"{type(self).__name__}(pad={self.pad}, in_keys={self.in_keys}, out_keys={self.out_keys})"


class RandomCrop(Transform):
    """RAD's random crop: a ``size`` window at an independent random offset per image.

    In eval mode the centre window is taken (RAD evaluates on centre crops). On an env, the
    observation spec is changed to the cropped shape.

    Args:
        size (int or (int, int)): output ``(height, width)``; an int for a square.

    Keyword Args:
        in_keys (sequence of NestedKey): the image entries. Defaults to ``["pixels"]``.
        out_keys (sequence of NestedKey): where to write the crops. Defaults to ``in_keys``.
        generator (torch.Generator, optional): source of the offsets; the global RNG if ``None``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> crop = RandomCrop(84, in_keys=["pixels"])
        >>> data = TensorDict({"pixels": torch.zeros(4, 2, 9, 100, 100, dtype=torch.uint8)}, [4, 2])
        >>> crop(data)["pixels"].shape
        torch.Size([4, 2, 9, 84, 84])
    """

    def __init__(
        self,
        size: int | Sequence[int],
        *,
        in_keys: Sequence[NestedKey] | None = None,
        out_keys: Sequence[NestedKey] | None = None,
        generator: torch.Generator | None = None,
    ):
        size = (int(size), int(size)) if isinstance(size, int) else tuple(int(s) for s in size)
        if len(size) != 2 or min(size) < 1:
            raise ValueError(f"size must be a positive int or a (height, width) pair, got {size!r}.")
        in_keys = ["pixels"] if in_keys is None else list(in_keys)
        out_keys = list(in_keys) if out_keys is None else list(out_keys)
        super().__init__(in_keys=in_keys, out_keys=out_keys)
        self.size = size
        self.generator = generator

    def _apply_transform(self, images: torch.Tensor) -> torch.Tensor:
        _check_image(images, type(self).__name__)
        *lead, _, in_h, in_w = images.shape
        height, width = self.size
        if height > in_h or width > in_w:
            raise ValueError(f"cannot crop {self.size} from images of size {(in_h, in_w)}.")
        if self.training:
            top = _randint(0, in_h - height + 1, lead, self.generator, images.device)
            left = _randint(0, in_w - width + 1, lead, self.generator, images.device)
        else:
            top = torch.full(tuple(lead), (in_h - height) // 2, device=images.device)
            left = torch.full(tuple(lead), (in_w - width) // 2, device=images.device)
        return _gather_windows(images, top, left, height, width)

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        with set_missing_tolerance(self, True):
            tensordict_reset = self._call(tensordict_reset)
        return tensordict_reset

    def transform_observation_spec(self, observation_spec: TensorSpec) -> TensorSpec:
        for in_key, out_key in zip(self.in_keys, self.out_keys):
            if in_key not in observation_spec.keys(True, True):
                continue
            spec = observation_spec[in_key]
            shape = (*spec.shape[:-2], *self.size)
            if isinstance(spec, Bounded):
                low = spec.space.low[..., : self.size[0], : self.size[1]].clone()
                high = spec.space.high[..., : self.size[0], : self.size[1]].clone()
                new = Bounded(low=low, high=high, shape=shape, dtype=spec.dtype, device=spec.device)
            else:
                new = Unbounded(shape=shape, dtype=spec.dtype, device=spec.device)
            observation_spec[out_key] = new
        return observation_spec

    def __repr__(self) -> str:
        return f"{type(self).__name__}(size={self.size}, in_keys={self.in_keys}, out_keys={self.out_keys})"


class ObservationNoise(Transform):
    """Additive Gaussian noise ``x + std * N(0, 1)``: the DrQ augmentation used from states.

    Float observations only. In eval mode the transform is the identity.

    Args:
        std (float): noise standard deviation, in observation units.

    Keyword Args:
        in_keys (sequence of NestedKey): entries to perturb. Defaults to ``["observation"]``.
        out_keys (sequence of NestedKey): where to write them. Defaults to ``in_keys``.
        generator (torch.Generator, optional): noise source; the global RNG if ``None``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> noise = ObservationNoise(0.01)
        >>> data = TensorDict({"observation": torch.zeros(3, 5)}, [3])
        >>> bool(noise(data)["observation"].abs().max() < 0.1)
        True
    """

    def __init__(
        self,
        std: float,
        *,
        in_keys: Sequence[NestedKey] | None = None,
        out_keys: Sequence[NestedKey] | None = None,
        generator: torch.Generator | None = None,
    ):
        if std < 0:
            raise ValueError(f"std must be non-negative, got {std}.")
        in_keys = ["observation"] if in_keys is None else list(in_keys)
        out_keys = list(in_keys) if out_keys is None else list(out_keys)
        super().__init__(in_keys=in_keys, out_keys=out_keys)
        self.std = float(std)
        self.generator = generator

    def _apply_transform(self, obs: torch.Tensor) -> torch.Tensor:
        if not obs.is_floating_point():
            raise TypeError(f"ObservationNoise needs float observations, got {obs.dtype}.")
        if not self.training or self.std == 0:
            return obs
        gen_device = self.generator.device if self.generator is not None else obs.device
        noise = torch.randn(obs.shape, generator=self.generator, device=gen_device, dtype=obs.dtype)
        return obs + self.std * noise.to(obs.device)

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        with set_missing_tolerance(self, True):
            tensordict_reset = self._call(tensordict_reset)
        return tensordict_reset

    def __repr__(self) -> str:
        return f"{type(self).__name__}(std={self.std}, in_keys={self.in_keys}, out_keys={self.out_keys})"
