"""The paper budget needs DAVIS 2017 (or an explicit opt-in), and the report marks stand-in backgrounds."""
import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf
from synthetic_results import write_run

from dcs_torchrl.experiments.launch import check_backgrounds, recipe_settings
from dcs_torchrl.report import build_report
from dcs_torchrl.report.load import backgrounds

ROOT = Path(__file__).resolve().parents[2]  # the project


def test_paper_budget_without_davis_stops_with_the_setting_to_pass():
    out = subprocess.run([sys.executable, str(ROOT / "recipes/experiments/status.py"), "experiment=benchmarks", "budget=paper"],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode != 0
    assert "budget.background_dir=" in out.stderr and "budget.stand_in_backgrounds=true" in out.stderr


def test_opt_in_and_folder(tmp_path):
    paper = OmegaConf.create({"name": "paper", "requires_davis": True, "background_dir": None,
                              "stand_in_backgrounds": False, "recipe": {"total_frames": 10}})
    with pytest.raises(ValueError, match="stand_in_backgrounds=true"):
        check_backgrounds(paper)
    check_backgrounds(OmegaConf.merge(paper, {"stand_in_backgrounds": True}))
    with pytest.raises(FileNotFoundError, match="not a directory"):
        check_backgrounds(OmegaConf.merge(paper, {"background_dir": str(tmp_path / "missing")}))
    with_davis = OmegaConf.merge(paper, {"background_dir": str(tmp_path)})
    check_backgrounds(with_davis)
    # the folder reaches every recipe run (and, through the training env, every evaluation)
    settings = recipe_settings(OmegaConf.create({"budget": with_davis}))
    assert settings == {"total_frames": 10, "env.background_dir": str(tmp_path)}


def test_backgrounds_of_a_run():
    assert backgrounds({"num_videos": 0}, {"num_videos": 0}) == "none"
    assert backgrounds({"num_videos": 0}, {"num_videos": 60, "background_blend": 0.0}) == "none"
    assert backgrounds({"num_videos": 0}, {"num_videos": 60, "background_blend": 0.4}) == "stand-in v1"  # recorded before versions
    assert backgrounds({"num_videos": 8, "embedded_videos": 2}, {"num_videos": 60, "embedded_videos": 1}) == "stand-in v1+v2"
    assert backgrounds({"num_videos": 8, "background_dir": "/data/davis"}, {"num_videos": 8, "background_dir": "/data/davis"}) == "folder"


def test_report_marks_stand_in_backgrounds_only_where_they_were_used(tmp_path):
    results = tmp_path / "results"
    for seed in (0, 1):
        write_run(results, 100.0 + seed, seed=seed, experiment="robustness", axis="camera", value=0.5)
        write_run(results, 50.0 + seed, seed=seed, experiment="benchmarks", axis="benchmark", value="easy")
    report = build_report(results, tmp_path / "report", log=None)
    text = (report.out / "report.md").read_text()
    robustness = text.split("## ")[[i for i, s in enumerate(text.split("## ")) if s.startswith("Robustness") or "robustness" in s.split("\n")[0].lower()][0]]
    assert "stand-in videos" not in robustness  # camera only: no videos
    benchmarks = [s for s in text.split("## ") if s.lower().startswith("benchmark")][0]
    assert "embedded stand-in videos, not DAVIS 2017" in benchmarks


def test_report_says_when_runs_mix_versions_of_the_stand_in_videos():
    import pandas as pd

    from dcs_torchrl.report.build import stand_in_note
    from dcs_torchrl.results import with_videos_version
    from dcs_torchrl.videos import EMBEDDED_VERSION

    shown = {"num_videos": 8, "background_blend": 1.0, "background_dir": None}
    assert with_videos_version(shown)["embedded_videos"] == EMBEDDED_VERSION  # what every run now records
    one = pd.DataFrame({"backgrounds": ["stand-in v2", "none"]})
    assert stand_in_note(one).endswith("(v2)")
    mixed = pd.DataFrame({"backgrounds": ["stand-in v1", "stand-in v2"]})
    assert "mix versions of them (v1, v2)" in stand_in_note(mixed)
    assert stand_in_note(pd.DataFrame({"backgrounds": ["none", "folder"]})) == ""


def test_a_curve_never_averages_two_versions_of_the_stand_ins(tmp_path, capsys):
    import json

    import pandas as pd

    # seed 0 of SAC+RAD swept again on version 3, seed 1 only on version 1; QT-Opt+RAD only on version 1
    def put(score, version, **kw):
        path = write_run(tmp_path / "runs", score, experiment="robustness", axis="background_blend", **kw)
        doc = json.loads(path.read_text())
        doc["eval_env"]["embedded_videos"] = version
        path.write_text(json.dumps(doc))

    put(400.0, 3, method="SAC+RAD", value=0.5, seed=0)
    put(600.0, 1, method="SAC+RAD", value=0.5, seed=1)
    put(500.0, 1, method="QT-Opt+RAD", value=0.5, seed=0)
    write_run(tmp_path / "runs", 800.0, method="SAC+RAD", experiment="robustness", axis="camera", value=0.5, seed=1)
    report = build_report(tmp_path / "runs", tmp_path / "out", "robustness")
    assert "left out 1 runs on older stand-in videos" in capsys.readouterr().err
    assert report.loaded.older_videos["score"].tolist() == [600.0]
    curves = pd.read_csv(tmp_path / "out" / "tables" / "robustness_curves.csv")
    at = curves[(curves.axis == "background_blend") & (curves.value == 0.5)]  # one task: its curve is the mean
    assert dict(zip(at["method"], at["mean"])) == {"SAC+RAD": 400.0, "QT-Opt+RAD": 500.0}  # not (400 + 600) / 2
    md = (tmp_path / "out" / "report.md").read_text()
    assert "3 runs loaded, 1 left out" in md
    assert "- robustness, SAC+RAD, cheetah run: 1 runs on v1" in md
    assert pd.read_csv(tmp_path / "out" / "left_out_videos.csv")["seed"].tolist() == [1]
    assert 800.0 in pd.read_csv(tmp_path / "out" / "runs.csv")["score"].tolist()  # no videos: kept
