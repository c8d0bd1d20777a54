"""The interactions table (Stone et al. 2021, Sec. 5.3, Table 5: "Interactions of distracting effects").

Per method, difficulty (easy / medium) and setting (static / dynamic): the relative score of
each distraction alone (its mean over tasks divided by the no-distraction mean over tasks),
their product (the score expected if the degradations were independent), whether the product
is above (">") or below ("<") the relative score of the combined benchmark, and that
benchmark's relative score.

Inputs, each taken from the first experiment that has it (never pooled across experiments):

- camera β / colour β / b videos alone, trained and evaluated with them: ``interactions``,
  else ``training`` (the paper uses its Fig. 5 runs);
- the combined benchmark and the no-distraction reference: ``interactions``, else ``benchmarks``.

All inputs of a row are averaged over the same tasks: those present in every input that has
runs (an input without any run is reported missing and leaves its relative score empty).
"""
from __future__ import annotations

import math

import pandas as pd

from dcs_torchrl.report.experiments import INTERACTION_DIFFICULTIES, METHODS, single_distraction_settings
from dcs_torchrl.report.markdown import MISSING, fmt_ratio, fmt_value, md_table
from dcs_torchrl.report.missing import no_runs_text
from dcs_torchrl.report.paper import paper_interactions
from dcs_torchrl.report.select import first_source, tasks_of
from dcs_torchrl.report.stats import task_mean
from dcs_torchrl.report.tables import setting_name

__all__ = ["SINGLE_SOURCES", "BENCHMARK_SOURCES", "INPUTS", "INTERACTION_COLUMNS", "interactions_table",
           "interactions_missing", "interactions_markdown", "compare"]

SINGLE_SOURCES = ("interactions", "training")
BENCHMARK_SOURCES = ("interactions", "benchmarks")
# Table column -> sweep axis of the single-distraction runs.
INPUTS = {"camera": "camera", "color": "color", "background": "num_videos"}
RELATIVE = ("camera", "color", "background", "product", "comparison", "benchmark")
INTERACTION_COLUMNS = (
    "dynamic", "difficulty", "method", *RELATIVE, "none_mean", "benchmark_mean", "expected", "n_tasks",
    "missing", *(f"paper_{c}" for c in RELATIVE),
)


def compare(product: float, benchmark: float) -> str:
    """``">"`` if the product is above the benchmark's relative score, ``"<"`` if below.

    Compared unrounded; ``"="`` only for exact equality, ``""`` if either is missing.

    Examples:
        >>> compare(0.24, 0.22), compare(0.1, 0.3), compare(0.2, 0.2), compare(float("nan"), 0.1)
        ('>', '<', '=', '')
    """
    if math.isnan(product) or math.isnan(benchmark):
        return ""
    return ">" if product > benchmark else "<" if product < benchmark else "="


def _inputs(runs: pd.DataFrame, difficulty: str, dynamic: bool, method: str) -> dict[str, tuple[str, pd.DataFrame]]:
    """name -> (description, runs) for the five inputs of one row."""
    single = single_distraction_settings(difficulty)
    out = {}
    _, rows = first_source(runs, BENCHMARK_SOURCES, axis="benchmark", value="none", method=method)
    out["none"] = ("no distraction", rows)
    for column, axis in INPUTS.items():
        value = single[axis]
        _, rows = first_source(runs, SINGLE_SOURCES, axis=axis, value=value, dynamic=dynamic,
                               eval_split="train", method=method)
        out[column] = (f"{axis} {fmt_value(value)}", rows)
    _, rows = first_source(runs, BENCHMARK_SOURCES, axis="benchmark", value=difficulty, dynamic=dynamic, method=method)
    out["benchmark"] = (f"benchmark {difficulty}", rows)
    return out


def _rows(runs: pd.DataFrame):
    """(dynamic, difficulty, method, paper row or None, inputs) for every row of the table."""
    paper = {(r.method, r.difficulty, bool(r.dynamic)): r for r in paper_interactions().itertuples()}
    for dynamic in (False, True):
        for difficulty in INTERACTION_DIFFICULTIES:
            for method in METHODS:
                inputs = _inputs(runs, difficulty, dynamic, method)
                p = paper.get((method, difficulty, dynamic))
                if p is None and all(rows.empty for _, rows in inputs.values()):
                    continue
                yield dynamic, difficulty, method, p, inputs


def _lacking(inputs: dict, tasks: list[tuple[str, str]]) -> list[tuple[str, tuple]]:
    """(input description, tasks it has no run for) for every incomplete input."""
    out = []
    for what, rows in inputs.values():
        have = set(zip(rows["domain"], rows["task"]))
        lacking = tuple(t for t in tasks if t not in have)
        if lacking:
            out.append((what, lacking))
    return out


def interactions_table(runs: pd.DataFrame, expected_tasks: list[tuple[str, str]] | None = None) -> pd.DataFrame:
    """The interactions table, one row per (setting, difficulty, method), with the paper's values.

    Rows: the paper's rows plus any method with at least one input in ``runs``.

    Args:
        runs: the runs table.
        expected_tasks: the tasks a complete row has (default: the tasks found in ``runs``).

    Returns:
        columns :data:`INTERACTION_COLUMNS`: relative scores (NaN when an input is missing),
        ``expected`` = ``none_mean`` × ``product``, ``n_tasks`` the tasks averaged over,
        ``missing`` which inputs lack which tasks.
    """
    expected_tasks = expected_tasks if expected_tasks is not None else tasks_of(runs)
    records = []
    for dynamic, difficulty, method, p, inputs in _rows(runs):
        present = [set(zip(rows["domain"], rows["task"])) for _, rows in inputs.values() if len(rows)]
        # an input without any run is missing on its own, it does not empty the row
        common = set(expected_tasks).intersection(*present) if present else set()
        tasks = [t for t in expected_tasks if t in common]
        means = {k: task_mean(rows, tasks) for k, (_, rows) in inputs.items()}
        means = {k: (s.mean if s is not None else math.nan) for k, s in means.items()}
        none = means["none"]
        rel = {k: (means[k] / none if none > 0 else math.nan) for k in (*INPUTS, "benchmark")}
        product = rel["camera"] * rel["color"] * rel["background"]
        record = {
            "dynamic": dynamic, "difficulty": difficulty, "method": method,
            **{k: rel[k] for k in INPUTS}, "product": product,
            "comparison": compare(product, rel["benchmark"]), "benchmark": rel["benchmark"],
            "none_mean": none, "benchmark_mean": means["benchmark"], "expected": none * product,
            "n_tasks": len(tasks),
            "missing": "; ".join(f"{what}: {no_runs_text(lacking, expected_tasks)}"
                                 for what, lacking in _lacking(inputs, expected_tasks)),
        }
        for c in RELATIVE:
            record[f"paper_{c}"] = getattr(p, c) if p is not None else (math.nan if c != "comparison" else "")
        records.append(record)
    return pd.DataFrame.from_records(records, columns=list(INTERACTION_COLUMNS))


def interactions_missing(runs: pd.DataFrame, expected_tasks: list[tuple[str, str]]) -> list[str]:
    """Lines describing the missing inputs of the interactions table, grouped over methods.

    Tasks with no run in any input are named once; then one line per (setting, difficulty,
    input, lacking tasks) lists the methods concerned.
    """
    rows = list(_rows(runs))
    seen = set()
    for *_, inputs in rows:
        for _, r in inputs.values():
            seen |= set(zip(r["domain"], r["task"]))
    tasks = [t for t in expected_tasks if t in seen]
    lines = []
    absent = [t for t in expected_tasks if t not in seen]
    if absent and seen:
        lines.append("no input has runs for " + ", ".join(f"{d} {t}" for d, t in absent))
    if not seen:
        return ["no runs for any input of the table"]
    grouped: dict[tuple, list[str]] = {}
    for dynamic, difficulty, method, _, inputs in rows:
        if all(r.empty for _, r in inputs.values()):
            grouped.setdefault((setting_name(dynamic), difficulty, None, None), []).append(method)
            continue
        for what, lacking in _lacking(inputs, tasks):
            grouped.setdefault((setting_name(dynamic), difficulty, what, lacking), []).append(method)
    for (setting, difficulty, what, lacking), methods in grouped.items():
        text = "no input has runs" if what is None else f"{what}: {no_runs_text(lacking, tasks)}"
        lines.append(f"{difficulty}, {setting} — {text} ({', '.join(methods)})")
    return lines


def interactions_markdown(table: pd.DataFrame) -> str:
    """Markdown: this run's interactions table, then the paper's, with a footnote."""
    header = ["Setting", "Difficulty", "Method", "Camera", "Color", "Backgr.", "Product", "", "Benchmark"]
    n_tasks = int(table["n_tasks"].max()) if len(table) else 0
    parts = ["# Interactions of distracting effects", "", f"This run: relative scores over {n_tasks} tasks.", ""]
    for source, prefix in (("This run", ""), ("Paper (Stone et al., 2021)", "paper_")):
        rows = []
        for r in table.itertuples():
            if prefix and not r.paper_comparison:
                continue
            cells = [fmt_ratio(getattr(r, f"{prefix}{c}")) for c in ("camera", "color", "background", "product")]
            comparison = getattr(r, f"{prefix}comparison") or MISSING
            method = r.method
            if not prefix and 0 < r.n_tasks < n_tasks:
                method += f" ({r.n_tasks} tasks)"
            rows.append([setting_name(r.dynamic), r.difficulty, method, *cells, comparison,
                         fmt_ratio(getattr(r, f"{prefix}benchmark"))])
        parts += [f"## {source}", "", md_table(header, rows, "lllrrrrcr") if rows else "No rows.", ""]
    parts.append(
        "Scores relative to the no-distraction score (mean over tasks with the distraction / mean over "
        "tasks without). Camera, Color: that distraction alone at the benchmark's scale (easy 0.1, "
        "medium 0.2); Backgr.: the benchmark's number of training videos alone (easy 4, medium 8), "
        "trained and evaluated with it. Product: their product, the relative score expected if the "
        "degradations were independent; `>` when it is above the combined benchmark's relative score "
        "(the distractions compound). A row averaged over fewer tasks than the others says how many."
    )
    return "\n".join(parts) + "\n"
