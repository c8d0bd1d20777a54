"""benchmarks/concurrent_runs.py: N recipe runs started together, each timed from its own
metrics.csv, the aggregate against one run's (on the CPU, tiny sizes; the GPU figure:
docs/performance.md)."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import concurrent_runs  # noqa: E402

TINY = ["--device", "cpu", "--batch-size", "4", "--hidden", "16", "--seed-steps", "10", "--loop-steps", "75"]


@pytest.mark.slow  # the benchmark script's own run (three recipe runs in subprocesses, ~40 s)
def test_two_runs_at_once_are_each_timed_and_summed(capsys):
    rows = concurrent_runs.main([*TINY, "--runs", "1", "2", "--threads", "1"])
    assert [r["runs"] for r in rows] == [1, 2] and [len(r["fps"]) for r in rows] == [1, 2]
    assert all(f > 0 for r in rows for f in r["fps"])
    assert rows[1]["aggregate"] == pytest.approx(sum(rows[1]["fps"]))
    out = capsys.readouterr().out
    assert out.startswith("CPU: ") and "| 2 | 1 |" in out and "| 1 | 1 |" in out


@pytest.mark.parametrize("bad, message", [
    (["--runs", "0"], "each count must be at least 1"),
    (["--threads", "two"], "--threads must be auto or a positive integer"),
])
def test_bad_arguments_name_the_fix(bad, message, capsys):
    with pytest.raises(SystemExit):
        concurrent_runs.main([*TINY, *bad])
    assert message in capsys.readouterr().err


def test_an_unknown_variant_is_refused_before_any_run_starts():
    with pytest.raises(SystemExit, match="unknown variant"):
        concurrent_runs.main([*TINY, "--variant", "eager+fast"])
