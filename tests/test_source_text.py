"""The package's source holds no control characters but newlines and tabs (and carriage returns).

A backslash sequence in a docstring that is not raw (``\\bar``, ``\\frac``) becomes a backspace or
form-feed byte: invisible in most editors, garbled in the rendered docs.
"""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


@pytest.mark.parametrize("path", sorted((ROOT / "dcs_torchrl").rglob("*.py")), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_control_characters(path):
    lines = path.read_text(encoding="utf-8").split("\n")  # not splitlines(): it splits at form feeds too
    assert [f"{i}: {line.strip()[:80]!r}" for i, line in enumerate(lines, 1) if CONTROL.search(line)] == []
