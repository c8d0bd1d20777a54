"""Metrics of a run: ``metrics.csv`` always, TensorBoard or Weights & Biases by config.

Rows are ``frames,name,value,wall_time`` (long format: one row per scalar, names namespaced
``train/``, ``eval/``, ``loss/``, ``time/``), appended and flushed as they are logged. A
checkpoint records :attr:`MetricsLogger.rows`; on resume, :meth:`MetricsLogger.truncate` drops
the rows logged after it (the run repeats that stretch), so a killed and resumed run has every
row once. TensorBoard drops its events after the checkpoint's frames (``purge_step``; TorchRL's
``TensorboardLogger`` cannot, so this one is torch's ``SummaryWriter``). W&B goes through
TorchRL's ``WandbLogger``: every metric is plotted against the frames (its group's ``step``), and
a resumed run continues the same W&B run (its id is kept in the checkpoints), where the repeated
stretch shows twice. :class:`RunningMeans` keeps the update's metrics on their device between
logging rows.
"""
from __future__ import annotations

import csv
import os
import time
from collections.abc import Mapping
from pathlib import Path

import torch

__all__ = ["BACKENDS", "MetricsLogger", "RunningMeans", "read_metrics"]

BACKENDS = ("csv", "tensorboard", "wandb")
_HEADER = ["frames", "name", "value", "wall_time"]


def read_metrics(path: str | os.PathLike) -> list[dict]:
    """The rows of a ``metrics.csv`` as dicts (``frames`` int, ``value`` and ``wall_time`` float).

    A last row cut short (a run killed while writing it: no line end) is left out.
    """
    with open(path, newline="") as f:
        lines = f.readlines()
    if lines and not lines[-1].endswith("\n"):
        lines.pop()
    return [
        {"frames": int(r["frames"]), "name": r["name"], "value": float(r["value"]), "wall_time": float(r["wall_time"])}
        for r in csv.DictReader(lines)
    ]


class MetricsLogger:
    """Appends scalars to ``<run_dir>/metrics.csv`` and, optionally, TensorBoard or W&B.

    Args:
        run_dir (path): the run's directory.

    Keyword Args:
        backend (str): ``"csv"`` (only the CSV), ``"tensorboard"`` or ``"wandb"`` (the CSV too).
        resume (tuple of int, optional): ``(rows, frames)`` of the checkpoint a resumed run starts
            from: rows after it are dropped. ``None`` for a fresh run (an existing ``metrics.csv``
            is then an error: the run directory belongs to another run).
        project, run_name, wandb_id: W&B settings (``wandb_id`` resumes the same W&B run).
        config (dict): logged to W&B.
        wall_offset (float): seconds already spent (a resumed run's ``wall_time`` continues).
    """

    def __init__(
        self,
        run_dir: str | os.PathLike,
        *,
        backend: str = "csv",
        resume: tuple[int, int] | None = None,
        project: str = "dcs-torchrl",
        run_name: str | None = None,
        wandb_id: str | None = None,
        config: dict | None = None,
        wall_offset: float = 0.0,
    ):
        if backend not in BACKENDS:
            raise ValueError(f"unknown logger backend {backend!r}: choose one of {BACKENDS} (logger.backend=...).")
        self.path = Path(run_dir) / "metrics.csv"
        self._start = time.time() - wall_offset
        if resume is None and self.path.exists():
            raise FileExistsError(f"{self.path} exists but there is no checkpoint to resume from: use a new run directory.")
        self.rows = 0
        if resume is not None and self.path.exists():
            self.truncate(resume[0])
        fresh = not self.path.exists()
        self._file = open(self.path, "a", newline="")
        self._writer = csv.writer(self._file)
        if fresh:
            self._writer.writerow(_HEADER)
            self._file.flush()
        self._tb = self._wandb = None
        self.wandb_id = wandb_id
        if backend == "tensorboard":
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError as err:
                raise ImportError("logger.backend=tensorboard needs `pip install dcs-torchrl[tensorboard]`.") from err
            self._tb = SummaryWriter(str(Path(run_dir) / "tensorboard"), purge_step=None if resume is None else resume[1])
        elif backend == "wandb":
            try:
                import wandb  # noqa: F401
            except ImportError as err:
                raise ImportError("logger.backend=wandb needs `pip install dcs-torchrl[wandb]`.") from err
            from torchrl.record.loggers import WandbLogger

            # TorchRL's logger: each metric gets the step axis of its group ("train/step" for
            # "train/return", ...), here the frames; wandb_id (saved in the checkpoints) resumes the run
            self._wandb = WandbLogger(run_name or Path(run_dir).name, save_dir=str(run_dir), id=wandb_id,
                                      project=project, config=config, log_env_packages=False)
            self.wandb_id = self._wandb.experiment.id

    def truncate(self, rows: int) -> None:
        """Keeps only the first ``rows`` rows (rewritten atomically)."""
        rows = read_metrics(self.path)[:rows]
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(_HEADER)
            writer.writerows([r[k] for k in _HEADER] for r in rows)
        os.replace(tmp, self.path)
        self.rows = len(rows)

    def log(self, frames: int, metrics: dict[str, float]) -> None:
        """Logs each ``name: value`` at ``frames``."""
        now = time.time() - self._start
        for name, value in metrics.items():
            self._writer.writerow([frames, name, repr(float(value)), f"{now:.3f}"])
            self.rows += 1
            if self._tb is not None:
                self._tb.add_scalar(name, float(value), frames)
        self._file.flush()
        if self._wandb is not None:
            self._wandb.log_metrics({k: float(v) for k, v in metrics.items()}, step=frames)

    def close(self) -> None:
        self._file.close()
        if self._tb is not None:
            self._tb.close()
        if self._wandb is not None:
            self._wandb.close()


class RunningMeans:
    """Means of named 0-d tensors (an update's metrics), summed where they are: no host read until
    :meth:`means`, once per logging row.

    Each name's sum is one float64 tensor on its metric's device, added to in place (no memory
    grows with the updates); float64 sums in order give the same means as summing the values
    read as Python floats.

    Examples:
        >>> means = RunningMeans()
        >>> means.add({"loss/critic": torch.tensor(1.0)})
        >>> means.add({"loss/critic": torch.tensor(2.0)})
        >>> means.means()
        {'loss/critic': 1.5}
        >>> means.means()
        {}
    """

    def __init__(self) -> None:
        self.sums: dict[str, torch.Tensor] = {}
        self.counts: dict[str, int] = {}

    def add(self, values: Mapping[str, torch.Tensor]) -> None:
        """Adds one value per name (0-d tensors, or numbers)."""
        for name, value in values.items():
            value = torch.as_tensor(value).detach()
            total = self.sums.get(name)
            if total is None:
                self.sums[name] = value.to(torch.float64, copy=True)
                self.counts[name] = 1
            else:
                total.add_(value)
                self.counts[name] += 1

    def means(self) -> dict[str, float]:
        """``{name: mean}`` since the last call (one transfer per device), then starts again."""
        names = list(self.sums)
        by_device: dict[torch.device, list[str]] = {}
        for name in names:
            by_device.setdefault(self.sums[name].device, []).append(name)
        means = {}
        for group in by_device.values():
            for name, total in zip(group, torch.stack([self.sums[n] for n in group]).tolist()):
                means[name] = total / self.counts[name]
        self.sums.clear()
        self.counts.clear()
        return {name: means[name] for name in names}
