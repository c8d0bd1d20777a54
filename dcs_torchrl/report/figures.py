"""Figures (matplotlib's Agg canvas, no pyplot state, PNG): score vs intensity curves and benchmark bars.

- :func:`curves_figure`: one panel per sweep of the experiment (the paper's Figs. 4-5, then any sweep
  beyond the paper the curves hold: lighting β_light, textures β_tex); x the intensity, y the mean
  score over tasks; one colour per method, static solid, dynamic dashed, shaded ± s.e.; with several
  tasks, a row of panels per task under the mean's.
- :func:`benchmark_figure`: per benchmark (none / easy / medium / blind) one bar per method with
  its s.e.; a black star at the expected score if the degradations were independent (no-
  distraction score × product of the single-distraction relative scores, the paper's Figs. 6-7);
  the paper's means as hollow diamonds (over the same tasks as the bars when the run's tasks are not
  exactly the paper's six) and its expected scores (over its six tasks, the only ones it publishes) as
  hollow stars. The legend names only the markers drawn (:func:`benchmark_markers`).
"""
from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from dcs_torchrl.methods import METHODS as REGISTRY
from dcs_torchrl.report.curves import ALL_TASKS, BLEND_2021, curve_tasks, with_defaults
from dcs_torchrl.report.experiments import BENCHMARK_ORDER, METHODS, TASK_ORDER, experiment_panels
from dcs_torchrl.report.markdown import fmt_value
from dcs_torchrl.report.paper import MEAN_DOMAIN
from dcs_torchrl.report.tables import is_paper_task_set, setting_name, task_columns, tasks_text

__all__ = ["METHOD_COLORS", "curves_figure", "benchmark_figure"]

# One colour per method, the same in every figure: the augmented methods as in the paper's
# text (QT-Opt blue/green, SAC orange/pink), the plain ones in muted tones. Keyed by the
# registry's (algorithm, augmentation): the method names live in dcs_torchrl.methods only.
_PALETTE = {
    ("sac", "none"): "#8c564b", ("sac", "rad"): "#ff7f0e", ("sac", "drq"): "#e377c2",
    ("qtopt", "none"): "#7f7f7f", ("qtopt", "rad"): "#1f77b4", ("qtopt", "drq"): "#2ca02c",
}
METHOD_COLORS = MappingProxyType({m.name: _PALETTE[m.algo, m.aug] for m in REGISTRY.values()})
LINESTYLES = MappingProxyType({False: "-", True: "--"})
BLEND_MARKERS = MappingProxyType({"paper": "o", BLEND_2021: "x"})
YLABEL = "mean episode return over tasks"


def _method_handles(methods) -> list:
    return [Line2D([], [], color=METHOD_COLORS[m], lw=2.5, label=m) for m in methods]


def curves_figure(curves: pd.DataFrame, experiment: str, path: str | Path, note: str = "",
                  spread: str = "mean ± s.e. over seeds", axes_shown: Sequence[str] | None = None,
                  num_videos: int = 60) -> Path:
    """Score vs intensity, one panel per sweep of ``experiment``, saved as a PNG; with several
    tasks (the ``task`` column), the mean over them on the first row, then a row per task.

    Args:
        curves: :func:`~dcs_torchrl.report.curves.curve_table` of the experiment.
        experiment: ``robustness`` or ``training``.
        path: the PNG to write.
        note: a line under the title (e.g. that the backgrounds are stand-in videos).
        spread: what the line and its band are, in the title.
        axes_shown: only the panels of these axes (default: every panel of the paper's experiment,
            then those beyond the paper that ``curves`` holds: lighting, textures).
        num_videos: the b of the background-blend panels' label (the paper's: 60).
    """
    curves = with_defaults(curves)
    found = set(curves["axis"]) if "axis" in curves else set()
    panels = [p for p in experiment_panels(experiment, found | set(axes_shown or ()))
              if axes_shown is None or p.axis in axes_shown]
    tasks = curve_tasks(curves) if len(curves) else [ALL_TASKS]
    # room for the legend under one panel; the title and legend take the same height whatever the rows
    fig = Figure(figsize=(4.2 * max(len(panels), 2), 1.0 + 3.0 * len(tasks)))
    axes = fig.subplots(len(tasks), len(panels), squeeze=False)
    methods = [m for m in METHODS if m in set(curves["method"])]
    n_tasks = int(curves["n_tasks"].max()) if len(curves) else 0
    for i, (row, task) in enumerate(zip(axes, tasks)):
        for ax, panel in zip(row, panels):
            mine = curves[(curves.axis == panel.axis) & (curves.eval_split == panel.eval_split) & (curves.task == task)]
            label = panel.xlabel.replace("(b = 60 videos)", f"(b = {num_videos} videos)") if i == len(tasks) - 1 else None
            _draw_curves(ax, mine, panel, title=panel.title if i == 0 else None, xlabel=label)
        if task == ALL_TASKS:
            row[0].set_ylabel(YLABEL.replace("tasks", f"{n_tasks} tasks") if n_tasks > 1 else "mean episode return")
        else:
            row[0].set_ylabel(f"{task}\nmean episode return")
    drawn = sorted({bool(d) for d in curves["dynamic"].dropna()}) if len(curves) else [False, True]
    styles = [Line2D([], [], color="k", ls=LINESTYLES[d], label="dynamic" if d else "static") for d in drawn]
    if (curves["blend"] == BLEND_2021).any():
        styles += [Line2D([], [], color="k", marker=BLEND_MARKERS[b], ms=5, lw=0, label=label)
                   for b, label in (("paper", "blend as the paper"), (BLEND_2021, "blend as the 2021 code"))]
    handles = _method_handles(methods) + styles
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), frameon=False, fontsize=10)
    titles = {"robustness": "Trained without distractions, evaluated with one distraction",
              "training": "Trained and evaluated with one distraction"}
    title = _suptitle(fig, f"{titles.get(experiment, experiment)} ({spread})", note)
    _tight_layout(fig, title, bottom=0.4 / fig.get_figheight())
    return _save(fig, path)


def _draw_curves(ax, mine: pd.DataFrame, panel, title: str | None, xlabel: str | None) -> None:
    """One panel of :func:`curves_figure`: its curves (one task's, or the mean's) over the panel's axis."""
    values = sorted(set(mine["value"]))
    for (dynamic, method, blend), g in mine.groupby(["dynamic", "method", "blend"], sort=False):
        g = g.set_index("value").reindex(values)  # a missing point breaks the line instead of bridging it
        x = np.asarray(values, float)
        y, se = g["mean"].to_numpy(float), np.nan_to_num(g["stderr"].to_numpy(float))
        color = METHOD_COLORS[method]
        ax.plot(x, y, LINESTYLES[bool(dynamic)], color=color, lw=1.8, marker=BLEND_MARKERS.get(blend, "o"),
                ms=3 if blend != BLEND_2021 else 5)
        ax.fill_between(x, y - se, y + se, color=color, alpha=0.15, lw=0)
    if panel.axis == "num_videos":
        ax.set_xscale("symlog", linthresh=1)
        ticks = [v for v in panel.values]
        ax.set_xticks(ticks, [fmt_value(v) for v in ticks])
        ax.minorticks_off()
    if title:
        ax.set_title(title, fontsize=11)
    if xlabel:
        ax.set_xlabel(xlabel)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if mine.empty:
        ax.text(0.5, 0.5, "no results", transform=ax.transAxes, ha="center", va="center", color="0.4")
        ax.set_yticks([])


def benchmark_figure(tables: pd.DataFrame, interactions: pd.DataFrame, dynamic: bool, path: str | Path,
                     note: str = "") -> Path:
    """Bars per benchmark and method for one setting, with expected-score stars and paper markers.

    Args:
        tables: concatenated :func:`~dcs_torchrl.report.tables.benchmark_table` frames.
        interactions: :func:`~dcs_torchrl.report.interactions.interactions_table`.
        dynamic: the setting to plot (the no-distraction benchmark appears in both).
        path: the PNG to write.
        note: a line under the title (e.g. that the backgrounds are stand-in videos).
    """
    means = tables[(tables.domain == MEAN_DOMAIN) & (tables.dynamic.isna() | (tables.dynamic == dynamic))]
    benchmarks = [b for b in BENCHMARK_ORDER if b in set(means["benchmark"])]
    benchmarks += sorted(set(means["benchmark"]) - set(benchmarks))
    inter = interactions[interactions.dynamic == dynamic]
    columns = task_columns(tables)
    subset = not is_paper_task_set(columns)
    paper_label = f"paper: mean over the same {tasks_text(len(columns))}" if subset else "paper: mean"
    # the paper publishes its relative scores (so its expected score) over its six tasks only
    expected_label = f"paper: expected, over its {len(TASK_ORDER)} tasks" if subset else "paper: expected"
    width = 0.8 / len(METHODS)
    fig = Figure(figsize=(10, 4.8))
    ax = fig.subplots()
    any_missing = drew_expected = drew_paper_expected = False
    for i, method in enumerate(METHODS):
        m = means[means.method == method].set_index("benchmark").reindex(benchmarks)
        x = np.arange(len(benchmarks)) + (i - (len(METHODS) - 1) / 2) * width
        have = m["mean"].notna().to_numpy()
        any_missing |= not have.all()
        mean, stderr = m["mean"].to_numpy(float), m["stderr"].to_numpy(float)
        ax.bar(x[have], mean[have], width, color=METHOD_COLORS[method])
        spread = have & np.isfinite(stderr)  # one seed has no standard error: no bar rather than a zero one
        ax.errorbar(x[spread], mean[spread], yerr=stderr[spread], fmt="none", ecolor="k", capsize=2, lw=0.8)
        ax.scatter(x[~have], np.zeros((~have).sum()), marker="x", s=18, color="0.55", lw=1, zorder=3, clip_on=False)
        ax.scatter(x, m["paper_same_tasks"], marker="D", s=28, facecolors="none", edgecolors="k", lw=1, zorder=3)
        rows = inter[inter.method == method].set_index("difficulty")
        for j, b in enumerate(benchmarks):
            if b in rows.index:
                expected = rows.at[b, "expected"]
                ax.scatter(x[j], expected, marker="*", s=110, color="k", zorder=4)
                paper_none = m.at["none", "paper_mean"] if "none" in m.index else np.nan
                paper_expected = paper_none * rows.at[b, "paper_product"]
                ax.scatter(x[j], paper_expected, marker="*", s=110, facecolors="none", edgecolors="k", lw=0.8, zorder=4)
                drew_expected |= bool(np.isfinite(expected))
                drew_paper_expected |= bool(np.isfinite(paper_expected))
    ax.set_xticks(np.arange(len(benchmarks)), benchmarks)
    ax.set_xlabel("benchmark (none: no distraction; blind: medium with the camera turned away)")
    ax.set_ylabel(YLABEL)
    ax.set_ylim(bottom=0)
    ax.grid(axis="y", alpha=0.3)
    # over the whole figure, legend included: a long note would be cut off over the axes alone
    title = _suptitle(fig, f"Benchmarks, {setting_name(dynamic)} setting: mean ± s.e. over seeds", note)
    handles = [Patch(color=METHOD_COLORS[m], label=m) for m in METHODS] + benchmark_markers(
        expected=drew_expected, paper_expected=drew_paper_expected, missing=any_missing,
        paper_label=paper_label, expected_label=expected_label)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    _tight_layout(fig, title)
    return _save(fig, path)


def benchmark_markers(*, expected: bool, paper_expected: bool, missing: bool, paper_label: str,
                      expected_label: str) -> list[Line2D]:
    """The legend's marker entries of :func:`benchmark_figure`: only those of markers it drew.

    The expected-score stars need the interactions experiment's runs (each distraction alone at the
    benchmark's level); a study without them draws none and its legend names none.
    """
    entries = [
        (expected, Line2D([], [], marker="*", color="k", ls="", ms=11, label="expected (independent degradations)")),
        (paper_expected, Line2D([], [], marker="*", color="k", mfc="none", ls="", ms=11, label=expected_label)),
        (True, Line2D([], [], marker="D", color="k", mfc="none", ls="", ms=6, label=paper_label)),
        (missing, Line2D([], [], marker="x", color="0.55", ls="", ms=6, label="no results")),
    ]
    return [entry for drawn, entry in entries if drawn]


def _suptitle(fig: Figure, title: str, note: str):
    """``title`` with ``note`` on its own lines under it, wrapped to the figure's width (12-point text)."""
    lines = [title] + textwrap.wrap(note, int(11 * fig.get_figwidth()))
    return fig.suptitle("\n".join(lines), fontsize=12)


def _tight_layout(fig: Figure, title, bottom: float = 0.0) -> None:
    """``fig.tight_layout`` above ``bottom`` (figure fraction), then the panels moved down where
    their own titles would run into a ``title`` of several lines (tight_layout leaves too little room)."""
    fig.tight_layout(rect=(0, bottom, 1, 1))
    to_fig = fig.transFigure.inverted()
    title_bottom = to_fig.transform((0, title.get_window_extent().y0))[1]
    axes_top = max(to_fig.transform((0, ax.get_tightbbox().y1))[1] for ax in fig.axes)
    overlap = axes_top - title_bottom + 0.1 / fig.get_figheight()
    if overlap > 0:
        fig.subplots_adjust(top=fig.subplotpars.top - overlap)


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=120)
    return path
