"""How much each background video alone distracts an agent, beside the video's statistics.

    python benchmarks/clip_distraction.py sac_rad_cartpole_swingup [--videos DIR] [--beta 0.3] \\
        [--episodes 4] [--clips 60] [--out clips.csv]

Evaluates the agent (a shipped agent's name, an exported agent or a finished run) with one
training video at a time as its background (b = 1, the paper's blend at ``--beta``, static),
for the first ``--clips`` videos of ``--videos`` (default: the embedded stand-ins, version
``dcs_torchrl.videos.EMBEDDED_VERSION``), and prints per clip its mean return and its
statistics (:func:`dcs_torchrl.videos.statistics.clip_statistics`, plus ``warmth``: the mean
R - B where the cameras look), then each statistic's correlation with the return over the
clips. An env with b videos shows one of them per episode, so the mean over the first b
clips' returns is about the score under ``num_videos=b``. Rows are appended to ``--out`` as
they finish, each with the agent, videos, β_bg and episodes it was measured with; run again with
the same ones, the clips it holds are skipped (an ``--out`` holding rows of other settings is
refused).
"""
from __future__ import annotations

import argparse
import csv
import os
import tempfile
from pathlib import Path

import cv2
import numpy as np
import torch

from dcs_torchrl.pretrained import load_pretrained
from dcs_torchrl.videos import open_source
from dcs_torchrl.videos.statistics import CLIP_NAMES, clip_statistics, warmth

SIZE = 256
STATS = tuple(n for n in CLIP_NAMES if n != "slope") + ("warmth",)


def single_clip_folder(root: Path, name: str, clip: np.ndarray) -> Path:
    """A folder holding only ``clip`` (PNG frames), the background_dir of a b = 1 env."""
    folder = root / name / name
    folder.mkdir(parents=True)
    for i, frame in enumerate(clip):
        cv2.imwrite(str(folder / f"{i:05d}.png"), np.ascontiguousarray(frame[..., ::-1]))
    return folder.parent


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("agent")
    parser.add_argument("--videos", default=None, help="a folder of videos (default: the embedded stand-ins)")
    parser.add_argument("--beta", type=float, default=0.3, help="β_bg, the paper's blend")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--clips", type=int, default=60, help="the first CLIPS training videos")
    parser.add_argument("--out", default="clip_distraction.csv")
    args = parser.parse_args(argv)
    if not 0.0 <= args.beta <= 1.0 or args.episodes < 1 or args.clips < 1:
        parser.error("--beta must be in [0, 1], --episodes and --clips >= 1")
    source = open_source(args.videos)
    videos = repr(source) + (f" version {source.version}" if getattr(source, "version", None) else "")
    setting = {"agent": args.agent, "videos": videos, "beta": f"{args.beta:g}", "episodes": str(args.episodes)}
    out = Path(args.out)
    rows = list(csv.DictReader(out.open())) if out.exists() else []
    other = next((row for row in rows if {k: row.get(k) for k in setting} != setting), None)
    if other is not None:
        raise SystemExit(f"{out} holds rows measured with {({k: other.get(k) for k in setting})}, not {setting}: "
                         "choose another --out.")
    done = {row["clip"] for row in rows}
    torch.set_num_threads(1)  # the policy of one env: the render dominates; more threads only contend
    agent = load_pretrained(args.agent)
    columns = ["clip", "mean_return", *STATS, *setting]
    with tempfile.TemporaryDirectory() as scratch, out.open("a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        if not rows:
            writer.writeheader()
        for index in range(min(args.clips, len(source))):
            name = source.names[index]
            if name in done:
                continue
            clip = source.frames(index, SIZE)
            folder = single_clip_folder(Path(scratch), name, clip)
            result = agent.evaluate(args.episodes, background_blend=args.beta, num_videos=1, dynamic=False,
                                    background_dir=os.fspath(folder))
            stats = clip_statistics([clip], frames_per_clip=16, slope=False)[0]
            row = {"clip": name, "mean_return": result.mean, **{k: stats[k] for k in STATS[:-1]}, "warmth": warmth(clip[::4]),
                   **setting}
            writer.writerow(row)
            f.flush()
            rows.append(row)
            print(f"{name:<28} {result.mean:7.1f}  " + "  ".join(f"{k} {row[k]:.3f}" for k in STATS), flush=True)
    returns = np.array([float(r["mean_return"]) for r in rows])
    print(f"\n{len(rows)} clips, β_bg = {args.beta}: mean return {returns.mean():.0f} (first 4: "
          f"{returns[:4].mean():.0f}, first 8: {returns[:8].mean():.0f})")
    print("correlation of each statistic with the return over the clips:")
    for key in STATS:
        values = np.array([float(r[key]) for r in rows])
        if len(rows) < 3 or values.std() == 0 or returns.std() == 0:  # no correlation to speak of (nan)
            print(f"  {key:<12} n/a ({len(rows)} clips, spread {values.std():.3g} against the returns' {returns.std():.3g})")
        else:
            print(f"  {key:<12} {np.corrcoef(values, returns)[0, 1]:+.2f}")


if __name__ == "__main__":
    main()
