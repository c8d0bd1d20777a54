"""Synthetic results directories: results.json files (docs/results_format.md) with chosen scores.

Imported by the report tests (``from synthetic_results import write_run``) and usable to build
a demo directory.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

ALGO_AUG = {
    "SAC": ("sac", "none"), "SAC+RAD": ("sac", "rad"), "SAC+DrQ": ("sac", "drq"),
    "QT-Opt": ("qtopt", "none"), "QT-Opt+RAD": ("qtopt", "rad"), "QT-Opt+DrQ": ("qtopt", "drq"),
}
# The benchmark presets (the paper's Sec. 5.3) for the env dicts of synthetic runs.
PRESETS = {"none": (0.0, 0.0, 0), "easy": (0.1, 0.1, 4), "medium": (0.2, 0.2, 8), "blind": (0.2, 0.2, 8)}


def env_dict(axis: str, value, dynamic: bool, split: str = "train") -> dict:
    """The resolved env settings a run with this sweep point would record."""
    cam, rgb, videos, blend, bench = 0.0, 0.0, 0, 1.0, None
    if axis == "benchmark":
        cam, rgb, videos = PRESETS.get(value, (0.0, 0.0, 0))
        bench = value
    elif axis == "camera":
        cam = value
    elif axis == "color":
        rgb = value
    elif axis == "num_videos":
        videos = value
    elif axis in ("background_blend", "background_blend_2021"):
        videos, blend = 60, value
    return {"benchmark": bench, "dynamic": dynamic, "camera_scale": cam, "color_scale": rgb, "num_videos": videos,
            "background_blend": blend, "blind": value == "blind", "background_split": split,
            "reference_blend": axis == "background_blend_2021"}


def run_doc(score: float, method: str = "SAC", domain: str = "cheetah", task: str = "run", seed: int = 0, *,
            experiment: str | None = "benchmarks", axis: str = "benchmark", value="easy", dynamic: bool = False,
            eval_split: str | None = None, steps: int = 500_000, episodes: int = 2) -> dict:
    """One results.json document with eval.mean = ``score`` over ``episodes`` evaluation episodes."""
    algo, aug = ALGO_AUG[method]
    sweep = {"axis": axis, "value": value, "dynamic": dynamic}
    if eval_split is not None:
        sweep["eval_split"] = eval_split
    env = env_dict(axis, value, dynamic, eval_split or "train")
    returns = [score + (1.0 if i % 2 else -1.0) for i in range(episodes - episodes % 2)] + [score] * (episodes % 2)
    return {
        "schema": 1, "experiment": experiment, "method": method, "algo": algo, "aug": aug, "domain": domain,
        "task": task, "seed": seed, "steps": steps, "wall_time": 12.5, "train_env": env, "eval_env": env,
        "sweep": sweep, "eval": {"mean": float(score), "stderr": 1.0, "episodes": episodes, "returns": returns},
        "config": {"seed": seed},
    }


def write_run(root: Path, score: float, **kw) -> Path:
    """Writes :func:`run_doc` under ``root`` in a directory of its own; returns the file."""
    doc = run_doc(score, **kw)
    split = doc["sweep"].get("eval_split", "train")
    sub = (f"{doc['experiment']}/{doc['method']}/{doc['domain']}-{doc['task']}/{doc['sweep']['axis']}="
           f"{doc['sweep']['value']}-{split}/{'dynamic' if doc['sweep']['dynamic'] else 'static'}/seed{doc['seed']}")
    path = Path(root) / sub / "results.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc))
    return path


# Fractions of the no-distraction score along each sweep (shapes loosely like the paper's figures).
CURVES = {
    ("robustness", "camera"): lambda x: math.exp(-3.5 * x),
    ("robustness", "color"): lambda x: 1 - 0.5 * (x / 0.6) ** 2 if x <= 0.6 else 0.5 * math.exp(-2 * (x - 0.6)),
    ("robustness", "background_blend"): lambda x: 0.15 + 0.85 * math.exp(-12 * x),
    ("training", "camera"): lambda x: math.exp(-2.5 * x),
    ("training", "color"): lambda x: 1 - 0.6 * x,
    ("training", "num_videos"): lambda b: 1 / (1 + 0.12 * b),
    ("training", "num_videos", "val"): lambda b: 0.2 + 0.3 * (1 - math.exp(-b / 6)),
}


def write_sweep(root: Path, *, methods, tasks, seeds, intensities, num_videos, base: dict, noise: float = 0.05,
                seed: int = 0, stretch: dict | None = None) -> int:
    """A complete synthetic sweep of every experiment; returns the number of files written.

    ``base[(method, domain, task, benchmark, dynamic)]`` is a cell's score (dynamic False for
    ``none``); the curves scale the no-distraction score by :data:`CURVES`, evaluated at
    ``intensity * stretch[method]`` (default 1) so that methods can differ in robustness.
    """
    rng = np.random.default_rng(seed)
    count = 0

    def put(score, **kw):
        nonlocal count
        write_run(root, max(0.0, score * (1 + noise * rng.standard_normal())), **kw)
        count += 1

    for method in methods:
        k = (stretch or {}).get(method, 1.0)
        for domain, task in tasks:
            none = base[(method, domain, task, "none", False)]
            for s in seeds:
                kw = dict(method=method, domain=domain, task=task, seed=s)
                for bench in ("none", "easy", "medium", "blind"):
                    for dyn in ((False,) if bench == "none" else (False, True)):
                        put(base[(method, domain, task, bench, dyn)], experiment="benchmarks", axis="benchmark",
                            value=bench, dynamic=dyn, **kw)
                for dyn in (False, True):
                    bonus = 1.1 if dyn else 1.0
                    for axis in ("camera", "color", "background_blend"):
                        for x in intensities:
                            put(none * CURVES[("robustness", axis)](x * k), experiment="robustness", axis=axis,
                                value=x, dynamic=dyn, **kw)
                    for axis in ("camera", "color"):
                        for x in intensities:
                            put(none * CURVES[("training", axis)](x * k) * (bonus if axis == "camera" else 1.0),
                                experiment="training", axis=axis, value=x, dynamic=dyn, **kw)
                    for b in num_videos:
                        put(none * CURVES[("training", "num_videos")](b * k) * bonus, experiment="training",
                            axis="num_videos", value=b, dynamic=dyn, **kw)
                        put(none * CURVES[("training", "num_videos", "val")](b / k), experiment="training",
                            axis="num_videos", value=b, dynamic=dyn, eval_split="val", **kw)
    return count


def paper_base(blind: float = 60.0) -> dict:
    """Cell scores from the paper's tables (blind: a constant, as the paper gives no numbers)."""
    from dcs_torchrl.report.paper import paper_benchmarks

    df = paper_benchmarks()
    base = {(r.method, r.domain, r.task, r.benchmark, bool(r.dynamic)): float(r.mean) for r in df.itertuples()}
    for (method, domain, task, bench, dyn) in list(base):
        if bench == "medium":
            base[(method, domain, task, "blind", dyn)] = blind
    return base
