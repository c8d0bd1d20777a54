"""Bad recipe input: a clear error that names the fix, raised before anything is written."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest
from hydra import compose, initialize_config_module
from hydra.errors import ConfigCompositionException

from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import RunMismatchError, train


def config(algo: str, *overrides: str):
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        return compose(algo, overrides=list(overrides))


@pytest.mark.parametrize(
    "algo,overrides,error,match",
    [
        ("sac", ["algo.aug=crop"], ValueError, r"unknown augmentation 'crop'.*algo.aug="),
        ("qtopt", ["algo.name=ppo"], ValueError, r"unknown algorithm 'ppo'"),
        ("sac", ["env.benchmark=extreme"], ValueError, r"unknown benchmark 'extreme'; choose one of"),
        ("sac", ["env.task=sprint"], ValueError, r"unknown task 'sprint'"),
        ("qtopt", ["env.background_dir=/no/such/davis"], FileNotFoundError, r"env.background_dir='/no/such/davis' does not exist"),
        ("sac", ["algo.batch_size=2048", "replay_buffer.size=1000"], ValueError, r"larger than the replay buffer"),
        ("sac", ["total_frames=0"], ValueError, r"total_frames must be a positive integer"),
    ],
)
def test_bad_settings_fail_before_writing(tmp_path, algo, overrides, error, match):
    cfg = config(algo, *overrides)
    with pytest.raises(error, match=match):
        train(cfg, agent_class(algo), tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_unknown_setting_is_refused_by_hydra():
    with pytest.raises(ConfigCompositionException, match="env.cam_scale"):
        config("sac", "env.cam_scale=0.3")


def test_resume_with_another_config_is_refused_and_overwrites_nothing(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    recorded = {"seed": 0, "env": {"domain": "cartpole", "task": "swingup"}}
    (run / "run_config.json").write_text(json.dumps(recorded))
    (run / "metrics.csv").write_text("frames,name,value,wall_time\n")
    cfg = config("sac", "algo.aug=rad")
    with pytest.raises(RunMismatchError, match="holds a run of another configuration"):
        train(cfg, agent_class("sac"), run)
    assert json.loads((run / "run_config.json").read_text()) == recorded
    assert (run / "metrics.csv").read_text() == "frames,name,value,wall_time\n"


FAILING_RUN = """
import sys
from hydra import compose, initialize_config_module
from dcs_torchrl.training import train

def broken_agent(*args):
    raise RuntimeError("the agent could not be built")

with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
    cfg = compose(sys.argv[1], overrides=["pixels.image_size=48", "pixels.render_profile=fast", "progress=false",
                                              "collector.num_workers=2"])
train(cfg, broken_agent, sys.argv[2])
"""


def test_an_error_after_the_env_workers_started_ends_the_process(tmp_path):
    # the spawned env workers (collector.num_workers=2) are closed on the way out; left open, the process never exits
    done = subprocess.run([sys.executable, "-c", FAILING_RUN, "sac", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode != 0 and "the agent could not be built" in done.stderr
