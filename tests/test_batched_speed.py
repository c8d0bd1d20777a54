"""benchmarks/batched_speed.py runs as one command, with --processes too (tiny sizes; the figures come from its
documented command): every row it promises, each with a positive rate. In the default suite: the GPU box's
one command (benchmarks/gpu_check.sh batched) runs this script, with --processes."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mujoco_warp")

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "batched_speed.py"


def _run(*args: str) -> str:
    done = subprocess.run([sys.executable, str(SCRIPT), "--rounds", "1", "--seconds", "0.2", "--tasks", "cartpole:swingup",
                           *args], capture_output=True, text=True, timeout=600, env={**os.environ, "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def _rate(row: str) -> float:
    return float(row.split("|")[2].split()[0])


def test_the_benchmark_prints_the_batch_in_processes_beside_the_batch_in_one():
    out = _run("--sizes", "2", "--presets", "medium", "--no-gl", "--processes", "2")
    rows = [line for line in out.splitlines() if line.startswith("| warp N=2")]
    assert [row.split("|")[1].strip() for row in rows] == ["warp N=2", "warp N=2, 2 processes"]
    assert all(_rate(row) > 0 for row in rows)
    assert re.search(r"\| \d+% \| \d+% \| \d+% \|$", rows[0])  # the shares of the batch in this process

    out = _run("--physics-only", "--sizes", "4", "--processes", "2")
    header, _, row = [line for line in out.splitlines() if line.startswith("|")]
    assert "BatchPhysics in 2 processes" in header
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert len(cells) == len(header.strip("|").split("|")) == 8
    assert all(float(cell.split()[0]) > 0 for cell in cells[2:])
