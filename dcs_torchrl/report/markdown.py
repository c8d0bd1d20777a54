"""Markdown formatting: tables, "mean ± s.e." cells with bold and seed counts, ratios."""
from __future__ import annotations

import math
from collections.abc import Sequence

from dcs_torchrl.report.experiments import SEEDS

__all__ = ["MISSING", "md_table", "fmt_score", "fmt_ratio", "fmt_value", "seed_counts"]

MISSING = "—"


def md_table(header: Sequence[str], rows: Sequence[Sequence[str]], align: str | None = None) -> str:
    """A GitHub-flavoured markdown table.

    Args:
        header: column titles.
        rows: cells, already formatted.
        align: one character per column, ``l`` or ``r`` (default: first left, others right).

    Examples:
        >>> print(md_table(["Method", "Mean"], [["SAC", "265 ± 13"]]))
        | Method | Mean |
        |:--|--:|
        | SAC | 265 ± 13 |
    """
    align = align or "l" + "r" * (len(header) - 1)
    rule = "|" + "|".join(":--" if a == "l" else "--:" for a in align) + "|"
    lines = ["| " + " | ".join(header) + " |", rule]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def fmt_score(mean: float | None, stderr: float | None = None, n: int | None = None, bold: bool = False,
              decimals: int = 0) -> str:
    """``mean ± s.e.``; bold as ``**…**``; ``(n=k)`` when k differs from the paper's 5 seeds.

    A single seed has no standard error and prints as ``mean (n=1)``; a missing cell as ``—``.

    Examples:
        >>> fmt_score(812.3, 5.14, 5, bold=True), fmt_score(90, 2, 3), fmt_score(90, float("nan"), 1)
        ('**812 ± 5**', '90 ± 2 (n=3)', '90 (n=1)')
        >>> fmt_score(None)
        '—'
    """
    if mean is None or (isinstance(mean, float) and math.isnan(mean)):
        return MISSING
    text = f"{mean:.{decimals}f}"
    if stderr is not None and not math.isnan(stderr):
        text += f" ± {stderr:.{decimals}f}"
    if bold:
        text = f"**{text}**"
    if n is not None and n != SEEDS:
        text += f" (n={n})"
    return text


def fmt_ratio(x: float | None) -> str:
    """A relative score with two decimals, ``—`` when missing.

    Examples:
        >>> fmt_ratio(0.2349), fmt_ratio(float("nan"))
        ('0.23', '—')
    """
    if x is None or math.isnan(x):
        return MISSING
    return f"{x:.2f}"


def fmt_value(value) -> str:
    """A sweep value as printed in tables: ``0.1``, ``8``, ``easy``.

    Examples:
        >>> fmt_value(0.30000000000000004), fmt_value(8), fmt_value("easy")
        ('0.3', '8', 'easy')
    """
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def seed_counts(ns) -> tuple[bool, str]:
    """Whether cells need their own ``(n=k)``, and a note for the table.

    When every present cell (n > 0) has the same number of seeds, one note says so and the
    cells stay unannotated; otherwise each cell whose count differs from 5 is annotated.

    Examples:
        >>> seed_counts([2, 2, 0]), seed_counts([5, 5]), seed_counts([5, 3])
        ((False, 'Every result: n = 2 seeds (the paper: 5).'), (False, ''), (True, ''))
    """
    present = {int(n) for n in ns if n and n > 0}
    if len(present) > 1:
        return True, ""
    if present and present != {SEEDS}:
        return False, f"Every result: n = {present.pop()} seeds (the paper: {SEEDS})."
    return False, ""
