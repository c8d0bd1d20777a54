"""Wall time of `python -m dcs_torchrl.robustness` on the shipped agent, as a user runs it.

    python benchmarks/robustness_speed.py                       # the quick and the full sweep, 2 workers
    python benchmarks/robustness_speed.py --sweeps quick --workers 1 2 --keep /tmp/robustness
    python benchmarks/robustness_speed.py --sweeps quick --backends gl warp     # side by side

Sweeps (the shipped SAC+RAD cartpole swingup agent), each over the paper's three axes (camera, color,
background; the command's default adds light and texture, beyond the paper, and is not what the
recorded times are of):
- quick: the command's other defaults, 6 intensities x 3 axes, static, 10 episodes per point;
- full: the paper's experiment 1 for one agent, 11 intensities x 3 axes x static and dynamic,
  20 episodes per point.
``--backends gl warp`` times each sweep with the command's ``--backend`` of each (warp: several points'
episodes at once, in one batched env per worker). Each run starts from an empty output directory (a temporary one, or below --keep, which keeps
the results: the full sweep is the shipped agent's experiment-1 data). Time the machine idle:
nothing else running. Prints the CPU model beside the wall times.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import cpu_model

AGENT = "sac_rad_cartpole_swingup"
ELEVEN = [f"{0.1 * i:.1f}" for i in range(11)]
PAPER_AXES = ["--axes", "camera", "color", "background"]
SWEEPS = {
    "quick": [*PAPER_AXES],  # the command's other defaults
    "full": [*PAPER_AXES, "--intensities", *ELEVEN, "--setting", "both", "--episodes", "20"],
}




def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sweeps", nargs="+", default=list(SWEEPS), choices=list(SWEEPS))
    parser.add_argument("--workers", nargs="+", type=int, default=[2])
    parser.add_argument("--backends", nargs="+", default=["gl"], choices=["gl", "warp"])
    parser.add_argument("--keep", default=None, help="keep each run's output below this directory")
    args = parser.parse_args()
    rows = []
    for sweep in args.sweeps:
        for workers in args.workers:
            for backend in args.backends:
                parent = Path(args.keep) if args.keep else Path(tempfile.mkdtemp())
                out = parent / f"{sweep}-workers{workers}" if backend == "gl" else parent / f"{sweep}-workers{workers}-{backend}"
                if out.exists():
                    raise SystemExit(f"{out} exists: the benchmark times a sweep from scratch; remove it or choose another --keep.")
                command = [sys.executable, "-m", "dcs_torchrl.robustness", AGENT, "--workers", str(workers),
                           "--backend", backend, "--out", str(out), "--no-progress", *SWEEPS[sweep]]
                print("$", " ".join(command[1:]), flush=True)
                start = time.perf_counter()
                subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
                seconds = time.perf_counter() - start
                rows.append((sweep, workers, backend, seconds))
                print(f"{sweep}, {workers} worker(s), {backend}: {seconds:.0f} s", flush=True)
                if not args.keep:
                    shutil.rmtree(parent)
    print(f"\nCPU: {cpu_model()}\n")
    print("| sweep | workers | backend | wall time |\n|---|--:|---|--:|")
    for sweep, workers, backend, seconds in rows:
        print(f"| {sweep} | {workers} | {backend} | {seconds / 60:.1f} min |")


if __name__ == "__main__":
    main()
