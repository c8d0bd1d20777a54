"""Score-vs-intensity curves and the half-score points."""
import math

import pytest
from synthetic_results import write_run

from dcs_torchrl.report.curves import curve_table, curves_markdown, half_score_table
from dcs_torchrl.report.load import load_results

TASKS = [("cartpole", "swingup"), ("cheetah", "run")]


@pytest.fixture
def curves(results_dir):
    # QT-Opt+RAD, camera, static: 800 at 0, 600 at 0.1, 400 at 0.2 (half), 100 at 0.5 (tasks 2:1 around it)
    for value, mean in ((0.0, 800.0), (0.1, 600.0), (0.2, 400.0), (0.5, 100.0)):
        for seed, noise in ((0, -10.0), (1, 10.0)):
            for (domain, task), factor in zip(TASKS, (4 / 3, 2 / 3)):
                write_run(results_dir, mean * factor + noise, method="QT-Opt+RAD", domain=domain, task=task,
                          seed=seed, experiment="robustness", axis="camera", value=value)
    # SAC, colour, dynamic: never below half
    for value in (0.0, 0.5, 1.0):
        for domain, task in TASKS:
            write_run(results_dir, 500.0 - 100 * value, method="SAC", domain=domain, task=task,
                      experiment="robustness", axis="color", value=value, dynamic=True)
    # SAC, camera, static at 0.1 lacks cheetah: no point there
    write_run(results_dir, 300.0, method="SAC", domain="cartpole", task="swingup", experiment="robustness",
              axis="camera", value=0.1)
    return curve_table(load_results(results_dir).runs, "robustness")


def test_points_are_means_over_tasks_and_seeds(curves):
    qt = curves[curves.method == "QT-Opt+RAD"].set_index("value")
    assert qt["mean"].tolist() == pytest.approx([800.0, 600.0, 400.0, 100.0])
    assert qt.loc[0.2, "stderr"] == pytest.approx(10.0)  # seeds 390 and 410
    assert (qt.loc[0.2, "n"], qt.loc[0.2, "n_tasks"]) == (2, 2)
    assert ((curves.method == "SAC") & (curves.axis == "camera")).sum() == 0  # incomplete point left out


def test_half_score_points(curves):
    half = half_score_table(curves).set_index(["method", "axis"])
    assert half.loc[("QT-Opt+RAD", "camera"), "half_at"] == 0.2
    assert half.loc[("QT-Opt+RAD", "camera"), "paper"] == "0.2"
    assert math.isnan(half.loc[("SAC", "color"), "half_at"])
    assert half.loc[("SAC", "color"), "paper"] == "0.6"
    md = curves_markdown(curves, "robustness")
    assert "| camera | static | — | — | — | — | 0.2 | — | 0.2 |" in md.splitlines()
    assert "| color | dynamic | > 1 | — | — | — | — | — | 0.6 |" in md.splitlines()
    row = "| QT-Opt+RAD (static) | 800 ± 10 (n=2) | 600 ± 10 (n=2) | 400 ± 10 (n=2) | 100 ± 10 (n=2) |"
    assert row in md.splitlines()
    assert "| SAC (dynamic) | 500 (n=1) | 450 (n=1) | 400 (n=1) |" in md.splitlines()
    assert "## Background — background blend β_bg (b = 60 videos)\n\nNo results." in md
