"""What a person looks at after a run: an mp4 of an evaluation episode and the learning curve."""
from __future__ import annotations

import os
from collections import defaultdict
from pathlib import Path

import numpy as np

__all__ = ["plot_learning_curve", "write_mp4"]


def write_mp4(frames: np.ndarray, path: str | os.PathLike, *, fps: int = 30, scale: int = 3) -> Path:
    """Writes ``[T, H, W, 3]`` uint8 RGB frames as an MPEG-4 video, each pixel ``scale`` x ``scale``.

    Examples:
        >>> import numpy as np, tempfile, os
        >>> path = write_mp4(np.zeros((4, 84, 84, 3), np.uint8), os.path.join(tempfile.mkdtemp(), "a.mp4"))
        >>> path.stat().st_size > 0
        True
    """
    import cv2

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise ValueError(f"expected uint8 frames shaped [T, H, W, 3], got {frames.dtype} {frames.shape}.")
    path = Path(path)
    height, width = frames.shape[1] * scale, frames.shape[2] * scale
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (width, height))
    if not writer.isOpened():
        raise RuntimeError(f"OpenCV cannot write an mp4v video to {path}.")
    try:
        for frame in frames:
            big = cv2.resize(frame, (width, height), interpolation=cv2.INTER_NEAREST)
            writer.write(cv2.cvtColor(big, cv2.COLOR_RGB2BGR))
    finally:
        writer.release()
    return path


def plot_learning_curve(rows: list[dict], path: str | os.PathLike, *, title: str = "", baseline: float | None = None) -> Path:
    """Plots ``eval/return_mean`` (± ``eval/return_stderr``) and ``train/episode_return`` against
    frames from metrics rows (:func:`~dcs_torchrl.training.metrics.read_metrics`) into a PNG.

    Args:
        rows (list of dict): metrics rows.
        path: the PNG to write.

    Keyword Args:
        title (str): figure title.
        baseline (float, optional): a horizontal reference line (e.g. a random policy's return).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series: dict[str, dict[int, float]] = defaultdict(dict)
    for row in rows:
        series[row["name"]][row["frames"]] = row["value"]
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    train = series.get("train/episode_return", {})
    if train:
        x = sorted(train)
        ax.plot(x, [train[f] for f in x], ".", color="tab:gray", alpha=0.5, markersize=4, label="training episodes")
    mean, err = series.get("eval/return_mean", {}), series.get("eval/return_stderr", {})
    if mean:
        x = sorted(mean)
        y = np.array([mean[f] for f in x])
        e = np.array([err.get(f, 0.0) for f in x])
        ax.plot(x, y, "o-", color="tab:blue", label="evaluation (deterministic), mean")
        ax.fill_between(x, y - e, y + e, color="tab:blue", alpha=0.25, label="± standard error")
    if baseline is not None:
        ax.axhline(baseline, color="tab:red", linestyle="--", label="random policy")
    ax.set_xlabel("environment steps (frames, counting action repeat)")
    ax.set_ylabel("episode return")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path
