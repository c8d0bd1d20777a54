"""Read every ``results.json`` under a directory into a tidy table, one row per run.

The schema is ``docs/results_format.md``. A file that does not parse, lacks a required key,
has a value of the wrong type or repeats a run already read (same experiment, method, task,
setting, seed, steps and evaluation episodes) is *skipped* and listed with its reason, never
averaged in.

The tables compare and average runs across cells (bold, mean over tasks, interactions), so the
report uses one training length and evaluation count: the ``(steps, eval.episodes)`` of most
runs in an experiment. Runs with other values are *left out* (:attr:`Loaded.left_out`), never
averaged in; plain runs (experiment null) are in no table and always kept.

Likewise a curve never averages scores on two versions of the embedded stand-in videos: where one
method's runs of one task in one experiment showed several versions, only those of the newest are
kept (:attr:`Loaded.older_videos` holds the others).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from dcs_torchrl.report.experiments import AXES, METHODS
from dcs_torchrl.results import JSON_TYPES, RESULTS_FILE, SCHEMA, shows_videos

__all__ = ["RESULTS_FILE", "RUN_COLUMNS", "Skipped", "Loaded", "load_results", "parse_run", "one_budget",
           "newest_stand_ins"]

EXPERIMENT_NAMES = ("robustness", "training", "benchmarks", "interactions")
EVAL_SPLITS = ("train", "val")

_NUMBER = (int, float)
REQUIRED: dict[str, tuple] = JSON_TYPES  # the record's keys and their JSON types (dcs_torchrl.results)
REQUIRED_EVAL: dict[str, tuple] = {"mean": _NUMBER, "stderr": _NUMBER, "episodes": (int,), "returns": (list,)}
REQUIRED_SWEEP: dict[str, tuple] = {"axis": (str,), "value": (int, float, str), "dynamic": (bool,)}

# One row per run; `score` is eval.mean, `score_stderr` eval.stderr (over episodes).
RUN_COLUMNS = (
    "path", "experiment", "method", "algo", "aug", "domain", "task", "seed", "steps", "wall_time",
    "axis", "value", "dynamic", "eval_split", "score", "score_stderr", "episodes", "backgrounds",
)
# Two runs with the same values here are the same run.
RUN_KEY = ("experiment", "method", "domain", "task", "axis", "value", "dynamic", "eval_split", "seed", "steps",
           "episodes")
# A run's budget: runs that differ here are never averaged or compared (one_budget).
BUDGET = ("steps", "episodes")


@dataclass(frozen=True)
class Skipped:
    """A results file left out of the report, and why.

    Attributes:
        path: the file, relative to the results directory.
        reason: what is wrong with it.
    """

    path: str
    reason: str


@dataclass(frozen=True)
class Loaded:
    """What :func:`load_results` found.

    Attributes:
        runs: one row per valid run of the report's budget, columns :data:`RUN_COLUMNS`, sorted
            by path.
        skipped: every file left out as invalid or duplicate, sorted by path.
        left_out: valid runs of experiments with another ``(steps, episodes)`` than ``budget``,
            same columns as ``runs``.
        budget: the ``(steps, episodes)`` of the experiment runs in ``runs`` (None: no such run).
        older_videos: runs of the budget left out for an older version of the stand-in videos
            than their method's runs of the same task and experiment showed (:func:`newest_stand_ins`).
    """

    runs: pd.DataFrame
    skipped: tuple[Skipped, ...]
    left_out: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(RUN_COLUMNS)))
    budget: tuple[int, int] | None = None
    older_videos: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(RUN_COLUMNS)))

    @property
    def n_left_out(self) -> int:
        """Valid runs not in ``runs``: another budget's and older stand-in videos'."""
        return len(self.left_out) + len(self.older_videos)


class _Invalid(ValueError):
    pass


def _type_ok(value, types: tuple) -> bool:
    if value is None:
        return None in types
    if isinstance(value, bool):  # JSON true/false is not a number
        return bool in types
    return isinstance(value, tuple(t for t in types if t is not None))


def _check(obj: dict, required: dict[str, tuple], where: str) -> None:
    for key, types in required.items():
        if key not in obj:
            raise _Invalid(f"missing key {where}{key!r}")
        if not _type_ok(obj[key], types):
            names = "/".join("null" if t is None else t.__name__ for t in types)
            raise _Invalid(f"{where}{key!r} is {obj[key]!r}, expected {names}")


def _sweep_value(axis: str, value):
    kind = AXES[axis]
    if kind is str:
        if not isinstance(value, str):
            raise _Invalid(f"sweep value {value!r} of axis {axis!r} must be a string")
        return value
    if isinstance(value, str) or not math.isfinite(value):
        raise _Invalid(f"sweep value {value!r} of axis {axis!r} must be a finite number")
    if kind is int:
        if float(value) != int(value):
            raise _Invalid(f"sweep value {value!r} of axis {axis!r} must be an integer")
        return int(value)
    return round(float(value), 6)


def _setting(data: dict) -> tuple[str | None, object, bool | None, str]:
    """(axis, value, dynamic, eval_split) of a run; a run without sweep is placed by its benchmark."""
    sweep = data["sweep"]
    if sweep is None:
        benchmark = data["eval_env"].get("benchmark")
        if isinstance(benchmark, str):
            return "benchmark", benchmark, bool(data["eval_env"].get("dynamic", False)), "train"
        if data["experiment"] is not None:
            raise _Invalid(f"experiment {data['experiment']!r} run without 'sweep' and without eval_env benchmark")
        return None, None, None, "train"
    _check(sweep, REQUIRED_SWEEP, "sweep.")
    if sweep["axis"] not in AXES:
        raise _Invalid(f"unknown sweep axis {sweep['axis']!r} (expected one of {', '.join(AXES)})")
    split = sweep.get("eval_split", "train")
    if split not in EVAL_SPLITS:
        raise _Invalid(f"unknown sweep eval_split {split!r} (expected train or val)")
    return sweep["axis"], _sweep_value(sweep["axis"], sweep["value"]), sweep["dynamic"], split


def parse_run(data: object, path: str = "") -> dict:
    """Validates one decoded ``results.json`` and returns its row of the runs table.

    Args:
        data: the decoded JSON document.
        path: where it came from, stored in the row.

    Raises:
        ValueError: the document breaks the schema; the message says how.

    Examples:
        >>> doc = {"schema": 1, "experiment": "benchmarks", "method": "SAC", "algo": "sac",
        ...        "aug": "none", "domain": "cheetah", "task": "run", "seed": 0, "steps": 500000,
        ...        "wall_time": 1.0, "train_env": {}, "eval_env": {}, "config": {},
        ...        "sweep": {"axis": "benchmark", "value": "easy", "dynamic": True},
        ...        "eval": {"mean": 90.0, "stderr": 2.0, "episodes": 100, "returns": []}}
        >>> row = parse_run(doc)
        >>> row["method"], row["axis"], row["value"], row["dynamic"], row["score"]
        ('SAC', 'benchmark', 'easy', True, 90.0)
    """
    if not isinstance(data, dict):
        raise _Invalid(f"top level is {type(data).__name__}, expected a JSON object")
    _check(data, REQUIRED, "")
    if data["schema"] != SCHEMA:
        raise _Invalid(f"schema {data['schema']!r} is not supported (expected {SCHEMA})")
    if data["method"] not in METHODS:
        raise _Invalid(f"unknown method {data['method']!r} (expected one of {', '.join(METHODS)})")
    if data["experiment"] is not None and data["experiment"] not in EXPERIMENT_NAMES:
        names = ", ".join(EXPERIMENT_NAMES)
        raise _Invalid(f"unknown experiment {data['experiment']!r} (expected one of {names} or null)")
    _check(data["eval"], REQUIRED_EVAL, "eval.")
    if not math.isfinite(data["eval"]["mean"]):
        raise _Invalid(f"eval.mean is {data['eval']['mean']!r}, expected a finite number")
    axis, value, dynamic, split = _setting(data)
    return {
        "path": path, "experiment": data["experiment"], "method": data["method"], "algo": data["algo"],
        "aug": data["aug"], "domain": data["domain"], "task": data["task"], "seed": data["seed"],
        "steps": data["steps"], "wall_time": float(data["wall_time"]), "axis": axis, "value": value,
        "dynamic": dynamic, "eval_split": split, "score": float(data["eval"]["mean"]),
        "score_stderr": float(data["eval"]["stderr"]), "episodes": data["eval"]["episodes"],
        "backgrounds": backgrounds(data["train_env"], data["eval_env"]),
    }


def backgrounds(*envs: dict) -> str:
    """Which background videos a run saw (trained or evaluated): ``"none"``, ``"folder"`` (a
    ``background_dir``: DAVIS 2017 or the user's videos) or ``"stand-in vN"`` (the embedded default
    videos of version N, not the paper's DAVIS backgrounds; runs recorded before versions were
    recorded saw version 1).

    Examples:
        >>> backgrounds({"num_videos": 4, "background_dir": None}, {"num_videos": 0})
        'stand-in v1'
        >>> backgrounds({"num_videos": 0}, {}), backgrounds({"num_videos": 8, "background_dir": "/d"})
        ('none', 'folder')
        >>> backgrounds({"num_videos": 8, "background_dir": None, "embedded_videos": 2})
        'stand-in v2'
    """
    used = [env for env in envs if shows_videos(env)]
    if not used:
        return "none"
    if all(env.get("background_dir") for env in used):
        return "folder"
    versions = sorted({env.get("embedded_videos", 1) for env in used if not env.get("background_dir")})
    return "stand-in " + "+".join(f"v{v}" for v in versions)


def one_budget(runs: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, tuple[int, int] | None]:
    """Splits the runs of experiments by ``(steps, episodes)``: keeps those of most runs.

    Ties go to the most steps, then the most evaluation episodes. Plain runs (experiment null)
    are always kept.

    Returns:
        ``(kept, left_out, budget)``, budget the kept ``(steps, episodes)`` (None without
        experiment runs).

    Examples:
        >>> runs = pd.DataFrame({"experiment": ["benchmarks"] * 3 + [None], "steps": [400, 400, 800, 9],
        ...                      "episodes": [2, 2, 2, 1]})
        >>> kept, left_out, budget = one_budget(runs)
        >>> len(kept), left_out["steps"].tolist(), budget
        (3, [800], (400, 2))
    """
    in_experiment = runs["experiment"].notna()
    if not in_experiment.any():
        return runs, runs.iloc[0:0], None
    counts = runs[in_experiment].groupby(list(BUDGET)).size()
    budget = max(counts.index, key=lambda b: (counts[b], b))
    same = (runs["steps"] == budget[0]) & (runs["episodes"] == budget[1])
    return runs[same | ~in_experiment], runs[~same & in_experiment], (int(budget[0]), int(budget[1]))


def newest_stand_ins(runs: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Splits off runs that showed an older version of the stand-in videos than others of their group.

    A group is one experiment's runs of one method on one task; a run's version is the newest it
    showed (``backgrounds`` ``"stand-in v1+v3"``: 3). Runs that showed no stand-ins (no videos, or
    a folder of the user's) are always kept, and so is a group's only version, however old.

    Returns:
        ``(kept, older)``.

    Examples:
        >>> runs = pd.DataFrame({"experiment": ["robustness"] * 4, "method": ["SAC"] * 4,
        ...                      "domain": ["cartpole"] * 4, "task": ["swingup"] * 4,
        ...                      "backgrounds": ["none", "stand-in v1", "stand-in v3", "folder"]})
        >>> kept, older = newest_stand_ins(runs)
        >>> kept["backgrounds"].tolist(), older["backgrounds"].tolist()
        (['none', 'stand-in v3', 'folder'], ['stand-in v1'])
    """
    version = runs["backgrounds"].astype(str).str.extractall(r"v(\d+)")[0].astype(int).groupby(level=0).max()
    version = version.reindex(runs.index)
    newest = version.groupby([runs[k] for k in ("experiment", "method", "domain", "task")], dropna=False).transform("max")
    older = version.notna() & (version < newest)
    return runs[~older], runs[older]


def load_results(root: str | Path) -> Loaded:
    """Reads every ``results.json`` below ``root`` (recursively).

    Args:
        root: the results directory (e.g. a Hydra multirun directory).

    Raises:
        FileNotFoundError: ``root`` is not a directory.

    Examples:
        >>> import json, tempfile, pathlib
        >>> root = pathlib.Path(tempfile.mkdtemp())
        >>> _ = (root / "results.json").write_text("{not json")
        >>> loaded = load_results(root)
        >>> len(loaded.runs), loaded.skipped[0].path, loaded.skipped[0].reason.startswith("invalid JSON")
        (0, 'results.json', True)
    """
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"results directory {str(root)!r} does not exist")
    rows, skipped, seen = [], [], {}
    for file in sorted(root.rglob(RESULTS_FILE)):
        rel = file.relative_to(root).as_posix()
        try:
            text = file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            skipped.append(Skipped(rel, f"unreadable: {getattr(err, 'strerror', None) or err}"))
            continue
        try:
            row = parse_run(json.loads(text), rel)
        except json.JSONDecodeError as err:
            skipped.append(Skipped(rel, f"invalid JSON: {err}"))
            continue
        except _Invalid as err:
            skipped.append(Skipped(rel, str(err)))
            continue
        key = tuple(row[k] for k in RUN_KEY)
        if key in seen:
            skipped.append(Skipped(rel, f"duplicate of {seen[key]} (same experiment, method, task, setting, seed, "
                                        "steps and evaluation episodes)"))
            continue
        seen[key] = rel
        rows.append(row)
    runs = pd.DataFrame(rows, columns=list(RUN_COLUMNS))
    runs = runs.astype({"seed": "int64", "steps": "int64", "score": "float64"}) if len(runs) else runs
    kept, left_out, budget = one_budget(runs)
    kept, older = newest_stand_ins(kept)
    return Loaded(runs=kept.reset_index(drop=True), skipped=tuple(skipped),
                  left_out=left_out.reset_index(drop=True), budget=budget, older_videos=older.reset_index(drop=True))
