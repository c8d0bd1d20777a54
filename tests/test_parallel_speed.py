"""benchmarks/parallel_speed.py runs as one command: the cores' ceiling line, then each chosen
path's rounds and its row in the table (tiny sizes; the figures come from the README's command)."""
import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import parallel_speed  # noqa: E402

# each kind of path once (the ParallelSuiteEnv variants differ only in their keyword arguments, tested in test_parallel.py)
PATHS = ["one env", "ParallelSuiteEnv", "2 processes", "ParallelSuiteEnv, LP_NUM_THREADS=0"]


@pytest.mark.slow  # the benchmark script's own run (~45 s: spawned workers and processes); the parallel env itself: test_parallel.py
def test_the_benchmark_prints_the_ceiling_and_a_row_per_path(capsys):
    before = dict(os.environ)
    results = parallel_speed.main(["--steps", "3", "--rounds", "1", "--benchmarks", "none", "--ceiling-rounds", "1",
                                   "--inline", "--only", *PATHS])
    assert dict(os.environ) == before  # LP_NUM_THREADS=0 only in the inline path's process
    out = capsys.readouterr().out
    assert "the cores' ceiling: 2 one-thread matmul processes at once = " in out
    assert list(results) == ["none"] and list(results["none"]) == PATHS
    for name in PATHS:
        assert f"| {name} | " in out
        [(rate, cpu_share)] = results["none"][name]
        assert rate > 0 and cpu_share >= 0, (name, rate, cpu_share)


def test_an_unknown_path_is_refused_with_the_paths_named(capsys):
    with pytest.raises(SystemExit):
        parallel_speed.main(["--only", "ParallelEnvv"])
    assert "unknown path(s) ['ParallelEnvv']; the paths: ['one env', 'ParallelEnv'," in capsys.readouterr().err
