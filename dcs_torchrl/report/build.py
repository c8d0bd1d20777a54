"""Build the whole report: tables (markdown + CSV), figures (PNG) and ``report.md`` linking them.

Layout of ``out``::

    report.md                     summary, skipped files, runs left out, missing cells, links
    runs.csv                      the tidy runs table (one row per run in the report)
    left_out.csv                  runs of another training length or evaluation count (if any)
    left_out_videos.csv           runs on older stand-in videos than their method's on that task (if any)
    tables/benchmark_<b>.md|csv   b in none, easy, medium, blind (+ any other benchmark found)
    tables/interactions.md|csv
    tables/<exp>_curves.md|csv, tables/<exp>_half_score.csv   exp in robustness, training
    figures/benchmarks_static.png, figures/benchmarks_dynamic.png
    figures/robustness.png, figures/training.png
"""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np
import pandas as pd

from dcs_torchrl.report import curves as curves_mod
from dcs_torchrl.report.experiments import METHODS, TASK_ORDER
from dcs_torchrl.report.figures import benchmark_figure, curves_figure
from dcs_torchrl.report.interactions import interactions_markdown, interactions_missing, interactions_table
from dcs_torchrl.report.load import Loaded, load_results
from dcs_torchrl.report.markdown import fmt_score, md_table, seed_counts
from dcs_torchrl.report.missing import expected_tasks, missing_cells
from dcs_torchrl.report.paper import MEAN_DOMAIN
from dcs_torchrl.report.select import select, tasks_of
from dcs_torchrl.report.tables import (BOLD_FOOTNOTE, benchmark_markdown, benchmark_names, benchmark_table,
                                       is_paper_task_set, setting_name, settings_of)

__all__ = ["REPORTED", "Report", "build_report"]

# The paper's experiments (Stone et al. 2021, Sec. 5), in the order of the report.
REPORTED = ("benchmarks", "interactions", "robustness", "training")
TITLES = {
    "benchmarks": "Benchmarks (Stone et al. 2021, Sec. 5.3: Tables 2-4 and Figs. 6-7)",
    "interactions": "Interactions of distractions (Stone et al. 2021, Sec. 5.3: Table 5)",
    "robustness": "Robustness at inference (Stone et al. 2021, Sec. 5.1: Fig. 4)",
    "training": "Training with distractions (Stone et al. 2021, Sec. 5.2: Fig. 5)",
}


@dataclass
class Report:
    """What :func:`build_report` wrote.

    Attributes:
        out: the output directory.
        loaded: the runs and skipped files.
        files: every file written, relative to ``out``.
        missing: per experiment, the lines describing missing cells.
    """

    out: Path
    loaded: Loaded
    files: list[str] = field(default_factory=list)
    missing: dict[str, list[str]] = field(default_factory=dict)


class _Writer:
    def __init__(self, report: Report):
        self.report = report

    def text(self, rel: str, text: str) -> str:
        path = self.report.out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        self.report.files.append(rel)
        return rel

    def csv(self, rel: str, frame: pd.DataFrame) -> str:
        return self.text(rel, frame.to_csv(index=False))

    def done(self, rel: str) -> str:
        self.report.files.append(rel)
        return rel


def _values(column: pd.Series) -> str:
    """``400``, or ``400 (3 runs), 800 (1 runs)`` when the runs differ (plain runs only)."""
    counts = column.value_counts().sort_index()
    if len(counts) == 1:
        return str(int(counts.index[0]))
    return ", ".join(f"{int(v)} ({n} runs)" for v, n in counts.items())


def _summary(runs: pd.DataFrame) -> str:
    rows = []
    for experiment, g in runs.groupby(runs["experiment"].fillna("null (plain runs, in no table)"), sort=True):
        rows.append([experiment, str(len(g)), str(g["method"].nunique()), str(len(tasks_of(g))),
                     str(g["seed"].nunique()), _values(g["steps"]), _values(g["episodes"])])
    if not rows:
        return "No runs."
    return md_table(["Experiment", "Runs", "Methods", "Tasks", "Seeds", "Steps", "Eval episodes"], rows, "lrrrrrr")


def _left_out_md(loaded: Loaded, w: _Writer) -> list[str]:
    """What was left out for another ``(steps, eval.episodes)`` than the report's; writes left_out.csv."""
    md = ["## Runs left out: another training length or evaluation count", ""]
    if loaded.budget is None:
        return md + ["None (no runs of an experiment).", ""]
    steps, episodes = loaded.budget
    used = f"`steps` = {steps} and `eval.episodes` = {episodes}"
    if loaded.left_out.empty:
        return md + [f"None: every run of an experiment has {used}.", ""]
    w.csv("left_out.csv", loaded.left_out)
    md += [f"Tables and figures use only runs with {used} (the most runs); runs of an experiment with another "
           "training length or number of evaluation episodes are left out, never averaged in or compared "
           "([left_out.csv](left_out.csv)):", ""]
    for (s, e), g in loaded.left_out.groupby(["steps", "episodes"], sort=True):
        per_experiment = ", ".join(f"{x} {n}" for x, n in g["experiment"].value_counts().sort_index().items())
        md.append(f"- `steps` = {s}, `eval.episodes` = {e}: {len(g)} runs ({per_experiment})")
    return md + [""]


def _older_videos_md(loaded: Loaded, w: _Writer) -> list[str]:
    """The runs left out for older stand-in videos (:func:`~dcs_torchrl.report.load.newest_stand_ins`)."""
    md = ["## Runs left out: older stand-in videos", ""]
    older = loaded.older_videos
    if older.empty:
        return md + ["None: no method's runs of a task mix versions of the stand-in videos.", ""]
    w.csv("left_out_videos.csv", older)
    md += ["Where one method's runs of a task in an experiment showed several versions of the embedded "
           "stand-in videos, only those of the newest version are used; the others are left out, never "
           "averaged in ([left_out_videos.csv](left_out_videos.csv)):", ""]
    for (x, m, d, t, b), g in older.groupby(["experiment", "method", "domain", "task", "backgrounds"], sort=True):
        md.append(f"- {x}, {m}, {d} {t}: {len(g)} runs on {b.removeprefix('stand-in ')}")
    return md + [""]


def _shown_path(results_dir: str | Path, out: Path) -> str:
    """The results directory relative to the report's directory (never a machine's absolute path)."""
    try:
        return Path(os.path.relpath(Path(results_dir).resolve(), out.resolve())).as_posix()
    except ValueError:  # another drive (Windows)
        return Path(results_dir).name


STAND_IN = ("Backgrounds: the embedded stand-in videos, not DAVIS 2017 — background results are not "
            "comparable to the paper's")


def _stand_in(runs: pd.DataFrame) -> pd.Series:
    return runs["backgrounds"].str.startswith("stand-in") if "backgrounds" in runs else pd.Series(False, runs.index)


def stand_in_note(runs: pd.DataFrame) -> str:
    """:data:`STAND_IN` if any of ``runs`` trained or evaluated on the embedded stand-in videos, else ``""``;
    it names the versions of the videos when the runs saw more than one."""
    versions = sorted(set(runs.loc[_stand_in(runs), "backgrounds"])) if len(runs) else []
    if not versions:
        return ""
    if len(versions) > 1:
        return STAND_IN + f"; the runs mix versions of them ({', '.join(v.removeprefix('stand-in ') for v in versions)})"
    return STAND_IN + f" ({versions[0].removeprefix('stand-in ')})"


def _stand_in_md(runs: pd.DataFrame) -> list[str]:
    note = stand_in_note(runs)
    if not note:
        return []
    return [f"**{note}** ({int(_stand_in(runs).sum())} runs of this section).", ""]


def _missing_md(lines: list[str]) -> list[str]:
    return ["### Missing", ""] + ([f"- {line}" for line in lines] or ["Nothing missing."]) + [""]


def _benchmarks(runs: pd.DataFrame, inter: pd.DataFrame, w: _Writer) -> list[str]:
    tasks = tasks_of(select(runs, experiment="benchmarks"))
    frames = []
    md = [f"Mean over {len(tasks)} tasks: " + ", ".join(f"{d} {t}" for d, t in tasks) + ".", ""]
    links = []
    for benchmark in benchmark_names(runs):
        tables = [benchmark_table(runs, benchmark, d, tasks) for d in settings_of(benchmark)]
        frames += tables
        name = f"tables/benchmark_{benchmark}"
        w.text(f"{name}.md", benchmark_markdown(tables, f"Benchmark `{benchmark}`"))
        w.csv(f"{name}.csv", pd.concat(tables, ignore_index=True))
        links.append(f"[{benchmark}]({name}.md) ([csv]({name}.csv))")
    md += ["Tables: " + ", ".join(links), ""]
    all_tables = pd.concat(frames, ignore_index=True)
    means = all_tables[all_tables.domain == MEAN_DOMAIN]
    columns = [(b, d) for b in benchmark_names(runs) for d in settings_of(b)]
    annotate, note = seed_counts(means["n"])
    rows = []
    for method in METHODS:
        cells = [method]
        for b, d in columns:
            r = means[(means.method == method) & (means.benchmark == b) & (means.dynamic.isna() if d is None
                                                                               else means.dynamic == d)].iloc[0]
            mine = fmt_score(None if np.isnan(r["mean"]) else r["mean"], r["stderr"],
                             int(r["n"]) if annotate else None, bool(r["bold"]))
            paper = "" if np.isnan(r["paper_mean"]) else f" ({r['paper_mean']:.0f})"
            cells.append(mine + paper)
        rows.append(cells)
    header = ["Method"] + [f"{b} {setting_name(d)}".strip() for b, d in columns]
    caveat = "" if is_paper_task_set(tasks) else (
        f" — this run's mean is over {len(tasks)} tasks, the paper's over {len(TASK_ORDER)}: not comparable")
    md += [f"Mean over tasks, this run (the paper's mean in brackets{caveat}):", "", md_table(header, rows), ""]
    md += [note, ""] if note else []
    md += [BOLD_FOOTNOTE, ""]
    for dynamic in (False, True):
        rel = w.done(str(benchmark_figure(all_tables, inter, dynamic,
                                          w.report.out / f"figures/benchmarks_{setting_name(dynamic)}.png",
                                          note=stand_in_note(select(runs, experiment="benchmarks")))
                         .relative_to(w.report.out)))
        md += [f"![benchmarks, {setting_name(dynamic)}]({rel})", ""]
    return md


def _interactions(runs: pd.DataFrame, inter: pd.DataFrame, w: _Writer) -> tuple[list[str], list[str]]:
    text = interactions_markdown(inter)
    w.text("tables/interactions.md", text)
    w.csv("tables/interactions.csv", inter)
    body = ("\n" + text.split("\n", 2)[2]).replace("\n## ", "\n### ")  # without the title, one level down
    missing = interactions_missing(runs, expected_tasks(runs))
    return ["Table: [interactions](tables/interactions.md) ([csv](tables/interactions.csv))", body], missing


def _curves(runs: pd.DataFrame, experiment: str, w: _Writer) -> list[str]:
    curves = curves_mod.curve_table(runs, experiment)
    half = curves_mod.half_score_table(curves)
    name = f"tables/{experiment}_curves"
    w.text(f"{name}.md", curves_mod.curves_markdown(curves, experiment))
    w.csv(f"{name}.csv", curves)
    w.csv(f"tables/{experiment}_half_score.csv", half)
    fig = w.done(str(curves_figure(curves, experiment, w.report.out / f"figures/{experiment}.png",
                                   note=stand_in_note(select(runs, experiment=experiment)))
                     .relative_to(w.report.out)))
    return [f"Tables: [curves]({name}.md) ([csv]({name}.csv)), "
            f"[half-score points](tables/{experiment}_half_score.csv)", "", f"![{experiment}]({fig})", "",
            "Where each method loses half its score:", "", curves_mod.half_score_markdown(half), ""]


_STDERR = object()  # resolved when called, so that a redirected sys.stderr is honoured


def build_report(results_dir: str | Path, out: str | Path, experiment: str | None = None,
                 *, log: TextIO | None = _STDERR) -> Report:
    """Loads every ``results.json`` under ``results_dir`` and writes the report into ``out``.

    Args:
        results_dir: directory searched recursively for ``results.json``.
        out: output directory (created).
        experiment: report only this experiment (one of :data:`REPORTED`); all runs are still
            loaded, since the interactions table reads the training and benchmarks sweeps.
        log: where skipped files are listed (default ``sys.stderr``; None: nowhere).

    Raises:
        ValueError: unknown ``experiment``.
        FileNotFoundError: ``results_dir`` does not exist.
    """
    if experiment is not None and experiment not in REPORTED:
        raise ValueError(f"unknown experiment {experiment!r} (expected one of {', '.join(REPORTED)})")
    loaded = load_results(results_dir)
    log = sys.stderr if log is _STDERR else log
    if log is not None:
        for s in loaded.skipped:
            print(f"skipped {s.path}: {s.reason}", file=log)
        for (s, e), g in loaded.left_out.groupby(["steps", "episodes"], sort=True):
            print(f"left out {len(g)} runs with steps={s}, eval.episodes={e} (the report uses "
                  f"steps={loaded.budget[0]}, eval.episodes={loaded.budget[1]})", file=log)
        if len(loaded.older_videos):
            print(f"left out {len(loaded.older_videos)} runs on older stand-in videos than their method's "
                  "other runs of the same task (report.md lists them)", file=log)
    report = Report(out=Path(out), loaded=loaded)
    report.out.mkdir(parents=True, exist_ok=True)
    w = _Writer(report)
    runs = loaded.runs
    w.csv("runs.csv", runs)
    inter = interactions_table(runs, expected_tasks(runs))
    md = ["# Distracting Control Suite: results report", "",
          f"Results directory: `{_shown_path(results_dir, report.out)}` (relative to this report) — {len(runs)} "
          f"runs loaded, {loaded.n_left_out} left out, {len(loaded.skipped)} files skipped "
          "([all runs](runs.csv)).", "", *_stand_in_md(runs), _summary(runs), "", "## Skipped files", ""]
    md += [f"- `{s.path}`: {s.reason}" for s in loaded.skipped] or ["None."]
    md.append("")
    md += _left_out_md(loaded, w)
    md += _older_videos_md(loaded, w)
    for name in REPORTED if experiment is None else (experiment,):
        md += [f"## {TITLES[name]}", ""]
        if name == "interactions":
            body, missing = _interactions(runs, inter, w)
            md += _stand_in_md(runs[runs["experiment"].isin(["benchmarks", "training"])])
            md += body
            report.missing[name] = missing
            md += _missing_md(missing)
            continue
        if select(runs, experiment=name).empty:
            md += [f"No results for experiment `{name}`.", ""]
        else:
            md += _stand_in_md(select(runs, experiment=name))
            md += _benchmarks(runs, inter, w) if name == "benchmarks" else _curves(runs, name, w)
        report.missing[name] = missing_cells(runs, name)
        md += _missing_md(report.missing[name])
    md += ["## How the numbers are computed", "", BOLD_FOOTNOTE,
           "See `docs/report.md` in the dcs-torchrl repository for the details.", ""]
    w.text("report.md", "\n".join(md))
    return report
