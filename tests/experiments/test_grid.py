"""The experiment configs as grids: the paper's sizes, the report's panels, recipe commands, status."""
from __future__ import annotations

import json
import os
import shlex
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.override_parser.overrides_parser import OverridesParser

from dcs_torchrl.experiments.grid import NONE, Point, expand
from dcs_torchrl.experiments.launch import grid_runs, grid_status, recipe_command, status_text
from dcs_torchrl.report.experiments import EXPERIMENTS, METHODS, TASK_ORDER
from dcs_torchrl.report.load import parse_run

CONF = Path(__file__).resolve().parents[2] / "recipes" / "experiments" / "conf"
EXPERIMENT_NAMES = ("robustness", "training", "benchmarks", "interactions")


def config(experiment: str, budget: str = "paper", *overrides: str, root="/results"):
    # the paper budget needs DAVIS or this opt-in (tests/report/test_backgrounds.py); the grid is the same
    opt_in = ["budget.stand_in_backgrounds=true"] if budget == "paper" else []
    with initialize_config_dir(str(CONF), version_base=None):
        return compose("config", [f"experiment={experiment}", f"budget={budget}", f"root={root}", *opt_in, *overrides],
                       return_hydra_config=True)


@pytest.fixture(scope="module")
def paper():
    return {name: grid_runs(config(name)) for name in EXPERIMENT_NAMES}


def test_paper_grids_have_the_papers_size(paper):
    models = len(METHODS) * len(TASK_ORDER) * 5  # methods x tasks x seeds
    assert len(paper["benchmarks"]) == models * 7  # none + 3 benchmarks x static/dynamic
    # intensity 0 is trained once, without distraction (the `none` run), and evaluated 6 ways
    assert len(paper["training"]) == models * (2 * (10 + 10 + 7) + 1)
    none = [r for r in paper["training"] if r.point == NONE]
    assert len(none) == models and all(r.experiment == "benchmarks" for r in none)
    assert sorted(Path(e.path).relative_to("training").parts[2] for e in none[0].evaluations if e.sweep["value"] == 0) == [
        "camera-0-dynamic", "camera-0-static", "color-0-dynamic", "color-0-static",
        *["num_videos-0-dynamic"] * 2, *["num_videos-0-static"] * 2]  # each also on the unseen videos
    unseen = [e for r in paper["training"] for e in r.evaluations if e.path.endswith("/unseen")]
    assert len(unseen) == models * 8 * 2 and all(e.sweep["eval_split"] == "val" for e in unseen)
    # camera, colour, background blend as the paper describes it and as the 2021 code blends
    assert len(paper["robustness"]) == models and all(len(r.evaluations) == 4 * 11 * 2 for r in paper["robustness"])
    assert len(paper["interactions"]) == models * (2 * 2 * 3 + 5)


def _sweep_points(runs) -> dict[str, set]:
    """(axis, value, dynamic, eval_split) of every results.json each experiment writes."""
    points: dict[str, set] = {}
    for run in runs:
        points.setdefault(run.experiment, set()).add((*run.point.sweep().values(), "train"))
        for e in run.evaluations:
            points.setdefault(e.experiment, set()).add(
                (e.sweep["axis"], e.sweep["value"], e.sweep["dynamic"], e.sweep.get("eval_split", "train")))
    return points


@pytest.mark.parametrize("experiment", ["robustness", "training", "benchmarks"])
def test_paper_grids_cover_the_reports_panels_exactly(paper, experiment):
    expected = set()
    for panel in EXPERIMENTS[experiment]:
        for axis in filter(None, (panel.axis, panel.blend_axis)):  # blend_axis: the same panel, 2021 blend
            for value in panel.values:
                for dynamic in ((False,) if value == "none" else (False, True)):
                    expected.add((axis, value, dynamic, panel.eval_split))
    assert _sweep_points(paper[experiment])[experiment] == expected


def test_robustness_evaluates_the_benchmarks_no_distraction_runs(paper):
    benchmarks = {r.dir("/results") for r in paper["benchmarks"] if r.point.name == "none"}
    assert {r.dir("/results") for r in paper["robustness"]} == benchmarks
    run = paper["robustness"][0]
    assert run.experiment == "benchmarks" and {e.experiment for e in run.evaluations} == {"robustness"}
    assert run.eval_dir("/results", run.evaluations[0]) == Path("/results/robustness") / run.id / "camera-0-static"


def test_every_result_has_its_own_directory(paper):
    for runs in paper.values():
        places = [r.dir("/r") for r in runs] + [r.eval_dir("/r", e) for r in runs for e in r.evaluations]
        assert len(places) == len(set(places))


def test_interactions_are_runs_of_the_training_and_benchmarks_grids(paper):
    others = {r.dir("/results") for name in ("training", "benchmarks") for r in paper[name]}
    assert {r.dir("/results") for r in paper["interactions"]} <= others
    assert {r.experiment for r in paper["interactions"]} == {"training", "benchmarks"}


def test_smoke_budget_is_small_and_has_two_tasks_and_two_seeds():
    for name in EXPERIMENT_NAMES:
        runs = grid_runs(config(name, "smoke"))
        assert {(r.domain, r.task) for r in runs} == {("ball_in_cup", "catch"), ("cartpole", "swingup")}
        assert {r.seed for r in runs} == {0, 1}
        assert len(runs) <= 8 * 17  # interactions: 12 single distractions, none, easy and medium


def test_sweeper_params_list_every_run_and_parse():
    cfg = config("training", "smoke", "budget.methods=[SAC]")
    ids = OverridesParser.create().parse_overrides([f"run={cfg.hydra.sweeper.params.run}"])[0]
    assert list(ids.sweep_iterator()) == [r.id for r in grid_runs(cfg)]
    assert len(grid_runs(cfg)) == 2 * 2 * (3 * 2 * 2 + 1) and all(r.method == "SAC" for r in grid_runs(cfg))


def test_recipe_command_runs_the_package_with_the_recipes_override_names_and_parses():
    cfg = config("training", "smoke")
    run = next(r for r in grid_runs(cfg) if r.point == Point("num_videos", 8, True) and r.method == "QT-Opt+DrQ")
    command = recipe_command(run, cfg)
    assert command[1:4] == ["-m", "dcs_torchrl.training", "--config-name=qtopt"]  # no file of recipes/ is run
    overrides = {o.key_or_group: o.value() for o in OverridesParser.create().parse_overrides(command[4:])}
    assert overrides["algo.aug"] == "drq" and overrides["env.domain"] == run.domain and overrides["seed"] == run.seed
    assert overrides["env.num_videos"] == 8 and overrides["env.background_blend"] == 1.0 and overrides["env.dynamic"] is True
    assert overrides["experiment"] == "training" and overrides["total_frames"] == 400
    assert overrides["sweep"] == {"axis": "num_videos", "value": 8, "dynamic": True}
    assert overrides["hydra.run.dir"] == f"/results/training/{run.id}"


def test_unknown_names_fail_before_any_run():
    base = {"methods": ["SAC"], "tasks": ["cartpole-swingup"], "seeds": [0]}
    axes = {"camera": {"key": "camera_scale"}}
    with pytest.raises(ValueError, match="unknown method"):
        expand({"name": "x", "train": [{"axis": "camera", "values": [0]}]}, {**base, "methods": ["PPO"]}, axes, {})
    with pytest.raises(ValueError, match="unknown axis"):
        expand({"name": "x", "train": [{"axis": "zoom", "values": [0]}]}, base, axes, {})
    with pytest.raises(ValueError, match="domain>-<task"):
        expand({"name": "x", "train": [{"axis": "camera", "values": [0]}]}, {**base, "tasks": ["cartpole"]}, axes, {})


def _write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))


def test_status_reads_results_status_files_and_checkpoints(tmp_path):
    cfg = config("training", "smoke", "budget.methods=[SAC]", "budget.seeds=[0]", "budget.tasks=[cartpole-swingup]",
                 root=str(tmp_path))
    runs = {r.point.name: r for r in grid_runs(cfg)}
    done, failed, killed, partial = (runs[n] for n in ("camera-0.2-dynamic", "camera-0.2-static", "camera-1-static", "color-1-static"))
    _write(done.dir(tmp_path) / "results.json", {"steps": 400, "eval": {"episodes": 2}})
    _write(tmp_path / "status/training" / f"{failed.id}.json",
           {"state": "failed", "stage": "train", "error": "Traceback ...\nValueError: boom"})
    _write(tmp_path / "status/training" / f"{killed.id}.json", {"state": "running", "host": os.uname().nodename, "pid": 2**22 + 1})
    (partial.dir(tmp_path) / "checkpoints").mkdir(parents=True)
    (partial.dir(tmp_path) / "checkpoints/checkpoint_000000000200.pt").write_bytes(b"")
    by_state = {state: [r.id for r, _ in rows] for state, rows in grid_status(cfg).items()}
    assert by_state["done"] == [done.id] and by_state["failed"] == [failed.id]
    assert set(by_state["interrupted"]) == {killed.id, partial.id} and len(by_state["missing"]) == 13 - 4
    text, _ = status_text(cfg, ["experiment=training", f"root={tmp_path}"])
    assert "ValueError: boom" in text and "1 done" in text and "1 failed" in text
    relaunch = text.splitlines()[-1]
    assert "run.py -m experiment=training" in relaunch and failed.id in relaunch and done.id not in relaunch
    assert Path(shlex.split(relaunch)[1]).resolve() == CONF.parent / "run.py"  # the one beside the configs


def test_a_trained_run_with_missing_evaluations_is_not_done(tmp_path):
    cfg = config("training", "smoke", "budget.methods=[SAC]", "budget.seeds=[0]", "budget.tasks=[cartpole-swingup]",
                 root=str(tmp_path))
    run = next(r for r in grid_runs(cfg) if r.evaluations)
    _write(run.dir(tmp_path) / "results.json", {"steps": 400, "eval": {"episodes": 2}})
    assert [r.id for r, _ in grid_status(cfg)["missing"]].count(run.id) == 1
    for evaluation in run.evaluations[:-1]:
        _write(run.eval_dir(tmp_path, evaluation) / "results.json", {"steps": 400, "eval": {"episodes": 2}})
    assert run.id not in [r.id for r, _ in grid_status(cfg)["done"]]
    _write(run.eval_dir(tmp_path, run.evaluations[-1]) / "results.json", {"steps": 400, "eval": {"episodes": 1}})
    assert run.id not in [r.id for r, _ in grid_status(cfg)["done"]]  # fewer episodes than the budget's
    _write(run.eval_dir(tmp_path, run.evaluations[-1]) / "results.json", {"steps": 400, "eval": {"episodes": 2}})
    assert [r.id for r, _ in grid_status(cfg)["done"]] == [run.id]


def test_a_job_gives_its_evaluations_the_budgets_processes_and_threads(tmp_path, monkeypatch):
    """run_job trains (here: stands in) and then evaluates the run's checkpoint under every
    evaluation of the run, in budget.eval_processes processes with budget.threads torch threads."""
    import dcs_torchrl.experiments.evaluate
    import dcs_torchrl.experiments.launch as launch

    cfg = config("robustness", "smoke", "budget.methods=[SAC+RAD]", "budget.seeds=[0]", "budget.tasks=[cartpole-swingup]",
                 "budget.eval_processes=3", root=str(tmp_path))
    (run,) = [r for r in grid_runs(cfg) if r.evaluations]
    calls = []
    monkeypatch.setattr(launch, "_train", lambda run, cfg: (0, tmp_path / "train.log"))
    monkeypatch.setattr(dcs_torchrl.experiments.evaluate, "evaluate_checkpoint",
                        lambda train_dir, evaluations, **kwargs: calls.append((train_dir, evaluations, kwargs)))
    assert launch.run_job(cfg, run.id) == "done"
    ((train_dir, evaluations, kwargs),) = calls
    assert train_dir == run.dir(tmp_path) and len(evaluations) == len(run.evaluations)
    assert kwargs["processes"] == 3 and kwargs["threads"] == cfg.budget.threads == 1


def test_point_sweeps_are_valid_results_sweeps():
    for point in (Point("benchmark", "none", False), Point("camera", 0.3, True), Point("num_videos", 60, False)):
        doc = {"schema": 1, "experiment": "training", "method": "SAC", "algo": "sac", "aug": "none", "domain": "cartpole",
               "task": "swingup", "seed": 0, "steps": 1, "wall_time": 1.0, "train_env": {}, "eval_env": {},
               "sweep": point.sweep("val"), "eval": {"mean": 1.0, "stderr": 0.0, "episodes": 1, "returns": [1.0]},
               "config": {}}
        row = parse_run(doc)
        assert (row["axis"], row["value"], row["dynamic"], row["eval_split"]) == (*point.sweep().values(), "val")
