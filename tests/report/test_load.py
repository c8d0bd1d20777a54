"""Loading results.json files: valid runs become rows, broken files are listed with a reason."""
import json

import pytest
from synthetic_results import run_doc, write_run

from dcs_torchrl.report.load import RUN_COLUMNS, load_results, parse_run
from dcs_torchrl.report.tables import benchmark_table


def test_valid_runs_become_one_row_each(results_dir):
    write_run(results_dir, 812.5, method="QT-Opt+RAD", domain="cartpole", task="swingup", seed=3, value="easy",
              dynamic=True)
    write_run(results_dir, 0.25, experiment="training", axis="camera", value=0.30000000000000004, seed=1)
    write_run(results_dir, 7.0, experiment="training", axis="num_videos", value=8, eval_split="val")
    loaded = load_results(results_dir)
    assert loaded.skipped == ()
    assert list(loaded.runs.columns) == list(RUN_COLUMNS)
    runs = loaded.runs.set_index("score")
    assert runs.loc[812.5, ["method", "domain", "task", "seed", "axis", "value", "dynamic", "eval_split"]].tolist() == [
        "QT-Opt+RAD", "cartpole", "swingup", 3, "benchmark", "easy", True, "train"]
    assert runs.loc[0.25, "value"] == 0.3  # float noise of a swept intensity is rounded away
    assert runs.loc[7.0, ["value", "eval_split"]].tolist() == [8, "val"]


@pytest.mark.parametrize(
    "edit, reason",
    [
        (lambda d: d.pop("eval"), "missing key 'eval'"),
        (lambda d: d["eval"].pop("mean"), "missing key eval.'mean'"),
        (lambda d: d.update(seed="3"), "'seed' is '3', expected int"),
        (lambda d: d.update(seed=True), "'seed' is True, expected int"),
        (lambda d: d.update(schema=2), "schema 2 is not supported"),
        (lambda d: d.update(method="PPO"), "unknown method 'PPO'"),
        (lambda d: d.update(experiment="ablation"), "unknown experiment 'ablation'"),
        (lambda d: d["eval"].update(mean=float("nan")), "eval.mean is nan"),
        (lambda d: d["sweep"].update(axis="lighting"), "unknown sweep axis 'lighting'"),
        (lambda d: d["sweep"].update(value=0.1), "sweep value 0.1 of axis 'benchmark' must be a string"),
        (lambda d: d["sweep"].update(eval_split="test"), "unknown sweep eval_split 'test'"),
        (lambda d: d.update(sweep=None, eval_env={}), "run without 'sweep'"),
    ],
)
def test_schema_violations_are_refused(edit, reason):
    doc = run_doc(100.0)
    edit(doc)
    with pytest.raises(ValueError, match=reason.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        parse_run(doc)


def test_broken_files_are_skipped_and_listed(results_dir):
    good = write_run(results_dir, 100.0, seed=0)
    (results_dir / "crashed").mkdir()
    (results_dir / "crashed" / "results.json").write_text('{"schema": 1, "method": ')
    incomplete = run_doc(50.0, seed=1)
    del incomplete["steps"]
    (results_dir / "incomplete").mkdir()
    (results_dir / "incomplete" / "results.json").write_text(json.dumps(incomplete))
    (results_dir / "array").mkdir()
    (results_dir / "array" / "results.json").write_text("[1, 2]")
    loaded = load_results(results_dir)
    assert loaded.runs["path"].tolist() == [good.relative_to(results_dir).as_posix()]
    reasons = {s.path: s.reason for s in loaded.skipped}
    assert set(reasons) == {"crashed/results.json", "incomplete/results.json", "array/results.json"}
    assert reasons["crashed/results.json"].startswith("invalid JSON")
    assert reasons["incomplete/results.json"] == "missing key 'steps'"
    assert reasons["array/results.json"] == "top level is list, expected a JSON object"


def test_a_repeated_run_is_skipped_as_duplicate(results_dir):
    write_run(results_dir, 100.0, seed=4)
    copy = results_dir / "rerun" / "results.json"
    copy.parent.mkdir()
    copy.write_text(json.dumps(run_doc(300.0, seed=4)))
    loaded = load_results(results_dir)
    assert loaded.runs["score"].tolist() == [100.0]
    assert len(loaded.skipped) == 1 and loaded.skipped[0].path == "rerun/results.json"
    assert loaded.skipped[0].reason.startswith("duplicate of benchmarks/SAC/")


def _cell(loaded):
    table = benchmark_table(loaded.runs, "easy", False, [("cheetah", "run")])
    return table.set_index(["method", "task"]).loc[("SAC", "run"), ["mean", "n"]].tolist()


@pytest.mark.parametrize("other", [{"steps": 100_000}, {"episodes": 10}])
def test_runs_of_another_length_or_evaluation_count_are_left_out(results_dir, other):
    """Seeds 0 and 1 at 500K steps, 2 episodes; seed 2 differs: the cell averages seeds 0 and 1 only."""
    write_run(results_dir, 100.0, seed=0)
    write_run(results_dir, 200.0, seed=1)
    odd = write_run(results_dir / "other", 900.0, seed=2, **other)
    loaded = load_results(results_dir)
    assert loaded.budget == (500_000, 2) and loaded.skipped == ()
    assert loaded.runs["score"].tolist() == [100.0, 200.0]
    assert loaded.left_out["path"].tolist() == [odd.relative_to(results_dir).as_posix()]
    assert _cell(loaded) == [150.0, 2]


def test_the_same_seed_at_another_length_is_not_a_duplicate(results_dir):
    write_run(results_dir, 100.0, seed=0, steps=400)
    write_run(results_dir / "longer", 300.0, seed=0, steps=800)
    loaded = load_results(results_dir)
    assert loaded.skipped == () and loaded.budget == (800, 2)  # a tie: the longer runs are kept
    assert loaded.runs["score"].tolist() == [300.0] and loaded.left_out["score"].tolist() == [100.0]


def test_plain_runs_of_any_length_are_kept(results_dir):
    write_run(results_dir, 100.0, seed=0)
    write_run(results_dir / "plain", 5.0, experiment=None, steps=16_000)
    loaded = load_results(results_dir)
    assert sorted(loaded.runs["steps"].tolist()) == [16_000, 500_000] and loaded.left_out.empty
    assert loaded.budget == (500_000, 2)


def test_a_run_without_sweep_is_placed_by_its_benchmark():
    doc = run_doc(42.0, value="medium", dynamic=True)
    doc["sweep"] = None
    row = parse_run(doc)
    assert (row["axis"], row["value"], row["dynamic"]) == ("benchmark", "medium", True)


def test_plain_run_without_experiment_or_sweep_is_kept():
    doc = run_doc(42.0, experiment=None)
    doc["sweep"], doc["eval_env"] = None, {}
    row = parse_run(doc)
    assert (row["experiment"], row["axis"], row["score"]) == (None, None, 42.0)


def test_missing_directory_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_results(tmp_path / "nowhere")


def test_empty_directory_gives_an_empty_table(results_dir):
    loaded = load_results(results_dir)
    assert loaded.runs.empty and list(loaded.runs.columns) == list(RUN_COLUMNS) and loaded.skipped == ()
    assert loaded.left_out.empty and loaded.budget is None
