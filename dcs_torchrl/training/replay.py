"""A uint8 replay buffer for stacked pixel observations that stores every frame once.

A transition of DrQ's pixel setup holds two stacks of ``S`` frames (observation and next
observation, ``3 * S`` channels each). Stored as they are, 100K transitions of 84x84 RGB with
``S = 3`` take 100K x 2 x 9 x 84 x 84 bytes = 12.7 GB. Consecutive stacks share ``S - 1`` frames,
so :class:`FrameStackReplayBuffer` keeps one ring of single frames and, per transition, the ids
of the ``S`` frames of each stack: one new frame per transition (plus ``S`` at an episode's
start), 100K transitions in ~2.2 GB, and a sample is one gather.

A transition is valid while all its frames are still in the frame ring. The ring holds
``capacity * (1 + S / min_episode_steps) + slack`` frames, so with episodes of at least
``min_episode_steps`` transitions (DM Control: 1000 / action repeat >= 125) every stored
transition stays valid; with shorter episodes the oldest ones expire a little earlier, and they
are never sampled once a frame of theirs is overwritten.
"""
from __future__ import annotations

import math

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.utils import NestedKey

__all__ = ["FrameStackReplayBuffer"]


class FrameStackReplayBuffer:
    """Uniform replay of stacked uint8 frames, each frame stored once.

    Args:
        capacity (int): transitions kept (FIFO).
        frame_stack (int): ``S``, frames per observation stack.
        frame_shape (sequence of int): one frame, ``(C, H, W)``; observations are ``(S*C, H, W)``.
        action_shape (sequence of int): one action.

    Keyword Args:
        batch_size (int): transitions per :meth:`sample`; at most ``capacity``.
        pixels_key (NestedKey): the stacked pixels entry (and ``("next", pixels_key)``).
        min_episode_steps (int): sizes the frame ring (see the module docstring). Defaults to 50.
        generator (torch.Generator, optional): source of the sampled indices (a CPU generator:
            indices are drawn on the host whatever the storage).
        device (torch.device, optional): ``None`` (default): everything on the host. A device:
            the frames and per-transition arrays live there, the frame ids on the host, and
            samples are made there (the module docstring); ``"cpu"`` runs that path on the host.

    Reads from each :meth:`extend` batch (shaped ``[T]`` for one env or ``[envs, T]``, time
    last, as TorchRL collectors give): ``pixels_key``, ``"action"``, and under ``"next"``:
    ``pixels_key``, ``"reward"``, ``"done"``, ``"terminated"``. A new episode is detected by the
    previous transition of the same env being ``done``, so collectors may reset envs freely.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> rb = FrameStackReplayBuffer(100, 3, (3, 8, 8), (1,), batch_size=4)
        >>> stack = torch.zeros(5, 9, 8, 8, dtype=torch.uint8)
        >>> data = TensorDict({"pixels": stack, "action": torch.zeros(5, 1),
        ...                    "next": {"pixels": stack, "reward": torch.zeros(5, 1),
        ...                             "done": torch.zeros(5, 1, dtype=torch.bool),
        ...                             "terminated": torch.zeros(5, 1, dtype=torch.bool)}}, [5])
        >>> rb.extend(data)
        >>> len(rb), rb.sample()["next", "pixels"].shape
        (5, torch.Size([4, 9, 8, 8]))
    """

    def __init__(
        self,
        capacity: int,
        frame_stack: int,
        frame_shape: tuple[int, ...],
        action_shape: tuple[int, ...],
        *,
        batch_size: int,
        pixels_key: NestedKey = "pixels",
        min_episode_steps: int = 50,
        generator: torch.Generator | None = None,
        device: str | torch.device | None = None,
    ):
        if capacity < 1 or frame_stack < 1 or min_episode_steps < 1:
            raise ValueError(
                f"capacity, frame_stack and min_episode_steps must be >= 1, got {capacity}, {frame_stack}, {min_episode_steps}."
            )
        if not 1 <= batch_size <= capacity:
            raise ValueError(
                f"batch_size={batch_size} must be between 1 and the buffer capacity {capacity}: "
                "lower the batch size or raise the replay buffer size."
            )
        self.capacity, self.frame_stack, self.batch_size = int(capacity), int(frame_stack), int(batch_size)
        self.frame_shape, self.action_shape = tuple(frame_shape), tuple(action_shape)
        self.pixels_key = pixels_key
        self.generator = generator
        self.num_slots = self.ring_slots(capacity, frame_stack, min_episode_steps)
        self.device = None if device is None else torch.device(device)
        storage = self.device or torch.device("cpu")
        # torch.empty maps the pages lazily on the host: memory grows with what is written, not the capacity.
        self._frames = torch.empty((self.num_slots, *self.frame_shape), dtype=torch.uint8, device=storage)
        self._obs_ids = torch.zeros((capacity, frame_stack), dtype=torch.int64)  # always on the host
        self._next_ids = torch.zeros((capacity, frame_stack), dtype=torch.int64)
        self._action = torch.zeros((capacity, *self.action_shape), dtype=torch.float32, device=storage)
        self._reward = torch.zeros((capacity, 1), dtype=torch.float32, device=storage)
        self._done = torch.zeros((capacity, 1), dtype=torch.bool, device=storage)
        self._terminated = torch.zeros((capacity, 1), dtype=torch.bool, device=storage)
        self.frames_written = 0  # ids of frames ever written; slot = id % num_slots
        self.transitions_written = 0
        self._stacks: dict[int, torch.Tensor | None] = {}  # env index -> frame ids of its current stack
        self._staged: tuple[list, list, list, list] | None = None  # device path: what an extend writes

    @staticmethod
    def ring_slots(capacity: int, frame_stack: int, min_episode_steps: int = 50) -> int:
        """Frames the ring holds for ``capacity`` transitions (the module docstring)."""
        return capacity + math.ceil(capacity * frame_stack / min_episode_steps) + 64 * frame_stack

    @classmethod
    def storage_bytes(cls, capacity: int, frame_stack: int, frame_shape: tuple[int, ...], action_shape: tuple[int, ...],
                      min_episode_steps: int = 50) -> int:
        """Bytes a full buffer stores on its device (what a device allocates up front): the frame
        ring and the per-transition arrays."""
        frames = cls.ring_slots(capacity, frame_stack, min_episode_steps) * math.prod(frame_shape)
        return frames + capacity * (4 * math.prod(action_shape) + 4 + 1 + 1)

    def __len__(self) -> int:
        return min(self.transitions_written, self.capacity)

    def _write_frames(self, frames: torch.Tensor) -> torch.Tensor:
        ids = torch.arange(self.frames_written, self.frames_written + frames.shape[0])
        if self._staged is None:
            self._frames[ids % self.num_slots] = frames
        else:
            self._staged[0].append(ids)
            self._staged[1].append(frames)
        self.frames_written += frames.shape[0]
        return ids

    def _write_row(self, i: int, action: torch.Tensor, reward: torch.Tensor, done: torch.Tensor,
                   terminated: torch.Tensor) -> None:
        if self._staged is None:
            self._action[i] = action
            self._reward[i] = reward.reshape(1)
            self._done[i] = done.reshape(1)
            self._terminated[i] = terminated.reshape(1)
        else:
            self._staged[2].append(i)
            self._staged[3].append(torch.cat([action.reshape(-1).float(), reward.reshape(1).float(),
                                              done.reshape(1).float(), terminated.reshape(1).float()]))

    def _send(self, tensor: torch.Tensor) -> torch.Tensor:
        """A host tensor on the storage device: pinned and not waited for on CUDA."""
        if self.device.type == "cuda":
            return tensor.pin_memory().to(self.device, non_blocking=True)
        return tensor.to(self.device)

    def _flush(self) -> None:
        """The device path's writes of one extend: its new frames and rows, three copies in all.
        Where one extend wraps around the ring, only its last write of each slot is kept, as the
        host path's writes in order leave it."""
        frame_ids, frames, rows, values = self._staged
        self._staged = None
        ids, frames = torch.cat(frame_ids)[-self.num_slots:], torch.cat(frames)[-self.num_slots:]
        rows = torch.tensor(rows, dtype=torch.int64)[-self.capacity:]
        values = torch.stack(values)[-self.capacity:]
        index = self._send(torch.cat([ids % self.num_slots, rows]))
        slots, rows = index[:ids.numel()], index[ids.numel():]
        self._frames.index_copy_(0, slots, self._send(frames))
        values = self._send(values)
        actions = math.prod(self.action_shape)
        self._action.index_copy_(0, rows, values[:, :actions].reshape(-1, *self.action_shape))
        self._reward.index_copy_(0, rows, values[:, actions:actions + 1])
        self._done.index_copy_(0, rows, values[:, actions + 1:actions + 2] > 0.5)
        self._terminated.index_copy_(0, rows, values[:, actions + 2:] > 0.5)

    def _split(self, stack: torch.Tensor) -> torch.Tensor:
        expected = (self.frame_stack * self.frame_shape[0], *self.frame_shape[1:])
        if tuple(stack.shape) != expected:
            raise ValueError(f"expected stacked pixels of shape {expected}, got {tuple(stack.shape)}.")
        if stack.dtype != torch.uint8:
            raise TypeError(f"the buffer stores uint8 pixels, got {stack.dtype}: store the env's uint8 frames.")
        return stack.reshape(self.frame_stack, *self.frame_shape)

    def new_episodes(self) -> None:
        """Forgets every env's current stack: the next transition of each env starts an episode."""
        self._stacks.clear()

    def extend(self, data: TensorDictBase) -> None:
        """Adds a collector batch (``[T]`` or ``[envs, T]``)."""
        if data.ndim == 1:
            data = data.unsqueeze(0)
        if data.ndim != 2:
            raise ValueError(f"expected a batch shaped [T] or [envs, T], got {tuple(data.batch_size)}.")
        key = self.pixels_key
        obs, next_obs = data.get(key), data.get(("next", key))
        action = data.get("action")
        reward = data.get(("next", "reward"))
        done, terminated = data.get(("next", "done")), data.get(("next", "terminated"))
        if self.device is not None:
            self._staged = ([], [], [], [])
        for env in range(data.shape[0]):
            for t in range(data.shape[1]):
                stack = self._stacks.get(env)
                if stack is None:
                    stack = self._write_frames(self._split(obs[env, t]))
                newest = self._split(next_obs[env, t])[-1:]
                next_stack = torch.cat([stack[1:], self._write_frames(newest)])
                i = self.transitions_written % self.capacity
                self._obs_ids[i], self._next_ids[i] = stack, next_stack
                self._write_row(i, action[env, t], reward[env, t], done[env, t], terminated[env, t])
                self.transitions_written += 1
                self._stacks[env] = None if bool(done[env, t].any()) else next_stack
        if self._staged is not None:
            self._flush()

    def valid_indices(self) -> torch.Tensor:
        """Indices of the stored transitions whose frames are all still in the ring."""
        size = len(self)
        oldest = self.frames_written - self.num_slots
        return torch.nonzero(self._obs_ids[:size, 0] >= oldest).squeeze(-1)

    def _gather(self, ids: torch.Tensor) -> torch.Tensor:
        frames = self._frames[ids % self.num_slots]  # [B, S, C, H, W]
        return frames.reshape(ids.shape[0], self.frame_stack * self.frame_shape[0], *self.frame_shape[1:])

    def _draw(self, batch_size: int) -> torch.Tensor:
        """``batch_size`` indices of valid transitions, uniform with replacement, drawn on the host."""
        valid = self.valid_indices()
        if valid.numel() == 0:
            raise RuntimeError("the replay buffer is empty: extend it before sampling.")
        return valid[torch.randint(valid.numel(), (batch_size,), generator=self.generator)]

    def sample(self, batch_size: int | None = None) -> TensorDict:
        """A uniform sample (with replacement) of ``batch_size`` valid transitions (on the
        buffer's device)."""
        batch_size = self.batch_size if batch_size is None else batch_size
        index = self._draw(batch_size)
        if self.device is None:
            obs, next_obs = self._gather(self._obs_ids[index]), self._gather(self._next_ids[index])
        else:  # one copy to the device: the indices and the frame ids of both stacks
            slots = torch.cat([index.unsqueeze(1), self._obs_ids[index], self._next_ids[index]], dim=1)
            slots = self._send(slots)
            index, obs_ids, next_ids = slots.split([1, self.frame_stack, self.frame_stack], dim=1)
            index = index.squeeze(1)
            obs, next_obs = self._gather(obs_ids), self._gather(next_ids)
        return TensorDict(
            {
                self.pixels_key: obs,
                "action": self._action[index],
                "next": {
                    self.pixels_key: next_obs,
                    "reward": self._reward[index],
                    "done": self._done[index],
                    "terminated": self._terminated[index],
                },
            },
            batch_size=[batch_size],
            device=self.device,
        )

    def nbytes(self) -> int:
        """Bytes of stored data (frames written so far, plus the per-transition arrays)."""
        frames = min(self.frames_written, self.num_slots) * self._frames[0].numel()
        per_transition = sum(t.numel() * t.element_size() for t in (self._obs_ids, self._next_ids, self._action, self._reward, self._done, self._terminated))
        return frames + per_transition

    def state_dict(self) -> dict:
        """Everything needed to continue sampling; the envs' current stacks are not kept (a resumed
        run starts new episodes)."""
        n = min(self.frames_written, self.num_slots)
        size = len(self)
        return {
            "capacity": self.capacity, "frame_stack": self.frame_stack, "frame_shape": self.frame_shape,
            "num_slots": self.num_slots, "frames_written": self.frames_written,
            "transitions_written": self.transitions_written, "frames": _host_copy(self._frames[:n]),
            "obs_ids": self._obs_ids[:size].clone(), "next_ids": self._next_ids[:size].clone(),
            "action": _host_copy(self._action[:size]), "reward": _host_copy(self._reward[:size]),
            "done": _host_copy(self._done[:size]), "terminated": _host_copy(self._terminated[:size]),
        }

    def load_state_dict(self, state: dict) -> None:
        mine = (self.capacity, self.frame_stack, tuple(self.frame_shape), self.num_slots)
        theirs = (state["capacity"], state["frame_stack"], tuple(state["frame_shape"]), state["num_slots"])
        if mine != theirs:
            raise ValueError(f"replay buffer layout (capacity, stack, frame, slots) {theirs} does not match this buffer's {mine}.")
        n, size = state["frames"].shape[0], state["obs_ids"].shape[0]
        self._frames[:n] = state["frames"]
        for name in ("obs_ids", "next_ids", "action", "reward", "done", "terminated"):
            getattr(self, f"_{name}")[:size] = state[name]
        self.frames_written, self.transitions_written = state["frames_written"], state["transitions_written"]
        self.new_episodes()


def _host_copy(tensor: torch.Tensor) -> torch.Tensor:
    """A copy on the host (checkpoints hold host tensors whatever the storage)."""
    return tensor.to("cpu", copy=True)
