"""Helpers shared by the tests: the paper's tasks and small generated videos."""
import numpy as np

# The paper's six tasks (SPEC §3).
PAPER_TASKS = [
    ("ball_in_cup", "catch"),
    ("cartpole", "swingup"),
    ("cheetah", "run"),
    ("finger", "spin"),
    ("reacher", "easy"),
    ("walker", "walk"),
]


def solid_video(rgb, frames: int = 6, size: int = 32) -> np.ndarray:
    """A [frames, size, size, 3] uint8 video of one colour."""
    video = np.empty((frames, size, size, 3), np.uint8)
    video[...] = np.asarray(rgb, np.uint8)
    return video


def numbered_video(frames: int = 12, size: int = 32) -> np.ndarray:
    """A grey video whose frame i has brightness 10 * i, so the frame shown can be read off."""
    return np.stack([np.full((size, size, 3), 10 * i, np.uint8) for i in range(frames)])


def tinted_video(index: int, frames: int = 10, size: int = 32) -> np.ndarray:
    """Video ``index`` of a set of distinct clips: frame i is (10 * i, 20 + 25 * index, 0), so both
    the clip and the frame shown can be read off the rendered sky (index < 10)."""
    video = np.zeros((frames, size, size, 3), np.uint8)
    video[..., 0] = 10 * np.arange(frames)[:, None, None]
    video[..., 1] = 20 + 25 * index
    return video


def physics_of(env):
    """The dm_control physics under a suite env (or a plain DMControlEnv)."""
    from torchrl.envs import TransformedEnv

    base = env.base_env if isinstance(env, TransformedEnv) else env
    return base._env.physics
