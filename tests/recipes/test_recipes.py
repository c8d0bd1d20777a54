"""The SAC and QT-Opt recipes, run for real through Hydra in subprocesses with tiny budgets."""
from __future__ import annotations

import collections
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from dcs_torchrl.report.load import parse_run
from dcs_torchrl.training import read_metrics
from dcs_torchrl.training.checkpoint import list_checkpoints

ROOT = Path(__file__).resolve().parents[2]
TINY = [
    "total_frames=480", "collector.seed_steps=20", "algo.batch_size=16", "network.hidden_dim=32",
    "replay_buffer.size=1000", "pixels.image_size=32", "pixels.render_profile=fast", "eval.episodes=2",
    "eval.periodic_episodes=1", "eval.interval=240", "checkpoint.interval=160", "logger.interval=80", "progress=false",
]


def recipe(algo: str, run_dir: Path, *overrides: str, **kwargs) -> subprocess.CompletedProcess | subprocess.Popen:
    """Runs ``recipes/<algo>/<algo>.py``, or with ``package=True`` the package's entry point that the
    experiment launcher runs (``python -m dcs_torchrl.training --config-name=<algo>``)."""
    if kwargs.pop("package", False):
        entry = ["-m", "dcs_torchrl.training", f"--config-name={algo}"]
    else:
        entry = [str(ROOT / "recipes" / algo / f"{algo}.py")]
    command = [sys.executable, *entry, *TINY, *overrides, f"hydra.run.dir={run_dir}"]
    if kwargs.pop("background", False):
        return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return subprocess.run(command, capture_output=True, text=True, timeout=600, **kwargs)


def names(rows: list[dict]) -> set[str]:
    return {r["name"] for r in rows}


@pytest.mark.parametrize("algo,aug", [("sac", "none"), ("qtopt", "drq")])
def test_recipe_runs_end_to_end_and_is_skipped_once_finished(tmp_path, algo, aug):
    run_dir = tmp_path / "run"
    done = recipe(algo, run_dir, f"algo.aug={aug}", "env.benchmark=easy", "seed=3")
    assert done.returncode == 0, done.stdout + done.stderr
    results = json.loads((run_dir / "results.json").read_text())
    row = parse_run(results)  # the report reads it
    assert row["method"] == {"sac": "SAC", "qtopt": "QT-Opt+DrQ"}[algo]
    assert results["steps"] == 480 and results["seed"] == 3 and results["train_env"]["benchmark"] == "easy"
    assert results["eval"]["episodes"] == 2 and len(results["eval"]["returns"]) == 2
    assert results["config"]["algo"]["aug"] == aug
    metrics = read_metrics(run_dir / "metrics.csv")
    prefixes = {name.split("/")[0] for name in names(metrics)}
    assert {"train", "eval", "loss", "time"} <= prefixes
    assert (run_dir / "eval_episode.mp4").stat().st_size > 1000
    assert (run_dir / "learning_curve.png").stat().st_size > 1000
    before = (run_dir / "metrics.csv").read_bytes()
    # again through the package's entry point, from outside the clone: it finds the same run (same
    # run_config.json) and skips it (the recipe's script and the entry point both run train())
    package = recipe(algo, run_dir, f"algo.aug={aug}", "env.benchmark=easy", "seed=3", package=True, cwd=tmp_path)
    assert package.returncode == 0 and "already finished" in package.stdout, package.stdout + package.stderr
    assert (run_dir / "metrics.csv").read_bytes() == before


def test_sigkill_then_same_command_resumes_without_losing_or_repeating_rows(tmp_path):
    """Killed after a checkpoint, the same command resumes from it. The run starts with NCHW
    convolutions and resumes under the channels_last default: network.channels_last (and compile)
    change how the same math runs, not the run (the default went from false to true, and runs
    started before it still resume from their checkpoints)."""
    run_dir = tmp_path / "run"
    args = ("algo.aug=rad", "total_frames=960")
    process = recipe("sac", run_dir, *args, "network.channels_last=false", background=True)
    deadline = time.time() + 300
    while not list((run_dir / "checkpoints").glob("checkpoint_*.pt.sha256")) and time.time() < deadline:
        time.sleep(0.2)
    assert process.poll() is None, process.stdout.read()
    time.sleep(1.0)  # let it log past the checkpoint
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert not (run_dir / "results.json").exists()
    for frames, path in list_checkpoints(run_dir / "checkpoints"):  # each says what is due after it, not itself
        counters = torch.load(path, map_location="cpu", weights_only=True)["counters"]  # as a resume reads it
        assert counters["next_checkpoint"] > frames and counters["next_eval"] > frames, (frames, counters)
    resumed = recipe("sac", run_dir, *args)  # the default: channels_last=true
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert "resuming from the checkpoint at" in resumed.stdout
    rows = read_metrics(run_dir / "metrics.csv")
    counts = collections.Counter((r["frames"], r["name"]) for r in rows if r["name"] != "train/episode_return")
    assert max(counts.values()) == 1, [k for k, v in counts.items() if v > 1]
    logged = sorted(r["frames"] for r in rows if r["name"] == "time/fps")
    assert logged == list(range(80, 961, 80))  # every logging step once, before and after the kill
    episodes = [r["value"] for r in rows if r["name"] == "train/episodes"]
    assert episodes == sorted(episodes) and len(set(episodes)) == len(episodes)
    results = json.loads((run_dir / "results.json").read_text())
    assert results["steps"] == 960 and results["config"]["network"]["channels_last"] is True
    assert "channels_last" not in json.loads((run_dir / "run_config.json").read_text())["network"]


def test_a_run_killed_before_its_first_checkpoint_starts_again_from_frame_0(tmp_path):
    run_dir = tmp_path / "run"
    args = ("checkpoint.interval=100000",)  # no checkpoint before the end
    process = recipe("sac", run_dir, *args, background=True)
    deadline = time.time() + 300
    while time.time() < deadline and not any(r["name"] == "time/fps" for r in _rows(run_dir)):
        time.sleep(0.2)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert _rows(run_dir) and not list(run_dir.glob("checkpoints/checkpoint_*.pt"))
    again = recipe("sac", run_dir, *args)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "restarting from frame 0" in again.stdout
    rows = _rows(run_dir)
    counts = collections.Counter((r["frames"], r["name"]) for r in rows if r["name"] != "train/episode_return")
    assert max(counts.values()) == 1, [k for k, v in counts.items() if v > 1]
    assert sorted(r["frames"] for r in rows if r["name"] == "time/fps") == list(range(80, 481, 80))


def _rows(run_dir: Path) -> list[dict]:
    path = run_dir / "metrics.csv"
    return read_metrics(path) if path.exists() else []


def _science(rows: list[dict]) -> list[tuple]:
    """Every logged value except timings (frames, name, value)."""
    return [(r["frames"], r["name"], r["value"]) for r in rows if not r["name"].startswith("time/")]


def test_same_seed_reproduces_the_run_exactly(tmp_path):
    """On one machine with the same settings, a CPU run's losses, returns and evaluation repeat exactly."""
    runs = [recipe("sac", tmp_path / name, "algo.aug=rad", "env.benchmark=easy", "env.dynamic=true", "seed=5")
            for name in ("a", "b")]
    for done in runs:
        assert done.returncode == 0, done.stdout + done.stderr
    a, b = (_science(read_metrics(tmp_path / name / "metrics.csv")) for name in ("a", "b"))
    assert any(name.startswith("loss/") for _, name, _ in a)
    assert a == b
    results = [json.loads((tmp_path / name / "results.json").read_text())["eval"] for name in ("a", "b")]
    assert results[0] == results[1]
    # the console log is the file Hydra keeps in the run directory
    assert "final evaluation after 480 frames" in (tmp_path / "a" / "sac.log").read_text()
