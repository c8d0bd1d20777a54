"""What the test suite collects where an optional extra is missing.

The README's test command installs ``.[test]``, which holds every extra, so everything is
collected there. Elsewhere (e.g. a GPU box that runs the clone from ``PYTHONPATH``, without
Gymnasium) the modules that need a missing extra are not collected, and the report says which
(in its header and at its end), instead of the whole run stopping at a collection error.
"""
import importlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent
# extra's module -> the files that import it at their top (tests and the package's doctests)
NEEDS = {"gymnasium": ("tests/test_gymnasium.py", "dcs_torchrl/gym_env.py")}


def _missing(module: str) -> bool:
    try:
        importlib.import_module(module)
    except ModuleNotFoundError as error:  # the extra itself, not something it imports
        if error.name != module:
            raise
        return True
    return False


MISSING = {module: files for module, files in NEEDS.items() if _missing(module)}
_SKIPPED = {ROOT / f for files in MISSING.values() for f in files}


def pytest_ignore_collect(collection_path, config):
    return True if collection_path in _SKIPPED else None


def _lines() -> list[str]:
    return [f"{module} is not installed: not collected: {', '.join(files)} (pip install -e \".[test]\")"
            for module, files in MISSING.items()]


def pytest_report_header(config):
    return _lines()


def pytest_terminal_summary(terminalreporter):  # also under -q, at the end of the output
    for line in _lines():
        terminalreporter.write_line(line)
