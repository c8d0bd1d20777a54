"""benchmarks/gpu_speed.py, the GPU benchmark's one command, runs where there is no GPU too
(``--device cpu``, tiny sizes): its phases, reference, FLOP count and table. On CUDA:
tests/training/test_cuda.py::test_the_gpu_benchmark_runs_as_one_command; the recipe-loop part:
the slow test below."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import gpu_speed  # noqa: E402

TINY = ["--device", "cpu", "--batch-sizes", "2", "--updates", "2", "--warmup", "2", "--hidden", "16", "--matmul-size", "64"]


def test_one_command_prints_every_phase_and_the_update_against_the_reference(capsys):
    rows = gpu_speed.main([*TINY, "--loop-steps", "0"])
    out = capsys.readouterr().out
    assert out.startswith("CPU: ") and "| SAC+DrQ | 2 | eager | cpu |" in out and "| QT-Opt+DrQ | 2 | eager | cpu |" in out
    assert [r["method"] for r in rows] == ["SAC+DrQ", "QT-Opt+DrQ"]
    for row in rows:
        assert all(row[k] > 0 for k in ("sample_s", "update_s", "act_s", "ref_s", "flops")), row


def test_variants_that_need_cuda_are_refused_on_the_cpu():
    with pytest.raises(SystemExit, match="needs CUDA"):
        gpu_speed.main([*TINY, "--loop-steps", "0", "--variants", "cudagraph"])
    with pytest.raises(SystemExit, match="unknown variant"):
        gpu_speed.main([*TINY, "--loop-steps", "0", "--variants", "eager+fast"])


@pytest.mark.slow  # a recipe run in a subprocess (~1 min on a 2-core CPU)
def test_the_loop_is_the_recipe_itself():
    rows = gpu_speed.main([*TINY, "--methods", "qtopt", "--loop-steps", "75", "--seed-steps", "10", "--no-flops"])
    assert rows[0]["loop"]["step_s"] > 0 and set(rows[0]["loop"]["phases_ms"]) == set(gpu_speed.LOOP_ROWS)
