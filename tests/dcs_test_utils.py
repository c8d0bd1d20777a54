"""Helpers shared by the tests: the paper's tasks and small generated videos."""
import numpy as np

# The paper's six tasks (its Table 1).
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


def distraction_streams(env) -> dict[str, tuple[int, ...]]:
    """The next numbers each distraction of a suite env (``make_env``, ``pixel_env``) will draw, by
    type: read from copies of their generators, the env's own streams left as they are."""
    import copy

    from torchrl.envs import Compose

    from dcs_torchrl.distractions.base import DistractionTransform

    def flat(transform):
        return [t for child in transform.transforms for t in flat(child)] if isinstance(transform, Compose) else [transform]

    return {type(t).__name__: tuple(copy.deepcopy(t._rng).integers(2**62, size=4).tolist())
            for t in flat(env.transform) if isinstance(t, DistractionTransform)}


def shared_streams(streams: dict) -> list[tuple]:
    """The pairs of names in ``streams`` (name -> numbers drawn) whose numbers are the same."""
    import itertools

    return [(a, b) for a, b in itertools.combinations(streams, 2) if streams[a] == streams[b]]
