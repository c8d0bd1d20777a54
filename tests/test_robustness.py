"""python -m dcs_torchrl.robustness: the shipped agent's curves, in worker processes, resumable."""
import csv
import json

import pytest

from dcs_torchrl.pretrained import load_pretrained, shipped_agents
from dcs_torchrl.robustness import Point, main, robustness_sweep, sweep_agent, sweep_points

AGENT = "sac_rad_cartpole_swingup"


def test_points_share_the_undistracted_env_and_validate():
    points = sweep_points(["camera", "background"], [0.0, 0.5], "both", reference_blend=True)
    assert len(points) == 8 and len({p.key() for p in points}) == 5  # intensity 0 is one env for all
    background = Point("background", 0.5, True, True)
    assert background.overrides("/videos", 8) == {"background_blend": 0.5, "num_videos": 8, "dynamic": True,
                                               "reference_blend": True, "background_dir": "/videos"}
    assert not any(p.reference_blend for p in points if p.axis == "camera")
    with pytest.raises(ValueError, match="unknown axes"):
        sweep_points(["colour"])
    with pytest.raises(ValueError, match=r"in \[0, 1\]"):
        sweep_points(["camera"], [0.0, 1.5])
    with pytest.raises(ValueError, match="unknown setting"):
        sweep_points(["camera"], [0.0], "moving")
    with pytest.raises(FileNotFoundError, match="sac_rad_cartpole_swingup"):
        sweep_agent("no_such_agent", points, "unused")


def test_workers_give_every_episode_the_return_of_a_single_env_evaluation(tmp_path):
    points = [Point("camera", 0.3, True), Point("background", 0.5, True, reference_blend=True), Point("color", 0.0, False)]
    rows = sweep_agent(AGENT, points, tmp_path, episodes=2, workers=2, progress=False)
    agent = load_pretrained(AGENT)
    for point, row in zip(points, rows):
        alone = agent.evaluate(2, **point.overrides())  # this process, one env: the recipes' final evaluation
        assert row["returns"] == list(alone.returns), point
    assert rows[0]["returns"] != rows[2]["returns"]

    # run again: every point is read back, nothing evaluated, nothing rewritten
    stored = {p: p.stat().st_mtime_ns for p in (tmp_path / "points").iterdir()}
    assert len(stored) == 3
    again = sweep_agent(AGENT, points, tmp_path, episodes=2, workers=2, progress=False)
    assert again == rows and {p: p.stat().st_mtime_ns for p in (tmp_path / "points").iterdir()} == stored

    # another agent's points in the directory: refused, nothing touched
    record = json.loads(next(iter(stored)).read_text())
    record["agent"]["seed"] = 99
    next(iter(stored)).write_text(json.dumps(record))
    with pytest.raises(FileExistsError, match="another agent"):
        sweep_agent(AGENT, points, tmp_path, episodes=2, progress=False)


def test_command_writes_table_csv_and_figure(tmp_path, capsys):
    out = tmp_path / "out"
    paths = main([AGENT, "--axes", "color", "--intensities", "0", "1", "--episodes", "1", "--workers", "1",
                  "--out", str(out), "--no-progress"])
    with open(paths["csv"]) as f:
        rows = list(csv.DictReader(f))
    assert [(r["axis"], r["value"]) for r in rows] == [("color", "0.0"), ("color", "1.0")]
    assert "half at" in paths["md"].read_text() and paths["png"].stat().st_size > 10_000
    assert "Where the score falls to half" in capsys.readouterr().out


def test_any_policy_and_env_factory():
    agent = load_pretrained(shipped_agents()[AGENT])
    points = sweep_points(["color"], [0.0, 0.5])
    rows = robustness_sweep(agent.policy, lambda **o: agent.make_env(**o), points, episodes=1, seed=agent.eval_seed)
    assert rows[0]["returns"] == list(agent.evaluate(1).returns)
    assert rows[1]["returns"] == list(agent.evaluate(1, color_scale=0.5, dynamic=False).returns)


def test_workers_end_when_the_command_is_killed(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    command = [sys.executable, "-m", "dcs_torchrl.robustness", AGENT, "--axes", "camera", "--intensities", "0.1", "0.2",
               "--episodes", "50", "--workers", "2", "--out", str(tmp_path), "--no-progress"]
    main = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def workers():
        out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(main.pid)], capture_output=True, text=True).stdout
        return [int(p) for p in out.split()]

    deadline = time.time() + 120
    while len(workers()) < 2 and time.time() < deadline:
        time.sleep(0.5)
    children = workers()
    assert children, "the command started no workers"
    os.kill(main.pid, signal.SIGKILL)
    main.wait()
    deadline = time.time() + 30
    alive = children
    while alive and time.time() < deadline:
        time.sleep(0.5)
        alive = [p for p in alive if os.path.exists(f"/proc/{p}") and "Z" not in open(f"/proc/{p}/stat").read().split()[2]]
    assert not alive, f"workers {alive} outlived the command"
