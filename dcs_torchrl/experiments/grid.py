"""The runs of an experiment, expanded from its config (``recipes/experiments/conf``).

An experiment config lists *training points* (``experiment.train``): a distraction axis, its
values and the settings (static / dynamic). Each point is trained once per method × task × seed
of the budget; a point may add *evaluations* of the trained model under other settings
(evaluation-only, from its final checkpoint). A point is named ``<axis>-<value>-<setting>``
(``none`` for no distraction), a run ``<method>/<domain>-<task>/<point>/seed_<seed>``, and
lives in ``<root>/<label>/<run id>``, where the label is the experiment its ``results.json``
belongs to (``results_format.md``).

Training is shared wherever it is the same: a point at intensity 0 (camera, colour, videos) *is*
training without distraction, so it is the ``none`` run of the benchmarks experiment evaluated
under the point's settings (its ``results.json`` still sits at the point's place); the models
evaluated by ``robustness`` are those ``none`` runs too, and the runs of ``interactions`` are
runs of ``training`` and ``benchmarks``. Every such run is trained once, in one directory.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from dcs_torchrl import methods as registry
from dcs_torchrl.report.experiments import AXES

__all__ = ["NONE", "SETTINGS", "Point", "Evaluation", "Run", "expand", "method_parts", "override_value", "run_id", "select"]

SETTINGS = {"static": False, "dynamic": True}


def method_parts(method: str) -> tuple[str, str]:
    """``(algo, aug)`` of one of the paper's methods.

    Examples:
        >>> method_parts("QT-Opt+DrQ"), method_parts("SAC")
        (('qtopt', 'drq'), ('sac', 'none'))
    """
    found = registry.method(method)
    return found.algo, found.aug


def override_value(value) -> str:
    """A value as Hydra's override grammar reads it back.

    Examples:
        >>> [override_value(v) for v in (True, None, 0.5, 3, "easy", "a b")]
        ['true', 'null', '0.5', '3', 'easy', "'a b'"]
    """
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]
    if isinstance(value, str) and not value.replace("_", "").replace("-", "").replace(".", "").isalnum():
        return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
    return str(value)


def _typed(axis: str, value):
    if axis not in AXES:
        raise ValueError(f"unknown axis {axis!r}: choose among {', '.join(AXES)}.")
    kind = AXES[axis]
    return round(float(value), 6) if kind is float else kind(value)


@dataclass(frozen=True)
class Point:
    """One distraction setting: ``axis`` at ``value``, static or dynamic.

    Examples:
        >>> Point("camera", 0.3, True).name, Point("benchmark", "none", False).name
        ('camera-0.3-dynamic', 'none')
    """

    axis: str
    value: object
    dynamic: bool

    @property
    def name(self) -> str:
        if (self.axis, self.value) == ("benchmark", "none"):
            return "none"
        value = self.value if isinstance(self.value, str) else f"{self.value:g}"
        return f"{self.axis}-{value}-{'dynamic' if self.dynamic else 'static'}"

    def sweep(self, eval_split: str | None = None) -> dict:
        """The ``sweep`` entry of ``results.json`` (``docs/results_format.md``)."""
        return {"axis": self.axis, "value": self.value, "dynamic": self.dynamic,
                **({} if eval_split is None else {"eval_split": eval_split})}

    def env(self, axes: Mapping) -> dict:
        """The env settings of this point: ``axes[axis]`` says which key takes the value and
        which others are fixed (e.g. ``num_videos`` with ``background_blend`` 1)."""
        spec = axes[self.axis]
        return {**spec.get("fixed", {}), spec["key"]: self.value, "dynamic": self.dynamic}


@dataclass(frozen=True)
class Evaluation:
    """An evaluation-only result of a trained run: where it goes (relative to the root), its
    experiment label, its env overrides (on the training env) and its sweep."""

    path: str
    experiment: str
    eval_env: dict
    sweep: dict


NONE = Point("benchmark", "none", False)


@dataclass(frozen=True)
class Run:
    """One training run of the grid and the evaluations of its final checkpoint."""

    method: str
    domain: str
    task: str
    seed: int
    point: Point
    experiment: str  # the label of its results.json and the directory it lives in
    evaluations: tuple[Evaluation, ...] = ()

    @property
    def id(self) -> str:
        return run_id(self.method, f"{self.domain}-{self.task}", self.point, self.seed)

    def dir(self, root: str | Path) -> Path:
        return Path(root) / self.experiment / self.id

    def eval_dir(self, root: str | Path, evaluation: Evaluation) -> Path:
        return Path(root) / evaluation.path


def run_id(method: str, task: str, point: Point, seed: int) -> str:
    return f"{method}/{task}/{point.name}/seed_{seed}"


def _points(entry: Mapping) -> list[Point]:
    points = []
    for setting in entry.get("settings", list(SETTINGS)):
        if setting not in SETTINGS:
            raise ValueError(f"unknown setting {setting!r}: choose static or dynamic.")
        for value in entry["values"]:
            point = Point(entry["axis"], _typed(entry["axis"], value), SETTINGS[setting])
            if point.name == "none":  # no distraction has no static / dynamic: one run
                point = NONE
            if point not in points:
                points.append(point)
    return points


def _task(name: str) -> tuple[str, str]:
    domain, sep, task = name.partition("-")
    if not sep:
        raise ValueError(f"task {name!r} is not <domain>-<task> (e.g. cartpole-swingup).")
    return domain, task


def _entry_runs(entry: Mapping, name: str, budget: Mapping, axes: Mapping, unseen: Mapping) -> Iterable[Run]:
    label = entry.get("experiment", name)
    for point in _points(entry):
        env = point.env(axes)  # an axis without env mapping fails here, before any run
        undistracted = point.axis != "benchmark" and point.value == 0
        for method in budget["methods"]:
            method_parts(method)
            for task in budget["tasks"]:
                _task(task)
                for seed in budget["seeds"]:
                    place = Path(label) / run_id(method, task, point, int(seed))
                    # intensity 0 is the `none` run, evaluated under this point's settings, at its place
                    evaluations = [Evaluation(str(place), label, env, point.sweep())] if undistracted else []
                    for spec in entry.get("evaluate", ()):
                        if spec.get("unseen"):  # the same model on the held-out videos (the paper's Sec. 5.2)
                            evaluations.append(Evaluation(str(place / "unseen"), spec.get("experiment", label),
                                                          {**env, **unseen}, point.sweep("val")))
                            continue
                        for other in _points(spec):
                            path = Path(spec.get("experiment", name)) / run_id(method, task, point, int(seed)) / other.name
                            evaluations.append(Evaluation(str(path), spec.get("experiment", name), other.env(axes), other.sweep()))
                    trained, trained_label = (NONE, "benchmarks") if undistracted else (point, label)
                    yield Run(method, *_task(task), int(seed), trained, trained_label, tuple(evaluations))


def expand(experiment: Mapping, budget: Mapping, axes: Mapping, unseen: Mapping) -> list[Run]:
    """Every training run of ``experiment`` under ``budget`` (points × methods × tasks × seeds),
    each with its evaluations; a run needed by several points is listed once.

    Args:
        experiment: ``{name, train: [{axis, values, settings?, experiment?, evaluate?}]}``;
            ``evaluate`` lists ``{axis, values, settings?}`` or ``{unseen: true}``.
        budget: ``{methods, tasks, seeds}`` (tasks as ``<domain>-<task>``).
        axes: per axis, ``{key, fixed?}``: the env key that takes the value.
        unseen: the eval env overrides of the held-out videos.

    Examples:
        >>> axes = {"benchmark": {"key": "benchmark"}, "camera": {"key": "camera_scale"}}
        >>> budget = {"methods": ["SAC"], "tasks": ["cartpole-swingup"], "seeds": [0]}
        >>> exp = {"name": "robustness", "train": [{"axis": "benchmark", "values": ["none"],
        ...        "experiment": "benchmarks", "evaluate": [{"axis": "camera", "values": [0, 1]}]}]}
        >>> (run,) = expand(exp, budget, axes, {})
        >>> run.id, run.experiment, [e.path for e in run.evaluations][-1]
        ('SAC/cartpole-swingup/none/seed_0', 'benchmarks', 'robustness/SAC/cartpole-swingup/none/seed_0/camera-1-dynamic')
        >>> [(r.id, [e.path for e in r.evaluations]) for r in expand(
        ...     {"name": "training", "train": [{"axis": "camera", "values": [0, 1], "settings": ["static"]}]},
        ...     budget, axes, {})]
        [('SAC/cartpole-swingup/none/seed_0', ['training/SAC/cartpole-swingup/camera-0-static/seed_0']), ('SAC/cartpole-swingup/camera-1-static/seed_0', [])]
    """
    runs: dict[str, Run] = {}
    for entry in experiment["train"]:
        for run in _entry_runs(entry, experiment["name"], budget, axes, unseen):
            if run.id in runs:  # the same training from several points: one run, all their evaluations
                old = runs[run.id]
                run = replace(old, evaluations=old.evaluations + tuple(e for e in run.evaluations if e not in old.evaluations))
            runs[run.id] = run
    return list(runs.values())


def select(runs: Iterable[Run], ids: Iterable[str]) -> list[Run]:
    """The runs named ``ids`` (all of them must be in the grid)."""
    by_id = {r.id: r for r in runs}
    unknown = [i for i in ids if i not in by_id]
    if unknown:
        raise ValueError(f"run(s) {unknown} are not in this grid (check experiment=, budget= and the overrides).")
    return [by_id[i] for i in ids]
