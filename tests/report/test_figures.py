"""The figures' legends name the markers and line styles they drew, and only those."""
from synthetic_results import write_run

from dcs_torchrl.report import figures
from dcs_torchrl.report.build import build_report
from dcs_torchrl.report.figures import benchmark_markers

LABELS = dict(paper_label="paper: mean", expected_label="paper: expected")


def test_every_marker_drawn_is_named():
    labels = [h.get_label() for h in benchmark_markers(expected=True, paper_expected=True, missing=True, **LABELS)]
    assert labels == ["expected (independent degradations)", "paper: expected", "paper: mean", "no results"]


def test_stars_not_drawn_are_not_named():
    # a study without the interactions experiment's runs has no expected score to draw
    labels = [h.get_label() for h in benchmark_markers(expected=False, paper_expected=True, missing=False, **LABELS)]
    assert labels == ["paper: expected", "paper: mean"]
    labels = [h.get_label() for h in benchmark_markers(expected=False, paper_expected=False, missing=False, **LABELS)]
    assert labels == ["paper: mean"]


def test_figure_without_interaction_runs_names_no_expected_score(results_dir, tmp_path, monkeypatch):
    # benchmark runs only, no single-distraction training runs: no expected score of this run to draw,
    # the paper's (its published relative scores) drawn
    for value, score in (("none", 800.0), ("easy", 300.0), ("medium", 200.0)):
        write_run(results_dir, score, method="SAC+RAD", domain="cartpole", task="swingup",
                  experiment="benchmarks", axis="benchmark", value=value)
    calls = []

    def recording(**kw):
        calls.append(kw)
        return benchmark_markers(**kw)

    monkeypatch.setattr(figures, "benchmark_markers", recording)
    build_report(results_dir, tmp_path / "report")
    assert len(calls) == 2  # static and dynamic figures
    assert all(not c["expected"] and c["paper_expected"] and c["missing"] for c in calls)
    assert (tmp_path / "report" / "figures" / "benchmarks_static.png").stat().st_size > 10_000


def _title_clear_of_panels(fig) -> bool:
    to_fig = fig.transFigure.inverted()
    title_bottom = to_fig.transform((0, fig._suptitle.get_window_extent().y0))[1]
    return all(to_fig.transform((0, ax.get_tightbbox().y1))[1] < title_bottom for ax in fig.axes)


def test_a_title_of_several_lines_stays_clear_of_the_panels(results_dir, tmp_path, monkeypatch):
    # a note that wraps to three lines once ran the curves figure's top panel titles into it
    for value, score in (("none", 800.0), ("easy", 300.0), ("medium", 200.0)):
        write_run(results_dir, score, method="SAC+RAD", domain="cartpole", task="swingup",
                  experiment="benchmarks", axis="benchmark", value=value)
    for domain, task in (("cartpole", "swingup"), ("cheetah", "run"), ("finger", "spin"), ("walker", "walk")):
        for value, score in ((0.0, 800.0), (0.5, 400.0), (1.0, 100.0)):  # a row of panels per task: a tall figure
            write_run(results_dir, score, method="SAC+RAD", domain=domain, task=task,
                      experiment="robustness", axis="camera", value=value)
    saved, suptitle = [], figures._suptitle
    monkeypatch.setattr(figures, "_suptitle", lambda fig, title, note: suptitle(fig, title, note + " more" * 60))
    monkeypatch.setattr(figures, "_save", lambda fig, path: saved.append(fig) or path)
    build_report(results_dir, tmp_path / "report")
    assert len(saved) == 3  # the robustness curves, the static and the dynamic benchmarks
    for fig in saved:
        assert fig.get_suptitle().count("\n") >= 3
        assert _title_clear_of_panels(fig)


def test_the_curves_legend_names_only_the_settings_drawn(results_dir, tmp_path, monkeypatch):
    # the robustness command's quick sweep is static only: no "dynamic" line style to name
    for value, score in ((0.0, 800.0), (0.5, 400.0), (1.0, 100.0)):
        write_run(results_dir, score, method="SAC+RAD", domain="cartpole", task="swingup",
                  experiment="robustness", axis="camera", value=value)
    saved = []
    monkeypatch.setattr(figures, "_save", lambda fig, path: saved.append(fig) or path)
    build_report(results_dir, tmp_path / "static")
    assert _curves_legend(saved) == ["SAC+RAD", "static"]
    for value, score in ((0.5, 300.0), (1.0, 80.0)):
        write_run(results_dir, score, method="SAC+RAD", domain="cartpole", task="swingup",
                  experiment="robustness", axis="camera", value=value, dynamic=True)
    build_report(results_dir, tmp_path / "both")
    assert _curves_legend(saved) == ["SAC+RAD", "static", "dynamic"]


def _curves_legend(saved: list) -> list[str]:
    """The legend of the last robustness-curves figure saved."""
    [*_, fig] = [f for f in saved if f.get_suptitle().startswith("Trained without distractions")]
    return [t.get_text() for t in fig.legends[0].get_texts()]
