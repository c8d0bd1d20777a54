"""Seed statistics and the bold rule (a one-sided z-test on mean ± s.e. at p < 0.1)."""
import math

import pandas as pd
import pytest
from scipy import stats

from dcs_torchrl.report.paper import paper_benchmarks, paper_interactions
from dcs_torchrl.report.stats import (Estimate, Score, better_p_value, bold_flags, seed_scores, task_mean,
                                      z_p_value)


def test_score_is_mean_and_standard_error_over_seeds():
    s = Score.of([200.0, 210.0, 220.0], [0, 1, 2])
    assert (s.mean, s.n, s.seeds) == (210.0, 3, (0, 1, 2))
    assert s.stderr == pytest.approx(10 / math.sqrt(3))


def test_single_seed_has_no_standard_error():
    assert math.isnan(Score.of([5.0]).stderr)


def test_empty_score_is_refused():
    with pytest.raises(ValueError, match="at least one seed"):
        Score.of([])


def test_seed_with_two_runs_counts_once():
    runs = pd.DataFrame({"method": ["SAC"] * 3, "seed": [0, 0, 1], "score": [10.0, 30.0, 50.0]})
    assert seed_scores(runs, ["method"])["score"].tolist() == [20.0, 50.0]


def test_mean_over_tasks_is_per_seed_then_over_complete_seeds():
    runs = pd.DataFrame({
        "domain": ["a", "b"] * 3 + ["a"], "task": ["x"] * 7, "seed": [0, 0, 1, 1, 2, 2, 3],
        "score": [100.0, 300.0, 110.0, 310.0, 120.0, 320.0, 999.0],  # seed 3 lacks task b
    })
    s = task_mean(runs, [("a", "x"), ("b", "x")])
    assert s.values == (200.0, 210.0, 220.0) and s.seeds == (0, 1, 2)
    assert task_mean(runs, [("a", "x"), ("c", "x")]) is None  # no seed has task c


def test_clearly_worse_is_not_bold_and_close_is_bold():
    flags = bold_flags({
        "best": Score.of([300.0, 310.0, 320.0]),
        "close": Score.of([295.0, 305.0, 315.0]),  # z = 5 / sqrt(2 * 100 / 3), p ~ 0.27
        "worse": Score.of([100.0, 101.0, 102.0]),
    })
    assert flags == {"best": True, "close": True, "worse": False}


def test_threshold_is_p_below_0_1():
    best, other = Score.of([10.0, 12.0, 14.0, 16.0, 18.0]), Score.of([8.0, 10.0, 12.0, 14.0, 16.0])
    p = better_p_value(best, other)
    assert 0.05 < p < 0.5
    assert bold_flags({"b": best, "o": other}, alpha=p + 1e-9)["o"] is False
    assert bold_flags({"b": best, "o": other}, alpha=p - 1e-9)["o"] is True


def test_ties_are_all_bold_and_the_reference_is_the_tie_with_most_seeds():
    flags = bold_flags({
        "one seed, top": Score.of([310.0]),
        "three seeds, top": Score.of([300.0, 310.0, 320.0]),
        "close": Score.of([295.0, 305.0, 315.0]),
    })
    assert flags == {"one seed, top": True, "three seeds, top": True, "close": True}


def test_single_seed_below_the_best_is_not_bold():
    flags = bold_flags({"best": Score.of([300.0, 310.0, 320.0]), "single": Score.of([309.0])})
    assert flags == {"best": True, "single": False}
    assert math.isnan(better_p_value(Score.of([300.0, 310.0, 320.0]), Score.of([309.0])))


def test_single_seed_best_makes_others_untestable():
    flags = bold_flags({"single": Score.of([500.0]), "many": Score.of([499.0, 499.5, 500.0])})
    assert flags == {"single": True, "many": False}


def test_zero_variance_both_sides_is_a_certain_difference():
    flags = bold_flags({"a": Score.of([200.0] * 3), "b": Score.of([190.0] * 3), "c": Score.of([200.0] * 2)})
    assert flags == {"a": True, "b": False, "c": True}


def test_zero_variance_on_one_side_uses_the_other_standard_error():
    p = better_p_value(Score.of([200.0] * 3), Score.of([100.0, 150.0, 200.0]))
    assert p == pytest.approx(stats.norm.sf(50 / (50 / math.sqrt(3))), rel=1e-12)  # z = sqrt(3): p = 0.0416


def test_p_value_is_a_one_sided_z_test_on_mean_and_standard_error():
    a, b = Score.of([10.0, 12.0, 17.0, 11.0]), Score.of([8.0, 9.5, 12.0, 7.0, 9.0])
    z = (a.mean - b.mean) / math.sqrt(a.stderr**2 + b.stderr**2)
    assert better_p_value(a, b) == pytest.approx(0.5 * math.erfc(z / math.sqrt(2)), rel=1e-12)
    # not Welch's t-test on the same seeds, whose p is larger (heavier tails with few seeds)
    welch = stats.ttest_ind(a.values, b.values, equal_var=False, alternative="greater").pvalue
    assert better_p_value(a, b) < welch - 0.005


def test_z_p_value_of_published_numbers():
    """The paper's finger spin, medium dynamic: SAC+RAD 63 ± 24 against QT-Opt 28 ± 11."""
    assert z_p_value(63, 24, 28, 11) == pytest.approx(0.0925, abs=5e-5)
    assert bold_flags({"SAC+RAD": Estimate(63, 24), "QT-Opt": Estimate(28, 11)}) == {"SAC+RAD": True, "QT-Opt": False}
    assert (z_p_value(1, 0, 1, 0), z_p_value(2, 0, 1, 0)) == (1.0, 0.0)
    assert math.isnan(z_p_value(2, math.nan, 1, 0))


def test_missing_cells_are_not_bold():
    assert bold_flags({"a": None, "b": Score.of([1.0, 2.0])}) == {"a": False, "b": True}
    assert bold_flags({"a": None}) == {"a": False}


def _paper_columns():
    """Each column of the paper's tables default/easy/medium: {method: Estimate} and {method: bold}."""
    df = paper_benchmarks()
    for key, g in df.groupby(["benchmark", "dynamic", "domain", "task"]):
        yield key, {r.method: Estimate(r.mean, r.stderr) for r in g.itertuples()}, dict(zip(g.method, g.bold))


def test_rule_reproduces_every_bold_mark_of_the_papers_tables():
    """The z-test at p < 0.1 on the published mean ± s.e. gives every one of the 210 bold marks."""
    count, disagree = 0, []
    for key, estimates, printed in _paper_columns():
        computed = bold_flags(estimates)
        count += len(computed)
        disagree += [(*key, method) for method in printed if computed[method] != printed[method]]
    assert count == 210 and disagree == []
    assert "bold" not in paper_interactions().columns  # the only other table prints no bold marks


def test_welchs_t_test_would_miss_four_of_the_papers_bold_marks():
    """The rule used before: Welch's one-sided t-test on the same numbers (n = 5) gets 206 of 210."""
    def welch(best, other, n=5):
        v1, v2 = best.stderr**2, other.stderr**2
        if v1 + v2 == 0:
            return 0.0 if best.mean > other.mean else 1.0
        df = (v1 + v2) ** 2 / ((v1**2 + v2**2) / (n - 1))
        return stats.t.sf((best.mean - other.mean) / math.sqrt(v1 + v2), df)

    misses = []
    for key, estimates, printed in _paper_columns():
        best = max(estimates.values(), key=lambda e: e.mean)
        for method, e in estimates.items():
            if (e.mean == best.mean or welch(best, e) >= 0.1) != printed[method]:
                misses.append((key[0], key[1], key[2], method))
    assert misses == [("medium", True, "finger", "QT-Opt"), ("medium", True, "finger", "QT-Opt+DrQ"),
                      ("none", False, "cartpole", "SAC+RAD"), ("none", False, "reacher", "SAC+RAD")]
