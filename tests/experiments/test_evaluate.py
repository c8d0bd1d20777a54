"""Evaluation-only runs record the stand-in videos each env actually showed, and are reused only while they hold."""
import json
import shutil

from dcs_torchrl.experiments.evaluate import evaluate_checkpoint, stale_reason
from dcs_torchrl.experiments.grid import Evaluation
from dcs_torchrl.pretrained import checkpoint_sha256, shipped_agents
from dcs_torchrl.report.load import backgrounds
from dcs_torchrl.results import RunResults
from dcs_torchrl.videos import EMBEDDED_VERSION

# The agent acting every 100 physics steps: episodes of 10 steps (against 125), where what these tests
# check (which evaluations run, where, what they record) holds for episodes of any length.
SHORT = {"action_repeat": 100}


def test_an_agent_trained_before_video_versions_were_recorded_keeps_none(tmp_path):
    agent = shutil.copytree(shipped_agents()["sac_rad_cartpole_swingup"], tmp_path / "agent")
    trained = json.loads((agent / "results.json").read_text())
    trained["train_env"]["num_videos"] = 2  # trained on stand-in videos, recorded without their version
    (agent / "results.json").write_text(json.dumps(trained))
    evaluation = Evaluation("", "robustness", {"num_videos": 2, **SHORT}, {"axis": "num_videos", "value": 2, "dynamic": False})
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


def test_a_finished_evaluation_is_reused_only_while_its_checkpoint_and_videos_hold(tmp_path):
    """A finished evaluation is skipped; one of another checkpoint of the run (retrained under the
    same directory) or of other stand-in videos is evaluated again, its old record kept beside it."""
    agent = shutil.copytree(shipped_agents()["sac_rad_cartpole_swingup"], tmp_path / "agent")
    evaluation = Evaluation("", "robustness", {"num_videos": 2, **SHORT}, {"axis": "num_videos", "value": 2, "dynamic": False})
    out = tmp_path / "evaluation"
    run = lambda: evaluate_checkpoint(agent, [(out, evaluation)], settings={"eval.episodes": 1})[0]  # noqa: E731
    first = run()
    assert first["config"]["evaluated_from"]["checkpoint_sha256"] == checkpoint_sha256(agent)
    assert run() == first and not list(out.glob("results.stale-*.json"))  # reused as it is
    for stale, reason in [({"eval_env": {**first["eval_env"], "embedded_videos": EMBEDDED_VERSION - 1}}, "videos"),
                          ({"config": {**first["config"], "evaluated_from": {
                              **first["config"]["evaluated_from"], "checkpoint_sha256": "0" * 64}}}, "checkpoint")]:
        (out / "results.json").write_text(json.dumps({**first, **stale}))
        again = run()
        assert again["wall_time"] != first["wall_time"], reason  # evaluated again
        assert again["eval_env"]["embedded_videos"] == EMBEDDED_VERSION
        assert again["eval"]["returns"] == first["eval"]["returns"]  # the same agent, videos, seeds
    kept = sorted(out.glob("results.stale-*.json"))
    assert [p.name for p in kept] == ["results.stale-1.json", "results.stale-2.json"]
    assert json.loads(kept[1].read_text())["config"]["evaluated_from"]["checkpoint_sha256"] == "0" * 64


def test_stale_reason_names_what_changed():
    shown = {"num_videos": 2, "background_blend": 1.0, "background_dir": None}
    done = {"config": {"evaluated_from": {"checkpoint_sha256": "a" * 64}},
            "eval_env": {**shown, "embedded_videos": EMBEDDED_VERSION}}
    assert stale_reason(done, "a" * 64, shown) is None
    assert "another checkpoint (SHA-256 aaaaaaaaaaaa…, now bbbbbbbbbbbb…)" in stale_reason(done, "b" * 64, shown)
    unversioned = {"eval_env": shown}  # before versions and digests were recorded: stand-ins version 1
    assert stale_reason(unversioned, "a" * 64, shown) == (
        f"it showed stand-in videos version 1, today's are version {EMBEDDED_VERSION}")
    no_videos = {"num_videos": 0, "background_blend": 1.0, "background_dir": None}
    assert stale_reason({"eval_env": no_videos}, "a" * 64, no_videos) is None


def test_an_evaluation_renders_on_the_chosen_device_and_records_it(tmp_path, monkeypatch):
    """``execution.render_device``: an EGL index renders there (here 0, in a process spawned on it,
    this process pretending to render on 1) with the returns of this process; recorded in the config."""
    agent = shipped_agents()["sac_rad_cartpole_swingup"]
    evaluation = Evaluation("", "robustness", {"camera_scale": 0.2, **SHORT},
                            {"axis": "camera_scale", "value": 0.2, "dynamic": False})
    (here,) = evaluate_checkpoint(agent, [(tmp_path / "here", evaluation)], settings={"eval.episodes": 1})
    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "1")
    (there,) = evaluate_checkpoint(agent, [(tmp_path / "there", evaluation)],
                                   settings={"eval.episodes": 1, "execution.render_device": 0})
    assert here["config"]["execution"]["render_device"] == "process" and there["config"]["execution"]["render_device"] == 0
    assert there["eval"]["returns"] == here["eval"]["returns"]
