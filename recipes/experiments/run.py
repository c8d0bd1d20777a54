"""Launches one of the paper's experiments (Stone et al. 2021, Sec. 5) as a Hydra multirun through submitit.

    python recipes/experiments/run.py -m experiment=robustness budget=smoke              # this machine
    python recipes/experiments/run.py -m experiment=training budget=paper launcher=slurm \\
        hydra.launcher.partition=gpu                                                     # a SLURM cluster
    python recipes/experiments/run.py -m experiment=training budget=smoke run=<id>,<id>  # only these runs

Each job trains one run with its recipe (skipped if finished, resumed from its last checkpoint
if interrupted) and evaluates its final checkpoint under the run's evaluation settings. The
grid and its settings: conf/ (docs/experiments.md). At the end, the status of the grid is
printed with the command that relaunches its unfinished runs (also: status.py).
"""
from __future__ import annotations

import hydra
from omegaconf import DictConfig

from dcs_torchrl.experiments.launch import run_job


@hydra.main(config_path="conf", config_name="config", version_base=None)
def main(cfg: DictConfig) -> str:
    if cfg.run is None:
        raise SystemExit("Launch the grid with -m (multirun), or one run with run=<id> (status.py lists the ids).")
    return run_job(cfg, str(cfg.run))


if __name__ == "__main__":
    main()
