"""The whole report from a synthetic sweep: every table and figure file, skipped files, missing cells."""
import subprocess
import sys

import matplotlib.image
import pandas as pd
import pytest
from synthetic_results import paper_base, write_run, write_sweep

from dcs_torchrl.report.__main__ import main
from dcs_torchrl.report.build import build_report
from dcs_torchrl.report.experiments import METHODS

TASKS = [("cartpole", "swingup"), ("cheetah", "run")]
TABLES = [f"tables/benchmark_{b}.{ext}" for b in ("none", "easy", "medium", "blind") for ext in ("md", "csv")] + [
    "tables/interactions.md", "tables/interactions.csv",
    "tables/robustness_curves.md", "tables/robustness_curves.csv", "tables/robustness_half_score.csv",
    "tables/training_curves.md", "tables/training_curves.csv", "tables/training_half_score.csv",
]
FIGURES = ["figures/benchmarks_static.png", "figures/benchmarks_dynamic.png", "figures/robustness.png",
           "figures/training.png"]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("results")
    write_sweep(root, methods=METHODS, tasks=TASKS, seeds=(0, 1), intensities=(0.0, 0.1, 0.2, 0.5, 1.0),
                num_videos=(0, 4, 8, 60), base=paper_base(), seed=0)
    (root / "broken").mkdir()
    (root / "broken" / "results.json").write_text("{")
    out = tmp_path_factory.mktemp("report")
    assert main([str(root), "--out", str(out)]) == 0
    return root, out


def test_every_table_and_figure_is_written(built):
    _, out = built
    for rel in TABLES + FIGURES + ["report.md", "runs.csv"]:
        assert (out / rel).is_file(), rel
    for rel in FIGURES:
        image = matplotlib.image.imread(out / rel)
        assert image.shape[0] >= 400 and image.shape[1] >= 900 and image.std() > 0.05, rel
    assert len(pd.read_csv(out / "runs.csv")) == 6 * 2 * 2 * (7 + 3 * 5 * 2 + 2 * 5 * 2 + 2 * 4 * 2)


def test_report_links_tables_figures_and_lists_the_skipped_file(built, capsys):
    _, out = built
    md = (out / "report.md").read_text()
    for rel in ["tables/benchmark_easy.md", "tables/interactions.md", "tables/robustness_curves.md"] + FIGURES:
        assert f"]({rel})" in md, rel
    assert "- `broken/results.json`: invalid JSON" in md
    assert "- no results in this experiment for ball_in_cup catch, finger spin, reacher easy, walker walk" in md
    assert "- every result has 2 seeds (the paper: 5)" in md
    assert "| QT-Opt+RAD |" in md and "Welch's one-sided t-test" in md


def test_skipped_files_go_to_stderr(tmp_path, capsys):
    write_run(tmp_path / "runs", 10.0)
    (tmp_path / "runs" / "bad").mkdir()
    (tmp_path / "runs" / "bad" / "results.json").write_text('{"schema": 1}')
    report = build_report(tmp_path / "runs", tmp_path / "out", "benchmarks")
    assert "skipped bad/results.json: missing key 'experiment'" in capsys.readouterr().err
    assert [s.path for s in report.loaded.skipped] == ["bad/results.json"]
    # --experiment: only that section; a partial sweep still says what is missing
    md = (tmp_path / "out" / "report.md").read_text()
    assert "## Benchmarks" in md and "## Robustness" not in md and "## Interactions" not in md
    assert "- SAC+RAD: no results in this experiment" in md
    assert "- SAC — benchmark, dynamic: easy, medium, blind: no runs" in md
    assert "- every result has 1 seed (the paper: 5)" in md
    assert not (tmp_path / "out" / "figures" / "robustness.png").exists()


def test_experiment_without_results_is_reported_as_such(tmp_path):
    write_run(tmp_path / "runs", 10.0)
    build_report(tmp_path / "runs", tmp_path / "out", "training", log=None)
    md = (tmp_path / "out" / "report.md").read_text()
    assert "No results for experiment `training`." in md and "- QT-Opt: no results in this experiment" in md


def test_unknown_experiment_is_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown experiment 'ablation'"):
        build_report(tmp_path, tmp_path / "out", "ablation")


def test_cli_runs_as_a_module(tmp_path):
    write_run(tmp_path / "runs", 10.0)
    done = subprocess.run([sys.executable, "-m", "dcs_torchrl.report", str(tmp_path / "runs"), "--experiment",
                           "benchmarks"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "1 runs, 0 skipped" in done.stdout
    assert (tmp_path / "runs" / "report" / "tables" / "benchmark_easy.md").is_file()


def test_cli_refuses_a_missing_directory(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path / "nowhere")])
    assert exit_info.value.code == 2
    assert "does not exist" in capsys.readouterr().err
