"""benchmarks/evaluation_speed.py runs as one command: a row per path, the returns of each path's
episodes (one episode each here; the figures come from the README's command)."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import evaluation_speed  # noqa: E402


@pytest.mark.slow  # the benchmark script's own run (spawned evaluations); the paths' equal episodes: test_evaluation.py, test_pretrained.py
def test_the_benchmark_times_each_path_and_the_two_env_paths_run_the_same_episodes(capsys):
    results = evaluation_speed.main(["--episodes", "2", "--rounds", "1"])
    out = capsys.readouterr().out
    paths = ["one env", "2 processes (workers=2)", "ParallelSuiteEnv, batched policy"]
    assert list(results["seconds"]) == paths
    for name in paths:
        assert f"| {name} | " in out and results["seconds"][name][0] > 0
    # two envs with the same seeds: the same two episodes, a batch of two rounding the policy's floats otherwise
    assert results["returns"]["2 processes (workers=2)"] == pytest.approx(
        results["returns"]["ParallelSuiteEnv, batched policy"], rel=1e-3)
    assert results["returns"]["one env"][0] == results["returns"]["2 processes (workers=2)"][0]  # env 0: one env's seed
