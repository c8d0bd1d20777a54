"""Checkpoints: atomic, verified, the previous one used when the newest is corrupt or half-written."""
from __future__ import annotations

import pytest
import torch

from dcs_torchrl.training import load_latest, save_checkpoint
from dcs_torchrl.training.checkpoint import list_checkpoints


def test_keeps_the_newest_and_loads_the_latest(tmp_path):
    for frames in (100, 200, 300):
        save_checkpoint(tmp_path, frames, {"w": torch.full((3,), float(frames))}, keep=2)
    assert [f for f, _ in list_checkpoints(tmp_path)] == [200, 300]
    frames, state = load_latest(tmp_path)
    assert frames == 300 and torch.equal(state["w"], torch.full((3,), 300.0))


@pytest.mark.parametrize("damage", ["flip_byte", "truncate", "no_checksum"])
def test_a_damaged_checkpoint_falls_back_to_the_previous(tmp_path, damage):
    save_checkpoint(tmp_path, 100, {"w": torch.ones(1000)})
    newest = save_checkpoint(tmp_path, 200, {"w": torch.zeros(1000)})
    data = bytearray(newest.read_bytes())
    if damage == "flip_byte":
        data[len(data) // 2] ^= 0xFF
        newest.write_bytes(bytes(data))
    elif damage == "truncate":  # a write cut short (as by SIGKILL without the atomic rename)
        newest.write_bytes(bytes(data[: len(data) // 3]))
    else:  # killed between the data and its checksum
        newest.with_name(newest.name + ".sha256").unlink()
    with pytest.warns(UserWarning, match="skipping checkpoint"):
        frames, state = load_latest(tmp_path)
    assert frames == 100 and torch.equal(state["w"], torch.ones(1000))
    assert newest.exists()  # left for inspection, not deleted


@pytest.mark.parametrize("mismatch", ["other_data", "other_checksum"])
def test_a_readable_checkpoint_that_does_not_match_its_checksum_is_skipped(tmp_path, mismatch):
    """The file loads cleanly with torch.load, so only the checksum comparison can reject it."""
    save_checkpoint(tmp_path, 100, {"w": torch.ones(1000)})
    newest = save_checkpoint(tmp_path, 200, {"w": torch.zeros(1000)})
    sidecar = newest.with_name(newest.name + ".sha256")
    if mismatch == "other_data":  # replaced by another valid checkpoint after its checksum was written
        torch.save({"w": torch.full((1000,), 7.0)}, newest)
    else:  # a checksum recorded for other bytes
        sidecar.write_text("0" * 64)
    assert torch.load(newest, weights_only=False)["w"].shape == (1000,)  # valid torch data
    with pytest.warns(UserWarning, match="does not match its checksum"):
        frames, state = load_latest(tmp_path)
    assert frames == 100 and torch.equal(state["w"], torch.ones(1000))


def test_no_checkpoint(tmp_path):
    assert load_latest(tmp_path / "missing") is None
    (tmp_path / "checkpoint_000000000001.pt.tmp").write_bytes(b"partial")
    assert load_latest(tmp_path) is None
