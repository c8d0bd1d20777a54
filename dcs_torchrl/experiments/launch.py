"""What one job of an experiment's multirun does, and the status of a grid.

A job trains one run with the package's entry point (``python -m dcs_torchrl.training
--config-name=<algo>``, what ``recipes/<algo>/<algo>.py`` runs) in a subprocess, output appended to
``train.log`` in the run directory (it skips a finished run and resumes an interrupted one), then
evaluates the final checkpoint under the run's evaluation settings
(:mod:`dcs_torchrl.experiments.evaluate`, in this process). A failure is recorded, not raised, so
that one failed run does not stop the sweep: ``<root>/status/<experiment>/<run id>.json`` says
what failed and where its log is; :func:`grid_status` reads those files and the results to say
which runs are done, failed, interrupted, running or missing, and prints the command that
relaunches the unfinished ones alone.
"""
from __future__ import annotations

import fcntl
import json
import os
import shlex
import socket
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from hydra.experimental.callback import Callback
from omegaconf import DictConfig, OmegaConf

from dcs_torchrl.experiments.grid import Run, expand, method_parts, override_value, select
from dcs_torchrl.report.experiments import SWEEP_AXES
from dcs_torchrl.training.rundir import finished_results, flatten, write_json_atomic

__all__ = ["StatusCallback", "check_backgrounds", "grid_runs", "grid_status", "recipe_command", "run_job", "status_text"]

TRAINING = "dcs_torchrl.training"  # the module a job runs (python -m), one config per algorithm
TRAIN_LOG = "train.log"
STATES = ("done", "running", "interrupted", "failed", "missing")


def _root(cfg: DictConfig) -> Path:
    """The results root, absolute (a relative ``root`` is below the directory of the launch)."""
    return Path(cfg.root).expanduser().absolute()


def check_backgrounds(budget: DictConfig) -> None:
    """A budget compared with the paper (``requires_davis``) needs DAVIS 2017, or an explicit opt-in to
    the stand-in videos; a ``background_dir`` must exist."""
    if (budget.get("requires_davis", False) and budget.get("background_dir") is None
            and not budget.get("stand_in_backgrounds", False)):
        raise ValueError(
            f"budget={budget.name} is compared with the paper's DAVIS 2017 backgrounds, and no DAVIS folder is set: "
            "pass budget.background_dir=<DAVIS 2017 folder, e.g. ~/data/DAVIS/JPEGImages/480p>, or "
            "budget.stand_in_backgrounds=true to run on the embedded stand-in videos (the report then marks every "
            "background table and figure as not comparable to the paper's)."
        )
    folder = budget.get("background_dir")
    if folder is not None and not Path(str(folder)).expanduser().is_dir():
        raise FileNotFoundError(f"budget.background_dir={folder!r} is not a directory: point it at DAVIS 2017's "
                                "JPEGImages/480p folder (or the DAVIS root).")


def grid_runs(cfg: DictConfig) -> list[Run]:
    """Every run of the configured experiment and budget."""
    check_backgrounds(cfg.budget)
    plain = {key: OmegaConf.to_container(cfg[key], resolve=True) for key in ("experiment", "budget", "axes", "unseen")}
    return expand(**plain)


def _register_resolver() -> None:
    def run_ids(*, _root_: DictConfig) -> str:
        return ",".join(run.id for run in grid_runs(_root_))

    OmegaConf.register_new_resolver("dcs_runs", run_ids, replace=True)
    OmegaConf.register_new_resolver(
        "dcs_axes", lambda: OmegaConf.create({axis: spec.config() for axis, spec in SWEEP_AXES.items()}), replace=True
    )


_register_resolver()


def recipe_settings(cfg: DictConfig) -> dict[str, object]:
    """The budget's recipe overrides, flattened (``{"eval.episodes": 100, ...}``), with its DAVIS folder."""
    settings = flatten(OmegaConf.to_container(cfg.budget.recipe, resolve=True))
    folder = cfg.budget.get("background_dir")
    if folder is not None:
        settings["env.background_dir"] = str(Path(str(folder)).expanduser().absolute())
    return settings


def recipe_command(run: Run, cfg: DictConfig) -> list[str]:
    """The command line that trains ``run`` (the recipe's overrides, the package's entry point)."""
    algo, aug = method_parts(run.method)
    sweep = ",".join(f"{k}:{override_value(v)}" for k, v in run.point.sweep().items())
    env = run.point.env(OmegaConf.to_container(cfg.axes))
    overrides = [
        f"algo.aug={aug}", f"env.domain={run.domain}", f"env.task={run.task}", f"seed={run.seed}",
        *(f"env.{k}={override_value(v)}" for k, v in env.items()),
        f"experiment={run.experiment}", f"sweep={{{sweep}}}",
        *(f"{k}={override_value(v)}" for k, v in recipe_settings(cfg).items()),
        f"hydra.run.dir={override_value(str(run.dir(_root(cfg))))}",
    ]
    return [sys.executable, "-m", TRAINING, f"--config-name={algo}", *overrides]


def _status_path(cfg: DictConfig, run: Run) -> Path:
    return _root(cfg) / "status" / cfg.experiment.name / f"{run.id}.json"


def _write_status(cfg: DictConfig, run: Run, **fields) -> None:
    path = _status_path(cfg, run)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"run": run.id, "time": time.strftime("%Y-%m-%d %H:%M:%S"), **fields})


def _tail(path: Path, lines: int = 15) -> str:
    """The end of a log, without Hydra's closing hint (so that the error is its last line)."""
    try:
        text = path.read_text(errors="replace").splitlines()
    except OSError:
        return ""
    text = [line for line in text if line.strip() and not line.startswith("Set the environment variable HYDRA_FULL_ERROR")]
    return "\n".join(text[-lines:])


def _train(run: Run, cfg: DictConfig) -> tuple[int | None, Path]:
    """Trains ``run`` in a subprocess (which skips a finished run and resumes an interrupted one).

    Returns its exit code, ``None`` if another job is training the same run directory (two
    sweeps sharing a run, e.g. benchmarks and robustness launched together).
    """
    run_dir = run.dir(_root(cfg))
    run_dir.mkdir(parents=True, exist_ok=True)
    log = run_dir / TRAIN_LOG
    env = {**os.environ, "HYDRA_FULL_ERROR": "1"}  # the whole traceback in train.log
    env["PYTHONSAFEPATH"] = "1"  # python -m: the installed package, not a dcs_torchrl/ in the launch directory
    if cfg.budget.threads is not None:
        env["OMP_NUM_THREADS"] = str(cfg.budget.threads)
    command = recipe_command(run, cfg)
    with open(run_dir / ".lock", "w") as lock, open(log, "a") as out:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return None, log
        out.write(f"\n=== {time.strftime('%Y-%m-%d %H:%M:%S')} on {socket.gethostname()}: {shlex.join(command)}\n")
        out.flush()
        return subprocess.run(command, stdout=out, stderr=subprocess.STDOUT, env=env, check=False).returncode, log


def run_job(cfg: DictConfig, run_id: str) -> str:
    """One job: train ``run_id`` (unless ``evaluate_only``), then its evaluations. Returns its state."""
    from dcs_torchrl.experiments.evaluate import evaluate_checkpoint

    (run,) = select(grid_runs(cfg), [run_id])
    where = {"host": socket.gethostname(), "pid": os.getpid(), "slurm_job": os.environ.get("SLURM_JOB_ID")}
    _write_status(cfg, run, state="running", **where)
    if cfg.evaluate_only:
        if not (run.dir(_root(cfg)) / "results.json").exists():
            _write_status(cfg, run, state="failed", stage="evaluate", **where,
                          error=f"evaluate_only=true but {run.dir(_root(cfg))} has no results.json: train this run first")
            return "failed"
    else:
        code, log = _train(run, cfg)
        if code is None:
            _write_status(cfg, run, state="failed", stage="train", log=str(log), **where,
                          error="another job is training this run directory (locked); relaunch once it is done")
            return "failed"
        if code != 0:
            _write_status(cfg, run, state="failed", stage="train", returncode=code, log=str(log), error=_tail(log), **where)
            return "failed"
    if run.evaluations:
        try:
            evaluate_checkpoint(run.dir(_root(cfg)), [(run.eval_dir(_root(cfg), e), e) for e in run.evaluations],
                                settings=recipe_settings(cfg), threads=cfg.budget.threads,
                                processes=OmegaConf.select(cfg, "budget.eval_processes", default=1),
                                trust_checkpoint=bool(OmegaConf.select(cfg, "checkpoint.trust", default=False)))
        except Exception as err:  # noqa: BLE001 - recorded for the status, the sweep goes on
            _write_status(cfg, run, state="failed", stage="evaluate", error=f"{type(err).__name__}: {err}", **where)
            return "failed"
    _write_status(cfg, run, state="done", **where)
    return "done"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def run_state(run: Run, cfg: DictConfig) -> tuple[str, str]:
    """``(state, detail)`` of one run: one of :data:`STATES`."""
    settings = recipe_settings(cfg)
    trained = finished_results(run.dir(_root(cfg)), steps=settings.get("total_frames"))
    if trained is not None:
        episodes = settings.get("eval.episodes")
        if all(finished_results(run.eval_dir(_root(cfg), e), steps=trained["steps"], episodes=episodes)
               for e in run.evaluations):
            return "done", ""
    try:
        status = json.loads(_status_path(cfg, run).read_text())
    except (OSError, json.JSONDecodeError):
        status = {}
    state, pid = status.get("state"), status.get("pid")
    if state == "failed":
        error = (status.get("error") or "").strip().splitlines()
        return "failed", f"{status.get('stage')}: {error[-1] if error else 'no message'}"
    if state == "running":
        if status.get("host") != socket.gethostname():
            return "running", f"on {status.get('host')} since {status.get('time')} (or killed there)"
        if isinstance(pid, int) and pid > 0 and _pid_alive(pid):
            return "running", f"pid {pid} since {status.get('time')}"
        return "interrupted", f"its job (pid {pid}) ended without finishing"
    if any(run.dir(_root(cfg)).glob("checkpoints/checkpoint_*.pt")):
        return "interrupted", "checkpoints but no results"
    return ("missing", "trained, evaluations missing") if trained is not None else ("missing", "")


def grid_status(cfg: DictConfig) -> dict[str, list[tuple[Run, str]]]:
    """The runs of the grid by state."""
    by_state: dict[str, list[tuple[Run, str]]] = {s: [] for s in STATES}
    for run in grid_runs(cfg):
        state, detail = run_state(run, cfg)
        by_state[state].append((run, detail))
    return by_state


def launcher_script(cfg: DictConfig) -> Path:
    """The experiments' ``run.py``: beside the config directory ``cfg`` was composed from
    (``recipes/experiments/conf``), relative to the working directory when below it."""
    hydra_cfg = cfg.hydra if "hydra" in cfg else HydraConfig.get()
    sources = [s.path for s in hydra_cfg.runtime.config_sources if s.provider == "main" and s.schema == "file"]
    script = Path(sources[0]).parent / "run.py" if sources else Path("recipes/experiments/run.py")
    return script.relative_to(Path.cwd()) if script.is_relative_to(Path.cwd()) else script


def relaunch_command(overrides: list[str], ids: list[str] | None, script: str | os.PathLike) -> str:
    """The multirun command of ``script`` with the same overrides, for the runs ``ids`` only (``None``: all)."""
    kept = [o for o in overrides if not o.startswith(("run=", "hydra.mode="))]
    return shlex.join(["python", str(script), "-m", *kept, *([] if ids is None else ["run=" + ",".join(ids)])])


def status_text(cfg: DictConfig, overrides: list[str]) -> tuple[str, dict[str, list[tuple[Run, str]]]]:
    """A summary of the grid's state and the command relaunching its unfinished runs; the runs by state."""
    by_state = grid_status(cfg)
    total = sum(len(v) for v in by_state.values())
    counts = Counter({s: len(v) for s, v in by_state.items() if v})
    lines = [f"experiment {cfg.experiment.name}, budget {cfg.budget.name}: {total} runs in {_root(cfg)} — "
             + ", ".join(f"{n} {s}" for s, n in counts.items())]
    for state in ("failed", "interrupted", "running", "missing"):
        for run, detail in by_state[state][:20]:
            lines.append(f"  {state:<11} {run.id}" + (f"  ({detail})" if detail else ""))
        if len(by_state[state]) > 20:
            lines.append(f"  ... and {len(by_state[state]) - 20} more {state}")
    redo = [run.id for s in ("failed", "interrupted", "missing") for run, _ in by_state[s]]
    script = launcher_script(cfg)
    if len(redo) == total:
        lines.append("Launch the grid:\n  " + relaunch_command(overrides, None, script))
    elif redo:
        lines.append("Relaunch the unfinished runs alone (or the whole grid: finished runs are skipped):\n  "
                     + relaunch_command(overrides, redo, script))
    return "\n".join(lines), by_state


def _overrides(config: DictConfig) -> list[str]:
    return [*config.hydra.overrides.hydra, *config.hydra.overrides.task]


class StatusCallback(Callback):
    """After a multirun: prints the grid's status; exits with 1 if a run failed."""

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        text, by_state = status_text(config, _overrides(config))
        print(text, flush=True)
        if by_state["failed"]:
            raise SystemExit(1)
