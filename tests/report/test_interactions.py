"""The interactions table: relative scores, their product, the comparison sign, missing inputs."""
import math

import pytest
from synthetic_results import write_run

from dcs_torchrl.report.interactions import interactions_markdown, interactions_missing, interactions_table
from dcs_torchrl.report.load import load_results

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
