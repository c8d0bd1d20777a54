"""The replay's device storage (``FrameStackReplayBuffer(device=...)``) against the host storage.

The device path (frames and rows on the device, frame ids and the draws on the host, batched
writes per extend, one index copy per sample) runs here with ``device="cpu"``: the code a GPU
runs, on the host. A seed gives the same indices and the same batches on both storages.
"""
from __future__ import annotations

import pytest
import torch
from test_replay import C, H, S, episodes

from dcs_torchrl.training import FrameStackReplayBuffer


def pair(capacity: int, **kwargs) -> tuple[FrameStackReplayBuffer, FrameStackReplayBuffer]:
    """A host buffer and a device-path buffer with generators of the same seed."""
    return tuple(FrameStackReplayBuffer(capacity, S, (C, H, H), (1,), batch_size=8, generator=torch.Generator().manual_seed(0),
                                        device=device, **kwargs) for device in (None, "cpu"))


def assert_same_samples(host: FrameStackReplayBuffer, device: FrameStackReplayBuffer, draws: int = 3) -> None:
    for _ in range(draws):
        a, b = host.sample(64), device.sample(64)
        assert set(a.keys(True, True)) == set(b.keys(True, True))
        for key in a.keys(True, True):
            assert a[key].dtype == b[key].dtype and torch.equal(a[key], b[key]), key


def test_same_seed_same_indices_and_batches_on_both_storages():
    host, device = pair(1000)
    a, b = episodes(1, [5, 7, 4]), episodes(2, [9, 7])
    data = torch.stack([torch.stack(a), torch.stack(b[:16])])  # two envs ending episodes at other times
    for part in (data[:, :10], data[:, 10:]):
        host.extend(part)
        device.extend(part)
    assert len(host) == len(device) == 32 and host.frames_written == device.frames_written
    assert torch.equal(host.valid_indices(), device.valid_indices())
    assert device.sample().device == torch.device("cpu") and host.sample().device is None
    assert_same_samples(host, device)


@pytest.mark.parametrize("chunk", [1, 7, 60], ids=["one_per_extend", "chunks", "wrapping_in_one_extend"])
def test_the_ring_wraps_alike(chunk):
    """Many short episodes in a small buffer (frames expire before transitions), extended one
    transition at a time (the recipes), in chunks, or all at once (one extend wrapping the ring)."""
    host, device = pair(20, min_episode_steps=1)
    data = torch.stack(episodes(0, [2] * 30))
    for start in range(0, 60, chunk):
        host.extend(data[start:start + chunk])
        device.extend(data[start:start + chunk])
    assert torch.equal(host.valid_indices(), device.valid_indices())
    for name in ("_action", "_reward", "_done", "_terminated", "_obs_ids", "_next_ids"):
        assert torch.equal(getattr(host, name), getattr(device, name)), name
    written = min(host.frames_written, host.num_slots)  # the rest of the ring was never written
    assert torch.equal(host._frames[:written], device._frames[:written])
    assert_same_samples(host, device)


def test_episode_ends_reach_the_device_storage():
    host, device = pair(50)
    data = torch.stack(episodes(0, [4, 6]))
    data["next", "terminated"][3] = True  # the first episode terminates, the second is cut by a time limit
    host.extend(data)
    device.extend(data)
    assert torch.equal(device._done[:10].squeeze(-1), data["next", "done"].squeeze(-1))
    assert torch.equal(device._terminated[:10].squeeze(-1), data["next", "terminated"].squeeze(-1))
    assert_same_samples(host, device)


def test_checkpoints_move_between_storages():
    host, device = pair(50)
    data = torch.stack(episodes(0, [30, 30]))
    host.extend(data)
    state = host.state_dict()
    assert all(t.device.type == "cpu" for t in state.values() if isinstance(t, torch.Tensor))
    device.load_state_dict(state)
    assert_same_samples(host, device)
    back = FrameStackReplayBuffer(50, S, (C, H, H), (1,), batch_size=8, generator=torch.Generator().manual_seed(0))
    back.load_state_dict(device.state_dict())  # the device's checkpoint on a host buffer
    host.generator.manual_seed(1)
    back.generator.manual_seed(1)
    assert_same_samples(host, back)
    saved = device.state_dict()["frames"]
    device.extend(torch.stack(episodes(1, [3])))
    assert torch.equal(saved, host.state_dict()["frames"])  # a checkpoint is a copy, not a view


def test_storage_bytes_is_what_a_device_allocates():
    rb = FrameStackReplayBuffer(100, S, (3, 84, 84), (6,), batch_size=8, min_episode_steps=125, device="cpu")
    allocated = sum(t.numel() * t.element_size() for t in (rb._frames, rb._action, rb._reward, rb._done, rb._terminated))
    assert FrameStackReplayBuffer.storage_bytes(100, S, (3, 84, 84), (6,), 125) == allocated
    # DrQ's 100K transitions of 84x84 RGB, 3 stacked, action repeat 8: ~2.2 GB on the device
    assert 2.1e9 < FrameStackReplayBuffer.storage_bytes(100_000, 3, (3, 84, 84), (6,), 125) < 2.3e9
