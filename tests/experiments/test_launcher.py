"""The experiments through the real launcher: Hydra multirun, submitit's local executor, the recipes.

CI runs a subset of the smoke grid of experiment ``robustness`` (one method, one seed, the two
smoke tasks, the camera at intensities 0 and 1): training, evaluation-only runs from the
checkpoints (in the job's process: each spawned process costs seconds; ``budget.eval_processes``
reaches them, tests/experiments/test_grid.py, and evaluations in spawned processes are
tests/experiments/test_evaluate.py's and tests/test_robustness.py's), a failed run listed and
relaunched alone, a relaunch that skips everything, the report; and the SLURM launcher up to ``sbatch``. The whole smoke grid of every experiment, and a
launcher killed mid-way, are ``slow``.
"""
from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import matplotlib.image
import pandas as pd
import pytest

from dcs_torchrl.report.__main__ import main as report

REPO = Path(__file__).resolve().parents[2]
RUN = [sys.executable, str(REPO / "recipes" / "experiments" / "run.py"), "-m"]
SUBSET = ["experiment=robustness", "budget.methods=[SAC+RAD]", "budget.seeds=[0]", "budget.eval_processes=1",
          "experiment.train.0.evaluate=[{axis:camera,values:[0.0,1.0]}]", "budget.recipe.total_frames=200",
          "budget.recipe.eval.episodes=1", "budget.recipe.pixels.image_size=32"]
CARTPOLE = "SAC+RAD/cartpole-swingup/none/seed_0"
BALL = "SAC+RAD/ball_in_cup-catch/none/seed_0"


def launch(args: list[str], **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=1800, cwd=REPO, **kwargs)


def jobs(output: str) -> list[str]:
    """The run ids Hydra launched (its `#<n> : run=<id> ...` lines)."""
    return [line.split("run=")[1].split()[0] for line in output.splitlines() if "\t#" in line and "run=" in line]


@pytest.fixture(scope="module")
def robustness(tmp_path_factory):
    root = tmp_path_factory.mktemp("smoke")
    conflict = root / "benchmarks" / CARTPOLE  # a directory of another run: its job fails, the sweep goes on
    conflict.mkdir(parents=True)
    (conflict / "run_config.json").write_text(json.dumps({"seed": 99}))
    first = launch([*RUN, *SUBSET, f"root={root}"])
    first.record = json.loads((root / "status" / "robustness" / f"{CARTPOLE}.json").read_text())
    (conflict / "run_config.json").unlink()
    relaunch = shlex.split(first.stdout.strip().splitlines()[-1])
    second = launch([sys.executable, *relaunch[1:]])
    mtimes = {p: p.stat().st_mtime for p in root.rglob("results.json")}
    third = launch([*RUN, *SUBSET, f"root={root}"])
    return root, first, second, third, mtimes


def test_a_failed_run_is_listed_and_the_others_finish(robustness):
    root, first, *_ = robustness
    assert first.returncode == 1, first.stdout + first.stderr
    assert sorted(jobs(first.stderr + first.stdout)) == sorted([BALL, CARTPOLE])
    status = first.stdout
    assert "2 runs" in status and "1 done" in status and "1 failed" in status
    failed = next(line for line in status.splitlines() if line.strip().startswith("failed"))
    assert CARTPOLE in failed and "another configuration" in failed
    record = first.record  # the status file as the first launch left it
    assert record["state"] == "failed" and record["stage"] == "train" and Path(record["log"]).is_file()
    assert (root / "benchmarks" / BALL / "results.json").is_file()


def test_the_failed_run_is_relaunched_alone(robustness):
    root, first, second, *_ = robustness
    assert first.stdout.strip().splitlines()[-1].endswith(f"run={CARTPOLE}")
    assert second.returncode == 0, second.stdout + second.stderr
    assert jobs(second.stderr + second.stdout) == [CARTPOLE]
    assert "2 done" in second.stdout
    assert (root / "benchmarks" / CARTPOLE / "results.json").is_file()


def test_a_relaunch_skips_finished_runs(robustness):
    root, *_, third, mtimes = robustness
    assert third.returncode == 0, third.stdout + third.stderr
    assert {p: p.stat().st_mtime for p in root.rglob("results.json")} == mtimes
    for run in (BALL, CARTPOLE):
        assert "already finished" in (root / "benchmarks" / run / "train.log").read_text().splitlines()[-1]


def test_evaluation_only_runs_reuse_the_trained_checkpoint(robustness):
    root, *_ = robustness
    for run in (BALL, CARTPOLE):
        trained = json.loads((root / "benchmarks" / run / "results.json").read_text())
        evaluations = sorted((root / "robustness" / run).glob("*/results.json"))
        assert len(evaluations) == 2 * 2  # camera at 0 and 1, static and dynamic
        for path in evaluations:
            result = json.loads(path.read_text())
            assert result["experiment"] == "robustness" and result["steps"] == trained["steps"] == 200
            assert result["train_env"] == trained["train_env"] and result["eval"]["episodes"] == 1
            assert result["eval_env"]["dynamic"] == result["sweep"]["dynamic"]
            if result["sweep"]["value"] == 0:  # no distraction: the training's own final evaluation, episode by episode
                assert result["eval"]["returns"] == trained["eval"]["returns"]
        camera = json.loads((root / "robustness" / run / "camera-1-dynamic" / "results.json").read_text())
        assert camera["eval_env"]["camera_scale"] == 1.0 and camera["train_env"]["camera_scale"] == 0.0


def test_the_report_draws_the_robustness_curves(robustness, tmp_path):
    root, *_ = robustness
    assert report([str(root), "--out", str(tmp_path), "--experiment", "robustness"]) == 0
    curves = pd.read_csv(tmp_path / "tables" / "robustness_curves.csv")
    assert set(curves["axis"]) == {"camera"} and set(curves["value"]) == {0.0, 1.0}
    mean = curves[curves["task"] == "mean"]
    assert set(mean["n_tasks"]) == {2} and len(mean) == 2 * 2
    assert sorted(set(curves["task"])) == ["ball_in_cup-catch", "cartpole-swingup", "mean"] and len(curves) == 3 * 2 * 2
    image = matplotlib.image.imread(tmp_path / "figures" / "robustness.png")
    assert image.shape[1] >= 900 and image.std() > 0.05


def test_slurm_launcher_submits_one_job_array_with_the_resources(tmp_path):
    """Up to sbatch: a fake sbatch (and srun) on PATH captures the submission script."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "sbatch").write_text('#!/bin/sh\ncp "$1" "$CAPTURE"\necho "sbatch: no cluster here" >&2\nexit 1\n')
    (bin_dir / "srun").write_text("#!/bin/sh\nexit 0\n")
    for tool in bin_dir.iterdir():
        tool.chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "CAPTURE": str(tmp_path / "job.sh")}
    done = launch([*RUN, "experiment=benchmarks", "launcher=slurm", "hydra.launcher.partition=gpu",
                   f"root={tmp_path / 'root'}"], env=env)
    assert done.returncode != 0 and "sbatch: no cluster here" in done.stderr
    script = (tmp_path / "job.sh").read_text()
    for line in ("--array=0-55%56", "--partition=gpu", "--gpus-per-node=1", "--cpus-per-task=8", "--time=1440",
                 "--signal=USR2@120", "--job-name=dcs_benchmarks"):
        assert f"#SBATCH {line}\n" in script, line
    assert "-m submitit.core._submit" in script


@pytest.mark.slow
def test_a_killed_launch_resumes_its_runs_from_their_checkpoints(tmp_path):
    args = [*RUN, "experiment=benchmarks", "budget.methods=[SAC+RAD]", "budget.seeds=[0]",
            "budget.tasks=[cartpole-swingup]", "budget.recipe.total_frames=3200", f"root={tmp_path}"]
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO, start_new_session=True)
    deadline = time.time() + 900
    while not list(tmp_path.glob("benchmarks/*/*/*/*/checkpoints/*.pt.sha256")) and time.time() < deadline:
        time.sleep(0.5)
    os.killpg(process.pid, signal.SIGKILL)  # the launcher, its jobs and their recipes
    process.wait()
    killed = {p.parent.parent for p in tmp_path.glob("benchmarks/*/*/*/*/checkpoints/*.pt.sha256")}
    assert killed and not any((run / "results.json").exists() for run in killed)
    status = launch([sys.executable, str(REPO / "recipes/experiments/status.py"), *args[3:]])
    assert "interrupted" in status.stdout
    again = launch(args)
    assert again.returncode == 0, again.stdout + again.stderr
    for run in killed:
        assert "resuming from the checkpoint at" in (run / "train.log").read_text()
        assert json.loads((run / "results.json").read_text())["steps"] == 3200


EXPERIMENTS = ("benchmarks", "robustness", "training", "interactions")
TABLES = [f"tables/benchmark_{b}.md" for b in ("none", "easy", "medium", "blind")] + [
    "tables/interactions.md", "tables/robustness_curves.md", "tables/training_curves.md"]
FIGURES = ["figures/benchmarks_static.png", "figures/benchmarks_dynamic.png", "figures/robustness.png",
           "figures/training.png"]


@pytest.mark.slow
def test_the_whole_smoke_grid_produces_every_table_and_figure(tmp_path):
    root = tmp_path / "smoke"
    for experiment in EXPERIMENTS:
        done = launch([*RUN, f"experiment={experiment}", "budget=smoke", f"root={root}"])
        assert done.returncode == 0, done.stdout + done.stderr
        assert " 0 " not in done.stdout and "done" in done.stdout and "failed" not in done.stdout
    out = tmp_path / "report"
    assert report([str(root), "--out", str(out)]) == 0
    for rel in TABLES + FIGURES:
        assert (out / rel).is_file(), rel
    runs = pd.read_csv(out / "runs.csv")
    assert set(runs["experiment"]) == {"benchmarks", "robustness", "training"}
    assert set(zip(runs["domain"], runs["task"])) == {("ball_in_cup", "catch"), ("cartpole", "swingup")}
    interactions = pd.read_csv(out / "tables" / "interactions.csv")
    ran = interactions[interactions["method"].isin(set(runs["method"]))]  # the table lists the paper's four methods
    assert len(ran) == 2 * 2 * 2  # smoke methods x easy, medium x static, dynamic
    assert ran[["camera", "color", "background", "benchmark"]].notna().all().all()
