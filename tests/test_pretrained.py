"""The shipped trained agent: the suite's end-to-end regression test.

SAC+RAD trained on cartpole swingup from the suite's pixels (docs/results.md). A change in
rendering, camera placement or colours that moves what the agent sees makes it fail here.
"""
import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from dcs_torchrl.evaluation import evaluate
from dcs_torchrl.pretrained import load_pretrained

ROOT = Path(__file__).resolve().parents[1]
AGENT = ROOT / "recipes/pretrained/sac_rad_cartpole_swingup"
RANDOM_POLICY = 125  # a random policy's return on cartpole swingup (docs/results.md: 125 ± 6)


def test_shipped_agent_is_small_and_networks_only():
    files = [p for p in AGENT.rglob("*") if p.is_file()]
    assert sum(p.stat().st_size for p in files) <= 15e6
    (checkpoint,) = AGENT.glob("checkpoints/checkpoint_*.pt")
    state = torch.load(checkpoint, map_location="cpu", weights_only=False)
    assert set(state) == {"policy"}  # no replay buffer, no optimiser state, no critics


def test_shipped_agent_far_above_a_random_policy():
    agent = load_pretrained(AGENT)
    assert agent.results["method"] == "SAC+RAD" and agent.results["domain"] == "cartpole"
    env = agent.make_env(seed=0)
    try:
        result = evaluate(env, agent.policy, 3, seed=10_000)
    finally:
        env.close()
    assert result.mean > 4 * RANDOM_POLICY, result.returns


def test_shipped_agent_acts_under_any_make_env_setting():
    agent = load_pretrained(AGENT)
    env = agent.make_env(benchmark="medium", dynamic=True, seed=1)
    try:
        with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
            rollout = env.rollout(5, agent.policy)
    finally:
        env.close()
    assert rollout["action"].shape == (5, 1) and rollout["action"].abs().max() <= 1


def test_evaluate_recipe_on_the_shipped_agent(tmp_path):
    out = tmp_path / "eval"
    done = subprocess.run(
        [sys.executable, str(ROOT / "recipes/evaluate/evaluate.py"), f"train_dir={AGENT}", "eval_env.camera_scale=0.3",
         "eval.episodes=2", f"hydra.run.dir={out}"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    results = json.loads((out / "results.json").read_text())
    assert results["eval"]["episodes"] == 2 and results["eval_env"]["camera_scale"] == 0.3
    assert results["method"] == "SAC+RAD"


def test_export_refuses_to_overwrite(tmp_path):
    from dcs_torchrl.pretrained import export_policy

    with pytest.raises(FileExistsError, match="nothing is overwritten"):
        export_policy(AGENT, AGENT)


def test_shipped_agents_load_by_name_and_bad_names_say_which_exist():
    from dcs_torchrl.pretrained import agent_directory, shipped_agents

    assert shipped_agents()["sac_rad_cartpole_swingup"].resolve() == AGENT.resolve()
    assert agent_directory("sac_rad_cartpole_swingup").resolve() == AGENT.resolve()
    with pytest.raises(FileNotFoundError, match="sac_rad_cartpole_swingup"):
        agent_directory("sac_rad_cartpole_swingup_v2")
    agent = load_pretrained("sac_rad_cartpole_swingup", final=True)
    assert agent.results["steps"] == 100_000 and agent.eval_seed == 10_000
