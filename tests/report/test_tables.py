"""Benchmark tables from a synthetic results directory whose table is known exactly."""
import math

import pytest
from synthetic_results import write_run

from dcs_torchrl.report.experiments import TASK_ORDER
from dcs_torchrl.report.load import load_results
from dcs_torchrl.report.tables import benchmark_markdown, benchmark_table

A, B = ("cartpole", "swingup"), ("cheetah", "run")
# method -> task -> per-seed scores (seed i gets the i-th value); QT-Opt has no cartpole run.
EASY_STATIC = {
    "QT-Opt+RAD": {A: [300, 310, 320], B: [100, 110, 120]},
    "QT-Opt+DrQ": {A: [295, 305, 315], B: [10, 20, 30]},
    "SAC": {A: [100, 101, 102], B: [200, 200, 200]},
    "SAC+RAD": {A: [310], B: [5]},
    "SAC+DrQ": {A: [309], B: [200, 200]},
    "QT-Opt": {B: [190, 190, 190]},
}


@pytest.fixture
def table(results_dir):
    for method, per_task in EASY_STATIC.items():
        for (domain, task), scores in per_task.items():
            for seed, score in enumerate(scores):
                write_run(results_dir, score, method=method, domain=domain, task=task, seed=seed, value="easy")
    # another setting and another experiment must not leak into the easy static table
    write_run(results_dir, 999.0, method="SAC", domain="cartpole", task="swingup", value="easy", dynamic=True)
    write_run(results_dir, 999.0, method="SAC", domain="cartpole", task="swingup", experiment="interactions")
    runs = load_results(results_dir).runs
    return benchmark_table(runs, "easy", False, [A, B]).set_index(["method", "task"])


def test_cells_are_mean_and_stderr_over_seeds(table):
    r = table.loc[("QT-Opt+RAD", "swingup")]
    assert (r["mean"], r["stderr"], r["n"]) == (310.0, pytest.approx(10 / math.sqrt(3)), 3)
    assert table.loc[("SAC", "swingup"), "mean"] == 101.0
    assert math.isnan(table.loc[("SAC+RAD", "swingup"), "stderr"])
    assert math.isnan(table.loc[("QT-Opt", "swingup"), "mean"]) and table.loc[("QT-Opt", "swingup"), "n"] == 0


def test_mean_over_tasks_uses_each_seeds_task_average(table):
    r = table.loc[("QT-Opt+RAD", "mean")]
    assert (r["mean"], r["n"]) == (210.0, 3)  # seeds: (300+100)/2, (310+110)/2, (320+120)/2
    assert r["stderr"] == pytest.approx(10 / math.sqrt(3))
    assert table.loc[("SAC", "mean"), "mean"] == pytest.approx(150.5)
    assert (table.loc[("SAC+DrQ", "mean"), "mean"], table.loc[("SAC+DrQ", "mean"), "n"]) == (254.5, 1)  # seed 0
    assert math.isnan(table.loc[("QT-Opt", "mean"), "mean"])  # no cartpole run at all


def test_bold_per_column(table):
    bold = lambda task: sorted(m for (m, t), b in table["bold"].items() if t == task and b)  # noqa: E731
    # cartpole: best 310 (3 seeds); 305 ± 5.8 is not significantly below; the single seed 310 ties;
    # the single seed 309 cannot be tested; 101 is far below
    assert bold("swingup") == ["QT-Opt+DrQ", "QT-Opt+RAD", "SAC+RAD"]
    # cheetah: 200 with zero variance (two methods tie); 190 with zero variance is certainly below
    assert bold("run") == ["SAC", "SAC+DrQ"]
    # mean: the single-seed SAC+DrQ has the highest mean, so no other cell can be tested
    assert bold("mean") == ["SAC+DrQ"]


def test_paper_numbers_are_alongside(table):
    r = table.loc[("QT-Opt+RAD", "mean")]
    assert (r["paper_mean"], r["paper_stderr"], r["paper_bold"]) == (317.0, 8.0, True)
    assert table.loc[("SAC", "run"), "paper_mean"] == 64.0
    # two of the paper's six tasks: its score to compare with is its mean over the same two
    assert r["paper_same_tasks"] == pytest.approx((446 + 220) / 2)
    assert table.loc[("SAC", "run"), "paper_same_tasks"] == 64.0


def test_markdown_shows_bold_seed_counts_missing_and_the_paper(table):
    md = benchmark_markdown([table.reset_index()], "Benchmark `easy`")
    lines = md.splitlines()
    assert "| QT-Opt+RAD | 210 ± 6 (n=3) | **310 ± 6** (n=3) | 110 ± 6 (n=3) |" in lines
    assert "| SAC+RAD | 158 (n=1) | **310** (n=1) | 5 (n=1) |" in lines  # single seed: no standard error
    assert "| QT-Opt | — | — | 190 ± 0 (n=3) |" in lines  # missing cells
    assert "| QT-Opt+RAD | **317 ± 8** | **446 ± 23** | **220 ± 5** |" in lines  # the paper's row, its bold
    # two of six tasks: the ratio is to the paper's mean over the same two (446 and 220), not to 317
    assert "This run's 2 tasks are not the paper's 6" in md
    assert "| static | QT-Opt+RAD | 210 ± 6 (n=3) | 317 ± 8 | 333 | 0.63 |" in lines
    assert "one-sided z-test on mean ± s.e." in md


def test_no_distraction_table_pools_static_and_dynamic(results_dir):
    write_run(results_dir, 100.0, value="none", dynamic=False, seed=0)
    write_run(results_dir, 300.0, value="none", dynamic=True, seed=0)  # the same seed, both flags
    write_run(results_dir, 500.0, value="none", dynamic=False, seed=1)
    table = benchmark_table(load_results(results_dir).runs, "none", True, [("cheetah", "run")])
    r = table.set_index(["method", "task"]).loc[("SAC", "run")]
    assert (r["mean"], r["n"], r["dynamic"]) == (350.0, 2, None)  # seed 0 counts once, as 200


def test_markdown_with_every_task_compares_with_the_papers_mean(results_dir):
    for domain, task in TASK_ORDER:
        write_run(results_dir, 317.0 * 0.5, method="QT-Opt+RAD", domain=domain, task=task, value="easy")
    table = benchmark_table(load_results(results_dir).runs, "easy", False, list(TASK_ORDER))
    md = benchmark_markdown([table], "Benchmark `easy`")
    assert "same tasks" not in md and "tasks: its mean is compared" not in md
    assert "| static | QT-Opt+RAD | 158 | 317 ± 8 | 0.50 |" in md.splitlines()
    assert table.loc[table.domain == "all", "paper_same_tasks"].equals(table.loc[table.domain == "all", "paper_mean"])


def test_six_tasks_that_are_not_the_papers_are_compared_task_by_task(results_dir):
    tasks = [*TASK_ORDER[:5], ("cheetah", "walk")]  # five of the paper's and one it did not run
    for domain, task in tasks:
        write_run(results_dir, 100.0, method="QT-Opt+RAD", domain=domain, task=task, value="easy")
    table = benchmark_table(load_results(results_dir).runs, "easy", False, tasks)
    mean = table[(table.method == "QT-Opt+RAD") & (table.domain == "all")].iloc[0]
    assert mean["paper_mean"] == 317.0 and math.isnan(mean["paper_same_tasks"])  # no paper score for one task
    md = benchmark_markdown([table], "Benchmark `easy`")
    assert "This run's 6 tasks are not the paper's 6" in md
    assert "| static | QT-Opt+RAD | 100 | 317 ± 8 | — | — |" in md.splitlines()
