"""Score vs distraction intensity (experiments ``robustness`` and ``training``; Stone et al. 2021, Secs. 5.1-5.2, Figs. 4-5).

Each point is the mean over tasks (per seed, then mean ± s.e. over seeds, as in the tables)
of one method at one intensity in one setting; with several tasks, each task's own curve comes
too (column ``task``: :data:`ALL_TASKS` for the mean, else ``<domain>-<task>``). The half-score
table gives the first intensity at which a method's score is at most half its score at
intensity 0, beside the paper's statements ("top methods lose half their score at β_cam = 0.2,
β_rgb = 0.6, β_bg < 0.1"). The sweeps beyond the paper (lighting β_light, textures β_tex:
:data:`~dcs_torchrl.report.experiments.BEYOND_PAPER`) come after the paper's panels where the runs hold
them, and their rows say "beyond the paper" where the paper's statement would be.
"""
from __future__ import annotations

import math

import pandas as pd

from dcs_torchrl.report.experiments import BEYOND_PAPER_AXES, METHODS, Panel, experiment_panels
from dcs_torchrl.report.markdown import MISSING, fmt_score, fmt_value, md_table, seed_counts
from dcs_torchrl.report.paper import paper_notes
from dcs_torchrl.report.select import select, tasks_of
from dcs_torchrl.report.stats import task_mean
from dcs_torchrl.report.tables import setting_name

__all__ = ["ALL_TASKS", "BEYOND_PAPER_TEXT", "BLEND_2021", "CURVE_COLUMNS", "beyond_paper_note", "blend_suffix",
           "curve_table", "curve_tasks", "half_score_table", "half_score_markdown", "curves_markdown", "paper_text",
           "with_defaults"]

CURVE_COLUMNS = ("experiment", "axis", "eval_split", "dynamic", "method", "value", "mean", "stderr", "n", "n_tasks",
                 "blend", "task")

#: The ``task`` of a curve that is the mean over every task of the experiment.
ALL_TASKS = "mean"


#: The ``blend`` of a curve whose background blend accumulates over episodes as in the 2021 code
#: (``reference_blend``); curves without a ``blend`` column, or with ``"paper"``, blend as the paper says.
BLEND_2021 = "2021 code"


#: What a half-score row of an axis beyond the paper (lighting, textures) shows where the paper's statement would be.
BEYOND_PAPER_TEXT = "beyond the paper"


def paper_text(axis: str, paper: str, missing: str = MISSING) -> str:
    """The paper column of a half-score row: the paper's statement, :data:`BEYOND_PAPER_TEXT` for an
    axis beyond the paper, else ``missing``.

    Examples:
        >>> paper_text("camera", "0.2"), paper_text("light", ""), paper_text("num_videos", "")
        ('0.2', 'beyond the paper', '—')
    """
    return paper or (BEYOND_PAPER_TEXT if axis in BEYOND_PAPER_AXES else missing)


def beyond_paper_note(axes) -> str:
    """A sentence saying which of ``axes`` are beyond the paper (empty where none is)."""
    beyond = [a for a in dict.fromkeys(axes) if a in BEYOND_PAPER_AXES]
    if not beyond:
        return ""
    return (f"{' and '.join(f'`{a}`' for a in beyond)}: beyond the paper (docs/lighting_textures.md), "
            "which states no half-score point for {}.".format("it" if len(beyond) == 1 else "them"))


def blend_suffix(blend: str = "paper") -> str:
    """What a row label adds for a curve of the 2021 code's blend."""
    return " (2021 blend)" if blend == BLEND_2021 else ""


def curve_tasks(curves: pd.DataFrame) -> list[str]:
    """The curves' ``task`` values, the mean first (a table without the column: one, the mean).

    Examples:
        >>> curve_tasks(pd.DataFrame({"task": ["cartpole-swingup", "mean", "ball_in_cup-catch", "mean"]}))
        ['mean', 'cartpole-swingup', 'ball_in_cup-catch']
    """
    if "task" not in curves:
        return [ALL_TASKS]
    found = list(dict.fromkeys(curves["task"]))
    return sorted(found, key=lambda t: t != ALL_TASKS)


def with_defaults(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with the columns older curve tables lack: ``blend`` ``"paper"``, ``task`` :data:`ALL_TASKS`.

    Examples:
        >>> sorted(with_defaults(pd.DataFrame({"value": [0.0]})).columns)
        ['blend', 'task', 'value']
    """
    return table.assign(**{c: d for c, d in (("blend", "paper"), ("task", ALL_TASKS)) if c not in table})


def task_suffix(task: str) -> str:
    """What a row label adds for one task's curve (nothing for the mean)."""
    return "" if task == ALL_TASKS else f" — {task}"


def panel_runs(runs: pd.DataFrame, experiment: str, panel: Panel, axis: str | None = None) -> pd.DataFrame:
    """The runs of one panel of an experiment (``axis``: another axis drawn in it, e.g. its ``blend_axis``)."""
    return select(runs, experiment=experiment, axis=axis or panel.axis, eval_split=panel.eval_split)


def curve_table(runs: pd.DataFrame, experiment: str) -> pd.DataFrame:
    """Every point of the experiment's curves that has a complete seed (all tasks).

    Args:
        runs: the runs table.
        experiment: ``robustness`` or ``training``.

    Returns:
        columns :data:`CURVE_COLUMNS`, sorted by panel, blend, task, setting, method, value. The
        ``task`` :data:`ALL_TASKS` rows are the mean over every task found in the experiment
        (``n_tasks``), so a point lacking a task is absent there; with more than one task, each
        task's own rows follow (``n_tasks`` 1). A panel's ``blend_axis`` runs are its curves with
        ``blend`` :data:`BLEND_2021`, under the panel's axis.
    """
    tasks = tasks_of(select(runs, experiment=experiment))
    variants = [(ALL_TASKS, tasks)] + ([(f"{d}-{t}", [(d, t)]) for d, t in tasks] if len(tasks) > 1 else [])
    records = []
    for panel in experiment_panels(experiment, set(select(runs, experiment=experiment)["axis"])):
        for axis, blend in ((panel.axis, "paper"), (panel.blend_axis, BLEND_2021)):
            if axis is None:
                continue
            rows = panel_runs(runs, experiment, panel, axis)
            groups = {key: g for key, g in rows.groupby(["dynamic", "method", "value"], sort=False)}
            for name, over in variants:
                for dynamic in (False, True):
                    for method in METHODS:
                        for value in sorted(v for d, m, v in groups if d == dynamic and m == method):
                            score = task_mean(groups[(dynamic, method, value)], over)
                            if score is None:
                                continue
                            records.append({"experiment": experiment, "axis": panel.axis,
                                            "eval_split": panel.eval_split, "dynamic": dynamic, "method": method,
                                            "value": value, "mean": score.mean, "stderr": score.stderr, "n": score.n,
                                            "n_tasks": len(over), "blend": blend, "task": name})
    return pd.DataFrame.from_records(records, columns=list(CURVE_COLUMNS))


def _paper_half(experiment: str, axis: str) -> str:
    if axis in BEYOND_PAPER_AXES:  # the paper's statements are about its own sweeps only
        return ""
    for note in paper_notes()["half_score"]:
        if note["experiment"] == experiment and note["axis"] == axis:
            return ("" if note["relation"] == "=" else note["relation"] + " ") + fmt_value(note["value"])
    return ""


def half_score_table(curves: pd.DataFrame) -> pd.DataFrame:
    """Per curve: the score at intensity 0 and the first intensity where it is at most half that.

    ``half_at`` is NaN when the curve never drops to half within its points; ``score_at_0``
    is NaN (and ``half_at`` too) when the curve has no point at 0.

    Examples:
        >>> curves = pd.DataFrame({"experiment": "robustness", "axis": "camera", "eval_split": "train",
        ...     "dynamic": False, "method": "SAC", "value": [0.0, 0.1, 0.2, 0.3], "mean": [800., 500., 400., 100.]})
        >>> half_score_table(curves)[["score_at_0", "half_at", "paper"]].to_dict("records")
        [{'score_at_0': 800.0, 'half_at': 0.2, 'paper': '0.2'}]
    """
    records = []
    keys = ["experiment", "axis", "eval_split", "dynamic", "method"] + [c for c in ("blend", "task") if c in curves]
    for key, group in curves.groupby(keys, sort=False):
        group = group.sort_values("value")
        at0 = group[group["value"] == 0]["mean"]
        start = float(at0.iloc[0]) if len(at0) else math.nan
        below = group[(group["value"] > 0) & (group["mean"] <= start / 2)]
        half = below["value"].iloc[0] if len(below) and not math.isnan(start) else math.nan
        records.append({**dict(zip(keys, key)), "score_at_0": start, "half_at": half,
                        "max_value": group["value"].max(), "paper": _paper_half(key[0], key[1])})
    return pd.DataFrame.from_records(records, columns=keys + ["score_at_0", "half_at", "max_value", "paper"])


def half_text(r) -> str:
    if math.isnan(r.score_at_0):
        return "no point at 0"
    return fmt_value(r.half_at) if not math.isnan(r.half_at) else f"> {fmt_value(r.max_value)}"


def curves_markdown(curves: pd.DataFrame, experiment: str) -> str:
    """Markdown: per panel a table of mean ± s.e. (rows method × setting, columns intensity),
    then where each method loses half its score."""
    parts = [f"# Experiment `{experiment}`: score vs intensity", ""]
    curves = with_defaults(curves)
    n_tasks = int(curves["n_tasks"].max()) if len(curves) else 0
    annotate, note = seed_counts(curves["n"])
    each = (" Rows marked `— <task>` are that task alone." if len(curve_tasks(curves)) > 1 else "")
    parts += [f"Mean over {n_tasks} tasks (per seed, then mean ± s.e. over seeds); `(n=k)` marks a seed "
              "count other than 5." + (f" {note}" if note else "") + each, ""]
    for panel in experiment_panels(experiment, set(curves["axis"])):
        mine = curves[(curves.axis == panel.axis) & (curves.eval_split == panel.eval_split)]
        parts += [f"## {panel.title} — {panel.text_xlabel}", ""]
        if mine.empty:
            parts += ["No results.", ""]
            continue
        values = sorted(set(mine["value"]))
        rows = []
        for (dynamic, method, blend, task), g in mine.groupby(["dynamic", "method", "blend", "task"], sort=False):
            by_value = {v: r for v, r in zip(g["value"], g.itertuples())}
            rows.append([f"{method} ({setting_name(dynamic)}){blend_suffix(blend)}{task_suffix(task)}"] + [
                fmt_score(by_value[v].mean, by_value[v].stderr, by_value[v].n if annotate else None)
                if v in by_value else MISSING
                for v in values])
        parts += [md_table(["Method (setting)"] + [fmt_value(v) for v in values], rows), ""]
    parts += ["## Where each method loses half its score", "", half_score_markdown(half_score_table(curves)), ""]
    return "\n".join(parts)


def half_score_markdown(half: pd.DataFrame) -> str:
    """A compact table of :func:`half_score_table`: rows axis × setting (× task, with a Task column
    when there are several), columns methods, and the paper's statement.

    Examples:
        >>> curves = pd.DataFrame({"experiment": "robustness", "axis": "camera", "eval_split": "train",
        ...     "dynamic": False, "method": "SAC", "value": [0.0, 0.1, 0.2], "mean": [800., 500., 300.]})
        >>> print(half_score_markdown(half_score_table(curves)).splitlines()[2])
        | camera | static | 0.2 | — | — | — | — | — | 0.2 |
    """
    if half.empty:
        return "No results."
    rows = []
    half = with_defaults(half)
    per_task = len(curve_tasks(half)) > 1
    for (axis, split, blend, task, dynamic), g in half.groupby(["axis", "eval_split", "blend", "task", "dynamic"],
                                                              sort=False):
        by_method = {r.method: half_text(r) for r in g.itertuples()}
        label = axis + ("" if split == "train" else " (unseen videos)") + blend_suffix(blend)
        rows.append([label, setting_name(dynamic)] + ([task] if per_task else [])
                    + [by_method.get(m, MISSING) for m in METHODS] + [paper_text(axis, g["paper"].iloc[0])])
    header = ["Axis", "Setting"] + (["Task"] if per_task else []) + [*METHODS, "Paper (top methods)"]
    table = md_table(header, rows, "ll" + "l" * per_task + "r" * (len(METHODS) + 1))
    beyond = beyond_paper_note(half["axis"])
    note = ("The first intensity whose mean score over tasks (task `mean`; else that task's score) is at most half "
            "the score at 0; `> x`: not within the sweep (up to x)." if per_task else "The first intensity whose mean "
            "score over tasks is at most half the score at 0; `> x`: not within the sweep (up to x).")
    return f"{table}\n\n{note}" + (f" {beyond}" if beyond else "")
