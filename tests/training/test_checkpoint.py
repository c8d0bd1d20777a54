"""Checkpoints: atomic, verified, the previous one used when the newest is corrupt or half-written;
read as weights only, a checkpoint that would run code refused unless trusted."""
from __future__ import annotations

import random

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf
from tensordict import TensorDict
from torchrl.checkpoint import GlobalRNGState
from torchrl.data import Bounded

from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import FrameStackReplayBuffer, RunDirectory, load_latest, save_checkpoint
from dcs_torchrl.training.checkpoint import UntrustedCheckpointError, list_checkpoints
from dcs_torchrl.training.loop import Workspace
from test_pretrained import CreatesFile


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
    assert torch.load(newest, weights_only=True)["w"].shape == (1000,)  # valid torch data
    with pytest.warns(UserWarning, match="does not match its checksum"):
        frames, state = load_latest(tmp_path)
    assert frames == 100 and torch.equal(state["w"], torch.ones(1000))


def test_no_checkpoint(tmp_path):
    assert load_latest(tmp_path / "missing") is None
    (tmp_path / "checkpoint_000000000001.pt.tmp").write_bytes(b"partial")
    assert load_latest(tmp_path) is None


@pytest.mark.parametrize("algo", ["sac", "qtopt"])
def test_a_training_checkpoint_pickles_no_class_of_the_package(tmp_path, algo):
    """The agent, replay and RNG states are state dicts of tensors and builtins, so a checkpoint loads with
    ``weights_only=True`` (which refuses any other class): moving or renaming a package module (as
    ``dcs_torchrl.agents`` -> ``dcs_torchrl.modules``) leaves checkpoints written before loadable."""
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose(algo, overrides=["network.hidden_dim=16", "algo.aug=drq"])
    agent = agent_class(algo)(cfg, (9, 32, 32), Bounded(-torch.ones(2), torch.ones(2), shape=(2,)))
    buffer = FrameStackReplayBuffer(8, 3, (3, 32, 32), (2,), batch_size=2)
    stacks, flags = torch.zeros(4, 9, 32, 32, dtype=torch.uint8), torch.zeros(4, 1, dtype=torch.bool)
    buffer.extend(TensorDict({"pixels": stacks, "action": torch.zeros(4, 2), "next": {
        "pixels": stacks, "reward": torch.zeros(4, 1), "done": flags, "terminated": flags}}, [4]))
    state = {"agent": agent.state_dict(), "buffer": buffer.state_dict(), "counters": {"steps": 4},
             "rng": GlobalRNGState().state_dict(), "wandb_id": None, "config": {"seed": 0}}
    path = save_checkpoint(tmp_path, 4, state)
    loaded = torch.load(path, weights_only=True)
    assert loaded["agent"]["loss"].keys() == state["agent"]["loss"].keys()


def test_a_checkpoint_that_would_run_code_is_refused_unless_trusted(tmp_path):
    """Its checksum matches (it proves integrity, not trust): refused naming what it holds, nothing run,
    and no older checkpoint taken in its place; ``trust=True`` unpickles it."""
    marker = tmp_path / "ran"
    save_checkpoint(tmp_path, 100, {"w": torch.ones(3)})
    save_checkpoint(tmp_path, 200, {"w": torch.zeros(3), "payload": CreatesFile(marker)})
    refusal = r"000200\.pt holds .*\(io\.open\).*trust_checkpoint=True.*--trust-checkpoint.*checkpoint\.trust=true"
    with pytest.raises(UntrustedCheckpointError, match=refusal):
        load_latest(tmp_path)
    assert not marker.exists()
    frames, state = load_latest(tmp_path, trust=True)
    assert frames == 200 and marker.exists() and torch.equal(state["w"], torch.zeros(3))


@pytest.fixture
def tiny_run(tmp_path):
    """A SAC run's config and directory, a checkpoint of its fresh workspace written by the loop."""
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("sac", overrides=["pixels.image_size=32", "env.action_repeat=100", "network.hidden_dim=16",
                                        "replay_buffer.size=16", "algo.batch_size=4", "eval.video=false",
                                        "progress=false"])
    run = RunDirectory(tmp_path / "run", OmegaConf.to_container(cfg, resolve=True))
    run.claim()
    with Workspace(cfg, agent_class("sac"), run) as workspace:
        workspace.resume()
        workspace.counters["steps"] = 3
        workspace.checkpoint()
        workspace.logger.close()
    return cfg, run


def _resumed_counters(cfg, run, trust: bool) -> dict:
    cfg = OmegaConf.merge(cfg, {"checkpoint": {"trust": trust}})  # the recipes' checkpoint.trust=true
    with Workspace(cfg, agent_class("sac"), run) as workspace:
        workspace.resume()
        workspace.logger.close()
        return workspace.counters


@pytest.mark.parametrize("holds", ["code", "numpy_rng"])
def test_a_resume_refuses_a_checkpoint_that_needs_more_than_weights_unless_trusted(tiny_run, holds):
    """The loop's own checkpoint loads as weights only; one that would run code, or one of the format
    written before RNG states were tensors (NumPy's state as an array), is refused (nothing run) and
    resumes with ``checkpoint.trust=true``."""
    cfg, run = tiny_run
    ((frames, path),) = list_checkpoints(run.checkpoints)
    state = torch.load(path, weights_only=True)
    assert _resumed_counters(cfg, run, trust=False)["steps"] == 3
    marker = run.path / "ran"
    if holds == "code":
        state["payload"] = CreatesFile(marker)
    else:
        state["rng"] = {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}
    save_checkpoint(run.checkpoints, frames, state)
    with pytest.raises(UntrustedCheckpointError, match=r"numpy" if holds == "numpy_rng" else r"\(io\.open\)"):
        _resumed_counters(cfg, run, trust=False)
    assert not marker.exists()
    assert _resumed_counters(cfg, run, trust=True)["steps"] == 3
    assert marker.exists() == (holds == "code")
