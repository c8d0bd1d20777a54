"""What the benchmarks print beside an absolute figure: the CPU it ran on (absolute times differ
between machines of one kind; docs/performance.md); and the environment of their subprocesses."""
from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child_env(**extra: str) -> dict:
    """This process's environment with ``extra``, the project in front of ``PYTHONPATH`` (which may
    hold more: a GPU box's unpacked wheels)."""
    return {**os.environ, **extra, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def cpu_model() -> str:
    """``lscpu``'s model name, else the platform's processor name, else ``"unknown CPU"``."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        out = ""
    names = [line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name")]
    return names[0] if names else platform.processor() or "unknown CPU"
