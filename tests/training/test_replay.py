"""FrameStackReplayBuffer: stacks rebuilt exactly from single frames, memory, expiry, state."""
from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict

from dcs_torchrl.envs import resolve_settings
from dcs_torchrl.training import FrameStackReplayBuffer
from dcs_torchrl.training.envs import pixel_env

S, C, H = 3, 3, 6


def frame(value: int) -> torch.Tensor:
    return torch.full((C, H, H), value % 256, dtype=torch.uint8)


def episodes(env_id: int, lengths: list[int]) -> list[TensorDict]:
    """Transitions of consecutive episodes, as a TorchRL env with CatFrames would give them.

    Frame values encode (env, episode, step) so every stack can be checked exactly.
    """
    out = []
    for episode, length in enumerate(lengths):
        frames = [frame(env_id * 100 + episode * 20 + t) for t in range(length + 1)]
        stack = lambda t: torch.cat([frames[max(i, 0)] for i in range(t - S + 1, t + 1)])  # noqa: E731
        for t in range(length):
            out.append(TensorDict({
                "pixels": stack(t), "action": torch.tensor([float(t)]),
                "next": {"pixels": stack(t + 1), "reward": torch.tensor([float(episode)]),
                         "done": torch.tensor([t == length - 1]), "terminated": torch.tensor([False])},
            }, []))
    return out


def test_every_sampled_stack_equals_the_stored_one():
    rb = FrameStackReplayBuffer(1000, S, (C, H, H), (1,), batch_size=64, generator=torch.Generator().manual_seed(0))
    a, b = episodes(1, [5, 7, 4]), episodes(2, [9, 7])
    data = torch.stack([torch.stack(a), torch.stack(b[:16])])  # [envs=2, T=16], envs finishing episodes at other times
    rb.extend(data[:, :10])
    rb.extend(data[:, 10:])
    assert len(rb) == 32
    reference = {(float(td["action"]), int(td["pixels"][-1, 0, 0]), int(td["next", "pixels"][-1, 0, 0])): td for td in a + b[:16]}
    sample = rb.sample(256)
    for i in range(256):
        key = (float(sample["action"][i]), int(sample["pixels"][i, -1, 0, 0]), int(sample["next", "pixels"][i, -1, 0, 0]))
        ref = reference[key]
        assert torch.equal(sample["pixels"][i], ref["pixels"])
        assert torch.equal(sample["next", "pixels"][i], ref["next", "pixels"])
        assert sample["next", "reward"][i] == ref["next", "reward"]


def test_stores_each_frame_once():
    rb = FrameStackReplayBuffer(200, S, (C, H, H), (1,), batch_size=8)
    rb.extend(torch.stack(episodes(0, [100, 100])))
    assert rb.frames_written == 200 + 2 * S  # one frame per transition plus a stack per episode start
    # at DrQ's 84x84 RGB, 3 stacked frames: one frame and ~100 bytes per transition, not two stacks
    big = FrameStackReplayBuffer(200, S, (3, 84, 84), (6,), batch_size=8)
    stacks = torch.zeros(200, S * 3, 84, 84, dtype=torch.uint8)
    flags = torch.zeros(200, 1, dtype=torch.bool)
    big.extend(TensorDict({"pixels": stacks, "action": torch.zeros(200, 6), "next": {
        "pixels": stacks, "reward": torch.zeros(200, 1), "done": flags, "terminated": flags}}, [200]))
    assert big.nbytes() < 0.2 * 200 * 2 * S * 3 * 84 * 84


def test_fifo_eviction_never_returns_overwritten_frames():
    rb = FrameStackReplayBuffer(20, S, (C, H, H), (1,), batch_size=8, min_episode_steps=1)
    rb.extend(torch.stack(episodes(0, [2] * 30)))  # many short episodes: frames expire before transitions
    valid = rb.valid_indices()
    assert 0 < valid.numel() <= 20
    sample = rb.sample(200)
    newest = sample["next", "pixels"][:, -C:].reshape(200, -1)[:, 0]
    previous = sample["next", "pixels"][:, -2 * C:-C].reshape(200, -1)[:, 0]
    # within an episode of the generator, consecutive frames differ by 1 (or repeat at a start)
    assert torch.all((newest.int() - previous.int() == 1) | (newest == previous))


def test_state_dict_round_trip_and_layout_check():
    rb = FrameStackReplayBuffer(50, S, (C, H, H), (1,), batch_size=4)
    rb.extend(torch.stack(episodes(0, [30, 30])))
    copy = FrameStackReplayBuffer(50, S, (C, H, H), (1,), batch_size=4)
    copy.load_state_dict(rb.state_dict())
    assert len(copy) == len(rb) and copy.frames_written == rb.frames_written
    torch.testing.assert_close(copy._gather(copy._obs_ids[:5]), rb._gather(rb._obs_ids[:5]))
    with pytest.raises(ValueError, match="does not match"):
        FrameStackReplayBuffer(60, S, (C, H, H), (1,), batch_size=4).load_state_dict(rb.state_dict())


def test_bad_input_names_the_fix():
    with pytest.raises(ValueError, match="lower the batch size or raise the replay buffer size"):
        FrameStackReplayBuffer(10, S, (C, H, H), (1,), batch_size=11)
    rb = FrameStackReplayBuffer(10, S, (C, H, H), (1,), batch_size=2)
    with pytest.raises(RuntimeError, match="empty"):
        rb.sample()
    bad = torch.stack(episodes(0, [3]))
    bad["pixels"] = bad["pixels"].float()
    with pytest.raises(TypeError, match="uint8"):
        rb.extend(bad)



@pytest.fixture(scope="module")
def time_limited_rollout():
    """A real cartpole rollout with the recipes' pixel handling whose first episode ends by DM Control's
    time limit after 10 agent steps (action repeat 100 of its 1000 physics steps), then resets."""
    env = pixel_env(resolve_settings("cartpole", "swingup", action_repeat=100), frame_stack=S, image_size=H,
                    render_profile="default", seed=0)
    torch.manual_seed(0)  # the random actions identify the transitions
    data = env.rollout(14, break_when_any_done=False)
    env.close()
    assert data["next", "done"].squeeze(-1).nonzero().flatten().tolist() == [9]
    assert not data["next", "terminated"].any()
    return data


@pytest.mark.parametrize("terminated", [False, True], ids=["time_limit", "termination"])
def test_an_episode_end_reaches_the_loss_as_it_happened(time_limited_rollout, terminated):
    """The sample hands the loss ``terminated`` as the env set it (a time limit: done but not
    terminated, so the loss keeps bootstrapping), ``done``, and the stacks around the end: the last
    transition's next stack is the episode's final one, the next transition starts from the reset stack.
    (No DM Control task of the paper terminates: the termination case marks the same end terminated.)"""
    data = time_limited_rollout.clone()
    data["next", "terminated"][9] = terminated
    rb = FrameStackReplayBuffer(20, S, (C, H, H), (1,), batch_size=4, generator=torch.Generator().manual_seed(0))
    rb.extend(data)
    sample = rb.sample(400)  # every one of the 14 transitions, many times
    for t in (8, 9, 10):
        rows = (sample["action"] == data["action"][t].float()).squeeze(-1)
        assert rows.any(), t
        expected_end = (t == 9, terminated and t == 9)
        assert {(bool(d), bool(x)) for d, x in zip(sample["next", "done"][rows], sample["next", "terminated"][rows])} == {expected_end}
        for key in ("pixels", ("next", "pixels")):
            assert torch.equal(sample[key][rows], data[key][t].expand_as(sample[key][rows])), (t, key)
