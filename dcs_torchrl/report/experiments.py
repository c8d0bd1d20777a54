"""The paper's experiments as data: methods, tasks, sweep axes and the grid each one covers.

Stone et al. 2021, Secs. 4-5 (docs/paper.md). The report compares what a results directory holds against these grids to say
which cells are missing; values found in the results but not listed here are reported too. The sweeps of the
distractions beyond the paper (lighting and surface textures, docs/lighting_textures.md) are panels of their
own (:data:`BEYOND_PAPER`): the report draws them where the results hold them, and expects none.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from types import MappingProxyType

from dcs_torchrl.methods import METHODS as _METHODS
from dcs_torchrl.presets import BENCHMARKS, TASKS

__all__ = [
    "METHODS",
    "TASK_ORDER",
    "TASK_LABELS",
    "AXES",
    "SWEEP_AXES",
    "SweepAxis",
    "SEEDS",
    "Panel",
    "EXPERIMENTS",
    "BEYOND_PAPER",
    "BEYOND_PAPER_AXES",
    "experiment_panels",
    "BENCHMARK_ORDER",
    "INTERACTION_DIFFICULTIES",
    "single_distraction_settings",
    "task_label",
]

# The six baselines, in the paper's row order (dcs_torchrl.methods).
METHODS: tuple[str, ...] = tuple(_METHODS)

# The paper's six tasks in its column order, and its column headers.
TASK_ORDER: tuple[tuple[str, str], ...] = tuple(TASKS)
TASK_LABELS: MappingProxyType[tuple[str, str], str] = MappingProxyType(
    {
        ("ball_in_cup", "catch"): "BiC-Catch",
        ("cartpole", "swingup"): "C-Swingup",
        ("cheetah", "run"): "C-Run",
        ("finger", "spin"): "F-Spin",
        ("reacher", "easy"): "R-Easy",
        ("walker", "walk"): "W-Walk",
    }
)

# Seeds per cell in the paper (its Sec. 5); cells with another count are annotated.
SEEDS = 5


@dataclass(frozen=True)
class SweepAxis:
    """How a sweep axis sets the env: ``key`` (a make_env setting) takes the value, of type ``kind``;
    ``fixed`` settings go with it."""

    key: str
    kind: type
    fixed: dict = field(default_factory=dict)

    def config(self) -> dict:
        """The ``axes`` entry of ``recipes/experiments/conf/config.yaml``: ``{key, fixed}``."""
        return {"key": self.key, "fixed": dict(self.fixed)}


# The sweep axes of results.json (`sweep.axis`), defined once: the experiments config reads them
# (`axes: ${dcs_axes:}`), the grid and the report their value types (AXES).
SWEEP_AXES: MappingProxyType[str, SweepAxis] = MappingProxyType({
    "benchmark": SweepAxis("benchmark", str),
    "camera": SweepAxis("camera_scale", float),
    "color": SweepAxis("color_scale", float),
    # β_bg with b = 60 (the paper's Sec. 5.1); b with β_bg = 1 (its Sec. 5.2)
    "background_blend": SweepAxis("background_blend", float, {"num_videos": 60}),
    # the same with the 2021 code's blend, which accumulates over an env's episodes (reference_blend)
    "background_blend_2021": SweepAxis("background_blend", float, {"num_videos": 60, "reference_blend": True}),
    "num_videos": SweepAxis("num_videos", int, {"background_blend": 1.0}),
    # beyond the paper (docs/lighting_textures.md): β_light and β_tex, each alone
    "light": SweepAxis("light_scale", float),
    "texture": SweepAxis("texture_scale", float),
})

# Sweep axes of results.json (`sweep.axis`) and the type of their `value`.
AXES: MappingProxyType[str, type] = MappingProxyType({axis: spec.kind for axis, spec in SWEEP_AXES.items()})

_INTENSITIES = tuple(round(0.1 * i, 1) for i in range(11))
# Fig. 1 caption: 0, 1, then doubling up to all 60 training videos.
_NUM_VIDEOS = (0, 1, 2, 4, 8, 16, 32, 60)

BENCHMARK_ORDER: tuple[str, ...] = ("none", "easy", "medium", "blind")


@dataclass(frozen=True)
class Panel:
    """One sweep of an experiment: an axis, its values and how to label it.

    Attributes:
        axis: the ``sweep.axis`` of the runs.
        values: the paper's grid along the axis.
        title: panel title in the figures.
        xlabel: x-axis label, with the symbol and unit.
        eval_split: ``train`` or ``val`` (unseen background videos, the paper's Sec. 5.2).
        blend_axis: the axis of the same sweep with the 2021 code's background blend, drawn in
            the same panel (optional: not part of the expected grid).
        beyond_paper: a sweep the paper does not run (:data:`BEYOND_PAPER`): no paper value is
            stated for it.
    """

    axis: str
    values: tuple
    title: str
    xlabel: str
    eval_split: str = "train"
    blend_axis: str | None = None
    beyond_paper: bool = False

    @property
    def text_xlabel(self) -> str:
        """The x label without matplotlib math markup, for markdown.

        Examples:
            >>> EXPERIMENTS["robustness"][0].text_xlabel
            'camera scale β_cam'
        """
        return re.sub(r"\$\\beta_\{(\w+)\}\$", r"β_\1", self.xlabel)


# What each experiment sweeps (the paper's Sec. 5). Each panel is swept static and dynamic.
EXPERIMENTS: MappingProxyType[str, tuple[Panel, ...]] = MappingProxyType(
    {
        "robustness": (
            Panel("camera", _INTENSITIES, "Camera", "camera scale $\\beta_{cam}$"),
            Panel("color", _INTENSITIES, "Colour", "colour scale $\\beta_{rgb}$"),
            Panel("background_blend", _INTENSITIES, "Background",
                  "background blend $\\beta_{bg}$ (b = 60 videos)", blend_axis="background_blend_2021"),
        ),
        "training": (
            Panel("camera", _INTENSITIES, "Camera", "camera scale $\\beta_{cam}$"),
            Panel("color", _INTENSITIES, "Colour", "colour scale $\\beta_{rgb}$"),
            Panel("num_videos", _NUM_VIDEOS, "Background (training videos)",
                  "number of training videos b ($\\beta_{bg}$ = 1)"),
            Panel("num_videos", _NUM_VIDEOS, "Background (unseen videos)",
                  "number of training videos b (eval: 30 unseen)", eval_split="val"),
        ),
        "benchmarks": (Panel("benchmark", BENCHMARK_ORDER, "Benchmarks", "benchmark"),),
    }
)

# The same experiments' sweeps of the distractions beyond the paper (docs/lighting_textures.md): not in
# the paper's grids (EXPERIMENTS), so never reported missing; drawn after the paper's panels where the
# results hold them (experiment_panels). A texture is drawn once an episode whatever the setting, so
# its dynamic setting is its static one: the robustness command sweeps it static only.
_BEYOND = (
    Panel("light", _INTENSITIES, "Lighting (beyond the paper)", "light scale $\\beta_{light}$", beyond_paper=True),
    Panel("texture", _INTENSITIES, "Texture (beyond the paper)", "texture scale $\\beta_{tex}$ (drawn per episode)",
          beyond_paper=True),
)
BEYOND_PAPER: MappingProxyType[str, tuple[Panel, ...]] = MappingProxyType({"robustness": _BEYOND, "training": _BEYOND})
BEYOND_PAPER_AXES: frozenset[str] = frozenset(p.axis for panels in BEYOND_PAPER.values() for p in panels)


def experiment_panels(experiment: str, axes_found=()) -> tuple[Panel, ...]:
    """The panels of ``experiment``: the paper's (:data:`EXPERIMENTS`), then those beyond it
    (:data:`BEYOND_PAPER`) whose axis is among ``axes_found`` (the axes the results hold).

    Examples:
        >>> [p.axis for p in experiment_panels("robustness", {"camera", "light"})]
        ['camera', 'color', 'background_blend', 'light']
        >>> experiment_panels("robustness", {"texture"})[-1].text_xlabel
        'texture scale β_tex (drawn per episode)'
    """
    found = set(axes_found)
    return EXPERIMENTS[experiment] + tuple(p for p in BEYOND_PAPER.get(experiment, ()) if p.axis in found)

# The difficulties of the interactions table (the paper's Table 5) and the benchmark they decompose.
INTERACTION_DIFFICULTIES: tuple[str, ...] = ("easy", "medium")


def single_distraction_settings(difficulty: str) -> dict[str, float | int]:
    """The single-distraction sweep values that make up benchmark ``difficulty``.

    Args:
        difficulty: a benchmark name of :data:`dcs_torchrl.presets.BENCHMARKS`.

    Examples:
        >>> single_distraction_settings("medium")
        {'camera': 0.2, 'color': 0.2, 'num_videos': 8}
    """
    b = BENCHMARKS[difficulty]
    return {"camera": b.camera_scale, "color": b.color_scale, "num_videos": b.num_videos}


def task_label(domain: str, task: str) -> str:
    """The paper's column header for a task (``"domain task"`` outside the paper's six).

    Examples:
        >>> task_label("cheetah", "run"), task_label("hopper", "hop")
        ('C-Run', 'hopper hop')
    """
    return TASK_LABELS.get((domain, task), f"{domain} {task}")
