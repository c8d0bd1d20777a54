"""Loading a dataset as a TorchRL replay buffer: memory-mapped, frame stacks rebuilt at sampling.

:func:`load` gives a ``TensorDictReplayBuffer`` over the set's memory-mapped transitions
(TorchRL's ``TensorStorage`` of the ``MemoryMappedTensor`` files, as TorchRL's own offline datasets
hold theirs: nothing is read until sampled), with TorchRL's ``ImmutableDatasetWriter`` and by
default its ``RandomSampler``. Each sample gets its ``"pixels"`` and ``("next", "pixels")`` from
the frames, each stored once, by :class:`StackFrames`: ``S`` frames stacked on the channels
(uint8 ``[3*S, H, W]``, the recipes' agents' observation), the reset frame repeated at an episode's
start, never a frame of another episode. Any TorchRL sampler works on the storage too, e.g.
``SliceSampler(traj_key="episode", slice_len=...)`` for sub-trajectories.

``layout="vd4rl"`` (:func:`load_vd4rl`) gives the samples the layout of TorchRL's
``VD4RLExperienceReplay``: float ``"pixels"`` in [0, 1], channel-first (TorchRL's
``ToTensorImage``), one frame by default; ``"is_init"``; ``"discount"``; float32 actions, rewards and
``"state"`` entries; ``done`` / ``terminated`` / ``truncated`` at the root and under ``"next"``.
Code written for V-D4RL runs on it; the set's own entries (distractions, episode, step, ...) come along.
"""
from __future__ import annotations

import os

import torch
from tensordict import TensorDictBase
from torchrl.data import TensorDictReplayBuffer, TensorStorage
from torchrl.data.replay_buffers.samplers import RandomSampler, Sampler
from torchrl.data.replay_buffers.writers import ImmutableDatasetWriter
from torchrl.envs import Compose, ToTensorImage, Transform

from dcs_torchrl.datasets.layout import load_data

__all__ = ["LAYOUTS", "ResizePixels", "StackFrames", "VD4RLLayout", "load", "load_vd4rl"]

LAYOUTS = ("ted", "vd4rl")


class StackFrames(Transform):
    """Writes the stacked frames of each sampled transition, read from ``frames``.

    Args:
        frames (TensorDictBase): the set's frames (``"pixels"`` uint8 ``[F, H, W, 3]``, and
            ``"masks"`` ``[F, H, W]`` where stored), memory-mapped.
        frame_stack (int): ``S``, frames per observation.

    A transition's ``"frame"`` and ``"first_frame"`` (layout.py) give the ids: ``frame - S + 1 ..
    frame`` and ``frame - S + 2 .. frame + 1`` (``"next"``), each clamped at ``first_frame``.
    Writes ``"pixels"`` uint8 ``[..., 3*S, H, W]`` (channel-first, oldest frame first) and
    ``"masks"`` ``[..., S, H, W]``, at the root and under ``"next"``.
    """

    def __init__(self, frames: TensorDictBase, frame_stack: int):
        if isinstance(frame_stack, bool) or not isinstance(frame_stack, int) or frame_stack < 1:
            raise ValueError(f"frame_stack must be an integer >= 1 (frames per observation), got {frame_stack!r}.")
        keys = [k for k in ("pixels", "masks") if k in frames.keys()]
        super().__init__(in_keys=["frame", "first_frame"], out_keys=keys + [("next", k) for k in keys])
        self.frames, self.frame_stack, self.keys = frames, frame_stack, keys

    def frame_ids(self, frame: torch.Tensor, first_frame: torch.Tensor) -> torch.Tensor:
        """``[2, *batch, S]``: the frame ids of each transition's observation and next observation."""
        offsets = torch.arange(1 - self.frame_stack, 1)
        ids = torch.stack([frame, frame + 1]).unsqueeze(-1) + offsets
        return torch.maximum(ids, first_frame.unsqueeze(-1))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        ids = self.frame_ids(tensordict.get("frame"), tensordict.get("first_frame"))
        unique, inverse = torch.unique(ids, return_inverse=True)  # sorted: reads in file order, each once
        for key in self.keys:
            frames = torch.index_select(self.frames.get(key), 0, unique)  # a memory map's fastest read
            if key == "pixels":  # channel-first, once per distinct frame
                frames = frames.permute(0, 3, 1, 2).contiguous()
            stack = frames.index_select(0, inverse.flatten()).reshape(*inverse.shape, *frames.shape[1:])
            if key == "pixels":  # [2, *batch, S, 3, H, W] -> the frames on the channels (a view)
                stack = stack.flatten(-4, -3)
            tensordict.set(key, stack[0])
            tensordict.set(("next", key), stack[1])
        return tensordict

    _call = forward

    def __repr__(self) -> str:
        return f"{type(self).__name__}(frame_stack={self.frame_stack}, keys={self.keys})"


class VD4RLLayout(Transform):
    """The entries TorchRL's ``VD4RLExperienceReplay`` gives that the set's layout names otherwise:
    ``"is_init"`` (bool ``[...]``: the episode's first transition), ``"discount"`` (float32 ``[...]``:
    0 where the step's ``("next", "terminated")`` is set, else 1, V-D4RL's discount of that step),
    float32 ``"action"``, ``("next", "reward")`` and ``"state"`` / ``("next", "state")`` entries."""

    def __init__(self):
        super().__init__(in_keys=["step", ("next", "terminated")], out_keys=["is_init", "discount"])

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict.set("is_init", tensordict.get("step") == 0)
        terminated = tensordict.get(("next", "terminated"))
        tensordict.set("discount", (~terminated).reshape(terminated.shape[:-1]).to(torch.float32))
        for key in ("action", ("next", "reward"), "state", ("next", "state")):
            value = tensordict.get(key, None)
            if value is not None:
                tensordict.set(key, value.to(torch.float32))
        return tensordict

    _call = forward


class ResizePixels(Transform):
    """Resizes float channel-first frames ``[..., C, H, W]`` to ``size`` × ``size``, as TorchRL's
    ``Resize`` does (bilinear, antialiased: what torchvision's ``resize`` computes on tensors) with
    ``torch.nn.functional.interpolate`` alone, so that no torchvision is needed."""

    def __init__(self, size: int, *, in_keys):
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"image_size must be a positive integer, got {size!r}.")
        super().__init__(in_keys=in_keys, out_keys=in_keys)
        self.size = size

    def _apply_transform(self, pixels: torch.Tensor) -> torch.Tensor:
        flat = pixels.reshape(-1, *pixels.shape[-3:])
        resized = torch.nn.functional.interpolate(flat, size=(self.size, self.size), mode="bilinear",
                                                  align_corners=False, antialias=True)
        return resized.reshape(*pixels.shape[:-2], self.size, self.size)


def load(path: str | os.PathLike, batch_size: int, frame_stack: int = 3, *, layout: str = "ted",
         sampler: Sampler | None = None, transform: Transform | None = None, prefetch: int | None = None,
         pin_memory: bool = False, image_size: int | None = None) -> TensorDictReplayBuffer:
    """A dataset (``python -m dcs_torchrl.datasets generate``) as a TorchRL replay buffer.

    Args:
        path: the set's folder.
        batch_size: transitions per ``sample()``.
        frame_stack: frames per observation (``S``; 1: single frames).

    Keyword Args:
        layout: ``"ted"`` (the set's own: uint8 stacks ``[3*S, H, W]``, the env's dtypes) or
            ``"vd4rl"`` (the layout of TorchRL's ``VD4RLExperienceReplay``, see the module).
        sampler: a TorchRL sampler (default: ``RandomSampler``, uniform with replacement).
        transform: applied to each sample after the frames are stacked (and, for ``vd4rl``, after its layout).
        prefetch, pin_memory: as ``TensorDictReplayBuffer``'s.
        image_size: ``vd4rl`` only: resize the pixels (:class:`ResizePixels`, as TorchRL's ``Resize``
            without torchvision), as ``VD4RLExperienceReplay``'s ``image_size``.

    The storage is the set's memory-mapped files: the buffer is read-only (TorchRL's
    ``ImmutableDatasetWriter``) and reads only what it samples.
    """
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}: choose one of {list(LAYOUTS)}.")
    if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
        raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}.")
    if image_size is not None and layout != "vd4rl":
        raise ValueError("image_size is for layout='vd4rl' (V-D4RL's resize); the set's own layout keeps its frames' size.")
    data = load_data(path)
    transforms = [StackFrames(data["frames"], frame_stack)]
    if layout == "vd4rl":
        transforms += [VD4RLLayout(), ToTensorImage(in_keys=["pixels", ("next", "pixels")], shape_tolerant=True)]
        if image_size is not None:
            transforms.append(ResizePixels(image_size, in_keys=["pixels", ("next", "pixels")]))
    if transform is not None:
        transforms.append(transform)
    return TensorDictReplayBuffer(storage=TensorStorage(data["transitions"]), sampler=sampler or RandomSampler(),
                                  writer=ImmutableDatasetWriter(), transform=Compose(*transforms),
                                  batch_size=batch_size, prefetch=prefetch, pin_memory=pin_memory)


def load_vd4rl(path: str | os.PathLike, batch_size: int, frame_stack: int = 1, **options) -> TensorDictReplayBuffer:
    """:func:`load` with ``layout="vd4rl"`` and V-D4RL's single frames by default: samples shaped
    as TorchRL's ``VD4RLExperienceReplay`` gives them (``"pixels"`` float32 ``[B, 3, H, W]``)."""
    return load(path, batch_size, frame_stack, layout="vd4rl", **options)
