"""The recipes' seeds: every worker and distraction its own stream, evaluation apart from training.

The batched envs are built by the recipes' own code (:func:`batched_pixel_env`, :class:`Workspace`)
with their workers in this process, so that each worker's env can be looked at: ``SerialEnv``
seeds its workers as ``ParallelSuiteEnv`` and ``ParallelEnv`` do (each the seed the previous one's ``set_seed`` returns).
"""
import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf
from torchrl.envs import DMControlEnv, SerialEnv

from dcs_torchrl.envs import resolve_settings
from dcs_torchrl.evaluation.protocol import evaluate
from dcs_torchrl.methods import agent_class
from dcs_torchrl.training import RunDirectory
from dcs_torchrl.training import loop
import dcs_torchrl.training.envs as training_envs
from dcs_torchrl.training.envs import batched_pixel_env, close_env
from dcs_torchrl.training.loop import Workspace
from dcs_torchrl.vector import parallel
from dcs_test_utils import distraction_streams, shared_streams


def _evaluate_in_this_process(make, policy, episodes, workers, *, seed):
    """evaluate_in_processes's seeds and episodes (env i seeded as a batched env's sub-env i), its envs here."""
    env = SerialEnv(workers, make)
    try:
        return evaluate(env, policy, episodes, seed=seed)
    finally:
        env.close()


@pytest.fixture
def workers_in_process(monkeypatch):
    in_process = lambda num_workers, make, **_: SerialEnv(num_workers, make)  # noqa: E731
    monkeypatch.setattr(training_envs, "ParallelSuiteEnv", in_process)
    monkeypatch.setattr(parallel, "ParallelSuiteEnv", in_process)  # make_env(num_envs=N)'s GL envs
    monkeypatch.setattr(loop, "evaluate_in_processes", _evaluate_in_this_process)


@pytest.fixture
def physics_seeds(monkeypatch):
    """Every seed given to a DM Control env's physics, as ``(env, seed)`` in order."""
    seeds = []
    original = DMControlEnv._set_seed

    def recording(self, seed):
        seeds.append((self, seed))
        return original(self, seed)

    monkeypatch.setattr(DMControlEnv, "_set_seed", recording)
    return seeds


def _workers(env) -> list:
    """The per-worker suite envs of a batched pixel env (in-process workers)."""
    return list(env.base_env._envs)


def test_every_worker_and_distraction_draws_its_own_stream(workers_in_process):
    settings = resolve_settings("cartpole", "swingup", benchmark="easy")
    env = batched_pixel_env(settings, num_workers=2, seed=5, image_size=16)
    try:
        streams = {(f"worker {i}", name): numbers for i, worker in enumerate(_workers(env))
                   for name, numbers in distraction_streams(worker).items()}
    finally:
        close_env(env)
    assert len(streams) == 6
    assert shared_streams(streams) == []


def test_evaluation_seeds_are_disjoint_from_the_training_seeds(tmp_path, workers_in_process, physics_seeds):
    """The seeds the training workers get, against every seed an evaluation env gets: at its
    construction, at a periodic evaluation and at the final one (short episodes: action repeat 100).
    On the CPU the evaluations' two envs run in processes of their own (here in this process, with
    the same seeds), the workspace's evaluation env being the one that records the video."""
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        cfg = compose("sac", overrides=[
            "seed=3", "collector.num_workers=2", "eval.num_workers=2", "pixels.image_size=32", "env.action_repeat=100",
            "network.hidden_dim=16", "replay_buffer.size=16", "algo.batch_size=4", "eval.episodes=2",
            "eval.periodic_episodes=2", "eval.video=false", "progress=false",
        ])
    run = RunDirectory(tmp_path / "run", OmegaConf.to_container(cfg, resolve=True))
    run.claim()
    with Workspace(cfg, agent_class("sac"), run) as workspace:
        train_envs = [worker.base_env for worker in _workers(workspace.env)]
        workspace.resume()
        workspace.counters["steps"] = 7  # mid-training: frames = 700
        workspace._evaluate_periodically()
        workspace.finish()
    seeds_of = lambda envs: [seed for env, seed in physics_seeds if seed is not None and any(env is e for e in envs)]  # noqa: E731
    train = seeds_of(train_envs)
    evaluation = [seed for env, seed in physics_seeds if seed is not None and not any(env is e for e in train_envs)]
    assert len(set(train)) == 2 and len(set(evaluation)) == 4  # two envs' periodic seeds, two envs' final ones
    assert set(train) & set(evaluation) == set()
