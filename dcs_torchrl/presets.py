"""The paper's settings as data: benchmarks (Stone et al. 2021, Sec. 5.3), tasks and action repeats (its Table 1).

Nothing here runs code: :func:`dcs_torchrl.make_env` reads these tables, and every
entry can be overridden there keyword by keyword.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType


@dataclass(frozen=True)
class Benchmark:
    """One benchmark of the paper (Sec. 5.3; the table in docs/paper.md).

    Attributes:
        camera_scale: β_cam, the camera distraction scale in [0, 1].
        color_scale: β_rgb, the colour distraction scale in [0, 1].
        num_videos: b, the number of background videos (the first b of the split);
            ``None`` means every video of the split (60 for the DAVIS 2017 training split).
        background_blend: β_bg, weight of the video against the original skybox.
        blind: turn the camera backwards so that no task-relevant body is in view.
    """

    camera_scale: float
    color_scale: float
    num_videos: int | None
    background_blend: float = 1.0
    blind: bool = False


BENCHMARKS: MappingProxyType[str, Benchmark] = MappingProxyType(
    {
        "none": Benchmark(camera_scale=0.0, color_scale=0.0, num_videos=0),
        "easy": Benchmark(camera_scale=0.1, color_scale=0.1, num_videos=4),
        "medium": Benchmark(camera_scale=0.2, color_scale=0.2, num_videos=8),
        # medium, camera turned backwards: the lower bound of the paper's Figs. 6-7
        "blind": Benchmark(camera_scale=0.2, color_scale=0.2, num_videos=8, blind=True),
        # in the authors' 2021 code only, not in the paper
        "hard": Benchmark(camera_scale=0.3, color_scale=0.3, num_videos=None),
    }
)

# The PlaNet benchmark tasks with the paper's action repeats (its Table 1).
TASKS: MappingProxyType[tuple[str, str], int] = MappingProxyType(
    {
        ("ball_in_cup", "catch"): 4,
        ("cartpole", "swingup"): 8,
        ("cheetah", "run"): 4,
        ("finger", "spin"): 2,
        ("reacher", "easy"): 4,
        ("walker", "walk"): 2,
    }
)

# Action repeat for a domain outside the paper's six tasks (DrQ/PlaNet convention).
DEFAULT_ACTION_REPEAT = 4

# Ground-plane (material "grid") opacity when background videos are shown (the paper's Sec. 3.3).
GROUND_ALPHA: MappingProxyType[str, float] = MappingProxyType(
    {"cheetah": 1.0, "walker": 1.0, "reacher": 0.0}
)
DEFAULT_GROUND_ALPHA = 0.3

# The camera a domain is rendered from; 0 unless listed (the authors' code).
CAMERAS: MappingProxyType[str, int] = MappingProxyType({"quadruped": 2})


def action_repeat(domain: str, task: str) -> int:
    """The paper's action repeat for ``(domain, task)``; 4 for tasks outside the paper."""
    return TASKS.get((domain, task), DEFAULT_ACTION_REPEAT)


def ground_alpha(domain: str) -> float:
    """The ground-plane opacity used with background videos in ``domain``."""
    return GROUND_ALPHA.get(domain, DEFAULT_GROUND_ALPHA)


def default_camera(domain: str) -> int:
    """The camera id the suite renders ``domain`` from."""
    return CAMERAS.get(domain, 0)
