"""What a results directory lacks against the paper's grid of an experiment.

The expected grid is every method × task × panel value × setting of
:data:`~dcs_torchrl.report.experiments.EXPERIMENTS` (plus any value or task found in the
results), each with :data:`~dcs_torchrl.report.experiments.SEEDS` seeds. The report lists
methods without any result, missing cells (grouped: one line per method, panel and setting
lists the missing values and which tasks they lack) and cells with fewer seeds.
"""
from __future__ import annotations

from collections import defaultdict

import pandas as pd

from dcs_torchrl.report.experiments import EXPERIMENTS, METHODS, SEEDS, TASK_ORDER, Panel
from dcs_torchrl.report.markdown import fmt_value
from dcs_torchrl.report.select import select, tasks_of

__all__ = ["missing_cells", "expected_tasks", "no_runs_text"]


def expected_tasks(runs: pd.DataFrame) -> list[tuple[str, str]]:
    """The paper's six tasks, then any other task found in ``runs``.

    Examples:
        >>> len(expected_tasks(pd.DataFrame({"domain": ["hopper"], "task": ["hop"]})))
        7
    """
    return list(TASK_ORDER) + [t for t in tasks_of(runs) if t not in TASK_ORDER]


def _settings(panel: Panel, value) -> tuple[bool | None, ...]:
    return (None,) if panel.axis == "benchmark" and value == "none" else (False, True)


def _panel_name(panel: Panel, dynamic: bool | None) -> str:
    name = panel.axis + (" (unseen videos)" if panel.eval_split == "val" else "")
    return name + ("" if dynamic is None else (", dynamic" if dynamic else ", static"))


def _task_text(tasks, all_tasks) -> str:
    return "all tasks" if set(tasks) == set(all_tasks) else ", ".join(f"{d} {t}" for d, t in tasks)


def no_runs_text(lacking, tasks) -> str:
    """``no runs`` when every task lacks, else ``no runs for <tasks>``.

    Examples:
        >>> no_runs_text([("a", "x")], [("a", "x")]), no_runs_text([("a", "x")], [("a", "x"), ("b", "y")])
        ('no runs', 'no runs for a x')
    """
    return "no runs" if set(lacking) >= set(tasks) else "no runs for " + _task_text(lacking, tasks)


def _methods_text(methods, present_methods) -> str:
    if len(methods) > 1 and set(methods) == set(present_methods):
        return "all methods"
    return ", ".join(methods)


def _grouped(cells: dict[tuple, list], present_methods, describe) -> list[str]:
    """(method, panel name, detail) -> values, regrouped as one line per (panel, detail, values)."""
    lines: dict[tuple, list[str]] = defaultdict(list)
    for (method, name, detail), values in cells.items():
        lines[(name, detail, tuple(values))].append(method)
    return [f"{_methods_text(methods, present_methods)} — {name}: {', '.join(fmt_value(v) for v in values)}: "
            f"{describe(detail)}" for (name, detail, values), methods in lines.items()]


def missing_cells(runs: pd.DataFrame, experiment: str) -> list[str]:
    """Lines (markdown list items, without the bullet) describing what ``experiment`` lacks.

    In order: methods without any result, tasks without any result, then cells missing some
    tasks and cells with fewer than 5 seeds, one line per sweep panel, setting and detail
    listing the values and the methods concerned ("all methods" when every method with
    results is).

    Args:
        runs: the runs table.
        experiment: ``robustness``, ``training`` or ``benchmarks``.

    Examples:
        >>> runs = pd.DataFrame(columns=["experiment", "method", "domain", "task", "axis", "value",
        ...                              "dynamic", "eval_split", "seed"])
        >>> missing_cells(runs, "benchmarks")[0]
        'SAC: no results in this experiment'
    """
    mine = select(runs, experiment=experiment)
    all_tasks = expected_tasks(mine)
    present_tasks = set(zip(mine["domain"], mine["task"]))
    tasks = [t for t in all_tasks if t in present_tasks]
    present_methods = [m for m in METHODS if (mine.method == m).any()]
    lines = [f"{m}: no results in this experiment" for m in METHODS if m not in present_methods]
    absent = [t for t in all_tasks if t not in present_tasks]
    if absent and present_methods:
        lines.append("no results in this experiment for " + _task_text(absent, all_tasks))
    gaps: dict[tuple, list] = defaultdict(list)  # (method, panel name, lacking tasks) -> values
    short: dict[tuple, list] = defaultdict(list)  # (method, panel name, ((task, n), ...)) -> values
    counts: set[int] = set()
    for panel in EXPERIMENTS[experiment]:
        rows = mine[(mine.axis == panel.axis) & (mine.eval_split == panel.eval_split)]
        values = list(panel.values) + sorted(set(rows["value"]) - set(panel.values), key=str)
        # (method, value, dynamic or None, (domain, task)) -> number of seeds
        setting = [None if _settings(panel, v) == (None,) else bool(d) for v, d in zip(rows["value"], rows["dynamic"])]
        rows = rows.assign(setting=pd.Series(setting, index=rows.index, dtype=object).map(str))
        seeds = {(method, value, None if setting == "None" else setting == "True", (domain, task)): n
                 for (method, value, setting, domain, task), n in
                 rows.groupby(["method", "value", "setting", "domain", "task"])["seed"].nunique().items()}
        counts |= set(seeds.values())
        for method in present_methods:
            for value in values:
                for dynamic in _settings(panel, value):
                    have = {t: seeds[key] for t in tasks if (key := (method, value, dynamic, t)) in seeds}
                    lacking = tuple(t for t in tasks if t not in have)
                    if lacking:
                        gaps[(method, _panel_name(panel, dynamic), lacking)].append(value)
                    few = tuple((t, have[t]) for t in tasks if t in have and have[t] < SEEDS)
                    if few:
                        short[(method, _panel_name(panel, dynamic), few)].append(value)
    lines += _grouped(gaps, present_methods, lambda lacking: no_runs_text(lacking, tasks))
    if len(counts) == 1 and short:
        n = counts.pop()
        lines.append(f"every result has {n} seed{'s' if n > 1 else ''} (the paper: {SEEDS})")
    else:
        lines += _grouped(short, present_methods, lambda few: f"fewer than {SEEDS} seeds: " + ", ".join(
            f"{d} {t} (n={n})" for (d, t), n in few))
    return lines
