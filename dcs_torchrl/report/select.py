"""Picking the runs of one setting out of the runs table, and the tasks a table spans."""
from __future__ import annotations

from collections.abc import Sequence

import pandas as pd

from dcs_torchrl.report.experiments import TASK_ORDER

__all__ = ["select", "tasks_of", "first_source"]


def select(
    runs: pd.DataFrame,
    *,
    experiment: str | None = None,
    axis: str | None = None,
    value=None,
    dynamic: bool | None = None,
    eval_split: str | None = None,
    method: str | None = None,
) -> pd.DataFrame:
    """The runs matching every given field (a field left as None is not filtered).

    The no-distraction benchmark (``axis="benchmark", value="none"``) has no static/dynamic
    setting: ``dynamic`` is ignored for it.

    Examples:
        >>> runs = pd.DataFrame({"experiment": ["benchmarks"] * 2, "axis": ["benchmark"] * 2,
        ...                      "value": ["none", "easy"], "dynamic": [True, True],
        ...                      "eval_split": ["train"] * 2, "method": ["SAC"] * 2})
        >>> len(select(runs, value="none", dynamic=False)), len(select(runs, value="easy", dynamic=False))
        (1, 0)
    """
    if dynamic is not None and axis in (None, "benchmark") and value == "none":
        dynamic = None
    mask = pd.Series(True, index=runs.index)
    for column, wanted in (("experiment", experiment), ("axis", axis), ("dynamic", dynamic),
                           ("eval_split", eval_split), ("method", method)):
        if wanted is not None:
            mask &= runs[column] == wanted
    if value is not None:
        # numeric values are stored rounded to 6 decimals (load.py): compare the same way
        mask &= runs["value"] == (value if isinstance(value, str) else round(float(value), 6))
    return runs[mask]


def tasks_of(runs: pd.DataFrame) -> list[tuple[str, str]]:
    """The (domain, task) pairs in ``runs``: the paper's six in its order, then others sorted.

    Examples:
        >>> runs = pd.DataFrame({"domain": ["walker", "hopper", "cartpole"], "task": ["walk", "hop", "swingup"]})
        >>> tasks_of(runs)
        [('cartpole', 'swingup'), ('walker', 'walk'), ('hopper', 'hop')]
    """
    present = set(zip(runs["domain"], runs["task"]))
    return [t for t in TASK_ORDER if t in present] + sorted(present - set(TASK_ORDER))


def first_source(runs: pd.DataFrame, experiments: Sequence[str], **fields) -> tuple[str | None, pd.DataFrame]:
    """The runs matching ``fields`` from the first of ``experiments`` that has any.

    Used by the interactions table, whose inputs may come from the ``interactions`` sweep or
    be shared with the ``training`` / ``benchmarks`` sweeps; the experiments are never pooled,
    so a seed is never counted twice.

    Examples:
        >>> runs = pd.DataFrame({"experiment": ["training", "interactions"], "axis": ["camera"] * 2,
        ...                      "value": [0.1, 0.1], "dynamic": [False] * 2, "eval_split": ["train"] * 2,
        ...                      "method": ["SAC"] * 2})
        >>> source, rows = first_source(runs, ["interactions", "training"], axis="camera", value=0.1)
        >>> source, len(rows)
        ('interactions', 1)
    """
    for experiment in experiments:
        rows = select(runs, experiment=experiment, **fields)
        if len(rows):
            return experiment, rows
    return None, runs.iloc[0:0]
