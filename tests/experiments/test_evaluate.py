"""Evaluation-only runs record the stand-in videos each env actually showed."""
import json
import shutil

from dcs_torchrl.experiments.evaluate import evaluate_checkpoint
from dcs_torchrl.experiments.grid import Evaluation
from dcs_torchrl.pretrained import shipped_agents
from dcs_torchrl.report.load import backgrounds
from dcs_torchrl.results import RunResults
from dcs_torchrl.videos import EMBEDDED_VERSION


def test_an_agent_trained_before_video_versions_were_recorded_keeps_none(tmp_path):
    agent = shutil.copytree(shipped_agents()["sac_rad_cartpole_swingup"], tmp_path / "agent")
    trained = json.loads((agent / "results.json").read_text())
    trained["train_env"]["num_videos"] = 2  # trained on stand-in videos, recorded without their version
    (agent / "results.json").write_text(json.dumps(trained))
    evaluation = Evaluation("", "robustness", {"num_videos": 2}, {"axis": "num_videos", "value": 2, "dynamic": False})
    (result,) = evaluate_checkpoint(agent, [(tmp_path / "evaluation", evaluation)], settings={"eval.episodes": 1})
    assert "embedded_videos" not in result["train_env"] and result["train_env"] == trained["train_env"]
    assert result["eval_env"]["embedded_videos"] == EMBEDDED_VERSION  # evaluated now, on today's stand-ins
    assert backgrounds(result["train_env"]) == "stand-in v1"  # what the report reads an unversioned record as


def test_an_evaluation_carries_the_version_the_trained_run_recorded():
    shown = {"num_videos": 2, "background_blend": 1.0, "background_dir": None}
    old = {**shown, "embedded_videos": EMBEDDED_VERSION - 1}
    config = {"seed": 0, "algo": {"name": "sac", "aug": "rad"}, "env": {"domain": "cartpole", "task": "swingup"}}
    record = RunResults.from_config(config, experiment=None, steps=1, wall_time=1.0, train_env=old, eval_env=shown,
                                    sweep=None, eval={}, trained=False)
    assert record.train_env == old and record.eval_env["embedded_videos"] == EMBEDDED_VERSION
    trained = RunResults.from_config(config, experiment=None, steps=1, wall_time=1.0, train_env=shown, eval_env=shown,
                                     sweep=None, eval={})
    assert trained.train_env["embedded_videos"] == EMBEDDED_VERSION  # a training run shows today's
