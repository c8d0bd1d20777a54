"""metrics.csv rows survive resumes exactly once; run directories refuse other configs; the learning curve names its training scene."""
from __future__ import annotations

import json

import pytest

from dcs_torchrl.training import MetricsLogger, RunDirectory, RunMismatchError, read_metrics


def test_resume_drops_rows_after_the_checkpoint(tmp_path):
    log = MetricsLogger(tmp_path)
    log.log(10, {"train/a": 1.0, "loss/b": 2.0})
    rows_at_checkpoint = log.rows
    log.log(20, {"train/a": 3.0})
    log.close()
    with pytest.raises(FileExistsError, match="new run directory"):
        MetricsLogger(tmp_path)
    resumed = MetricsLogger(tmp_path, resume=(rows_at_checkpoint, 10))
    resumed.log(20, {"train/a": 4.0})
    resumed.close()
    rows = read_metrics(tmp_path / "metrics.csv")
    assert [(r["frames"], r["name"], r["value"]) for r in rows] == [(10, "train/a", 1.0), (10, "loss/b", 2.0), (20, "train/a", 4.0)]


def test_a_row_cut_short_by_a_kill_is_dropped_on_resume(tmp_path):
    log = MetricsLogger(tmp_path)
    log.log(10, {"train/a": 1.0})
    log.close()
    with open(tmp_path / "metrics.csv", "a") as f:
        f.write("20,train/a,3.1")  # killed mid-row: no newline, the value may be cut
    assert [r["frames"] for r in read_metrics(tmp_path / "metrics.csv")] == [10]
    resumed = MetricsLogger(tmp_path, resume=(1, 10))
    resumed.log(20, {"train/a": 3.25})
    resumed.close()
    rows = read_metrics(tmp_path / "metrics.csv")
    assert [(r["frames"], r["value"]) for r in rows] == [(10, 1.0), (20, 3.25)]


def test_unknown_backend(tmp_path):
    with pytest.raises(ValueError, match="logger.backend"):
        MetricsLogger(tmp_path, backend="neptune")


def test_run_directory_identity(tmp_path):
    config = {"seed": 1, "env": {"domain": "cartpole"}, "total_frames": 100, "eval": {"episodes": 2}}
    RunDirectory(tmp_path, config).claim()
    recorded = (tmp_path / "run_config.json").read_text()
    RunDirectory(tmp_path, {**config, "total_frames": 500, "eval": {"episodes": 100}}).claim()  # budget may change
    with pytest.raises(RunMismatchError, match="env.domain: 'cartpole' there, 'walker' now"):
        RunDirectory(tmp_path, {**config, "env": {"domain": "walker"}}).claim()
    assert (tmp_path / "run_config.json").read_text() == recorded  # nothing overwritten
    run = RunDirectory(tmp_path, config)
    assert run.finished(100) is None
    run.write_results({"steps": 100, "eval": {"mean": 1.0}})
    assert run.finished(100)["steps"] == 100 and run.finished(200) is None
    assert json.loads((tmp_path / "results.json").read_text())["steps"] == 100


def test_how_the_same_math_runs_is_not_part_of_a_runs_identity(tmp_path):
    # a run started when network.channels_last defaulted to false resumes under the new default
    network = {"feature_dim": 50, "channels_last": False, "compile": False}
    config = {"seed": 1, "env": {"domain": "cartpole"}, "network": network, "device": "cpu"}
    (tmp_path / "run_config.json").write_text(json.dumps({k: v for k, v in config.items() if k != "device"}))
    RunDirectory(tmp_path, {**config, "network": {**network, "channels_last": True, "compile": True}}).claim()
    with pytest.raises(RunMismatchError, match="network.feature_dim: 50 there, 64 now"):
        RunDirectory(tmp_path, {**config, "network": {**network, "feature_dim": 64}}).claim()
    fresh = tmp_path / "fresh"
    RunDirectory(fresh, config).claim()
    assert json.loads((fresh / "run_config.json").read_text()) == {
        "seed": 1, "env": {"domain": "cartpole"}, "network": {"feature_dim": 50}}


def test_wandb_backend_is_torchrls_logger_and_resumes_the_same_run(tmp_path, monkeypatch):
    pytest.importorskip("wandb")
    from torchrl.record.loggers import WandbLogger

    monkeypatch.setenv("WANDB_MODE", "offline")  # a real wandb run, written to the run directory
    monkeypatch.setenv("WANDB_SILENT", "true")
    log = MetricsLogger(tmp_path, backend="wandb", project="dcs-test", run_name="r", config={"seed": 0})
    assert isinstance(log._wandb, WandbLogger)
    log.log(10, {"train/return": 1.0, "loss/critic": 2.0})
    rows, run_id = log.rows, log.wandb_id
    log.close()
    resumed = MetricsLogger(tmp_path, backend="wandb", resume=(rows, 10), wandb_id=run_id, project="dcs-test")
    assert resumed.wandb_id == run_id
    resumed.log(20, {"train/return": 3.0})
    resumed.close()
    runs = sorted(p.name for p in (tmp_path / "wandb").glob("offline-run-*"))
    assert len(runs) == 2 and all(name.split("-")[3] == run_id for name in runs)  # one W&B run, written twice
    assert [r["value"] for r in read_metrics(tmp_path / "metrics.csv")] == [1.0, 2.0, 3.0]


@pytest.mark.parametrize(
    "options, label",
    [
        ({}, "no distractions"),
        ({"benchmark": "easy", "dynamic": True}, "easy, dynamic"),
        ({"benchmark": "medium"}, "medium, static"),
        ({"camera_scale": 0.3}, "camera 0.3, static"),
        ({"color_scale": 0.2, "num_videos": 4, "dynamic": True}, "colour 0.2, 4 videos, dynamic"),
        ({"light_scale": 0.5}, "light 0.5, static"),
        ({"benchmark": "medium", "texture_scale": 0.3, "dynamic": True}, "medium, texture 0.3, dynamic"),
    ],
)
def test_learning_curve_title_names_the_training_scene(options, label):
    from dcs_torchrl.envs import resolve_settings
    from dcs_torchrl.training.loop import _scene_label

    assert _scene_label(resolve_settings("cartpole", "swingup", **options)) == label
