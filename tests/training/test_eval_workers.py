"""The recipes' evaluation with ``eval.num_workers`` > 1 on the CPU: each env in a process of its own.

A batched policy on the CPU makes the parallel env's workers wait while it acts on the batch
(docs/performance.md, "Evaluation on the CPU"), so there the workspace evaluates through
:func:`~dcs_torchrl.evaluation.protocol.evaluate_in_processes`: the episodes a batched evaluation gives,
each env's observations given to the policy one at a time.
"""
import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf
from torchrl.envs import SerialEnv

from dcs_torchrl.evaluation.protocol import evaluate
from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import RunDirectory
from dcs_torchrl.training.loop import EVAL_SEED_OFFSET, Workspace


def test_cpu_evaluation_with_workers_runs_each_env_in_its_own_process(tmp_path):
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("sac", overrides=[
            "seed=3", "eval.num_workers=2", "pixels.image_size=32", "env.action_repeat=100", "network.hidden_dim=16",
            "replay_buffer.size=16", "algo.batch_size=4", "eval.video=false", "progress=false",
        ])
    run = RunDirectory(tmp_path / "run", OmegaConf.to_container(cfg, resolve=True))
    run.claim()
    with Workspace(cfg, agent_class("sac"), run) as workspace:
        assert workspace.eval_make is not None
        assert tuple(workspace.eval_env.batch_size) == (1,)  # the env here records the video only
        seed = cfg.seed + EVAL_SEED_OFFSET
        result = workspace._evaluation(3, seed=seed)
        batched = SerialEnv(2, workspace.eval_make)  # sub-env i seeded as ParallelSuiteEnv's worker i
        try:
            expected = evaluate(batched, workspace.eval_policy, 3, seed=seed)
        finally:
            batched.close()
    # the policy acts on one observation or on a batch of two: the same episodes up to its float rounding
    assert result.episodes == 3 and len(set(result.returns)) == 3
    assert result.returns == pytest.approx(expected.returns, rel=1e-4, abs=1e-4)
