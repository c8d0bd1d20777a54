"""The paper's experiments (Stone et al. 2021, Sec. 5) as Hydra multiruns: grids, jobs, status, evaluation-only runs.

The experiments are configs (``recipes/experiments/conf``); this package expands them into runs
(:mod:`~.grid`), runs one of them per job (:mod:`~.launch`, through Hydra's submitit launcher)
and evaluates trained checkpoints under other settings (:mod:`~.evaluate`).
"""
from dcs_torchrl.experiments.grid import Evaluation, Point, Run, expand
from dcs_torchrl.experiments.launch import StatusCallback, grid_runs, grid_status, run_job, status_text

__all__ = ["Evaluation", "Point", "Run", "StatusCallback", "expand", "grid_runs", "grid_status", "run_job", "status_text"]
