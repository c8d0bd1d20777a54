"""The interactions table: relative scores, their product, the comparison sign, missing inputs."""
import math

import pytest
from synthetic_results import write_run

from dcs_torchrl.report.interactions import interactions_markdown, interactions_missing, interactions_table
from dcs_torchrl.report.load import load_results
from dcs_torchrl.report.paper import paper_interactions
from dcs_torchrl.report.tables import setting_name

TASKS = [("cartpole", "swingup"), ("cheetah", "run")]
# Scores per task (the same for seeds 0 and 1): mean over tasks 800 without distraction.
NONE = (1000.0, 600.0)


def _put(root, method, scale, *, experiment, axis, value, dynamic=False):
    for (domain, task), base in zip(TASKS, NONE):
        for seed in (0, 1):
            write_run(root, base * scale, method=method, domain=domain, task=task, seed=seed,
                      experiment=experiment, axis=axis, value=value, dynamic=dynamic)


@pytest.fixture
def runs(results_dir):
    for method, bench in (("QT-Opt+RAD", 0.2), ("SAC+RAD", 0.1), ("QT-Opt+DrQ", 0.3)):
        _put(results_dir, method, 1.0, experiment="benchmarks", axis="benchmark", value="none")
        _put(results_dir, method, 0.8, experiment="training", axis="camera", value=0.1)
        _put(results_dir, method, 0.5, experiment="training", axis="color", value=0.1)
        _put(results_dir, method, 0.4, experiment="training", axis="num_videos", value=4)
        _put(results_dir, method, bench, experiment="benchmarks", axis="benchmark", value="easy")
    # the interactions sweep's own camera runs take precedence over the training sweep's
    _put(results_dir, "QT-Opt+DrQ", 0.5, experiment="interactions", axis="camera", value=0.1)
    # SAC: everything but the camera input
    _put(results_dir, "SAC", 1.0, experiment="benchmarks", axis="benchmark", value="none")
    _put(results_dir, "SAC", 0.5, experiment="training", axis="color", value=0.1)
    _put(results_dir, "SAC", 0.4, experiment="training", axis="num_videos", value=4)
    _put(results_dir, "SAC", 0.3, experiment="benchmarks", axis="benchmark", value="easy")
    return load_results(results_dir).runs


@pytest.fixture
def table(runs):
    return interactions_table(runs, TASKS).set_index(["dynamic", "difficulty", "method"])


def test_relative_scores_product_and_comparison(table):
    r = table.loc[(False, "easy", "QT-Opt+RAD")]
    assert (r["camera"], r["color"], r["background"]) == pytest.approx((0.8, 0.5, 0.4))
    assert r["product"] == pytest.approx(0.16) and r["benchmark"] == pytest.approx(0.2)
    assert r["comparison"] == "<"  # combined is better than the product
    assert r["none_mean"] == 800.0 and r["expected"] == pytest.approx(128.0) and r["n_tasks"] == 2
    r = table.loc[(False, "easy", "SAC+RAD")]
    assert (r["product"], r["benchmark"], r["comparison"]) == (pytest.approx(0.16), pytest.approx(0.1), ">")


def test_interactions_sweep_takes_precedence(table):
    r = table.loc[(False, "easy", "QT-Opt+DrQ")]
    assert r["camera"] == pytest.approx(0.5) and r["product"] == pytest.approx(0.1)
    assert r["comparison"] == "<"


def test_missing_input_gives_no_product(table, runs):
    r = table.loc[(False, "easy", "SAC")]
    assert math.isnan(r["camera"]) and math.isnan(r["product"]) and r["comparison"] == ""
    assert r["color"] == pytest.approx(0.5)
    assert r["missing"] == "camera 0.1: no runs"
    lines = interactions_missing(runs, TASKS)
    assert "easy, static — camera 0.1: no runs (SAC)" in lines
    assert "easy, static — no input has runs (SAC+DrQ)" in lines  # a paper row without any run
    assert "easy, dynamic — benchmark easy: no runs (SAC, SAC+RAD, QT-Opt+RAD, QT-Opt+DrQ)" in lines


def test_paper_values_are_alongside(table):
    r = table.loc[(True, "easy", "QT-Opt+RAD")]
    assert (r["paper_camera"], r["paper_product"], r["paper_comparison"], r["paper_benchmark"]) == (
        0.80, 0.68, ">", 0.42)
    assert math.isnan(r["camera"])  # no dynamic runs in this directory
    assert (False, "easy", "QT-Opt") not in table.index  # not in the paper and no runs


def test_markdown_rows(table):
    md = interactions_markdown(table.reset_index()).splitlines()
    assert "| static | easy | QT-Opt+RAD | 0.80 | 0.50 | 0.40 | 0.16 | < | 0.20 |" in md
    assert "| static | easy | SAC | — | 0.50 | 0.40 | — | — | 0.30 |" in md
    assert "| static | medium | SAC+DrQ | 0.55 | 0.76 | 0.42 | 0.18 | > | 0.16 |" in md  # paper


def test_a_row_over_fewer_tasks_says_so(results_dir):
    _put(results_dir, "SAC+RAD", 1.0, experiment="benchmarks", axis="benchmark", value="none")
    for axis, value in (("camera", 0.1), ("color", 0.1), ("num_videos", 4)):
        _put(results_dir, "SAC+RAD", 0.5, experiment="training", axis=axis, value=value)
    _put(results_dir, "SAC+RAD", 0.1, experiment="benchmarks", axis="benchmark", value="easy")
    _put(results_dir, "QT-Opt+RAD", 1.0, experiment="benchmarks", axis="benchmark", value="none")
    for axis, value in (("camera", 0.1), ("color", 0.1), ("num_videos", 4)):
        _put(results_dir, "QT-Opt+RAD", 0.5, experiment="training", axis=axis, value=value)
    write_run(results_dir, 100.0, method="QT-Opt+RAD", domain="cheetah", task="run", value="easy")  # one task
    table = interactions_table(load_results(results_dir).runs, TASKS)
    r = table.set_index(["dynamic", "difficulty", "method"]).loc[(False, "easy", "QT-Opt+RAD")]
    assert r["n_tasks"] == 1 and r["benchmark"] == pytest.approx(100.0 / 600.0)
    assert r["missing"] == "benchmark easy: no runs for cartpole swingup"
    assert "| static | easy | QT-Opt+RAD (1 tasks) | 0.50 | 0.50 | 0.50 | 0.12 | < | 0.17 |" in (
        interactions_markdown(table).splitlines())


# The paper's interactions table (Stone et al. 2021, Sec. 5.3, "Interactions of distracting effects"),
# whole, as printed: (dynamic, difficulty, method) -> camera, color, background, product, comparison, benchmark.
PAPER_INTERACTIONS = {
    (False, "easy", "SAC+RAD"): (0.79, 0.74, 0.41, 0.24, ">", 0.22),
    (False, "easy", "SAC+DrQ"): (0.81, 1.01, 0.41, 0.33, ">", 0.21),
    (False, "easy", "QT-Opt+RAD"): (0.88, 0.92, 0.60, 0.48, ">", 0.39),
    (False, "easy", "QT-Opt+DrQ"): (0.91, 0.95, 0.59, 0.51, ">", 0.37),
    (False, "medium", "SAC+RAD"): (0.58, 0.64, 0.46, 0.17, ">", 0.14),
    (False, "medium", "SAC+DrQ"): (0.55, 0.76, 0.42, 0.18, ">", 0.16),
    (False, "medium", "QT-Opt+RAD"): (0.57, 0.92, 0.54, 0.28, ">", 0.20),
    (False, "medium", "QT-Opt+DrQ"): (0.61, 0.84, 0.54, 0.28, ">", 0.21),
    (True, "easy", "SAC+RAD"): (0.72, 0.80, 0.75, 0.43, ">", 0.32),
    (True, "easy", "SAC+DrQ"): (0.72, 1.02, 0.63, 0.46, ">", 0.25),
    (True, "easy", "QT-Opt+RAD"): (0.80, 0.97, 0.87, 0.68, ">", 0.42),
    (True, "easy", "QT-Opt+DrQ"): (0.84, 0.93, 0.83, 0.65, ">", 0.33),
    (True, "medium", "SAC+RAD"): (0.45, 0.71, 0.81, 0.26, ">", 0.11),
    (True, "medium", "SAC+DrQ"): (0.49, 0.69, 0.76, 0.26, ">", 0.11),
    (True, "medium", "QT-Opt+RAD"): (0.52, 0.91, 0.83, 0.39, ">", 0.13),
    (True, "medium", "QT-Opt+DrQ"): (0.54, 0.90, 0.79, 0.38, ">", 0.13),
}
PAPER_COLUMNS = ("camera", "color", "background", "product", "comparison", "benchmark")


def test_the_papers_interactions_table_is_loaded_cell_by_cell():
    """Every cell of the paper's table as the package's data holds it: a value in another column,
    row or setting fails here."""
    loaded = paper_interactions()
    assert len(loaded) == len(PAPER_INTERACTIONS)
    got = {(bool(r.dynamic), r.difficulty, r.method): tuple(getattr(r, c) for c in PAPER_COLUMNS)
           for r in loaded.itertuples()}
    assert got == PAPER_INTERACTIONS


def test_the_reports_table_shows_every_paper_cell_in_its_column(table):
    shown = {key: tuple(table.loc[key, f"paper_{c}"] for c in PAPER_COLUMNS) for key in PAPER_INTERACTIONS}
    assert shown == PAPER_INTERACTIONS
    paper_section = interactions_markdown(table.reset_index()).split("## Paper")[1]
    rows = {tuple(cell.strip() for cell in line.strip("|").split("|")) for line in paper_section.splitlines()
            if line.startswith("|") and "Method" not in line and set(line) - set("|:- ")}
    assert rows == {(setting_name(dynamic), difficulty, method, *(v if isinstance(v, str) else f"{v:.2f}" for v in cells))
                    for (dynamic, difficulty, method), cells in PAPER_INTERACTIONS.items()}
