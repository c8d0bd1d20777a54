"""python -m dcs_torchrl.robustness: the shipped agent's curves, in worker processes, resumable."""
import csv
import json
import re

import pytest

from dcs_torchrl.pretrained import load_pretrained, shipped_agents
from dcs_torchrl.robustness import (RENDERERS, Point, _parser, main, robustness_sweep, sweep_agent, sweep_points,
                                    write_outputs)
from dcs_torchrl.training.checkpoint import UntrustedCheckpointError
from test_pretrained import agent_that_runs_code

AGENT = "sac_rad_cartpole_swingup"


@pytest.fixture(scope="module")
def short_agent(tmp_path_factory):
    """The shipped agent acting every 100 physics steps (episodes of 10 steps, against 125): where and
    how a sweep evaluates its points holds for episodes of any length, at a tenth of the time."""
    import shutil

    directory = shutil.copytree(shipped_agents()[AGENT], tmp_path_factory.mktemp("agent") / AGENT)
    results = json.loads((directory / "results.json").read_text())
    results["config"]["env"]["action_repeat"] = 100
    (directory / "results.json").write_text(json.dumps(results))
    return directory


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
    with pytest.raises(ValueError, match=r"intensities \[0.5\] are given more than once"):
        sweep_points(["camera"], [0.5, 0.0, 0.5])
    with pytest.raises(ValueError, match="unknown setting"):
        sweep_points(["camera"], [0.0], "moving")
    with pytest.raises(FileNotFoundError, match="sac_rad_cartpole_swingup"):
        sweep_agent("no_such_agent", points, "unused")


def test_workers_give_every_episode_the_return_of_a_single_env_evaluation(tmp_path, monkeypatch, short_agent):
    """Each point's episodes in a spawned process are those of an evaluation in this process, and
    each process renders on its chosen device: --render-devices on a node shaped like four GPUs,
    render_devices=[2, 3] with three processes gives a pool of two processes on EGL device 2 and
    one on device 3 (process i on render_devices[i % len]). This machine has one EGL device, so
    each pool's device is recorded and its processes are spawned on device 0, with this process
    pretending to render on 1: a process that did not get its pool's variable fails its start.
    (One sweep for both checks: each spawned process costs seconds.)"""
    from dcs_torchrl.render import egl_devices
    from dcs_torchrl.render.egl_devices import EGL_DEVICE_VARIABLE
    from dcs_torchrl.vector import process_pool

    points = [Point("camera", 0.3, True), Point("background", 0.5, True, reference_blend=True), Point("color", 0.0, False)]
    agent = load_pretrained(short_agent)
    alone = [list(agent.evaluate(2, **p.overrides()).returns) for p in points]  # this process, one env each

    pools = []

    class OnDeviceZero(process_pool.SpawnedPool):
        def __init__(self, processes, *, environment, initargs, **kwargs):
            pools.append((environment[EGL_DEVICE_VARIABLE], processes))
            super().__init__(processes, environment={**environment, EGL_DEVICE_VARIABLE: 0},
                             initargs=(*initargs[:3], 0, *initargs[4:]), **kwargs)  # render: the 4th

    with monkeypatch.context() as device:
        device.setattr(process_pool, "SpawnedPool", OnDeviceZero)
        device.setattr(egl_devices, "render_device_indices", lambda devices: list(devices))
        device.setenv("MUJOCO_EGL_DEVICE_ID", "1")
        rows = sweep_agent(short_agent, points, tmp_path, episodes=2, workers=3, progress=False, render_devices=[2, 3])
    assert sorted(pools) == [(2, 2), (3, 1)]
    for point, row, returns in zip(points, rows, alone):  # the recipes' final evaluation, episode by episode
        assert row["returns"] == returns, point
    assert rows[0]["returns"] != rows[2]["returns"]

    # run again: every point is read back, nothing evaluated, nothing rewritten
    stored = {p: p.stat().st_mtime_ns for p in (tmp_path / "points").iterdir()}
    assert len(stored) == 3
    again = sweep_agent(short_agent, points, tmp_path, episodes=2, workers=2, progress=False)
    assert again == rows and {p: p.stat().st_mtime_ns for p in (tmp_path / "points").iterdir()} == stored

    # another agent's points in the directory: refused, nothing touched
    record = json.loads(next(iter(stored)).read_text())
    record["agent"]["seed"] = 99
    next(iter(stored)).write_text(json.dumps(record))
    with pytest.raises(FileExistsError, match="another agent"):
        sweep_agent(short_agent, points, tmp_path, episodes=2, progress=False)


def test_command_writes_table_csv_and_figure(tmp_path, capsys, short_agent):
    out = tmp_path / "out"
    paths = main([str(short_agent), "--axes", "color", "--intensities", "0", "1", "--episodes", "1", "--workers", "1",
                  "--out", str(out), "--no-progress"])
    with open(paths["csv"]) as f:
        rows = list(csv.DictReader(f))
    assert [(r["axis"], r["value"]) for r in rows] == [("color", "0.0"), ("color", "1.0")]
    assert "half at" in paths["md"].read_text() and paths["png"].stat().st_size > 10_000
    assert "Where the score falls to half" in capsys.readouterr().out


def test_the_command_refuses_an_agent_whose_checkpoint_would_run_code_unless_trusted(tmp_path, monkeypatch,
                                                                                   short_agent):
    """Refused in this process (--workers 1) and before any process starts (--workers 2), nothing run;
    with --trust-checkpoint it loads, here and in each process it starts (their start run here)."""
    from dcs_torchrl.evaluation import scheduling
    from dcs_torchrl.vector import process_pool

    marker = tmp_path / "ran"
    agent = agent_that_runs_code(tmp_path / "agent", marker, short_agent)
    command = [str(agent), "--axes", "color", "--episodes", "1", "--out", str(tmp_path / "out"), "--no-progress",
               "--intensities", "0", "1"]
    for workers in ("1", "2"):
        with pytest.raises(UntrustedCheckpointError, match=r"\(io\.open\).*--trust-checkpoint"):
            main([*command, "--workers", workers])
        assert not marker.exists()

    class Started(Exception):
        pass

    starts = []

    class StartsRecorded(process_pool.SpawnedPool):
        def __init__(self, processes, *, initializer, initargs, **kwargs):
            starts.append((initializer, initargs))
            raise Started

    with monkeypatch.context() as recorded:
        recorded.setattr(process_pool, "SpawnedPool", StartsRecorded)
        recorded.setattr(scheduling, "_WORKER_AGENT", None)
        with pytest.raises(Started):
            main([*command, "--workers", "2", "--trust-checkpoint"])
        marker.unlink()  # loaded here, before the processes start
        ((start, args),) = starts
        start(*args)
        assert marker.exists()
    marker.unlink()
    paths = main([*command[:-1], "--workers", "1", "--trust-checkpoint"])  # one point: intensity 0
    assert marker.exists() and paths["csv"].exists()


def test_any_policy_and_env_factory(short_agent):
    agent = load_pretrained(short_agent)
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


# ------------------------------------------------- which stored points a run may reuse
@pytest.fixture
def evaluated(monkeypatch):
    """Stands in for the evaluation (what these tests check is which points are evaluated): records
    the settings of each one, and returns a result saying which evaluation it was (its returns)."""
    calls = []

    def evaluate_settings(agent, settings, episodes, **_):
        for key, overrides in settings.items():
            calls.append(overrides)
            returns = [float(len(calls))] * episodes
            yield key, {"mean": returns[0], "stderr": 0.0, "episodes": episodes, "returns": returns}, 0.0

    monkeypatch.setattr("dcs_torchrl.evaluation.scheduling.evaluate_settings", evaluate_settings)
    return calls


def sweep(out, points, episodes=1, agent=AGENT, **kwargs):
    return sweep_agent(agent, points, out, episodes=episodes, progress=False, **kwargs)


COLOR = [Point("color", 0.0, False), Point("color", 0.5, False)]


def test_another_episode_count_evaluates_every_point_again(tmp_path, evaluated):
    first = sweep(tmp_path, COLOR, episodes=1)
    assert len(evaluated) == 2
    second = sweep(tmp_path, COLOR, episodes=2)
    assert len(evaluated) == 4 and [r["episodes"] for r in second] == [2, 2]
    assert sweep(tmp_path, COLOR, episodes=1) == first and len(evaluated) == 4  # both kept, each reused


def _retrain(directory):
    """Another checkpoint in place of ``directory``'s, at the same frames: the agent retrained under its name."""
    import torch

    from dcs_torchrl.training.checkpoint import list_checkpoints, save_checkpoint

    frames, path = list_checkpoints(directory / "checkpoints")[-1]
    state = torch.load(path, weights_only=True)
    weight = next(v for v in state["policy"].values() if v.is_floating_point())
    weight += 0.01
    save_checkpoint(directory / "checkpoints", frames, state, keep=1)


def test_an_agent_retrained_under_the_same_name_is_refused(tmp_path, evaluated):
    import shutil

    agent = shutil.copytree(shipped_agents()[AGENT], tmp_path / "agent")
    sweep(tmp_path / "out", COLOR, agent=agent)
    _retrain(agent)
    with pytest.raises(FileExistsError, match="another checkpoint.*choose another --out"):
        sweep(tmp_path / "out", COLOR, agent=agent)
    assert len(evaluated) == 2
    sweep(tmp_path / "retrained", COLOR, agent=agent)
    assert len(evaluated) == 4

    # a newer checkpoint that does not verify is not the one loaded: the same agent, its points reused
    (agent / "checkpoints" / "checkpoint_000000200000.pt").write_bytes(b"a write that did not finish")
    (agent / "checkpoints" / "checkpoint_000000200000.pt.sha256").write_text("0" * 64)
    sweep(tmp_path / "retrained", COLOR, agent=agent)
    assert len(evaluated) == 4


def test_points_on_other_stand_in_videos_are_evaluated_again(tmp_path, evaluated, monkeypatch):
    from dcs_torchrl.videos import EMBEDDED_VERSION

    points = [Point("background", 0.5, False), Point("camera", 0.5, False)]
    with monkeypatch.context() as older:
        older.setattr("dcs_torchrl.videos.embedded.EMBEDDED_VERSION", EMBEDDED_VERSION - 1)
        sweep(tmp_path, points)
    rows = sweep(tmp_path, points)
    assert [o.get("background_blend") for o in evaluated] == [0.5, None, 0.5]  # the camera point shows no videos
    assert rows[0]["returns"] == [3.0]
    records = [json.loads(p.read_text()) for p in (tmp_path / "points").iterdir()]
    assert sorted(r["env"].get("embedded_videos", 0) for r in records) == [0, EMBEDDED_VERSION - 1, EMBEDDED_VERSION]


def test_points_on_another_video_folder_are_evaluated_again(tmp_path, evaluated, monkeypatch):
    from videos.files import write_frames

    folder = tmp_path / "videos"
    for i in range(2):
        write_frames(folder / f"clip{i}", 2)
    points = [Point("background", 0.5, False), Point("camera", 0.5, False)]
    sweep(tmp_path / "out", points, background_dir=folder)
    monkeypatch.chdir(tmp_path)
    sweep(tmp_path / "out", points, background_dir="videos")  # the same folder by another path: reused
    assert len(evaluated) == 2
    write_frames(folder / "clip1", 3)  # another frame in a clip
    sweep(tmp_path / "out", points, background_dir=folder)
    assert [o.get("background_blend") for o in evaluated] == [0.5, None, 0.5]


def test_records_keep_the_video_folder_as_the_user_gave_it(tmp_path, evaluated, monkeypatch):
    """No absolute path of this machine in a stored point: the folder as given (relative, or with ~)."""
    from videos.files import write_frames

    monkeypatch.setenv("HOME", str(tmp_path))
    write_frames(tmp_path / "videos" / "clip0", 2)
    monkeypatch.chdir(tmp_path)
    points = [Point("background", 0.5, False)]
    for given in ("videos", "~/videos"):
        sweep(tmp_path / "out", points, background_dir=given)
    assert len(evaluated) == 1  # the same folder: the second path reused the point
    (record,) = [json.loads(p.read_text()) for p in (tmp_path / "out" / "points").iterdir()]
    assert record["env"]["background_dir"] == record["overrides"]["background_dir"] == "videos"
    assert str(tmp_path) not in json.dumps(record)


def test_num_videos_sets_the_background_axis_b_and_keys_its_points(tmp_path, evaluated):
    points = [Point("background", 0.5, False), Point("camera", 0.5, False)]
    sweep(tmp_path, points)
    sweep(tmp_path, points, num_videos=8)
    sweep(tmp_path, points, num_videos=8)  # stored: reused
    assert [(o.get("background_blend"), o.get("num_videos")) for o in evaluated] == [(0.5, 60), (None, None), (0.5, 8)]
    with pytest.raises(ValueError, match="--num-videos 61: the embedded stand-in set holds 60 training videos"):
        sweep(tmp_path, points, num_videos=61)
    with pytest.raises(ValueError, match="--num-videos must be >= 1"):
        sweep(tmp_path, points, num_videos=0)


def test_a_changed_env_default_evaluates_every_point_again(tmp_path, evaluated, monkeypatch):
    import dataclasses

    import dcs_torchrl.envs

    sweep(tmp_path, COLOR)
    texture_size = next(f for f in dataclasses.fields(dcs_torchrl.envs.EnvOptions) if f.name == "texture_size")
    monkeypatch.setattr(texture_size, "default", 128)  # no override sets it
    sweep(tmp_path, COLOR)
    assert len(evaluated) == 4


def test_every_output_names_an_axis_as_the_command_does(tmp_path, evaluated, monkeypatch):
    """The CSV, the half-score table and the per-point table call the background axis `background`
    (the command's --axes name), the 2021 code's blend marked in the tables."""
    import dcs_torchrl.report.figures

    monkeypatch.setattr(dcs_torchrl.report.figures, "curves_figure", lambda *_, **__: None)
    points = [Point("background", v, False, blend) for blend in (False, True) for v in (0.0, 1.0)] + COLOR
    paths = write_outputs(sweep(tmp_path, points), tmp_path)
    with open(paths["csv"]) as f:
        assert [r["axis"] for r in csv.DictReader(f)] == [p.axis for p in points]
    text = paths["md"].read_text()
    for section in text.split("## ")[1:]:  # the half-score table, the per-point table
        rows = [line for line in section.splitlines() if line.startswith("|")][2:]  # below the heading and the rule
        assert sorted({row.split("|")[1].strip() for row in rows}) == ["background", "background (2021 blend)", "color"]
    assert "background_blend" not in text


def test_outputs_name_their_renderer(tmp_path, evaluated, monkeypatch):
    """The csv has a backend column, the table's heading and the figure's title name the renderer,
    and rows of two renderers are refused (scores compare on one renderer only)."""
    import dcs_torchrl.report.figures

    notes = []
    monkeypatch.setattr(dcs_torchrl.report.figures, "curves_figure", lambda *_, note="", **__: notes.append(note))
    rows = {}
    for backend in ("gl", "warp"):
        rows[backend] = sweep(tmp_path / backend, COLOR, backend=backend)
        paths = write_outputs(rows[backend], tmp_path / backend, title="the agent")
        with open(paths["csv"]) as f:
            assert [r["backend"] for r in csv.DictReader(f)] == [backend] * len(COLOR)
        assert paths["md"].read_text().splitlines()[0] == f"# Robustness of the agent, {RENDERERS[backend]}"
        assert notes[-1] == f"the agent, {RENDERERS[backend]}"
    with pytest.raises(ValueError, match="one renderer only"):
        write_outputs(rows["gl"] + rows["warp"], tmp_path / "mixed")


def test_help_names_every_default():
    parser = _parser()
    options = [a for a in parser._actions if a.option_strings and a.dest != "help"]
    assert options and [a.dest for a in options if "default: " not in a.help] == []
    text = " ".join(parser.format_help().split())
    for shown in ("(default: camera color background light texture)", "(default: 0 0.2 0.4 0.6 0.8 1)",
                  "(the paper: 100; default: 10)", "texture static only, whatever --setting",
                  "(default: static)", "(default: gl)", "(default: off)"):
        assert shown in text


def test_the_bar_counts_the_envs_it_evaluates_and_the_last_line_says_so(tmp_path, evaluated, monkeypatch, capsys):
    """Intensity 0 is one env on every axis: 4 points of 2 axes at 0 and 1 are 3 envs, the bar's total."""
    import dcs_torchrl.report.figures
    import dcs_torchrl.robustness

    totals = []
    progress = dcs_torchrl.robustness._progress
    monkeypatch.setattr(dcs_torchrl.robustness, "_progress",
                        lambda items, enabled, desc="": totals.append(len(items)) or progress(items, False, desc))
    monkeypatch.setattr(dcs_torchrl.report.figures, "curves_figure", lambda *_, **__: None)
    main([AGENT, "--axes", "camera", "color", "--intensities", "0", "1", "--episodes", "1", "--out", str(tmp_path),
          "--no-progress"])
    assert totals == [3] and len(evaluated) == 3
    assert "4 points, 3 distinct envs (intensity 0 is one env on every axis), 3 evaluated now" in capsys.readouterr().out


def test_an_interrupted_sweep_resumes_with_the_points_it_misses(tmp_path, monkeypatch, short_agent):
    import dcs_torchrl.evaluation.scheduling

    evaluate_settings = dcs_torchrl.evaluation.scheduling.evaluate_settings
    points = sweep_points(["color"], [0.0, 1.0])
    whole = sweep(tmp_path / "whole", points, agent=short_agent)

    class Killed(Exception):
        pass

    def killed_after_one(agent, settings, episodes, **kwargs):
        yield next(evaluate_settings(agent, settings, episodes, **kwargs))
        raise Killed

    monkeypatch.setattr(dcs_torchrl.evaluation.scheduling, "evaluate_settings", killed_after_one)
    with pytest.raises(Killed):
        sweep(tmp_path / "resumed", points, agent=short_agent)
    assert len(list((tmp_path / "resumed" / "points").iterdir())) == 1
    resumed = []

    def counted(agent, settings, episodes, **kwargs):
        resumed.extend(settings.values())
        yield from evaluate_settings(agent, settings, episodes, **kwargs)

    monkeypatch.setattr(dcs_torchrl.evaluation.scheduling, "evaluate_settings", counted)
    assert sweep(tmp_path / "resumed", points, agent=short_agent) == whole and len(resumed) == 1


def test_a_render_device_the_machine_lacks_is_refused_before_anything_is_written(tmp_path, capsys):
    with pytest.raises(ValueError, match="EGL device 10000 does not exist: this machine's EGL devices are 0"):
        sweep_agent(AGENT, [Point("camera", 0.3, True)], tmp_path / "out", render_devices=[0, 10_000])
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit):
        main([AGENT, "--render-devices", "gpu1", "--out", str(tmp_path / "out")])
    assert "'gpu1' is not a render device: give an EGL device index" in capsys.readouterr().err


def test_an_evaluation_process_spawned_on_another_device_than_its_own_refuses_to_start(monkeypatch):
    from dcs_torchrl.evaluation.scheduling import _start_worker

    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "0")
    with pytest.raises(RuntimeError, match="must be spawned with MUJOCO_EGL_DEVICE_ID=3"):
        _start_worker(AGENT, "cpu", False, 3)


# ------------------------------------------------- the axes beyond the paper: light and texture
#: Each new axis' make_env setting, written out here (not read from the package) so that a wrong mapping shows.
BEYOND = {"light": "light_scale", "texture": "texture_scale"}


def test_light_and_texture_points_set_only_their_own_setting():
    """Every point of each new axis sets its setting alone (texture: static only, whatever the setting);
    intensity 0 is the one undistracted env of all five axes."""
    from dcs_torchrl.report.experiments import SWEEP_AXES

    for setting in ("static", "dynamic", "both"):
        points = sweep_points(list(BEYOND), [0.0, 0.5, 1.0], setting)
        for axis, key in BEYOND.items():
            mine = [p for p in points if p.axis == axis]
            dynamics = (False,) if axis == "texture" else {"static": (False,), "dynamic": (True,),
                                                           "both": (False, True)}[setting]
            assert [(p.value, p.dynamic) for p in mine] == [(v, d) for d in dynamics for v in (0.0, 0.5, 1.0)]
            for p in mine:
                assert p.sweep_axis == axis and not p.reference_blend
                assert p.overrides() == ({} if p.value == 0 else {key: p.value, "dynamic": p.dynamic}), p
            assert (SWEEP_AXES[axis].key, SWEEP_AXES[axis].kind) == (key, float)
    everything = sweep_points(["camera", "color", "background", "light", "texture"], [0.0], "both", "both")
    assert {p.axis for p in everything} == {"camera", "color", "background", "light", "texture"}
    assert {p.key() for p in everything} == {"{}"}
    assert sweep_points(reference_blend=False) == sweep_points(["camera", "color", "background", "light", "texture"])
    with pytest.raises(ValueError, match="texture axis is static only"):
        Point("texture", 0.5, True)


def test_an_unknown_axis_is_refused_naming_the_choices(capsys):
    choices = ["camera", "color", "background", "light", "texture"]
    for bad in (["lighting"], ["light", "textures"]):
        with pytest.raises(ValueError, match=re.escape(f"choose among {choices}")):
            sweep_points(bad)
    with pytest.raises(ValueError, match=re.escape(f"unknown axis 'lights': choose among {choices}")):
        Point("lights", 0.5, False)
    with pytest.raises(SystemExit):
        main([AGENT, "--axes", "light", "lighting", "--out", "unused"])
    err = capsys.readouterr().err
    assert "'lighting'" in err and all(f"'{axis}'" in err for axis in choices)


def test_the_command_sweeps_light_and_texture_and_names_them(tmp_path, capsys, short_agent):
    """--axes light texture --setting both: light static and dynamic, texture static only; every output
    names the axes as the command does, claims no half-score point of the paper for them, and each
    evaluated point sets only its axis' setting (intensity 0: none, one env for both axes)."""
    from dcs_torchrl.textures import STANDIN_VERSION

    out = tmp_path / "out"
    paths = main([str(short_agent), "--axes", "light", "texture", "--intensities", "0", "1", "--setting", "both",
                  "--episodes", "1", "--workers", "1", "--out", str(out), "--no-progress"])
    with open(paths["csv"]) as f:
        rows = list(csv.DictReader(f))
    assert [(r["axis"], r["setting"], r["value"]) for r in rows] == [
        ("light", "static", "0.0"), ("light", "static", "1.0"),
        ("light", "dynamic", "0.0"), ("light", "dynamic", "1.0"),
        ("texture", "static", "0.0"), ("texture", "static", "1.0")]
    assert len({r["mean"] for r in rows if r["value"] == "0.0"}) == 1  # one undistracted env
    text = paths["md"].read_text()
    half, points = text.split("## ")[1:]
    for section, wanted in ((half, ["light", "texture"]), (points, ["light", "texture"])):
        table = [line.split("|") for line in section.splitlines() if line.startswith("|")][2:]
        assert sorted({row[1].strip() for row in table}) == wanted
    for row in [line.split("|") for line in half.splitlines() if line.startswith("|")][2:]:
        assert row[-2].strip() == "beyond the paper"  # the paper's 0.2 / 0.6 / < 0.1 are its own axes'
    assert "`light` and `texture`: beyond the paper" in text and "`texture` is swept static only" in text
    assert "Where the score falls to half" in capsys.readouterr().out
    assert paths["png"].stat().st_size > 10_000
    records = [json.loads(p.read_text()) for p in (out / "points").iterdir()]
    assert sorted(json.dumps(r["overrides"], sort_keys=True) for r in records) == sorted([
        "{}", '{"dynamic": false, "light_scale": 1.0}', '{"dynamic": true, "light_scale": 1.0}',
        '{"dynamic": false, "texture_scale": 1.0}'])
    for record in records:  # what defines each: its own setting, and the textures it shows
        env = record["env"]
        assert env.get("light_scale") == record["overrides"].get("light_scale")
        assert env.get("texture_scale") == record["overrides"].get("texture_scale")
        textured = "texture_scale" in record["overrides"]
        assert (env.get("standin_textures"), "texture_split" in env) == ((STANDIN_VERSION, True) if textured
                                                                          else (None, False))


def test_points_on_other_stand_in_textures_are_evaluated_again(tmp_path, evaluated, monkeypatch):
    """A texture point is stored with the stand-in textures' version; the other axes' points (intensity 0
    too) show no texture and keep the identity they had before lighting and textures existed."""
    points = [Point("texture", 0.5, False), Point("light", 0.5, False), Point("camera", 0.5, False),
              Point("texture", 0.0, False)]
    with monkeypatch.context() as older:
        older.setattr("dcs_torchrl.textures.STANDIN_VERSION", 0)
        sweep(tmp_path, points)
    sweep(tmp_path, points)
    assert [(o.get("texture_scale"), o.get("light_scale")) for o in evaluated] == [
        (0.5, None), (None, 0.5), (None, None), (None, None), (0.5, None)]
    for record in (json.loads(p.read_text()) for p in (tmp_path / "points").iterdir()):
        if "light_scale" not in record["overrides"] and "texture_scale" not in record["overrides"]:
            assert not {"light_scale", "texture_scale", "texture_dir", "texture_split"} & set(record["env"])


def test_texture_points_on_another_texture_folder_are_evaluated_again(tmp_path, evaluated, monkeypatch):
    """An agent whose env takes its textures from a folder: a texture point counts that folder by its
    files (another path to it: the same point; another image in it: evaluated again)."""
    import shutil

    import cv2
    import numpy as np

    folder = tmp_path / "textures"
    folder.mkdir()
    for i in range(2):
        cv2.imwrite(str(folder / f"t{i}.png"), np.full((8, 8, 3), 60 * i, np.uint8))
    agent = shutil.copytree(shipped_agents()[AGENT], tmp_path / "agent")
    results = json.loads((agent / "results.json").read_text())
    results["config"]["env"]["texture_dir"] = str(folder)
    (agent / "results.json").write_text(json.dumps(results))
    points = [Point("texture", 0.5, False), Point("light", 0.5, False)]
    sweep(tmp_path / "out", points, agent=agent)
    monkeypatch.chdir(tmp_path)
    results["config"]["env"]["texture_dir"] = "textures"  # the same folder by another path: reused
    (agent / "results.json").write_text(json.dumps(results))
    sweep(tmp_path / "out", points, agent=agent)
    assert len(evaluated) == 2
    cv2.imwrite(str(folder / "t2.png"), np.zeros((8, 8, 3), np.uint8))
    sweep(tmp_path / "out", points, agent=agent)
    assert [(o.get("texture_scale"), o.get("light_scale")) for o in evaluated] == [
        (0.5, None), (None, 0.5), (0.5, None)]
    records = [json.loads(p.read_text()) for p in (tmp_path / "out" / "points").iterdir()]
    assert sorted(r["env"].get("texture_dir") or "" for r in records) == ["", str(folder), "textures"]


def _texture_folder(folder, n=6):
    import cv2
    import numpy as np

    folder.mkdir()
    for i in range(n):
        cv2.imwrite(str(folder / f"t{i}.png"), np.full((8, 8, 3), 40 * i, np.uint8))
    return folder


def test_texture_dir_gives_the_texture_points_its_images_and_keys_them(tmp_path, evaluated):
    """--texture-dir reaches the texture axis' points only; those points are the folder's (its listing in
    their identity: evaluated again without it, or with another image in it), the other axes' points stay."""
    import cv2
    import numpy as np

    folder = _texture_folder(tmp_path / "textures")
    points = [Point("texture", 0.5, False), Point("light", 0.5, False), Point("background", 0.5, False),
              Point("texture", 0.0, False)]
    sweep(tmp_path / "out", points, texture_dir=folder)
    assert [o.get("texture_dir") for o in evaluated] == [str(folder), None, None, None]
    records = [json.loads(p.read_text()) for p in (tmp_path / "out" / "points").iterdir()]
    textured = [r for r in records if r["overrides"].get("texture_scale")]
    assert len(textured) == 1 and textured[0]["env"]["texture_dir"] == str(folder)
    assert re.fullmatch("[0-9a-f]{64}", textured[0]["env"]["texture_listing"])
    assert all("texture_dir" not in r["env"] for r in records if r not in textured)
    sweep(tmp_path / "out", points, texture_dir=folder)  # stored: reused
    sweep(tmp_path / "out", points)  # the stand-ins: the texture point again
    cv2.imwrite(str(folder / "t6.png"), np.zeros((8, 8, 3), np.uint8))
    sweep(tmp_path / "out", points, texture_dir=folder)  # another image in the folder: again
    assert [(o.get("texture_scale"), o.get("texture_dir")) for o in evaluated[4:]] == [(0.5, None), (0.5, str(folder))]


@pytest.mark.parametrize("make, error", [
    (lambda tmp: tmp / "missing", "does not exist"),
    (lambda tmp: _texture_folder(tmp / "empty", 0), "no image files"),
])
def test_a_bad_texture_dir_is_refused_before_anything_is_written(tmp_path, evaluated, make, error):
    with pytest.raises(ValueError, match=error):
        sweep(tmp_path / "out", [Point("texture", 0.5, False)], texture_dir=make(tmp_path))
    assert evaluated == [] and not (tmp_path / "out").exists()


def test_the_command_takes_texture_dir_and_names_it(tmp_path, evaluated, monkeypatch, capsys):
    import dcs_torchrl.report.figures

    monkeypatch.setattr(dcs_torchrl.report.figures, "curves_figure", lambda *_, **__: None)
    folder = _texture_folder(tmp_path / "dtd_images")
    main([AGENT, "--axes", "texture", "--intensities", "0", "0.5", "--episodes", "1", "--texture-dir", str(folder),
          "--out", str(tmp_path / "out"), "--no-progress"])
    assert [o.get("texture_dir") for o in evaluated] == [None, str(folder)]
    assert "textures from dtd_images" in capsys.readouterr().out
