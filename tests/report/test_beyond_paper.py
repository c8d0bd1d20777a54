"""The sweeps beyond the paper (light, texture) in the report: their own panels, named, no paper value."""
from synthetic_results import write_run

from dcs_torchrl.report import figures
from dcs_torchrl.report.build import build_report
from dcs_torchrl.report.curves import curve_table, curves_markdown, half_score_markdown, half_score_table
from dcs_torchrl.report.experiments import AXES, EXPERIMENTS, SWEEP_AXES
from dcs_torchrl.report.load import load_results
from dcs_torchrl.report.missing import missing_cells

PAPER_TITLES = ["Camera", "Colour", "Background"]


def _write(root, axes):
    for axis in axes:
        for value, score in ((0.0, 800.0), (0.5, 500.0), (1.0, 300.0)):
            write_run(root, score, method="SAC+RAD", domain="cartpole", task="swingup", experiment="robustness",
                      axis=axis, value=value)


def test_light_and_texture_are_sweep_axes_of_their_own_settings():
    assert {axis: (SWEEP_AXES[axis].key, SWEEP_AXES[axis].fixed, AXES[axis]) for axis in ("light", "texture")} == {
        "light": ("light_scale", {}, float), "texture": ("texture_scale", {}, float)}
    assert [p.axis for p in EXPERIMENTS["robustness"]] == ["camera", "color", "background_blend"]  # the paper's grid


def test_the_report_draws_light_and_texture_as_panels_beyond_the_paper(results_dir, tmp_path, monkeypatch):
    _write(results_dir, ["camera", "light", "texture"])
    runs = load_results(results_dir).runs
    curves = curve_table(runs, "robustness")
    assert sorted(set(curves["axis"])) == ["camera", "light", "texture"]
    half = half_score_table(curves).set_index("axis")
    assert dict(half["paper"]) == {"camera": "0.2", "light": "", "texture": ""}  # the paper's notes: its own axes
    assert dict(half["half_at"]) == {"camera": 1.0, "light": 1.0, "texture": 1.0}
    md = curves_markdown(curves, "robustness")
    assert "## Lighting (beyond the paper) — light scale β_light" in md
    assert "## Texture (beyond the paper) — texture scale β_tex (drawn per episode)" in md
    text = half_score_markdown(half_score_table(curves)).splitlines()
    assert "| light | static | — | 1 | — | — | — | — | beyond the paper |" in text
    assert "| texture | static | — | 1 | — | — | — | — | beyond the paper |" in text
    assert "| camera | static | — | 1 | — | — | — | — | 0.2 |" in text
    assert not any("light" in line or "texture" in line for line in missing_cells(runs, "robustness"))

    saved = []
    monkeypatch.setattr(figures, "_save", lambda fig, path: saved.append(fig) or path)
    build_report(results_dir, tmp_path / "report")
    (fig,) = saved  # the robustness curves
    assert [ax.get_title() for ax in fig.axes] == PAPER_TITLES + ["Lighting (beyond the paper)",
                                                                  "Texture (beyond the paper)"]
    assert [ax.get_xlabel() for ax in fig.axes][3:] == ["light scale $\\beta_{light}$",
                                                        "texture scale $\\beta_{tex}$ (drawn per episode)"]


def test_a_report_without_them_is_as_before(results_dir):
    _write(results_dir, ["camera"])
    curves = curve_table(load_results(results_dir).runs, "robustness")
    md = curves_markdown(curves, "robustness")
    assert "beyond the paper" not in md and "β_light" not in md and "β_tex" not in md
    assert [line for line in md.splitlines() if line.startswith("## ")][:3] == [
        "## Camera — camera scale β_cam", "## Colour — colour scale β_rgb",
        "## Background — background blend β_bg (b = 60 videos)"]
