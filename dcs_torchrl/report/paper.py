"""The paper's published numbers (Stone et al., 2021), transcribed from its .tex as data.

Files in ``dcs_torchrl/report/data/``:

- ``paper_benchmarks.csv``: tables ``default`` (no distraction), ``easy`` and ``medium``
  (static and dynamic), one row per method and task plus the ``domain="all", task="mean"``
  row of the Mean column; ``mean`` and ``stderr`` over 5 seeds, ``bold`` as printed.
  The no-distraction table has no static/dynamic split and is stored with ``dynamic=false``.
- ``paper_interactions.csv``: table ``interaction_of_distractions`` (relative scores).
- ``paper_notes.json``: where methods lose half their score, other observations, what is
  not published as numbers (blind benchmark, curves) and ambiguities found in the .tex.
"""
from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

import pandas as pd

__all__ = ["paper_benchmarks", "paper_interactions", "paper_notes", "MEAN_DOMAIN", "MEAN_TASK"]

# The (domain, task) under which the paper's Mean column (mean over the six tasks) is stored.
MEAN_DOMAIN, MEAN_TASK = "all", "mean"
_DATA_PACKAGE = "dcs_torchrl.report"


def _read_csv(name: str) -> pd.DataFrame:
    with resources.files(_DATA_PACKAGE).joinpath("data", name).open("r") as f:
        return pd.read_csv(f, dtype={"dynamic": bool})


@lru_cache(maxsize=None)
def _benchmarks() -> pd.DataFrame:
    return _read_csv("paper_benchmarks.csv").astype({"bold": bool})


@lru_cache(maxsize=None)
def _interactions() -> pd.DataFrame:
    return _read_csv("paper_interactions.csv")


def paper_benchmarks() -> pd.DataFrame:
    """The paper's benchmark tables: one row per (method, domain, task, benchmark, dynamic).

    Columns: ``method, domain, task, benchmark, dynamic, mean, stderr, bold, source``;
    ``benchmark`` is ``none``, ``easy`` or ``medium``.

    Examples:
        >>> df = paper_benchmarks()
        >>> row = df[(df.method == "SAC") & (df.benchmark == "easy") & ~df.dynamic & (df.task == "mean")]
        >>> int(row["mean"].iloc[0]), int(row["stderr"].iloc[0])
        (94, 4)
    """
    return _benchmarks().copy()


def paper_interactions() -> pd.DataFrame:
    """The paper's interactions table: relative scores per distraction, product, benchmark.

    Columns: ``method, difficulty, dynamic, camera, color, background, product, comparison,
    benchmark, source``; ``comparison`` is ``">"`` or ``"<"`` (product vs benchmark).

    Examples:
        >>> df = paper_interactions()
        >>> df[(df.method == "QT-Opt+RAD") & (df.difficulty == "easy") & df.dynamic]["product"].item()
        0.68
    """
    return _interactions().copy()


def paper_notes() -> dict:
    """The paper's statements that are not table numbers (half-score points, observations).

    Examples:
        >>> [(n["axis"], n["relation"], n["value"]) for n in paper_notes()["half_score"]]
        [('camera', '=', 0.2), ('color', '=', 0.6), ('background_blend', '<', 0.1)]
    """
    with resources.files(_DATA_PACKAGE).joinpath("data", "paper_notes.json").open("r") as f:
        return json.load(f)
