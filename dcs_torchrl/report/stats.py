"""Seed statistics: mean ± standard error over seeds, the mean over tasks, and the bold rule.

The paper's Sec. 5 and its table captions (docs/paper.md): a cell's score is the mean over seeds of each run's
``eval.mean``, its error the standard error over seeds; a result is bold if it has the
highest mean or is not significantly worse than the highest mean at p < 0.1.

Choices (docs/report.md):

- Standard error: sample standard deviation (ddof = 1) / sqrt(n); undefined (NaN) for n = 1.
- A seed with several runs in one cell (e.g. a no-distraction run recorded both as static and
  dynamic) counts once, with the mean of its runs.
- Mean over tasks: per seed, the mean of that seed's per-task scores; then mean ± s.e. over
  the seeds that have every task. Seeds missing a task are left out of the mean; with no
  complete seed the mean is missing.
- Significance: a one-sided z-test on the two cells' mean ± standard error,
  ``z = (m_best - m) / sqrt(se_best^2 + se^2)``, ``p = 1 - Phi(z)``; bold if ``p >= 0.1``.
  Applied to the paper's own published mean ± s.e. it reproduces all 210 of its bold marks
  (Welch's t-test on the same numbers: 206). Both standard errors zero: the difference is
  certain, significant unless the means are equal. A single seed has no standard error (not
  zero): no test, the cell is not bold unless it ties the highest mean, and a single-seed best
  leaves every other cell not bold. Among tied highest means the reference is the one with
  most seeds.
"""
from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

__all__ = [
    "ALPHA", "Score", "Estimate", "seed_scores", "cell_scores", "task_mean", "z_p_value", "better_p_value",
    "bold_flags",
]

ALPHA = 0.1


@dataclass(frozen=True)
class Score:
    """Mean ± standard error over seeds.

    Attributes:
        values: one score per seed, in seed order.
        seeds: the seeds, same order.

    Examples:
        >>> s = Score.of([1.0, 2.0, 3.0])
        >>> s.mean, round(s.stderr, 4), s.n
        (2.0, 0.5774, 3)
        >>> math.isnan(Score.of([5.0]).stderr)
        True
    """

    values: tuple[float, ...]
    seeds: tuple[int, ...] = ()

    @classmethod
    def of(cls, values: Iterable[float], seeds: Iterable[int] | None = None) -> Score:
        values = tuple(float(v) for v in values)
        if not values:
            raise ValueError("a Score needs at least one seed")
        return cls(values, tuple(seeds) if seeds is not None else tuple(range(len(values))))

    @property
    def n(self) -> int:
        return len(self.values)

    @property
    def mean(self) -> float:
        return float(np.mean(self.values))

    @property
    def std(self) -> float:
        """Sample standard deviation over seeds (ddof = 1); NaN for one seed."""
        return float(np.std(self.values, ddof=1)) if self.n > 1 else math.nan

    @property
    def stderr(self) -> float:
        """Standard error of the mean over seeds; NaN for one seed."""
        return self.std / math.sqrt(self.n)


@dataclass(frozen=True)
class Estimate:
    """A published mean ± standard error (e.g. a cell of the paper's tables).

    Attributes:
        mean: the mean over seeds.
        stderr: its standard error (NaN: unknown, as for a single seed).
        n: the number of seeds (the paper: 5).

    Examples:
        >>> Estimate(63, 24).n
        5
    """

    mean: float
    stderr: float
    n: int = 5


def seed_scores(runs: pd.DataFrame, keys: Sequence[str]) -> pd.DataFrame:
    """One score per (``keys``, seed): the mean of that seed's runs' ``score``.

    Args:
        runs: the runs table (:func:`~dcs_torchrl.report.load.load_results`).
        keys: the columns that define a cell.

    Examples:
        >>> runs = pd.DataFrame({"method": ["SAC"] * 3, "seed": [0, 0, 1], "score": [1.0, 3.0, 5.0]})
        >>> seed_scores(runs, ["method"]).to_dict("records")
        [{'method': 'SAC', 'seed': 0, 'score': 2.0}, {'method': 'SAC', 'seed': 1, 'score': 5.0}]
    """
    keys = list(keys)
    return runs.groupby(keys + ["seed"], sort=True, dropna=False)["score"].mean().reset_index()


def cell_scores(runs: pd.DataFrame, keys: Sequence[str]) -> dict[tuple, Score]:
    """Mean ± s.e. over seeds for every cell (a combination of ``keys``) present in ``runs``.

    Examples:
        >>> runs = pd.DataFrame({"method": ["SAC", "SAC", "QT-Opt"], "seed": [0, 1, 0],
        ...                      "score": [1.0, 3.0, 5.0]})
        >>> {k: v.mean for k, v in cell_scores(runs, ["method"]).items()}
        {('QT-Opt',): 5.0, ('SAC',): 2.0}
    """
    per_seed = seed_scores(runs, keys)
    out = {}
    for key, group in per_seed.groupby(list(keys), sort=True, dropna=False):
        out[key if isinstance(key, tuple) else (key,)] = Score.of(group["score"], group["seed"])
    return out


def task_mean(runs: pd.DataFrame, tasks: Sequence[tuple[str, str]]) -> Score | None:
    """Mean over ``tasks`` per seed, then mean ± s.e. over the seeds that have all of them.

    Args:
        runs: runs of one cell except for the task (one method, one setting).
        tasks: the (domain, task) pairs to average over.

    Returns:
        the score, or None when no seed has a result for every task.

    Examples:
        >>> runs = pd.DataFrame({"domain": ["a", "b", "a", "b", "a"], "task": ["x"] * 5,
        ...                      "seed": [0, 0, 1, 1, 2], "score": [1.0, 3.0, 5.0, 7.0, 100.0]})
        >>> s = task_mean(runs, [("a", "x"), ("b", "x")])   # seed 2 lacks task b
        >>> s.values, s.seeds
        ((2.0, 6.0), (0, 1))
    """
    tasks = list(tasks)
    if not tasks or runs.empty:
        return None
    scores: dict[int, dict[tuple[str, str], list[float]]] = defaultdict(lambda: defaultdict(list))
    for seed, domain, task, score in zip(runs["seed"], runs["domain"], runs["task"], runs["score"]):
        scores[int(seed)][(domain, task)].append(float(score))
    complete = sorted(seed for seed, per_task in scores.items() if all(t in per_task for t in tasks))
    if not complete:
        return None
    values = [float(np.mean([np.mean(scores[seed][t]) for t in tasks])) for seed in complete]
    return Score.of(values, complete)


def z_p_value(best_mean: float, best_stderr: float, mean: float, stderr: float) -> float:
    """One-sided p-value that the best mean is higher: ``1 - Phi((m_best - m) / sqrt(se_best^2 + se^2))``.

    Returns NaN when either standard error is NaN (a single seed: no test); 0 or 1 when both are
    zero (the difference is certain).

    Examples:
        >>> round(z_p_value(63, 24, 28, 11), 4)   # the paper's finger spin, medium dynamic: not bold
        0.0925
        >>> z_p_value(2, 0, 1, 0), z_p_value(2, 0, 2, 0), z_p_value(2, float("nan"), 1, 1)
        (0.0, 1.0, nan)
    """
    if math.isnan(best_stderr) or math.isnan(stderr):
        return math.nan
    scale = math.hypot(best_stderr, stderr)
    if scale == 0:
        return 0.0 if best_mean > mean else 1.0
    return float(stats.norm.sf((best_mean - mean) / scale))


def better_p_value(best: Score | Estimate, other: Score | Estimate) -> float:
    """:func:`z_p_value` of two cells (NaN when either has a single seed).

    Examples:
        >>> better_p_value(Score.of([10, 11, 12]), Score.of([1, 2, 3])) < 1e-20
        True
        >>> better_p_value(Score.of([2, 2]), Score.of([1, 1])), better_p_value(Score.of([2, 2]), Score.of([2, 2]))
        (0.0, 1.0)
    """
    return z_p_value(best.mean, best.stderr, other.mean, other.stderr)


def bold_flags(scores: Mapping[object, Score | Estimate | None], alpha: float = ALPHA) -> dict[object, bool]:
    """Which cells are bold: the highest mean, and every cell not significantly below it.

    "Significantly below" means :func:`better_p_value` < ``alpha`` against the reference, the
    cell with the highest mean (with most seeds among equal highest means). Cells whose mean
    equals the highest (ties) are bold; a cell with one seed, or compared against a reference
    with one seed, is not testable and is not bold; missing cells (None) are not bold.

    Args:
        scores: one Score, Estimate (published mean ± s.e.) or None per row of a table column.
        alpha: significance level (the paper's p < 0.1).

    Examples:
        >>> flags = bold_flags({"a": Score.of([10, 11, 12]), "b": Score.of([9, 12, 13]),
        ...                     "c": Score.of([1, 2, 3]), "d": None})
        >>> flags
        {'a': True, 'b': True, 'c': False, 'd': False}
        >>> bold_flags({"SAC+RAD": Estimate(63, 24), "SAC+DrQ": Estimate(15, 7), "QT-Opt": Estimate(28, 11)})
        {'SAC+RAD': True, 'SAC+DrQ': False, 'QT-Opt': False}
        >>> bold_flags({"a": Estimate(500, 20), "b": Estimate(480, 10)})   # p = 0.19
        {'a': True, 'b': True}
    """
    present = {k: s for k, s in scores.items() if s is not None}
    flags = {k: False for k in scores}
    if not present:
        return flags
    # the reference: the highest mean; among tied highest means the one with most seeds (testable)
    best_key = max(present, key=lambda k: (present[k].mean, present[k].n))
    best = present[best_key]
    for key, score in present.items():
        if math.isclose(score.mean, best.mean, rel_tol=1e-12, abs_tol=1e-12):
            flags[key] = True
            continue
        p = better_p_value(best, score)
        flags[key] = bool(p >= alpha)  # NaN (untestable) compares False
    return flags
