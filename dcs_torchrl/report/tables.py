"""The paper's benchmark tables (no distraction, easy, medium, blind): per task and mean.

Rows are methods, columns the mean over tasks and each task; cells "mean ± s.e." over seeds
with the bold rule of :mod:`dcs_torchrl.report.stats`. Each table has the paper's published
numbers beside it (``paper_*`` columns in the CSV, a second table in the markdown).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from dcs_torchrl.report.experiments import BENCHMARK_ORDER, METHODS, SEEDS, TASK_ORDER, task_label
from dcs_torchrl.report.markdown import MISSING, fmt_score, md_table, seed_counts
from dcs_torchrl.report.paper import MEAN_DOMAIN, MEAN_TASK, paper_benchmarks
from dcs_torchrl.report.select import select
from dcs_torchrl.report.stats import ALPHA, Score, bold_flags, task_mean

__all__ = [
    "BENCHMARK_COLUMNS",
    "BOLD_FOOTNOTE",
    "settings_of",
    "is_paper_task_set",
    "task_columns",
    "tasks_text",
    "benchmark_table",
    "benchmark_markdown",
    "setting_name",
    "benchmark_names",
]

EXPERIMENT = "benchmarks"
BENCHMARK_COLUMNS = (
    "benchmark", "dynamic", "method", "domain", "task", "mean", "stderr", "n", "bold",
    "paper_mean", "paper_stderr", "paper_bold", "paper_same_tasks",
)

BOLD_FOOTNOTE = (
    f"Mean ± standard error over seeds (the paper: {SEEDS} seeds; `(n=k)` marks a cell with another "
    "count, a single seed has no standard error). **Bold**: the highest mean, and every result not "
    f"significantly below it at p < {ALPHA:g} by a one-sided z-test on mean ± s.e. "
    "(z = (best − mean) / √(s.e.best² + s.e.²), p = 1 − Φ(z): the rule that reproduces every bold mark "
    "of the paper's tables); results with a single seed have no standard error, cannot be tested and "
    "are bold only if they have the highest mean. Mean: per seed, the "
    "mean over the tasks of the table, then mean ± s.e. over the seeds that have every task."
)


def is_paper_task_set(tasks: Sequence[tuple[str, str]]) -> bool:
    """Whether ``tasks`` are exactly the paper's six, so that a mean over them compares with its mean."""
    return {tuple(t) for t in tasks} == set(TASK_ORDER)


def task_columns(table: pd.DataFrame) -> list[tuple[str, str]]:
    """The ``(domain, task)`` columns of benchmark tables, in order, without the mean."""
    rows = table.loc[table.domain != MEAN_DOMAIN, ["domain", "task"]].drop_duplicates()
    return [tuple(r) for r in rows.itertuples(index=False)]


def tasks_text(n: int) -> str:
    """``"1 task"`` / ``"6 tasks"``."""
    return f"{n} task" + "s" * (n != 1)


def settings_of(benchmark: str) -> tuple[bool | None, ...]:
    """The settings a benchmark is reported in: none has one, the others static and dynamic.

    Examples:
        >>> settings_of("none"), settings_of("easy")
        ((None,), (False, True))
    """
    return (None,) if benchmark == "none" else (False, True)


def setting_name(dynamic: bool | None) -> str:
    """``static`` / ``dynamic`` / ``""`` (the no-distraction benchmark has no setting)."""
    return "" if dynamic is None else ("dynamic" if dynamic else "static")


def _paper_lookup(benchmark: str, dynamic: bool | None) -> dict[tuple[str, str, str], pd.Series]:
    df = paper_benchmarks()
    df = df[df.benchmark == benchmark]
    if dynamic is not None:
        df = df[df.dynamic == dynamic]
    return {(r.method, r.domain, r.task): r for r in df.itertuples()}


def benchmark_table(runs: pd.DataFrame, benchmark: str, dynamic: bool | None,
                    tasks: Sequence[tuple[str, str]]) -> pd.DataFrame:
    """One benchmark table in tidy form: a row per method and column (the mean, then each task).

    Args:
        runs: the runs table; rows of experiment ``benchmarks`` are used.
        benchmark: ``none``, ``easy``, ``medium`` or ``blind``.
        dynamic: the setting (ignored for ``none``).
        tasks: the task columns (the mean is taken over them).

    Returns:
        columns :data:`BENCHMARK_COLUMNS`; the mean over tasks has ``domain="all", task="mean"``;
        a missing cell has NaN ``mean`` and ``n = 0``. ``paper_same_tasks`` is the paper's score to
        compare with: its published mean, or, when ``tasks`` are not exactly its six, the mean of its
        per-task scores over ``tasks`` (NaN if one of them is not published).
    """
    dynamic = None if benchmark == "none" else dynamic
    rows = select(runs, experiment=EXPERIMENT, axis="benchmark", value=benchmark, dynamic=dynamic)
    paper = _paper_lookup(benchmark, dynamic)
    columns = [(MEAN_DOMAIN, MEAN_TASK)] + list(tasks)
    records = []
    for domain, task in columns:
        scores: dict[str, Score | None] = {}
        for method in METHODS:
            mine = rows[rows.method == method]
            if domain == MEAN_DOMAIN:
                scores[method] = task_mean(mine, tasks)
            else:
                per_seed = mine[(mine.domain == domain) & (mine.task == task)].groupby("seed")["score"].mean()
                scores[method] = Score.of(per_seed.values, per_seed.index) if len(per_seed) else None
        bold = bold_flags(scores)
        for method in METHODS:
            s, p = scores[method], paper.get((method, domain, task))
            records.append({
                "benchmark": benchmark, "dynamic": dynamic, "method": method, "domain": domain, "task": task,
                "mean": s.mean if s else math.nan, "stderr": s.stderr if s else math.nan, "n": s.n if s else 0,
                "bold": bold[method],
                "paper_mean": float(p.mean) if p is not None else math.nan,
                "paper_stderr": float(p.stderr) if p is not None else math.nan,
                "paper_bold": bool(p.bold) if p is not None else None,
            })
    table = pd.DataFrame.from_records(records, columns=list(BENCHMARK_COLUMNS))
    # The paper's score to set beside this run's: per task its own, for the mean its published mean
    # if the table has all of its tasks, else the mean of its per-task scores over the table's tasks.
    table["paper_same_tasks"] = table["paper_mean"]
    if not is_paper_task_set(tasks):
        per_task = table[table.domain != MEAN_DOMAIN].groupby("method", sort=False)["paper_mean"]
        same = per_task.agg(lambda v: v.mean() if len(v) and not v.isna().any() else math.nan)
        is_mean = table.domain == MEAN_DOMAIN
        table.loc[is_mean, "paper_same_tasks"] = table.loc[is_mean, "method"].map(same).to_numpy(float)
    return table


def _grid(table: pd.DataFrame, prefix: str, annotate: bool) -> list[list[str]]:
    out = []
    for method, group in table.groupby("method", sort=False):
        cells = []
        for r in group.itertuples():
            mean, se, bold = getattr(r, f"{prefix}mean"), getattr(r, f"{prefix}stderr"), getattr(r, f"{prefix}bold")
            n = r.n if prefix == "" and annotate else None
            cells.append(fmt_score(None if np.isnan(mean) else mean, se, n, bool(bold)))
        out.append([method] + cells)
    return out


def benchmark_markdown(tables: Sequence[pd.DataFrame], title: str) -> str:
    """Markdown for one benchmark: this run's tables (one per setting), then the paper's.

    Args:
        tables: frames from :func:`benchmark_table`, one per setting.
        title: heading of the section.
    """
    first = tables[0]
    header = ["Method"] + ["Mean" if d == MEAN_DOMAIN else task_label(d, t)
                           for d, t in first[["domain", "task"]].drop_duplicates().itertuples(index=False)]
    annotate, note = seed_counts(pd.concat(tables)["n"])
    parts = [f"# {title}", ""]
    for source, prefix in (("This run", ""), ("Paper (Stone et al., 2021)", "paper_")):
        for table in tables:
            setting = setting_name(table["dynamic"].iloc[0])
            parts.append(f"## {source}" + (f" — {setting} setting" if setting else ""))
            parts.append("")
            if prefix and table["paper_mean"].isna().all():
                parts += ["Not published as numbers.", ""]
                continue
            if not prefix and (table["n"] == 0).all():
                parts += ["No results.", ""]
                continue
            parts += [md_table(header, _grid(table, prefix, annotate)), ""]
            if not prefix and note:
                parts += [note, ""]
    parts.append("## Mean over tasks: this run vs paper")
    parts.append("")
    columns = task_columns(first)
    n_tasks, subset = len(columns), not is_paper_task_set(columns)
    rows = []
    for table in tables:
        setting = setting_name(table["dynamic"].iloc[0]) or "—"
        for r in table[table.domain == MEAN_DOMAIN].itertuples():
            mine = fmt_score(None if np.isnan(r.mean) else r.mean, r.stderr, r.n if annotate else None)
            paper = fmt_score(None if np.isnan(r.paper_mean) else r.paper_mean, r.paper_stderr)
            row = [setting, r.method, mine, paper]
            reference = r.paper_same_tasks
            if subset:
                row.append(MISSING if np.isnan(reference) else f"{reference:.0f}")
            ratio = r.mean / reference if reference and not np.isnan(r.mean) else math.nan
            rows.append(row + [MISSING if np.isnan(ratio) else f"{ratio:.2f}"])
    header = ["Setting", "Method", "This run", f"Paper ({len(TASK_ORDER)} tasks)"]
    if subset:
        verb = "are" if n_tasks > 1 else "is"
        parts += [f"This run's {tasks_text(n_tasks)} {verb} not the paper's {len(TASK_ORDER)}: its mean is "
                  "compared with the mean of the paper's per-task scores on the same tasks, not with the "
                  "paper's mean.", ""]
        header += [f"Paper, same {tasks_text(n_tasks)}"]
    header += ["This run / paper" + (" (same tasks)" if subset else "")]
    parts += [md_table(header, rows, "llr" + "r" * (len(header) - 3)), ""]
    parts += [BOLD_FOOTNOTE, ""]
    return "\n".join(parts)


def benchmark_names(runs: pd.DataFrame) -> list[str]:
    """The paper's benchmarks, then any other benchmark name found in the ``benchmarks`` runs."""
    found = set(select(runs, experiment=EXPERIMENT, axis="benchmark")["value"])
    return list(BENCHMARK_ORDER) + sorted(found - set(BENCHMARK_ORDER))
