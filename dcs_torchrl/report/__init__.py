"""Tables and figures of the Distracting Control Suite paper from ``results.json`` files.

``python -m dcs_torchrl.report <results dir> [--out DIR] [--experiment NAME]`` or::

    from dcs_torchrl.report import build_report
    build_report("outputs/multirun", "outputs/report")

Modules: :mod:`~.load` (read and validate), :mod:`~.stats` (seeds, mean over tasks, bold),
:mod:`~.tables` (benchmark tables), :mod:`~.interactions`, :mod:`~.curves`, :mod:`~.figures`,
:mod:`~.missing`, :mod:`~.paper` (the published numbers), :mod:`~.build` (everything).
"""
from dcs_torchrl.report.build import REPORTED, Report, build_report
from dcs_torchrl.report.curves import curve_table, half_score_table
from dcs_torchrl.report.interactions import interactions_table
from dcs_torchrl.report.load import Loaded, Skipped, load_results
from dcs_torchrl.report.paper import paper_benchmarks, paper_interactions, paper_notes
from dcs_torchrl.report.stats import Score, bold_flags, task_mean
from dcs_torchrl.report.tables import benchmark_table

__all__ = [
    "REPORTED",
    "Report",
    "build_report",
    "curve_table",
    "half_score_table",
    "interactions_table",
    "Loaded",
    "Skipped",
    "load_results",
    "paper_benchmarks",
    "paper_interactions",
    "paper_notes",
    "Score",
    "bold_flags",
    "task_mean",
    "benchmark_table",
]
