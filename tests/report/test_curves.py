"""Score-vs-intensity curves and the half-score points."""
import math

import matplotlib.image
import pytest
from synthetic_results import write_run

from dcs_torchrl.report.curves import ALL_TASKS, curve_table, curves_markdown, half_score_table
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
    mean = curves[curves.task == ALL_TASKS]
    qt = mean[mean.method == "QT-Opt+RAD"].set_index("value")
    assert qt["mean"].tolist() == pytest.approx([800.0, 600.0, 400.0, 100.0])
    assert qt.loc[0.2, "stderr"] == pytest.approx(10.0)  # seeds 390 and 410
    assert (qt.loc[0.2, "n"], qt.loc[0.2, "n_tasks"]) == (2, 2)
    assert ((mean.method == "SAC") & (mean.axis == "camera")).sum() == 0  # incomplete point left out


def test_each_task_has_its_own_curve_beside_the_mean(curves, tmp_path):
    from dcs_torchrl.report.curves import curve_tasks
    from dcs_torchrl.report.figures import curves_figure

    assert curve_tasks(curves) == [ALL_TASKS, "cartpole-swingup", "cheetah-run"]
    qt = curves[(curves.method == "QT-Opt+RAD")].set_index(["task", "value"])
    assert qt.loc[("cartpole-swingup", 0.2), "mean"] == pytest.approx(400 * 4 / 3)
    assert qt.loc[("cheetah-run", 0.5), "mean"] == pytest.approx(100 * 2 / 3)
    assert qt.loc[("cheetah-run", 0.2), "stderr"] == pytest.approx(10.0)
    assert set(qt["n_tasks"].loc[["cartpole-swingup", "cheetah-run"]]) == {1}
    # SAC camera 0.1 has cartpole only: absent from the mean, present in cartpole's own curve
    sac = curves[(curves.method == "SAC") & (curves.axis == "camera")]
    assert list(sac["task"]) == ["cartpole-swingup"] and list(sac["mean"]) == [300.0]
    md = curves_markdown(curves, "robustness").splitlines()
    assert "| QT-Opt+RAD (static) — cheetah-run | 533 ± 10 (n=2) | 400 ± 10 (n=2) | 267 ± 10 (n=2) | 67 ± 10 (n=2) |" in md
    half = half_score_table(curves).set_index(["method", "axis", "task"])
    assert half.loc[("QT-Opt+RAD", "camera", "cheetah-run"), "half_at"] == 0.2
    # the figure: a row of panels per task under the mean's
    one = curves_figure(curves[curves.task == ALL_TASKS], "robustness", tmp_path / "mean.png")
    rows = curves_figure(curves, "robustness", tmp_path / "tasks.png")
    heights = [matplotlib.image.imread(path).shape[0] for path in (one, rows)]
    assert heights[1] > 2 * heights[0]


def test_half_score_points(curves):
    half = half_score_table(curves[curves.task == ALL_TASKS]).set_index(["method", "axis"])
    assert half.loc[("QT-Opt+RAD", "camera"), "half_at"] == 0.2
    assert half.loc[("QT-Opt+RAD", "camera"), "paper"] == "0.2"
    assert math.isnan(half.loc[("SAC", "color"), "half_at"])
    assert half.loc[("SAC", "color"), "paper"] == "0.6"
    md = curves_markdown(curves, "robustness")
    assert "| camera | static | mean | — | — | — | — | 0.2 | — | 0.2 |" in md.splitlines()
    assert "| color | dynamic | mean | > 1 | — | — | — | — | — | 0.6 |" in md.splitlines()
    assert "| color | dynamic | cheetah-run | > 1 | — | — | — | — | — | 0.6 |" in md.splitlines()
    row = "| QT-Opt+RAD (static) | 800 ± 10 (n=2) | 600 ± 10 (n=2) | 400 ± 10 (n=2) | 100 ± 10 (n=2) |"
    assert row in md.splitlines()
    assert "| SAC (dynamic) | 500 (n=1) | 450 (n=1) | 400 (n=1) |" in md.splitlines()
    assert "## Background — background blend β_bg (b = 60 videos)\n\nNo results." in md


def test_the_2021_blend_is_a_second_curve_in_the_background_panel(tmp_path):
    from dcs_torchrl.report.curves import BLEND_2021, half_score_markdown
    from dcs_torchrl.report.figures import curves_figure

    for seed in (0, 1):
        for value, paper, accumulated in ((0.0, 800.0, 800.0), (0.1, 700.0, 300.0), (0.5, 350.0, 100.0)):
            write_run(tmp_path, paper + seed, seed=seed, experiment="robustness", axis="background_blend", value=value)
            write_run(tmp_path, accumulated + seed, seed=seed, experiment="robustness", axis="background_blend_2021",
                      value=value)
    curves = curve_table(load_results(tmp_path).runs, "robustness")
    assert set(curves["axis"]) == {"background_blend"} and set(curves["blend"]) == {"paper", BLEND_2021}
    half = half_score_table(curves)
    assert dict(zip(half["blend"], half["half_at"])) == {"paper": 0.5, BLEND_2021: 0.1}
    text = half_score_markdown(half)
    assert "| background_blend (2021 blend) | static | 0.1 |" in text and "| background_blend | static | 0.5 |" in text
    assert "(2021 blend)" in curves_markdown(curves, "robustness")
    assert curves_figure(curves, "robustness", tmp_path / "robustness.png").stat().st_size > 10_000
