"""Missing cells of a partial sweep, against the paper's grid."""
from synthetic_results import write_run

from dcs_torchrl.report.load import load_results
from dcs_torchrl.report.missing import missing_cells

SIX = [("ball_in_cup", "catch"), ("cartpole", "swingup"), ("cheetah", "run"), ("finger", "spin"),
       ("reacher", "easy"), ("walker", "walk")]


def test_partial_benchmark_sweep(results_dir):
    # SAC+RAD and QT-Opt+RAD: every task of none and easy static with 5 seeds, except that
    # QT-Opt+RAD lacks walker walk in easy static and has 3 seeds of cheetah run there
    for method in ("SAC+RAD", "QT-Opt+RAD"):
        for domain, task in SIX:
            for seed in range(5):
                kw = dict(method=method, domain=domain, task=task, seed=seed)
                write_run(results_dir, 100.0, value="none", **kw)
                if method == "QT-Opt+RAD" and (task == "walk" or (task == "run" and seed >= 3)):
                    continue
                write_run(results_dir, 50.0, value="easy", **kw)
    lines = missing_cells(load_results(results_dir).runs, "benchmarks")
    assert lines[:4] == [f"{m}: no results in this experiment" for m in ("SAC", "SAC+DrQ", "QT-Opt", "QT-Opt+DrQ")]
    assert "QT-Opt+RAD — benchmark, static: easy: no runs for walker walk" in lines
    assert "all methods — benchmark, static: medium, blind: no runs" in lines
    assert "all methods — benchmark, dynamic: easy, medium, blind: no runs" in lines
    assert "QT-Opt+RAD — benchmark, static: easy: fewer than 5 seeds: cheetah run (n=3)" in lines
    assert not any(line.startswith("all methods — benchmark: none") for line in lines)  # complete
    assert len(lines) == 8


def test_curve_sweep_with_values_off_the_grid_and_a_task_nobody_ran(results_dir):
    for value in (0.0, 0.1, 0.15):
        for dynamic in (False, True):
            write_run(results_dir, 10.0, method="SAC", domain="cheetah", task="run", experiment="robustness",
                      axis="camera", value=value, dynamic=dynamic)
    lines = missing_cells(load_results(results_dir).runs, "robustness")
    assert ("no results in this experiment for ball_in_cup catch, cartpole swingup, finger spin, reacher easy, "
            "walker walk") in lines
    assert "SAC — camera, static: 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1: no runs" in lines
    assert "SAC — color, dynamic: 0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1: no runs" in lines
    assert "every result has 1 seed (the paper: 5)" in lines
    assert not any("0.15" in line for line in lines)  # a value off the grid counts as present


def test_empty_experiment_lists_every_method(results_dir):
    assert missing_cells(load_results(results_dir).runs, "training") == [
        f"{m}: no results in this experiment" for m in ("SAC", "SAC+RAD", "SAC+DrQ", "QT-Opt", "QT-Opt+RAD",
                                                         "QT-Opt+DrQ")]
