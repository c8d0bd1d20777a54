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
    assert "| QT-Opt+RAD |" in md and "one-sided z-test on mean ± s.e." in md


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


def test_runs_of_another_length_are_left_out_and_listed(tmp_path, capsys):
    for seed in (0, 1):
        write_run(tmp_path / "runs", 100.0 + seed, seed=seed)
    write_run(tmp_path / "runs" / "short", 900.0, seed=2, steps=100_000)
    write_run(tmp_path / "runs" / "quick_eval", 800.0, seed=3, episodes=10)
    report = build_report(tmp_path / "runs", tmp_path / "out", "benchmarks")
    assert "left out 1 runs with steps=100000, eval.episodes=2 (the report uses steps=500000" in capsys.readouterr().err
    md = (tmp_path / "out" / "report.md").read_text()
    assert "2 runs loaded, 2 left out, 0 files skipped" in md
    assert "Tables and figures use only runs with `steps` = 500000 and `eval.episodes` = 2" in md
    assert "- `steps` = 100000, `eval.episodes` = 2: 1 runs (benchmarks 1)" in md
    assert "- `steps` = 500000, `eval.episodes` = 10: 1 runs (benchmarks 1)" in md
    assert sorted(pd.read_csv(tmp_path / "out" / "left_out.csv")["score"]) == [800.0, 900.0]
    assert pd.read_csv(tmp_path / "out" / "runs.csv")["score"].tolist() == [100.0, 101.0]
    assert "| SAC | **100 ± 0** | **100 ± 0** |" in (tmp_path / "out" / "tables" / "benchmark_easy.md").read_text()
    assert "left_out.csv" in report.files


def test_nothing_left_out_says_so(tmp_path):
    write_run(tmp_path / "runs", 10.0)
    build_report(tmp_path / "runs", tmp_path / "out", "benchmarks", log=None)
    md = (tmp_path / "out" / "report.md").read_text()
    assert "None: every run of an experiment has `steps` = 500000 and `eval.episodes` = 2." in md
    assert not (tmp_path / "out" / "left_out.csv").exists()


@pytest.mark.parametrize("out, shown", [("report", ".."), ("../reports/smoke", "../../runs")])
def test_results_directory_is_named_relative_to_the_report(tmp_path, monkeypatch, out, shown):
    """Given as an absolute path or a relative one, report.md never names the machine's directories."""
    write_run(tmp_path / "runs", 10.0)
    for results_dir in (tmp_path / "runs", "runs"):
        monkeypatch.chdir(tmp_path)
        report = build_report(results_dir, tmp_path / "runs" / out, "benchmarks", log=None)
        md = (report.out / "report.md").read_text()
        assert f"Results directory: `{shown}` (relative to this report)" in md
        assert str(tmp_path) not in md and str(tmp_path) not in (report.out / "runs.csv").read_text()


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
    assert "1 runs, 0 left out, 0 skipped" in done.stdout
    assert (tmp_path / "runs" / "report" / "tables" / "benchmark_easy.md").is_file()


def test_cli_refuses_a_missing_directory(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path / "nowhere")])
    assert exit_info.value.code == 2
    assert "does not exist" in capsys.readouterr().err
