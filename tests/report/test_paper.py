"""The paper's numbers as data: hand-checked values, the means of Tables 2-4, internal consistency."""
import pytest

from dcs_torchrl.report.experiments import METHODS, TASK_ORDER
from dcs_torchrl.report.paper import paper_benchmarks, paper_interactions, paper_notes

# The paper's Tables 2-4 (docs/paper.md): mean over the six tasks; columns none, easy static, easy dynamic, medium static, medium dynamic.
PAPER_MEANS = {
    "SAC": (265, 94, 98, 76, 86),
    "SAC+RAD": (836, 182, 270, 113, 89),
    "SAC+DrQ": (808, 166, 199, 126, 89),
    "QT-Opt": (372, 149, 118, 109, 87),
    "QT-Opt+RAD": (820, 317, 343, 165, 103),
    "QT-Opt+DrQ": (801, 299, 265, 170, 102),
}
SETTINGS = (("none", False), ("easy", False), ("easy", True), ("medium", False), ("medium", True))


@pytest.fixture(scope="module")
def bench():
    return paper_benchmarks().set_index(["method", "domain", "task", "benchmark", "dynamic"]).sort_index()


def test_all_thirty_spec_means(bench):
    for method, means in PAPER_MEANS.items():
        for (benchmark, dynamic), mean in zip(SETTINGS, means):
            assert bench.loc[(method, "all", "mean", benchmark, dynamic), "mean"] == mean, (method, benchmark, dynamic)


@pytest.mark.parametrize("key, mean, stderr, bold", [
    (("SAC+RAD", "walker", "walk", "none", False), 762, 184, True),
    (("QT-Opt+DrQ", "reacher", "easy", "none", False), 974, 1, True),
    (("SAC", "cartpole", "swingup", "none", False), 384, 42, False),
    (("QT-Opt", "walker", "walk", "easy", False), 152, 6, True),
    (("SAC+DrQ", "cheetah", "run", "easy", False), 4, 2, False),
    (("SAC+RAD", "ball_in_cup", "catch", "easy", True), 366, 59, False),
    (("QT-Opt+RAD", "reacher", "easy", "easy", True), 428, 68, True),
    (("QT-Opt+DrQ", "cheetah", "run", "medium", False), 124, 9, True),
    (("SAC+DrQ", "finger", "spin", "medium", False), 259, 107, True),
    (("SAC", "finger", "spin", "medium", True), 1, 0, False),
    (("QT-Opt", "walker", "walk", "medium", True), 112, 4, True),
    (("QT-Opt+RAD", "all", "mean", "medium", True), 103, 3, True),
])
def test_hand_checked_cells(bench, key, mean, stderr, bold):
    row = bench.loc[key]
    assert (row["mean"], row["stderr"], row["bold"]) == (mean, stderr, bold)


def test_table_shape(bench):
    df = paper_benchmarks()
    assert len(df) == 6 * 7 * 5
    assert set(df.method) == set(METHODS)
    assert set(zip(df.domain, df.task)) == set(TASK_ORDER) | {("all", "mean")}
    assert set(zip(df.benchmark, df.dynamic)) == set(SETTINGS)
    assert not df.duplicated(["method", "domain", "task", "benchmark", "dynamic"]).any()


def test_mean_column_is_the_mean_of_the_task_columns_up_to_rounding():
    df = paper_benchmarks()
    tasks = df[df.task != "mean"].groupby(["method", "benchmark", "dynamic"])["mean"].mean()
    means = df[df.task == "mean"].set_index(["method", "benchmark", "dynamic"])["mean"]
    assert (tasks - means.reindex(tasks.index)).abs().max() <= 0.67


def test_every_column_bolds_its_highest_mean():
    df = paper_benchmarks()
    for _, g in df.groupby(["benchmark", "dynamic", "domain", "task"]):
        assert g.loc[g["mean"] == g["mean"].max(), "bold"].all()


def test_interactions_rows_and_hand_checked_values():
    df = paper_interactions()
    assert len(df) == 16 and set(df.method) == {"SAC+RAD", "SAC+DrQ", "QT-Opt+RAD", "QT-Opt+DrQ"}
    r = df.set_index(["method", "difficulty", "dynamic"]).loc[("SAC+DrQ", "easy", True)]
    assert (r.camera, r.color, r.background, r["product"], r.comparison, r.benchmark) == (
        0.72, 1.02, 0.63, 0.46, ">", 0.25)
    assert (df.comparison == ">").all()


def test_interactions_benchmark_column_is_benchmark_mean_over_no_distraction_mean(bench):
    for r in paper_interactions().itertuples():
        combined = bench.loc[(r.method, "all", "mean", r.difficulty, r.dynamic), "mean"]
        none = bench.loc[(r.method, "all", "mean", "none", False), "mean"]
        assert r.benchmark == pytest.approx(combined / none, abs=0.005)


def test_interactions_product_matches_its_factors_up_to_rounding():
    for r in paper_interactions().itertuples():
        assert r.product == pytest.approx(r.camera * r.color * r.background, abs=0.0075)


def test_notes_hold_the_half_score_statements():
    notes = paper_notes()
    assert [(n["experiment"], n["axis"], n["relation"], n["value"]) for n in notes["half_score"]] == [
        ("robustness", "camera", "=", 0.2), ("robustness", "color", "=", 0.6),
        ("robustness", "background_blend", "<", 0.1)]
    assert any("blind" in n for n in notes["not_published_as_numbers"])


def test_notes_cite_the_paper_by_name_not_a_file():
    source = paper_notes()["source"]
    assert "The Distracting Control Suite" in source and "arXiv:2101.02722" in source
    assert "/" not in source.replace("arXiv:", "")
